/*
 * test_stepper.c - host tests of the steppers (stepper.c): the profile
 * arithmetic, exact moves, the trapezoid's speed and acceleration, limit
 * switches, the failsafe and the requests' errors.
 */
#include <math.h>

#include "host_check.h"
#include "stepper.h"

/* Sends CT DT data (checksum added), runs the loop; returns the reply's code:
 * 0 for a success reply, the error code for an error reply.  The reply's
 * data (without CT DT CS) is left in reply[], events before it skipped. */
static uint8_t reply[64];
static uint8_t request(uint8_t dt, const uint8_t *data, uint8_t n)
{
    uint8_t buf[32], x = AIO_CT_STEPPER ^ dt, i;
    uint32_t at = 0;
    buf[0] = AIO_CT_STEPPER;
    buf[1] = dt;
    for (i = 0; i < n; i++) {
        buf[2 + i] = data[i];
        x ^= data[i];
    }
    buf[2 + n] = x;
    fake_tx_len = 0;
    fake_rx_push(buf, n + 3u);
    run();
    while (at < fake_tx_len && fake_tx[at] == AIO_CT_EVENT)
        at += 2u + AIO_REPLY_LEN_EVENT_STEPPER_DONE + 1u;
    if (at >= fake_tx_len)
        return 0xFF;
    if (fake_tx[at] == (AIO_CT_STEPPER | AIO_ERROR_FLAG))
        return fake_tx[at + 2];
    memcpy(reply, fake_tx + at + 2, fake_tx_len - at - 2);
    fake_tx_len = 0;
    return 0;
}

#define REQ(dt, ...) request(dt, (const uint8_t[]){__VA_ARGS__}, sizeof((const uint8_t[]){__VA_ARGS__}))
#define B32(v) (uint8_t)((uint32_t)(v) >> 24), (uint8_t)((uint32_t)(v) >> 16), (uint8_t)((uint32_t)(v) >> 8), (uint8_t)(v)
#define B16(v) (uint8_t)((uint16_t)(v) >> 8), (uint8_t)(v)

static int32_t be32(const uint8_t *p)
{
    return (int32_t)((uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3]);
}

/* The StepperDone events sent so far (taken from fake_tx): count, last reason and position. */
static int done_count, done_reason, done_index;
static int32_t done_pos;
static void take_events(void)
{
    uint32_t at = 0;
    while (at + 3u <= fake_tx_len && fake_tx[at] == AIO_CT_EVENT) {
        if (fake_tx[at + 1] == AIO_DT_EVENT_FAILSAFE_TRIPPED) {
            at += 3u;
            continue;
        }
        if (fake_tx[at + 1] != AIO_DT_EVENT_STEPPER_DONE)
            break;
        done_count++;
        done_index = fake_tx[at + 2];
        done_reason = fake_tx[at + 3];
        done_pos = be32(fake_tx + at + 4);
        at += 13u;
    }
    fake_tx_len = 0;
}

/* Ticks, with the main loop after each (events); records the tick of every step of pin. */
static uint32_t step_tick[40000];
static uint32_t steps_seen;
static void ticks(uint32_t n, uint8_t pin)
{
    while (n--) {
        uint32_t before = fake_step_rises[pin];
        fake_advance(1);
        if (fake_step_rises[pin] != before && steps_seen < sizeof step_tick / sizeof *step_tick)
            step_tick[steps_seen++] = fake_ticks;
        fake_tx_capacity = FAKE_TX_MAX;
        run();
        take_events();
    }
}

static void test_arithmetic(void)
{
    uint32_t s;
    /* Q32 steps a tick: 2^32 / 10,000 per step/s, within one part in 10^6 */
    for (s = 1; s < AIO_STEPPER_MAX_SPEED; s += 37) {
        double want = (double)s * 4294967296.0 / 10000.0;
        EXPECT(fabs(stepper_speed_q((uint16_t)s) - want) <= want * 1e-6 + 1.0);
        EXPECT(abs(stepper_speed_of(stepper_speed_q((uint16_t)s), 1) - (int)s) <= 1);
    }
    EXPECT(stepper_speed_q(AIO_STEPPER_MAX_SPEED) == 0xFFFFFFFFu);
    EXPECT(stepper_speed_of(stepper_speed_q(2500), -1) == -2500);
    for (s = 1; s <= AIO_STEPPER_MAX_ACCEL; s = s * 3 + 1) {
        double want = (double)s * 4294967296.0 / 1e8;
        EXPECT(fabs(stepper_accel_q(s) - want) <= want * 1e-4 + 1.0);
    }
}

/* A 10,000-step move: exact end, one step a tick at most, peak speed and
 * acceleration from the step ticks within 2 %, symmetric trapezoid. */
static void test_move(void)
{
    uint32_t i, cruise_from = 0, cruise_to = 0;
    double peak, a_est;
    board();
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 0, 4, 5) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_PROFILE, 0, B16(4000), B32(8000)) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_MOVE, 0, 0, B32(10000)) == 0);
    EXPECT(be32(reply + 2) == 10000);
    steps_seen = 0;
    done_count = 0;
    ticks(40000, 4);
    EXPECT(fake_step_rises[4] == 10000);
    EXPECT(steps_seen == 10000);
    EXPECT(done_count == 1 && done_reason == AIO_STEPPER_DONE_TARGET && done_pos == 10000);
    EXPECT(fake_pin_level[5] == 1); /* positive: the direction pin high */
    EXPECT(REQ(AIO_DT_STEPPER_READ, 0) == 0);
    EXPECT(be32(reply + 1) == 10000 && be32(reply + 5) == 10000 && reply[11] == 0);
    /* cruise: 4,000 steps/s is 2.5 ticks a step; the steps 2,000 from either end cruise */
    cruise_from = 3000;
    cruise_to = 7000;
    peak = (double)(cruise_to - cruise_from) / ((double)(step_tick[cruise_to] - step_tick[cruise_from]) * 1e-4);
    EXPECT(fabs(peak - 4000.0) <= 4000.0 * 0.02);
    /* acceleration: 4000^2 / (2 * 8000) = 1000 steps of ramp, reached in 0.5 s:
     * step n at t = sqrt(2 n / a) from the start */
    a_est = 2.0 * 800.0 / pow((double)(step_tick[799] - step_tick[0] + 1) * 1e-4 + sqrt(2.0 / 8000.0), 2);
    EXPECT(fabs(a_est - 8000.0) <= 8000.0 * 0.02);
    if (fabs(peak - 4000.0) > 80.0 || fabs(a_est - 8000.0) > 160.0)
        printf("  peak %.1f steps/s, acceleration %.1f steps/s^2\n", peak, a_est);
    /* ramp down takes about as long as ramp up */
    i = steps_seen - 1;
    EXPECT(abs((int)(step_tick[i] - step_tick[i - 800]) - (int)(step_tick[799] - step_tick[0])) < 60);
    /* a relative move back past zero: reversal, exact */
    done_count = 0;
    EXPECT(REQ(AIO_DT_STEPPER_MOVE, 0, 1, B32(-10500)) == 0);
    EXPECT(be32(reply + 2) == -500);
    ticks(40000, 4);
    EXPECT(fake_step_rises[4] == 20500);
    EXPECT(done_count == 1 && done_pos == -500);
    EXPECT(fake_pin_level[5] == 0);
}

/* Every stepper at 10,000 steps/s: one step every tick each, none lost. */
static void test_top_speed(void)
{
    uint8_t i;
    board();
    for (i = 0; i < 4; i++) {
        EXPECT(REQ(AIO_DT_STEPPER_CONFIG, i, (uint8_t)(2 + 2 * i), (uint8_t)(3 + 2 * i)) == 0);
        EXPECT(REQ(AIO_DT_STEPPER_PROFILE, i, B16(10000), B32(1000000)) == 0);
        EXPECT(REQ(AIO_DT_STEPPER_MOVE, i, 0, B32(-3000)) == 0);
    }
    done_count = 0;
    ticks(3200, 2);
    for (i = 0; i < 4; i++)
        EXPECT(fake_step_rises[2 + 2 * i] == 3000);
    EXPECT(done_count == 4);
}

/* A limit switch: no step once the tick has seen it; LIMIT_MAX event; moves
 * away from it still go. */
static void test_limit(void)
{
    uint32_t at;
    board();
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 1, 6, 7) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_LIMIT, 1, 1, 8, 0) == 0); /* positive side, D8 active low */
    EXPECT(fake_pin_mode[8] == HAL_IN_PULLUP);
    EXPECT(REQ(AIO_DT_STEPPER_PROFILE, 1, B16(5000), B32(50000)) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_RUN, 1, B16(5000)) == 0);
    done_count = 0;
    ticks(3000, 6);
    EXPECT(fake_step_rises[6] > 1000);
    fake_drive(8, 0);
    at = fake_step_rises[6];
    ticks(1, 6);
    EXPECT(fake_step_rises[6] == at); /* not one step after the tick saw it */
    ticks(100, 6);
    EXPECT(fake_step_rises[6] == at);
    EXPECT(done_count == 1 && done_index == 1 && done_reason == AIO_STEPPER_DONE_LIMIT_MAX &&
           done_pos == (int32_t)at);
    EXPECT(REQ(AIO_DT_STEPPER_READ, 1) == 0);
    EXPECT(be32(reply + 1) == (int32_t)at && reply[12] == 2);
    /* still into it: refused by the tick at once; away from it: goes */
    EXPECT(REQ(AIO_DT_STEPPER_MOVE, 1, 1, B32(10)) == 0);
    ticks(100, 6);
    EXPECT(fake_step_rises[6] == at);
    EXPECT(REQ(AIO_DT_STEPPER_MOVE, 1, 1, B32(-10)) == 0);
    ticks(2000, 6);
    EXPECT(fake_step_rises[6] == at + 10);
    EXPECT(REQ(AIO_DT_STEPPER_SET_POSITION, 1, B32(0)) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_READ, 1) == 0 && be32(reply + 1) == 0);
}

static void test_stop_and_failsafe(void)
{
    uint32_t at;
    board();
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 0, 10, 11) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_PROFILE, 0, B16(2000), B32(4000)) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_RUN, 0, B16(-2000)) == 0);
    ticks(10000, 10);
    EXPECT(REQ(AIO_DT_STEPPER_SET_POSITION, 0, B32(5)) == AIO_ERR_STEPPER_MOVING);
    /* decelerate: 2000^2 / (2 * 4000) = 500 steps more */
    at = fake_step_rises[10];
    done_count = 0;
    EXPECT(REQ(AIO_DT_STEPPER_STOP, 0, 0) == 0);
    ticks(10000, 10);
    EXPECT(fake_step_rises[10] - at >= 495 && fake_step_rises[10] - at <= 505);
    EXPECT(done_count == 1 && done_reason == AIO_STEPPER_DONE_STOPPED && done_pos == -(int32_t)fake_step_rises[10]);
    /* immediate */
    EXPECT(REQ(AIO_DT_STEPPER_RUN, 0, B16(2000)) == 0);
    ticks(5000, 10);
    at = fake_step_rises[10];
    EXPECT(REQ(AIO_DT_STEPPER_STOP, 0, 1) == 0);
    ticks(100, 10);
    EXPECT(fake_step_rises[10] == at);
    /* failsafe: armed at 50 ms, the host falls silent */
    EXPECT(REQ(AIO_DT_STEPPER_RUN, 0, B16(2000)) == 0);
    {
        uint8_t arm[] = {AIO_CT_FAILSAFE, AIO_DT_FAILSAFE_ARM, 0, 50, 0};
        arm[4] = (uint8_t)(arm[0] ^ arm[1] ^ arm[2] ^ arm[3]);
        fake_rx_push(arm, sizeof arm);
        run();
        fake_tx_len = 0;
    }
    done_count = 0;
    ticks(600, 10);
    at = fake_step_rises[10];
    EXPECT(done_count == 1 && done_reason == AIO_STEPPER_DONE_FAILSAFE);
    ticks(100, 10);
    EXPECT(fake_step_rises[10] == at);
    EXPECT(REQ(AIO_DT_STEPPER_MOVE, 0, 1, B32(5)) == AIO_ERR_FAILSAFE_TRIPPED);
    EXPECT(REQ(AIO_DT_STEPPER_READ, 0) == 0);
}

static void test_errors(void)
{
    board();
    EXPECT(REQ(AIO_DT_STEPPER_MOVE, 0, 0, B32(1)) == AIO_ERR_PIN_NOT_CONFIGURED);
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 4, 2, 3) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 0, 2, 2) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 0, 1, 2) == AIO_ERR_PIN_NOT_CAPABLE);
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 0, 2, 3) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 0, 2, 3) == 0); /* its own pins again */
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 1, 3, 4) == AIO_ERR_PIN_BUSY);
    EXPECT(REQ(AIO_DT_STEPPER_LIMIT, 1, 0, 5, 0) == AIO_ERR_PIN_NOT_CONFIGURED);
    EXPECT(REQ(AIO_DT_STEPPER_LIMIT, 0, 0, 2, 0) == AIO_ERR_PIN_BUSY);
    EXPECT(REQ(AIO_DT_STEPPER_LIMIT, 0, 2, 5, 0) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_LIMIT, 0, 0, 5, 1) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_LIMIT, 0, 1, 5, 1) == 0); /* one switch, both sides */
    EXPECT(REQ(AIO_DT_STEPPER_PROFILE, 0, B16(0), B32(1)) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_PROFILE, 0, B16(10001), B32(1)) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_PROFILE, 0, B16(100), B32(1000001)) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_RUN, 0, B16(-10001)) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_STOP, 0, 2) == AIO_ERR_VALUE_OUT_OF_RANGE);
    EXPECT(REQ(AIO_DT_STEPPER_MOVE, 0, 2, B32(1)) == AIO_ERR_VALUE_OUT_OF_RANGE);
    /* a new configuration frees the old pins (D2, D3) and the limit (D5) */
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 0, 6, 7) == 0);
    EXPECT(REQ(AIO_DT_STEPPER_CONFIG, 1, 2, 5) == 0);
}

void test_stepper(void)
{
    test_arithmetic();
    test_move();
    test_top_speed();
    test_limit();
    test_stop_and_failsafe();
    test_errors();
}

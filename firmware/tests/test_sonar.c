/*
 * test_sonar.c - host tests of the SONAR class (sonar.c over the shared edge timing of
 * pulse.c) with the fake HAL: the trigger pulse the board drives, the echo widths the
 * test drives (its own clock is the oracle) turned into millimetres, "no echo" after the
 * timeout, sonars fired one at a time in slot order, pin conflicts and release.
 * Run by tests/test_main.c (see host_check.h).
 */
#include "host_check.h"

static uint16_t be16(const uint8_t *p) { return (uint16_t)(p[0] << 8 | p[1]); }

static void advance_us(uint32_t us)
{
    fake_fine_now += 2u * us;
    run();
}

/* READ of slot s: distance, echo width and readings; 0 when the reply is not one. */
static int read_sonar(uint8_t s, uint16_t *dist, uint16_t *echo_us, uint16_t *readings)
{
    send_frame(B(AIO_CT_SONAR, AIO_DT_SONAR_READ, s));
    run();
    take();
    checks++;
    if (outn != 2u + AIO_REPLY_LEN_SONAR_READ + 1u || out[0] != AIO_CT_SONAR || out[2] != s) {
        failures++;
        printf("%s:%d: FAIL: read of sonar %u (%u bytes)\n", __FILE__, __LINE__, s, outn);
        return 0;
    }
    *dist = be16(out + 3);
    *echo_us = be16(out + 5);
    *readings = be16(out + 9);
    return 1;
}

/* The board raised `trig`: let it lower it (>= 10 us later), then echo `echo_us` on `echo`. */
static void answer(uint8_t trig, uint8_t echo, uint32_t echo_us)
{
    EXPECT(fake_pin_level[trig] == 1);
    advance_us(5);
    EXPECT(fake_pin_level[trig] == 1); /* not shorter than 10 us */
    advance_us(8);
    EXPECT(fake_pin_level[trig] == 0);
    advance_us(300);
    fake_drive(echo, 1);
    fake_fine_now += 2u * echo_us;
    fake_drive(echo, 0);
    run();
}

static void sonar_errors(void)
{
    board();
    CHECK(B(0x0B, 1, 4, 4, 5), B(0x8B, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* slot 4 of 0-3 */
    CHECK(B(0x0B, 1, 0, 4, 4), B(0x8B, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* one pin for both */
    CHECK(B(0x0B, 1, 0, 1, 5), B(0x8B, 1, AIO_ERR_PIN_NOT_CAPABLE));    /* D1: the UART */
    CHECK(B(0x0B, 1, 0, 4, 14), B(0x8B, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(0x0B, 2, 0), B(0x8B, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(0x0B, 2, 4), B(0x8B, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(0x0B, 3, 0, 0, 0x0D, 0x66), B(0x8B, 3, AIO_ERR_VALUE_OUT_OF_RANGE)); /* period 0 */
    CHECK(B(0x0B, 3, 0, 60, 0x0B, 0xB7), B(0x8B, 3, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 299.9 m/s */
    CHECK(B(2, 1, 7, 1), B(2, 1, 7, 1)); /* a GPIO output on D7 */
    CHECK(B(0x0B, 1, 0, 6, 7), B(0x8B, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(0x0B, 1, 0, 7, 6), B(0x8B, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(0x0B, 1, 0, 4, 5), B(0x0B, 1, 0, 4, 5));
    CHECK(B(0x0A, 1, 0, 5, 6, 4), B(0x8A, 1, AIO_ERR_PIN_BUSY)); /* an encoder on its echo */
    CHECK(B(0x0B, 1, 1, 5, 6), B(0x8B, 1, AIO_ERR_PIN_BUSY));    /* another sonar on it */
    CHECK(B(0x0B, 1, 0, 5, 4), B(0x0B, 1, 0, 5, 4));             /* the slot's own pins */
    /* PIN_RELEASE of the echo ends the sonar: both pins free */
    CHECK(B(2, 4, 4), B(2, 4, 4));
    CHECK(B(0x0B, 2, 0), B(0x8B, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(0x0A, 1, 0, 4, 5, 4), B(0x0A, 1, 0, 4, 5, 4));
}

static void sonar_distances(void)
{
    uint16_t dist, echo_us, readings;
    board();
    CHECK(B(0x0B, 1, 0, 4, 5), B(0x0B, 1, 0, 4, 5));
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == AIO_SONAR_NO_READING && readings == 0);
    run();
    answer(4, 5, 1000); /* 1000 us at 343.0 m/s: 171.5 mm, rounded up */
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == 172u && echo_us == 1000u && readings == 1);
    /* the next firing waits for the period (60 ms from the last) */
    advance_us(50000);
    EXPECT(fake_pin_level[4] == 0);
    advance_us(10000);
    answer(4, 5, 23324); /* 4 m */
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == 4000u && readings == 2);
    /* nothing heard: the part's echo stays high past the 30 ms timeout */
    advance_us(60000);
    EXPECT(fake_pin_level[4] == 1);
    advance_us(13);
    fake_drive(5, 1);
    advance_us(29000);
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == 4000u && readings == 2);
    advance_us(1100);
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == AIO_SONAR_NO_ECHO && echo_us == 0 &&
           readings == 3);
    advance_us(8000);
    fake_drive(5, 0); /* the end of the part's 38 ms pulse is no distance */
    run();
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == AIO_SONAR_NO_ECHO && readings == 3);
    /* the speed of sound: 300.0 m/s */
    CHECK(B(0x0B, 3, 0, 60, 0x0B, 0xB8), B(0x0B, 3, 0, 60, 0x0B, 0xB8));
    advance_us(30000);
    answer(4, 5, 2000);
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == 300u && readings == 4);
}

/* Two sonars: one at a time, in slot order; the next fires at once after an echo when
 * the period allows. */
static void sonar_in_turn(void)
{
    uint16_t dist, echo_us, readings;
    board();
    CHECK(B(0x0B, 3, 0, 1, 0x0D, 0x66), B(0x0B, 3, 0, 1, 0x0D, 0x66)); /* every 1 ms */
    CHECK(B(0x0B, 1, 0, 6, 7), B(0x0B, 1, 0, 6, 7)); /* fires at once */
    CHECK(B(0x0B, 1, 2, 8, 9), B(0x0B, 1, 2, 8, 9));
    run();
    EXPECT(fake_pin_level[6] == 1 && fake_pin_level[8] == 0); /* slot 0 first */
    advance_us(13);
    advance_us(5000); /* no echo yet: slot 2 must not fire */
    EXPECT(fake_pin_level[8] == 0);
    fake_drive(7, 1);
    fake_fine_now += 2u * 5831u; /* 1 m */
    fake_drive(7, 0);
    run();
    EXPECT(fake_pin_level[8] == 1 && fake_pin_level[6] == 0);
    answer(8, 9, 583);
    EXPECT(read_sonar(0, &dist, &echo_us, &readings) && dist == 1000u && readings == 1);
    EXPECT(read_sonar(2, &dist, &echo_us, &readings) && dist == 100u && readings == 1);
    EXPECT(fake_pin_level[6] == 0); /* 0.9 ms since slot 2 fired: the period is 1 ms */
    advance_us(110);
    EXPECT(fake_pin_level[6] == 1); /* back to slot 0 */
}

void test_sonar(void)
{
    sonar_errors();
    sonar_distances();
    sonar_in_turn();
}

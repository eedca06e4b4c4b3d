/*
 * pwm.c - PWM class (CT 0x05).
 *
 * D9/D10: Timer1 (hal_servo_*), 1 us resolution; OCR1x are double-buffered
 * by the hardware so a new width starts with the next period.
 *
 * D2-D7: software PWM, 1 us resolution.  Every 20 ms frame all pins with a
 * pulse go high together and each goes low after its width.  Each edge is an
 * alarm of Timer0 (0.5 us counts) scheduled from the previous edge's compare
 * match, so rise and fall have the same interrupt latency and the width is
 * exact to the count; pins with equal widths fall together.  Widths are
 * latched 128 us before a frame starts (so a running pulse is never cut short
 * or stretched) and put in time order in that gap, with interrupts enabled,
 * so the alarm itself only looks up the next edge.
 */
#include "pwm.h"

#include "duty.h"
#include "hal.h"
#include "pins.h"

#define SOFT_FIRST 2u
#define SOFT_COUNT 6u
#define FRAME_COUNTS ((uint16_t)(AIO_SERVO_PERIOD_US * HAL_FINE_PER_US))
#define LATCH_LEAD 256u /* counts before a frame when its widths are latched */
#define LATCH_AT ((uint16_t)(FRAME_COUNTS - LATCH_LEAD))
#define FIRST_ALARM 32u /* counts from starting the alarm to the first latch */

_Static_assert(AIO_PULSE_MAX_US * HAL_FINE_PER_US < LATCH_AT, "the last fall comes before the latch");
_Static_assert(AIO_SOFT_PWM_STEP_US * HAL_FINE_PER_US >= 1u, "a step is a whole number of counts");

static volatile uint16_t soft_next[SOFT_COUNT]; /* width in counts for the next frame, 0 = none */
static uint16_t soft_active[SOFT_COUNT];         /* width in counts in this frame (alarm only) */
static uint16_t soft_at;                         /* frame time of the pending edge (alarm only) */
static volatile uint8_t soft_running;            /* the edge alarm runs */
/* This frame's edges after the rise, in time order: frame time and the pins
 * that stay (keep mask); the last one is the latch (alarm only). */
static uint16_t fall_at[SOFT_COUNT + 1];
static uint8_t fall_keep[SOFT_COUNT + 1];
static uint8_t fall_next;
static uint8_t plan_due; /* the latched widths wait for pwm_soft_plan() */
volatile uint8_t pwm_soft_set, pwm_soft_keep;

void pwm_init(void)
{
    uint8_t i;
    for (i = 0; i < SOFT_COUNT; i++)
        soft_next[i] = soft_active[i] = 0;
    soft_running = 0;
    plan_due = 0;
    pwm_soft_set = 0;
    pwm_soft_keep = 0xFF;
}

static uint8_t is_soft(uint8_t pin) { return pins_capable(pin, AIO_PINS_SOFT_PWM); }

uint8_t pwm_check_pulse(uint8_t pin, uint16_t us)
{
    if (us == 0)
        return 0;
    if (us < AIO_PULSE_MIN_US || us > AIO_PULSE_MAX_US)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (is_soft(pin) && us % AIO_SOFT_PWM_STEP_US)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    return 0;
}

uint16_t pwm_soft_edge(void)
{
    uint16_t now = soft_at, w;
    uint8_t i, bit = 1u << SOFT_FIRST, mask = 0;

    pwm_soft_set = 0;
    if (now == LATCH_AT) {
        /* the next edge starts a frame: latch its widths (ordered later, by
         * pwm_soft_plan(), in the 128 us before the frame starts) */
        pwm_soft_keep = 0xFF;
        for (i = 0; i < SOFT_COUNT; i++, bit = (uint8_t)(bit << 1)) {
            w = soft_active[i] = soft_next[i];
            if (w)
                mask |= bit;
        }
        if (!mask) {
            soft_running = 0;
            return 0;
        }
        pwm_soft_set = mask;
        soft_at = 0;
        fall_next = 0;
        plan_due = 1;
        return LATCH_LEAD;
    }
    /* a rise or a fall went out: the next edge is planned already */
    i = fall_next++;
    pwm_soft_keep = fall_keep[i];
    soft_at = fall_at[i];
    return (uint16_t)(soft_at - now);
}

void pwm_soft_plan(void)
{
    uint16_t next, w, now = 0;
    uint8_t i, n = 0, bit, mask;

    if (!plan_due)
        return;
    plan_due = 0;
    /* the falls in time order: repeatedly the shortest width still ahead */
    for (;;) {
        next = LATCH_AT;
        mask = 0;
        for (i = 0, bit = 1u << SOFT_FIRST; i < SOFT_COUNT; i++, bit = (uint8_t)(bit << 1)) {
            w = soft_active[i];
            if (w <= now || w > next)
                continue;
            if (w < next) {
                next = w;
                mask = 0;
            }
            mask |= bit;
        }
        fall_at[n] = next;
        fall_keep[n] = (uint8_t)~mask; /* the latch: mask 0, nothing changes */
        n++;
        if (!mask)
            return;
        now = next;
    }
}

void pwm_set_pulse(uint8_t pin, uint16_t us)
{
    uint8_t s;
    if (!is_soft(pin)) {
        hal_servo_set(pin, us);
        return;
    }
    s = hal_irq_save();
    soft_next[pin - SOFT_FIRST] = (uint16_t)(us * HAL_FINE_PER_US);
    if (us && !soft_running) {
        soft_running = 1;
        soft_at = LATCH_AT;
        pwm_soft_set = 0;
        pwm_soft_keep = 0xFF;
        hal_softpwm_start(FIRST_ALARM);
    }
    hal_irq_restore(s);
}

void pwm_release(uint8_t pin)
{
    uint8_t s, bit;
    if (is_soft(pin)) {
        bit = (uint8_t)pins_bit_of(pin);
        s = hal_irq_save();
        soft_next[pin - SOFT_FIRST] = 0;
        soft_active[pin - SOFT_FIRST] = 0;
        pwm_soft_set &= (uint8_t)~bit; /* a pending rise leaves it low */
        hal_irq_restore(s);
        hal_softpwm_low(bit);
    } else {
        hal_servo_detach(pin);
    }
}

uint8_t pwm_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin = rq->data[0];
    uint16_t us = aio_be16(rq->data + 1);
    uint8_t err;

    if (rq->dt == AIO_DT_PWM_DUTY_CONFIG || rq->dt == AIO_DT_PWM_DUTY_SET)
        return duty_handle(rq, rp);
    if (rq->dt != AIO_DT_PWM_CONFIG && rq->dt != AIO_DT_PWM_SET)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (!pins_capable(pin, AIO_PINS_SOFT_PWM | AIO_PINS_SERVO_PWM))
        return AIO_ERR_PIN_NOT_CAPABLE;
    if (rq->dt == AIO_DT_PWM_CONFIG) {
        err = pins_claim_check(pin, AIO_PINS_SOFT_PWM | AIO_PINS_SERVO_PWM, ROLE_PWM, ROLE_PWM);
        if (!err && duty_timer_busy(is_soft(pin) ? DUTY_TIMER0 : DUTY_TIMER1))
            err = AIO_ERR_PIN_BUSY; /* duty PWM holds the timer the pulses need */
        if (!err)
            err = pwm_check_pulse(pin, us);
        if (err)
            return err;
        if (pins_role[pin] == ROLE_PWM) {
            pwm_set_pulse(pin, us);
        } else {
            pins_role[pin] = ROLE_PWM;
            if (is_soft(pin)) {
                hal_pin_mode(pin, HAL_OUT_LOW);
                pwm_set_pulse(pin, us);
            } else {
                hal_servo_attach(pin, us);
            }
        }
        return aio_echo(rq, rp);
    }
    /* SET */
    if (pins_role[pin] != ROLE_PWM)
        return AIO_ERR_PIN_NOT_CONFIGURED;
    err = pwm_check_pulse(pin, us);
    if (err)
        return err;
    pwm_set_pulse(pin, us);
    return aio_echo(rq, rp);
}

/*
 * pwm.c - PWM class (CT 0x05).
 *
 * D9/D10: Timer1 (hal_servo_*), 1 us resolution; OCR1x are double-buffered
 * by the hardware so a new width starts with the next period.
 * D2-D7: software PWM from the 100 us timebase.  Every 20 ms frame all pins
 * with a pulse go high together; each goes low after its width.  Widths are
 * latched at the start of a frame, so a running pulse is never cut short.
 */
#include "pwm.h"

#include "hal.h"
#include "pins.h"

#define SOFT_FIRST 2u
#define SOFT_COUNT 6u

static volatile uint8_t soft_next[SOFT_COUNT]; /* width in ticks for the next frame */
static uint8_t soft_active[SOFT_COUNT];         /* width in ticks in this frame (ISR only) */
static uint8_t frame_tick;                      /* ISR only */
static uint8_t soft_any;                        /* pins high in this frame (ISR only) */

void pwm_init(void)
{
    uint8_t i;
    for (i = 0; i < SOFT_COUNT; i++)
        soft_next[i] = soft_active[i] = 0;
    frame_tick = 0;
    soft_any = 0;
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

void pwm_set_pulse(uint8_t pin, uint16_t us)
{
    if (is_soft(pin))
        soft_next[pin - SOFT_FIRST] = (uint8_t)(us / AIO_SOFT_PWM_STEP_US);
    else
        hal_servo_set(pin, us);
}

void pwm_release(uint8_t pin)
{
    uint8_t s;
    if (is_soft(pin)) {
        s = hal_irq_save();
        soft_next[pin - SOFT_FIRST] = 0;
        soft_active[pin - SOFT_FIRST] = 0;
        hal_irq_restore(s);
        hal_softpwm_low((uint8_t)pins_bit_of(pin));
    } else {
        hal_servo_detach(pin);
    }
}

void pwm_tick(void)
{
    uint8_t i, mask = 0, bit = 1u << SOFT_FIRST, t;

    if (++frame_tick >= PWM_FRAME_TICKS)
        frame_tick = 0;
    t = frame_tick;
    if (t == 0) {
        for (i = 0; i < SOFT_COUNT; i++, bit = (uint8_t)(bit << 1)) {
            soft_active[i] = soft_next[i];
            if (soft_active[i])
                mask |= bit;
        }
        soft_any = mask;
        if (mask)
            hal_softpwm_high(mask);
        return;
    }
    if (!soft_any || t > AIO_PULSE_MAX_US / AIO_SOFT_PWM_STEP_US)
        return; /* no soft PWM pulse in this frame: nothing to end */
    for (i = 0; i < SOFT_COUNT; i++, bit = (uint8_t)(bit << 1))
        if (soft_active[i] == t)
            mask |= bit;
    if (mask)
        hal_softpwm_low(mask);
}

uint8_t pwm_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin = rq->data[0];
    uint16_t us = aio_be16(rq->data + 1);
    uint8_t err;

    if (!pins_capable(pin, AIO_PINS_SOFT_PWM | AIO_PINS_SERVO_PWM))
        return AIO_ERR_PIN_NOT_CAPABLE;
    if (rq->dt == AIO_DT_PWM_CONFIG) {
        err = pins_claim_check(pin, AIO_PINS_SOFT_PWM | AIO_PINS_SERVO_PWM, ROLE_PWM, ROLE_PWM);
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

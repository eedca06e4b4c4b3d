/* pwm.h - PWM class: servo pulses, Timer1 on D9/D10 and software PWM on D2-D7. */
#ifndef PWM_H
#define PWM_H

#include <stdint.h>

#include "aio.h"

#define PWM_FRAME_TICKS (AIO_SERVO_PERIOD_US / 100u) /* 200 ticks of 100 us */

void pwm_init(void);
uint8_t pwm_handle(const aio_request_t *rq, aio_reply_t *rp);
void pwm_release(uint8_t pin);
/* 0 if pulse_us is a valid width for pin (assumed PWM-capable), else VALUE_OUT_OF_RANGE. */
uint8_t pwm_check_pulse(uint8_t pin, uint16_t pulse_us);
/* New width of an attached pin; safe from interrupts (failsafe). */
void pwm_set_pulse(uint8_t pin, uint16_t pulse_us);
/* Timebase interrupt, every 100 us: software PWM. */
void pwm_tick(void);

#endif

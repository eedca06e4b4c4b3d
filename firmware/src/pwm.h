/* pwm.h - PWM class: servo pulses, Timer1 on D9/D10 and software PWM on D2-D7. */
#ifndef PWM_H
#define PWM_H

#include <stdint.h>

#include "aio.h"

void pwm_init(void);
uint8_t pwm_handle(const aio_request_t *rq, aio_reply_t *rp);
void pwm_release(uint8_t pin);
/* 0 if pulse_us is a valid width for pin (assumed PWM-capable), else VALUE_OUT_OF_RANGE. */
uint8_t pwm_check_pulse(uint8_t pin, uint16_t pulse_us);
/* New width of an attached pin; safe from interrupts (failsafe). */
void pwm_set_pulse(uint8_t pin, uint16_t pulse_us);

/* Software PWM edge alarm (hal_softpwm_start): the pending edge, applied by
 * the alarm as PORTD = (PORTD | pwm_soft_set) & pwm_soft_keep ... */
extern volatile uint8_t pwm_soft_set, pwm_soft_keep;
/* ... which then calls this: it prepares the next edge and returns the
 * alarm counts (HAL_FINE_PER_US a microsecond) from the one just applied to
 * it, or 0 when no pin has a pulse any more (the alarm stops). */
uint16_t pwm_soft_edge(void);
/* Called by the alarm, with interrupts enabled, after it scheduled an edge
 * 128 us or more ahead: the slow part of the schedule (ordering a frame's
 * falls) happens here. */
void pwm_soft_plan(void);

#endif

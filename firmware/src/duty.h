/* duty.h - duty-cycle PWM (CT 0x05, DUTY_CONFIG / DUTY_SET) on the timers' compare pins. */
#ifndef DUTY_H
#define DUTY_H

#include <stdint.h>

#include "aio.h"

/* Timer numbers (HAL argument). */
enum { DUTY_TIMER0 = 0, DUTY_TIMER1 = 1, DUTY_TIMER2 = 2, DUTY_TIMERS = 3 };

void duty_init(void);
uint8_t duty_handle(const aio_request_t *rq, aio_reply_t *rp);
void duty_release(uint8_t pin);
/* New duty (0..AIO_DUTY_FULL) of a pin with the duty role; safe from interrupts (failsafe). */
void duty_set(uint8_t pin, uint16_t duty);
/* Nonzero while duty PWM holds the timer: Timer0 then cannot run the fine alarms
 * (software PWM, stream sampling), Timer1 cannot run servo PWM. */
uint8_t duty_timer_busy(uint8_t timer);

#endif

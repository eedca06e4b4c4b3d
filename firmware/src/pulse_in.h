/* pulse_in.h - PULSE_IN class: high-pulse widths on any digital pin (RC receiver channels). */
#ifndef PULSE_IN_H
#define PULSE_IN_H

#include <stdint.h>

#include "aio.h"

#if AIO_WITH_PULSE_IN
void pulse_in_init(void);
uint8_t pulse_in_handle(const aio_request_t *rq, aio_reply_t *rp);
/* Ends the input on `pin`: the pin becomes free. */
void pulse_in_release(uint8_t pin);
/* Main loop: take the pulses the interrupt timed; signal lost/back events. */
void pulse_in_poll(void);
/* Stream: how many slots a sample carries (the highest configured slot + 1), and
 * their u16 width + u8 lost (1 also for a free slot) at p; interrupt context. */
uint8_t pulse_in_stream_slots(void);
uint8_t *pulse_in_put_stream(uint8_t *p, uint8_t n);
#else /* !AIO_WITH_PULSE_IN: the hooks other modules call do nothing */
static inline void pulse_in_init(void) {}
static inline void pulse_in_release(uint8_t pin) { (void)pin; }
static inline void pulse_in_poll(void) {}
#endif

#endif

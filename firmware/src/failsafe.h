/* failsafe.h - FAILSAFE class: link watchdog with safe output states (protocol.md 7.3). */
#ifndef FAILSAFE_H
#define FAILSAFE_H

#include <stdint.h>

#include "aio.h"

void failsafe_init(void);
uint8_t failsafe_handle(const aio_request_t *rq, aio_reply_t *rp);
/* Every valid request feeds the watchdog. */
void failsafe_feed(void);
uint8_t failsafe_tripped(void);
/* Whether failsafe_tick() has anything to watch (also read by the tick
 * interrupt's assembly, clock.c). */
uint8_t failsafe_armed(void);
extern volatile uint8_t failsafe_is_armed;
/* STATUS flags bits 0 and 1. */
uint8_t failsafe_status(void);
/* Timebase interrupt: checks the silence, trips. */
void failsafe_tick(void);
/* Main loop: sends a FAILSAFE_TRIPPED event the interrupt could not queue. */
void failsafe_poll(void);

#endif

/* clock.h - the timebase: Timer2 CTC, 100 us ticks (implements the time part of hal.h). */
#ifndef CLOCK_H
#define CLOCK_H

#include <stdint.h>

void clock_init(void);
/* hal_ticks() for callers that already run with interrupts disabled. */
uint16_t clock_ticks_isr(void);

/* The tick count itself (the receive interrupt copies its low half in assembly). */
extern volatile uint32_t clock_ticks;

#endif

/* clock.h - the timebase: Timer2 CTC, 100 us ticks (implements the time part of hal.h);
 * starts Timer0 free-running for the fine alarms of hal_avr.c. */
#ifndef CLOCK_H
#define CLOCK_H

#include <stdint.h>

void clock_init(void);
/* The tick count itself. */
extern volatile uint32_t clock_ticks;

#endif

/* pacing.h - the simulation paced to the wall clock, the event list and the
 * main loop (see pacing.c). */
#ifndef VIRTUAL_UNO_PACING_H
#define VIRTUAL_UNO_PACING_H

#include <stdint.h>

#include "json.h"

uint64_t now_ns(void);
uint64_t wall_cycles(uint64_t ns);
void rebase(void);
int64_t bridge_clock_phase(void); /* cycles: the bridge clocks' phase against the simulation's */
void catch_up_wall(void);
uint64_t stimulus_cycle(void);

/* harness events (not simavr cycle timers: avr_reset() cancels those) */
void schedule(uint64_t t);
void recompute_next_event(void);
void run_events(void);

void my_run(avr_t *a); /* installed as avr->run */
void run_paced(void);  /* the main loop, until pacing_quit() */
void pacing_quit(void); /* end the main loop (async-signal-safe) */

void pacing_start(void);              /* the wall clock's zero (status: wall_us) */
void pacing_status(struct sbuf *r);  /* its part of "status": ", key: value..." */

#endif

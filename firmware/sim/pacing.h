/* pacing.h - the simulation paced to the wall clock, the event list and the
 * main loop (see pacing.c). */
#ifndef VIRTUAL_UNO_PACING_H
#define VIRTUAL_UNO_PACING_H

#include <stdint.h>

/* statistics for the control channel's status */
extern uint64_t start_ns;
extern int64_t max_lag_cycles;
extern unsigned long rebase_count;
extern unsigned long runahead_jumps; /* host stimulus while running ahead: time base moved */
extern uint64_t runahead_jump_cycles;

uint64_t now_ns(void);
uint64_t wall_cycles(uint64_t ns);
void rebase(void);
extern int64_t bridge_clock_offset; /* cycles: the bridge clocks' phase against the simulation's */
void catch_up_wall(void);
uint64_t stimulus_cycle(void);

/* harness events (not simavr cycle timers: avr_reset() cancels those) */
extern uint64_t next_event;
void schedule(uint64_t t);
void recompute_next_event(void);
void run_events(void);

void my_run(avr_t *a); /* installed as avr->run */
void run_paced(void);  /* the main loop, until quit_flag */

#endif

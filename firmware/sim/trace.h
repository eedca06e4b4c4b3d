/* trace.h - timestamped harness events for finding where a round trip's time
 * goes (see trace.c); off unless $VIRTUAL_UNO_TRACE names a file. */
#ifndef VIRTUAL_UNO_TRACE_H
#define VIRTUAL_UNO_TRACE_H

#include <stdint.h>

extern int trace_on;

void trace_open(void);
void trace_event_(char kind, uint64_t arg);
/* For a write: the time taken just before it, so a host that reads the bytes can never
 * have seen them before the record's time (the record after the write could be later
 * than the host's own timestamp of the read). */
uint64_t trace_clock(void);
void trace_event_at_(char kind, uint64_t arg, uint64_t ns);
void trace_close(void);

/* One record: wall time (CLOCK_MONOTONIC, comparable with the host's
 * time.monotonic_ns()), simulated cycle, and the simulation's lead over the
 * wall clock at that moment. */
static inline void trace_event(char kind, uint64_t arg)
{
	if (trace_on)
		trace_event_(kind, arg);
}

#endif

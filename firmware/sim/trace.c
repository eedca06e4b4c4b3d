/*
 * trace.c - a debugging aid: with $VIRTUAL_UNO_TRACE=FILE the harness keeps a
 * record of every pty read and write, byte injection, UDR write and wait
 * (wall time, simulated cycle, lead over the wall clock) in memory and writes
 * them to FILE as text at exit, one "kind wall_ns cycle lead_cycles arg" line
 * each.  Joined with host-side timestamps (CLOCK_MONOTONIC on both sides) it
 * shows where a round trip's time goes: host write -> pty read, simulated
 * work, pty write -> host read.  Costs one branch per event when off.
 */
#include "harness.h"

#include <stdio.h>
#include <stdlib.h>

#include "pacing.h"
#include "trace.h"

#define TRACE_MAX (1u << 20)

struct trace_record {
	uint64_t ns, cycle;
	int64_t lead;
	uint64_t arg;
	char kind;
};

int trace_on;
static struct trace_record *records;
static unsigned nrecords;
static const char *trace_path;

void trace_open(void)
{
	trace_path = getenv("VIRTUAL_UNO_TRACE");
	if (!trace_path || !*trace_path)
		return;
	records = calloc(TRACE_MAX, sizeof(*records));
	trace_on = records != NULL;
}

void trace_event_(char kind, uint64_t arg)
{
	trace_event_at_(kind, arg, now_ns());
}

uint64_t trace_clock(void)
{
	return now_ns();
}

void trace_event_at_(char kind, uint64_t arg, uint64_t ns)
{
	if (nrecords >= TRACE_MAX)
		return;
	struct trace_record *r = &records[nrecords++];
	r->ns = ns;
	r->cycle = avr ? avr->cycle : 0;
	r->lead = (int64_t)r->cycle - (int64_t)wall_cycles(r->ns);
	r->arg = arg;
	r->kind = kind;
}

void trace_close(void)
{
	if (!trace_on)
		return;
	FILE *f = fopen(trace_path, "w");
	if (f) {
		for (unsigned i = 0; i < nrecords; i++) {
			struct trace_record *r = &records[i];
			fprintf(f, "%c %llu %llu %lld %llu\n", r->kind, (unsigned long long)r->ns,
				(unsigned long long)r->cycle, (long long)r->lead,
				(unsigned long long)r->arg);
		}
		fclose(f);
	}
	free(records);
	trace_on = 0;
}

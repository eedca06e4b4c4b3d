/*
 * stack.c - how deep the firmware's stack has been: paint the free RAM below
 * the stack pointer with a pattern, run the workload, find the lowest byte the
 * stack overwrote (the firmware does not paint its own stack).
 *
 *   stack_paint {from}   fill data[from .. SP] with 0xA5 (the bytes below the
 *                        stack pointer are free at that instant: the harness
 *                        runs between instructions); from = the end of .bss
 *   stack_low {from}     lowest = the first byte from `from` up that is no
 *                        longer 0xA5, sp = the stack pointer now, ramend;
 *                        free_min = lowest - from: the stack margin measured
 */
#include "harness.h"

#include "json.h"
#include "stack.h"

#define PAINT 0xA5
#define SPL 0x5D /* data addresses of SPL/SPH */

static int stack_pointer(void) { return avr->data[SPL] | avr->data[SPL + 1] << 8; }

void cmd_stack_paint(struct jobj *o, struct sbuf *r)
{
	double from = 0;
	int sp = stack_pointer();
	if (!get_num(o, "from", &from) || from < 0x100 || from >= sp) {
		sb_add(r, "{\"ok\": false, \"error\": \"stack_paint needs from (end of .bss) below SP\"}");
		return;
	}
	for (int a = (int)from; a <= sp; a++)
		avr->data[a] = PAINT;
	sb_add(r, "{\"ok\": true, \"sp\": %d, \"painted\": %d}", sp, sp + 1 - (int)from);
}

void cmd_stack_low(struct jobj *o, struct sbuf *r)
{
	double from = 0;
	if (!get_num(o, "from", &from) || from < 0x100 || from > avr->ramend) {
		sb_add(r, "{\"ok\": false, \"error\": \"stack_low needs from\"}");
		return;
	}
	int a = (int)from;
	while (a <= (int)avr->ramend && avr->data[a] == PAINT)
		a++;
	sb_add(r, "{\"ok\": true, \"lowest\": %d, \"sp\": %d, \"ramend\": %d, \"free_min\": %d}", a,
	       stack_pointer(), (int)avr->ramend, a - (int)from);
}

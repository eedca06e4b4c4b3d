/*
 * rcpulse.c - RC pulse sources: what a receiver's channel drives into the Uno (a high
 * pulse of `width_us` every `period_us`), with ground truth for the tests.
 *
 * {"cmd": "rcpulse", "pin": 4, "width_us": 1500, "period_us": 20000, "count": N} starts
 * (or, on the same pin, changes: the next pulse has the new width) a source; count 0 runs
 * until "rcpulse_stop" (which stops every source, or the one on "pin", between pulses:
 * the line low, as a receiver that lost its transmitter).  The edges run from the
 * harness's event list, exact to the instruction, as driven levels (circuit_set_driven).
 * Ground truth ("rcpulse_status"): per source the pulses completed, the last completed
 * pulse's width in microseconds (the cycles it was high / 16) and when it ended.
 */
#include "harness.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "circuit.h"
#include "json.h"
#include "pacing.h"
#include "pty.h"
#include "rcpulse.h"

#define NRC 6

struct rcsrc {
	int used, active, pin, high;
	unsigned long long pulses, left;  /* completed; still to start (0: no end) */
	uint64_t width_c, period_c, next_t, rise_t;
	uint64_t last_width_c, last_end_t;
};

static struct rcsrc s[NRC];

int rcpulse_running(void)
{
	for (int i = 0; i < NRC; i++)
		if (s[i].active)
			return 1;
	return 0;
}

void schedule_rcpulse(void)
{
	for (int i = 0; i < NRC; i++)
		if (s[i].active)
			schedule(s[i].next_t);
}

int run_rcpulse(uint64_t now)
{
	int progress = 0;
	for (int i = 0; i < NRC; i++) {
		struct rcsrc *g = &s[i];
		if (!g->active || g->next_t > now)
			continue;
		if (!g->high) {
			g->high = 1;
			g->rise_t = now;
			circuit_set_driven(g->pin, 1);
			g->next_t = now + g->width_c;
		} else {
			g->high = 0;
			circuit_set_driven(g->pin, 0);
			g->pulses++;
			g->last_width_c = now - g->rise_t;
			g->last_end_t = now;
			g->next_t = g->rise_t + g->period_c;
			if (g->next_t <= now)
				g->next_t = now + 1;
			if (g->left && !--g->left)
				g->active = 0;
		}
		apply_circuit();
		progress = 1;
	}
	return progress;
}

static int pin_of(struct jobj *o)
{
	struct jval *v = jget(o, "pin");
	int n = -1;
	if (v && v->type == J_NUM)
		n = (int)v->num;
	else if (v && v->type == J_STR && (v->str[0] == 'D' || v->str[0] == 'd'))
		n = atoi(v->str + 1);
	return n >= 2 && n < 14 ? n : -1;
}

static double num_or(struct jobj *o, const char *k, double dflt)
{
	double x;
	return get_num(o, k, &x) ? x : dflt;
}

/* {"cmd": "rcpulse", "pin": P, "width_us": W, "period_us": T, "count": N} */
void cmd_rcpulse(struct jobj *o, struct sbuf *r)
{
	int pin = pin_of(o);
	double width = num_or(o, "width_us", 1500), period = num_or(o, "period_us", 20000);
	double count = num_or(o, "count", 0);
	struct rcsrc *g = NULL;

	if (pin < 0 || width < 1 || period < width + 1 || period > 1e7 || count < 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"rcpulse needs pin (D2..D13), width_us>=1, "
			  "width_us < period_us <= 1e7, count>=0\"}");
		return;
	}
	if (!pty_plugged() || is_out(pin) || loop_partner(pin) >= 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"the pin is not a free input (output, jumpered or unplugged)\"}");
		return;
	}
	for (int i = 0; i < NRC && !g; i++)
		if (s[i].used && s[i].pin == pin)
			g = &s[i];
	for (int i = 0; i < NRC && !g; i++)
		if (!s[i].used || !s[i].active)
			g = &s[i];
	if (!g) {
		sb_add(r, "{\"ok\": false, \"error\": \"all %d sources are running\"}", NRC);
		return;
	}
	if (!g->used || g->pin != pin) {
		g->pulses = 0;
		g->last_width_c = g->last_end_t = 0;
		g->high = 0;
	}
	g->width_c = (uint64_t)llround(width * CYC_PER_US);
	g->period_c = (uint64_t)llround(period * CYC_PER_US);
	g->left = (unsigned long long)count;
	g->pin = pin;
	if (!g->active || !g->used) {
		g->high = 0;
		g->next_t = avr->cycle + 16;
		circuit_set_driven(pin, 0);
		apply_circuit();
	}
	g->used = g->active = 1;
	recompute_next_event();
	sb_add(r, "{\"ok\": true}");
}

/* {"cmd": "rcpulse_status"}: every source's ground truth */
void cmd_rcpulse_status(struct jobj *o, struct sbuf *r)
{
	int first = 1;
	(void)o;
	sb_add(r, "{\"ok\": true, \"sim_us\": %.3f, \"sources\": [", (double)avr->cycle / CYC_PER_US);
	for (int i = 0; i < NRC; i++) {
		struct rcsrc *g = &s[i];
		if (!g->used)
			continue;
		sb_add(r, "%s{\"pin\": %d, \"active\": %s, \"pulses\": %llu, \"width_us\": %.3f, "
			  "\"period_us\": %.3f, \"last_width_us\": %.3f, \"last_end_us\": %.3f}",
		       first ? "" : ", ", g->pin, g->active ? "true" : "false", g->pulses,
		       (double)g->width_c / CYC_PER_US, (double)g->period_c / CYC_PER_US,
		       (double)g->last_width_c / CYC_PER_US, (double)g->last_end_t / CYC_PER_US);
		first = 0;
	}
	sb_add(r, "]}");
}

/* {"cmd": "rcpulse_stop", "pin": P (optional)}: stop after the pulse under way */
void cmd_rcpulse_stop(struct jobj *o, struct sbuf *r)
{
	int pin = pin_of(o);
	for (int i = 0; i < NRC; i++) {
		if (!s[i].active || (pin >= 0 && s[i].pin != pin))
			continue;
		if (s[i].high) {
			s[i].left = 1; /* the pulse under way ends whole */
		} else
			s[i].active = 0;
	}
	recompute_next_event();
	sb_add(r, "{\"ok\": true}");
}

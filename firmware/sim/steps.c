/*
 * steps.c - what a stepper test needs from the circuit: every step pulse of a
 * pin with its simulated time (not just the last 32 of the pulse capture), so
 * a test counts a 10,000-step move exactly and derives speed and acceleration
 * from the step times; and a limit switch that closes at a chosen step, so a
 * test knows the exact simulated instant it closed.
 *
 *   step_log {pin, enable}  start (clear) or stop logging pin's rising edges
 *   steps {pin, from}       count (logged rises), times_us[from..] (at most
 *                           20,000 a reply; ask again from where it ended),
 *                           limit_us: when the first limit_at on this pin
 *                           fired, or null; fired_us: every one that fired
 *   limit_at {pin, after, drive, level}
 *                           once pin's log holds `after` rises, drive pin
 *                           `drive` to `level` (as the drive command), at the
 *                           instant of that rise; up to 4 per log (a switch
 *                           that closes, then opens again as the axis leaves)
 *
 * The logs are this module's own state; its part of `status` is step_logs (the
 * steps logged on each logging pin).
 */
#include "harness.h"

#include <stdlib.h>
#include <string.h>

#include "circuit.h"
#include "json.h"
#include "steps.h"

#define REPLY_MAX 20000u
#define NTRIG 4

struct steplog {
	int on;
	uint64_t *t;
	size_t n, cap;
	struct trigger {
		int armed, drive_pin, drive_to, fired;
		unsigned long after;
		uint64_t fired_t;
	} trig[NTRIG];
	int ntrig;
};
static struct steplog logs[NPINS];

static int pin_of(struct jobj *o, const char *k)
{
	struct jval *v = jget(o, k);
	if (!v)
		return -1;
	if (v->type == J_NUM)
		return v->num >= 0 && v->num < NPINS ? (int)v->num : -1;
	if (v->type == J_STR && (v->str[0] == 'D' || v->str[0] == 'd')) {
		int n = atoi(v->str + 1);
		return n >= 0 && n < 14 ? n : -1;
	}
	return -1;
}

void steps_rise(int p, uint64_t t)
{
	struct steplog *l = &logs[p];
	if (!l->on)
		return;
	if (l->n == l->cap) {
		size_t cap = l->cap ? 2 * l->cap : 4096;
		uint64_t *nt = realloc(l->t, cap * sizeof *nt);
		if (!nt)
			return;
		l->t = nt;
		l->cap = cap;
	}
	l->t[l->n++] = t;
	for (int k = 0; k < l->ntrig; k++) {
		struct trigger *g = &l->trig[k];
		if (g->armed && l->n >= g->after) {
			g->armed = 0;
			g->fired = 1;
			g->fired_t = t;
			circuit_drive(g->drive_pin, g->drive_to);
		}
	}
}

void cmd_step_log(struct jobj *o, struct sbuf *r)
{
	int p = pin_of(o, "pin");
	double en = 1;
	if (p < 2 || p >= 14) {
		sb_add(r, "{\"ok\": false, \"error\": \"step_log needs pin D2..D13\"}");
		return;
	}
	get_num(o, "enable", &en);
	struct steplog *l = &logs[p];
	free(l->t);
	memset(l, 0, sizeof *l);
	l->on = en != 0;
	sb_add(r, "{\"ok\": true}");
}

void cmd_steps(struct jobj *o, struct sbuf *r)
{
	int p = pin_of(o, "pin");
	double from = 0;
	if (p < 2 || p >= 14) {
		sb_add(r, "{\"ok\": false, \"error\": \"steps needs pin D2..D13\"}");
		return;
	}
	get_num(o, "from", &from);
	struct steplog *l = &logs[p];
	size_t i = from > 0 ? (size_t)from : 0, end = l->n;
	if (end > i + REPLY_MAX)
		end = i + REPLY_MAX;
	sb_add(r, "{\"ok\": true, \"count\": %zu, \"from\": %zu, \"limit_us\": ", l->n, i);
	if (l->ntrig && l->trig[0].fired)
		sb_add(r, "%.3f", (double)l->trig[0].fired_t / CYC_PER_US);
	else
		sb_add(r, "null");
	sb_add(r, ", \"fired_us\": [");
	for (int k = 0, first = 1; k < l->ntrig; k++)
		if (l->trig[k].fired) {
			sb_add(r, "%s%.3f", first ? "" : ", ", (double)l->trig[k].fired_t / CYC_PER_US);
			first = 0;
		}
	sb_add(r, "], \"times_us\": [");
	for (size_t k = i; k < end; k++)
		sb_add(r, "%s%.3f", k > i ? ", " : "", (double)l->t[k] / CYC_PER_US);
	sb_add(r, "]}");
}

void cmd_limit_at(struct jobj *o, struct sbuf *r)
{
	int p = pin_of(o, "pin"), d = pin_of(o, "drive");
	double after, level;
	if (p < 2 || p >= 14 || d < 2 || !get_num(o, "after", &after) || after < 1 ||
	    !get_num(o, "level", &level) || loop_partner(d) >= 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"limit_at needs pin, after>=1, drive (a free pin), level\"}");
		return;
	}
	struct steplog *l = &logs[p];
	if (!l->on) {
		sb_add(r, "{\"ok\": false, \"error\": \"limit_at needs a step_log on pin\"}");
		return;
	}
	if (l->ntrig == NTRIG) {
		sb_add(r, "{\"ok\": false, \"error\": \"limit_at: at most 4 triggers a log\"}");
		return;
	}
	struct trigger *g = &l->trig[l->ntrig++];
	g->armed = 1;
	g->fired = 0;
	g->after = (unsigned long)after;
	g->drive_pin = d;
	g->drive_to = level != 0;
	sb_add(r, "{\"ok\": true}");
}

void steps_status(struct sbuf *r)
{
	sb_add(r, ", \"step_logs\": {");
	for (int p = 0, first = 1; p < NPINS; p++)
		if (logs[p].on) {
			sb_add(r, "%s\"D%d\": %zu", first ? "" : ", ", p, logs[p].n);
			first = 0;
		}
	sb_add(r, "}");
}

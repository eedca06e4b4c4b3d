/*
 * sonar_model.c - HC-SR04 style ultrasonic rangers: a trigger pin the Uno drives and an
 * echo pin the model drives, with ground truth for the tests.
 *
 * {"cmd": "sonar", "trigger": 7, "echo": 8, "distance_mm": 500} adds (or, on the same
 * trigger pin, changes) a sonar; "distance_mm" 0 or beyond "range_mm" (default 4000) is
 * "nothing in range".  Like the part: a trigger pulse of >= 10 us high starts a
 * measurement at its falling edge; "delay_us" later (default 300: the part's 8-cycle
 * 40 kHz burst and its processing) the echo pin goes high for the sound's round trip,
 * 2 * distance / speed ("speed_m_s", default 343.0: 58.3 us per cm), or for
 * "noecho_us" (default 38000) when nothing is in range.  A trigger while the sonar's
 * own measurement runs is ignored (counted), a shorter one too.
 *
 * Ground truth ("sonar_status"): per sonar the triggers seen (with their times and
 * widths, the last 16), the echo widths sent in microseconds, measured in cycles, and
 * "overlaps": triggers that came while another sonar's ping could still be heard (until
 * its echo fell, or with nothing in range until the sound could have come back from
 * "range_mm": not for the rest of the part's 38 ms "nothing heard" pulse).  A firmware
 * that fires in turn never makes one.
 */
#include "harness.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "circuit.h"
#include "json.h"
#include "pacing.h"
#include "pty.h"
#include "sonar_model.h"

#define NSONAR 4
#define NLOG 16

enum { IDLE, DELAY, ECHO };

struct sonar {
	int used, trig, echo, trig_high, state, no_echo;
	double dist_mm, range_mm, speed, delay_us, noecho_us;
	uint64_t trig_rise_t, next_t, width_c, echo_rise_t;
	uint64_t hears_until; /* its ping can be heard until then */
	unsigned long long triggers, short_triggers, ignored, echoes, no_echoes;
	double last_echo_us;
	struct { double at_us, width_us, echo_us; } log[NLOG]; /* echo_us -1: none yet, 0: no echo */
	int log_next, log_n;
};

static struct sonar s[NSONAR];
static unsigned long long overlaps;

static int busy(const struct sonar *g) { return g->used && g->state != IDLE; }

void sonar_model_edge(int p, int level, uint64_t t)
{
	for (int i = 0; i < NSONAR; i++) {
		struct sonar *g = &s[i];
		if (!g->used || g->trig != p)
			continue;
		if (level) {
			g->trig_high = 1;
			g->trig_rise_t = t;
			continue;
		}
		if (!g->trig_high)
			continue;
		g->trig_high = 0;
		double width_us = (double)(t - g->trig_rise_t) / CYC_PER_US;
		g->triggers++;
		int k = g->log_next;
		g->log[k].at_us = (double)g->trig_rise_t / CYC_PER_US;
		g->log[k].width_us = width_us;
		g->log[k].echo_us = -1;
		g->log_next = (k + 1) % NLOG;
		if (g->log_n < NLOG)
			g->log_n++;
		if (width_us < 10.0) {
			g->short_triggers++;
			continue;
		}
		if (g->state != IDLE) {
			g->ignored++;
			continue;
		}
		for (int j = 0; j < NSONAR; j++)
			if (j != i && busy(&s[j]) && t < s[j].hears_until)
				overlaps++;
		g->no_echo = !(g->dist_mm > 0 && g->dist_mm <= g->range_mm);
		double echo_us = g->no_echo ? g->noecho_us : 2.0 * g->dist_mm / g->speed * 1000.0;
		double heard_us = g->no_echo ? 2.0 * g->range_mm / g->speed * 1000.0 : echo_us;
		g->width_c = (uint64_t)llround(echo_us * CYC_PER_US);
		g->state = DELAY;
		g->next_t = t + (uint64_t)llround(g->delay_us * CYC_PER_US);
		g->hears_until = g->next_t + (uint64_t)llround(heard_us * CYC_PER_US);
		schedule(g->next_t);
	}
}

void schedule_sonar_model(void)
{
	for (int i = 0; i < NSONAR; i++)
		if (busy(&s[i]))
			schedule(s[i].next_t);
}

int run_sonar_model(uint64_t now)
{
	int progress = 0;
	for (int i = 0; i < NSONAR; i++) {
		struct sonar *g = &s[i];
		if (!busy(g) || g->next_t > now)
			continue;
		if (g->state == DELAY) {
			g->state = ECHO;
			circuit_set_driven(g->echo, 1);
			g->echo_rise_t = now;
			g->next_t = now + g->width_c;
		} else {
			g->state = IDLE;
			circuit_set_driven(g->echo, 0);
			g->last_echo_us = g->no_echo ? 0.0 : (double)(now - g->echo_rise_t) / CYC_PER_US;
			if (g->no_echo)
				g->no_echoes++;
			else
				g->echoes++;
			g->log[(g->log_next + NLOG - 1) % NLOG].echo_us = g->last_echo_us;
		}
		apply_circuit();
		progress = 1;
	}
	return progress;
}

static int pin_arg(struct jobj *o, const char *k)
{
	struct jval *v = jget(o, k);
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

/* {"cmd": "sonar", "trigger": T, "echo": E, "distance_mm": D, ...} */
void cmd_sonar(struct jobj *o, struct sbuf *r)
{
	int trig = pin_arg(o, "trigger"), echo = pin_arg(o, "echo");
	struct sonar *g = NULL;

	for (int i = 0; i < NSONAR && !g; i++)
		if (s[i].used && s[i].trig == trig)
			g = &s[i];
	if (g && echo < 0)
		echo = g->echo;
	double dist = num_or(o, "distance_mm", g ? g->dist_mm : 0);
	double range = num_or(o, "range_mm", g ? g->range_mm : 4000);
	double speed = num_or(o, "speed_m_s", g ? g->speed : 343.0);
	double delay = num_or(o, "delay_us", g ? g->delay_us : 300);
	double noecho = num_or(o, "noecho_us", g ? g->noecho_us : 38000);
	if (trig < 0 || echo < 0 || trig == echo || dist < 0 || range <= 0 || speed < 100 ||
	    speed > 1000 || delay < 0 || delay > 1e5 || noecho < 1 || noecho > 1e6) {
		sb_add(r, "{\"ok\": false, \"error\": \"sonar needs trigger and echo (D2..D13, "
			  "different), distance_mm>=0, range_mm>0, 100<=speed_m_s<=1000, "
			  "0<=delay_us<=1e5, 1<=noecho_us<=1e6\"}");
		return;
	}
	if (!pty_plugged() || is_out(echo) || loop_partner(echo) >= 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"the echo pin is not a free input (output, jumpered or unplugged)\"}");
		return;
	}
	for (int i = 0; i < NSONAR && !g; i++)
		if (!s[i].used)
			g = &s[i];
	if (!g) {
		sb_add(r, "{\"ok\": false, \"error\": \"all %d sonars are in use\"}", NSONAR);
		return;
	}
	if (!g->used || g->echo != echo) {
		struct sonar fresh = {0};
		*g = fresh;
		g->used = 1;
		g->trig = trig;
		g->echo = echo;
		g->trig_high = pin_level(trig);
		circuit_set_driven(echo, 0);
		apply_circuit();
	}
	g->dist_mm = dist;
	g->range_mm = range;
	g->speed = speed;
	g->delay_us = delay;
	g->noecho_us = noecho;
	recompute_next_event();
	sb_add(r, "{\"ok\": true}");
}

/* {"cmd": "sonar_status"}: every sonar's ground truth */
void cmd_sonar_status(struct jobj *o, struct sbuf *r)
{
	int first = 1;
	(void)o;
	sb_add(r, "{\"ok\": true, \"sim_us\": %.3f, \"overlaps\": %llu, \"sonars\": [",
	       (double)avr->cycle / CYC_PER_US, overlaps);
	for (int i = 0; i < NSONAR; i++) {
		struct sonar *g = &s[i];
		if (!g->used)
			continue;
		sb_add(r, "%s{\"trigger\": %d, \"echo\": %d, \"distance_mm\": %.3f, \"busy\": %s, "
			  "\"triggers\": %llu, \"short_triggers\": %llu, \"ignored\": %llu, "
			  "\"echoes\": %llu, \"no_echoes\": %llu, \"last_echo_us\": %.3f, \"log\": [",
		       first ? "" : ", ", g->trig, g->echo, g->dist_mm, busy(g) ? "true" : "false",
		       g->triggers, g->short_triggers, g->ignored, g->echoes, g->no_echoes,
		       g->last_echo_us);
		for (int k = 0; k < g->log_n; k++) {
			int j = (g->log_next + NLOG - g->log_n + k) % NLOG;
			sb_add(r, "%s{\"at_us\": %.3f, \"width_us\": %.3f, \"echo_us\": %.3f}", k ? ", " : "",
			       g->log[j].at_us, g->log[j].width_us, g->log[j].echo_us);
		}
		sb_add(r, "]}");
		first = 0;
	}
	sb_add(r, "]}");
}

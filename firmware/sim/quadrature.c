/*
 * quadrature.c - quadrature signal generators on any pin pair: what a turning
 * encoder drives into the Uno, with its ground truth for the tests.
 *
 * A generator steps its position one quarter cycle per edge (AB = 00, 10, 11,
 * 01 going forward: A leads B, the firmware's forward), `rate` edges per
 * simulated second, each interval stretched or shrunk by up to `jitter` of
 * it (uniform), reversing with probability `reverse` at each edge.  Optional
 * faults, each counted: every `skip_every` edges a double step (both pins at
 * once: an invalid transition the board must count), every `glitch_every`
 * edges a pulse of `glitch_us` on one pin that returns (no net motion).
 * The position (quarter steps) is the oracle: `quadrature_status`.
 *
 * The levels go out as driven levels (circuit_set_driven), so the rest of the
 * circuit treats them like `drive`; the edges run from the harness's event
 * list, exact to the instruction.  Each generator has its own PRNG (seeded by
 * the request), so a run repeats and the line-fault PRNG is not disturbed.
 * The generators are this module's own state: the control commands below set
 * them up and read them, quadrature_status() reports them in "status".
 */
#include "harness.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "circuit.h"
#include "json.h"
#include "pacing.h"
#include "pty.h"
#include "quadrature.h"

#define NQUAD 4

struct quadgen {
	int used, active, a, b, dir;
	long long position;            /* quarter steps: the ground truth */
	unsigned long long left, edges; /* edges still to make, made */
	unsigned long long reversals, skips, glitches;
	double period_c, jitter, reverse;
	unsigned long skip_every, glitch_every, since_skip, since_glitch;
	uint64_t glitch_c, next_t, glitch_end_t;
	uint64_t max_late_c;           /* the latest an edge was applied after its due cycle */
	int glitch_pin;                /* -1: none in progress */
	uint64_t rng;
	/* interrupt latency (quadrature_vector_taken): per pin (0 = A, 1 = B) the cycle of its
	 * first edge the pin's vector has not yet been entered for (0: none), and where the
	 * CPU was then; the worst wait so far, with that place */
	uint64_t pend_c[2];
	uint32_t pend_pc[2];
	int pend_i[2];
	uint64_t max_irq_c;
	uint32_t max_irq_pc;
	int max_irq_i;
	unsigned long long irq_waits;  /* edges whose vector was entered (the measured ones) */
	int lv[2];                     /* the levels last driven on A, B (-1: none yet) */
};

static struct quadgen q[NQUAD];

static double unit(struct quadgen *g)
{
	g->rng ^= g->rng >> 12;
	g->rng ^= g->rng << 25;
	g->rng ^= g->rng >> 27;
	return (double)((g->rng * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

/* AB at a position: 00, 10, 11, 01 */
static int level_at(const struct quadgen *g, int pin)
{
	static const int A[4] = {0, 1, 1, 0}, B[4] = {0, 0, 1, 1};
	int p = (int)(((g->position % 4) + 4) % 4);
	return pin == g->a ? A[p] : B[p];
}

/* The first edge on pin k (0 = A, 1 = B) not yet answered by its vector. */
static void pend(struct quadgen *g, int k)
{
	if (!g->pend_c[k]) {
		g->pend_c[k] = avr->cycle ? avr->cycle : 1;
		g->pend_pc[k] = avr->pc;
		g->pend_i[k] = avr->sreg[S_I];
	}
}

static void put_levels(struct quadgen *g)
{
	int la = level_at(g, g->a), lb = level_at(g, g->b);
	if (g->active && g->lv[0] >= 0 && g->lv[0] != la)
		pend(g, 0);
	if (g->active && g->lv[1] >= 0 && g->lv[1] != lb)
		pend(g, 1);
	g->lv[0] = la;
	g->lv[1] = lb;
	circuit_set_driven(g->a, la);
	circuit_set_driven(g->b, lb);
}

int quadrature_running(void)
{
	for (int i = 0; i < NQUAD; i++)
		if (q[i].active)
			return 1;
	return 0;
}

void schedule_quadrature(void)
{
	for (int i = 0; i < NQUAD; i++) {
		if (!q[i].active)
			continue;
		schedule(q[i].next_t);
		if (q[i].glitch_pin >= 0)
			schedule(q[i].glitch_end_t);
	}
}

static void next_interval(struct quadgen *g)
{
	double f = 1.0 + g->jitter * (2.0 * unit(g) - 1.0);
	uint64_t c = (uint64_t)llround(g->period_c * f);
	g->next_t += c ? c : 1;
}

/* One edge (or double step) of generator g at its due time. */
static void edge(struct quadgen *g)
{
	if (g->edges && g->reverse > 0 && unit(g) < g->reverse) {
		g->dir = -g->dir;
		g->reversals++;
	}
	if (g->skip_every && ++g->since_skip >= g->skip_every && g->left >= 2) {
		g->since_skip = 0;
		g->position += 2 * g->dir; /* both pins change at once */
		g->skips++;
		g->left -= 2;
		g->edges += 2;
	} else {
		g->position += g->dir;
		g->left--;
		g->edges++;
	}
	put_levels(g);
	if (g->glitch_every && ++g->since_glitch >= g->glitch_every && g->left) {
		g->since_glitch = 0;
		/* a pulse on the pin that did not just change, back before the next edge */
		int p = (g->position & 1) ? g->b : g->a;
		int k = p == g->b;
		pend(g, k);
		g->lv[k] = !level_at(g, p);
		circuit_set_driven(p, g->lv[k]);
		g->glitch_pin = p;
		g->glitch_end_t = avr->cycle + g->glitch_c;
		g->glitches++;
	}
	if (!g->left)
		g->active = 0;
	else
		next_interval(g);
}

int run_quadrature(uint64_t now)
{
	int progress = 0;
	for (int i = 0; i < NQUAD; i++) {
		struct quadgen *g = &q[i];
		if (!g->active)
			continue;
		if (g->glitch_pin >= 0 && g->glitch_end_t <= now) {
			put_levels(g); /* the glitch ends: the position's levels again */
			g->glitch_pin = -1;
			apply_circuit();
			progress = 1;
		}
		if (g->next_t <= now) {
			if (now - g->next_t > g->max_late_c)
				g->max_late_c = now - g->next_t;
			if (g->glitch_pin >= 0)
				g->glitch_pin = -1; /* an edge ends a glitch too */
			edge(g);
			apply_circuit();
			progress = 1;
		}
	}
	return progress;
}

/* The interrupt vector number that answers a change of harness pin p now (0: none):
 * the external interrupt when its EIMSK bit is set (the Uno's D2/D3 = INT0/INT1, the
 * Mega's D2/D3 = INT4/INT5), else the pin's pin-change group. */
#define EIMSK_ADDR 0x3D
static unsigned vector_of_pin(int p)
{
	uint8_t eimsk = avr->data[EIMSK_ADDR];
	if (opt->mega2560) {
		if (p == 2 && (eimsk & 0x10u)) return 5;
		if (p == 3 && (eimsk & 0x20u)) return 6;
		if (p >= 10 && p <= 13) return 9;   /* PB4-7: PCINT0 */
		if (p == 14 || p == 15) return 10;  /* PJ1/PJ0: PCINT1 */
		return 0;
	}
	if (p == 2 && (eimsk & 0x01u)) return 1;
	if (p == 3 && (eimsk & 0x02u)) return 2;
	if (p <= 7) return 5;  /* PCINT2 */
	if (p <= 13) return 3; /* PCINT0 */
	return 4;              /* PCINT1 */
}

void quadrature_vector_taken(unsigned vector, uint64_t cycle)
{
	for (int i = 0; i < NQUAD; i++) {
		struct quadgen *g = &q[i];
		if (!g->used)
			continue;
		for (int k = 0; k < 2; k++) {
			if (!g->pend_c[k] || vector_of_pin(k ? g->b : g->a) != vector)
				continue;
			uint64_t waited = cycle - g->pend_c[k];
			g->irq_waits++;
			if (waited > g->max_irq_c) {
				g->max_irq_c = waited;
				g->max_irq_pc = g->pend_pc[k];
				g->max_irq_i = g->pend_i[k];
			}
			g->pend_c[k] = 0;
		}
	}
}

static struct quadgen *find(int a, int b)
{
	for (int i = 0; i < NQUAD; i++)
		if (q[i].used && q[i].a == a && q[i].b == b)
			return &q[i];
	return NULL;
}

static int pin_of(struct jobj *o, const char *k)
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

/* {"cmd": "quadrature", "a": 2, "b": 3, "edges": N, "rate": edges/s, "reverse": P,
 *  "jitter": F, "skip_every": N, "glitch_every": N, "glitch_us": US, "dir": 1|-1,
 *  "seed": N} */
void cmd_quadrature(struct jobj *o, struct sbuf *r)
{
	int a = pin_of(o, "a"), b = pin_of(o, "b");
	double edges = num_or(o, "edges", 0), rate = num_or(o, "rate", 0);
	double reverse = num_or(o, "reverse", 0), jitter = num_or(o, "jitter", 0);
	double skip_every = num_or(o, "skip_every", 0), glitch_every = num_or(o, "glitch_every", 0);
	double glitch_us = num_or(o, "glitch_us", 1), dir = num_or(o, "dir", 1), seed = num_or(o, "seed", 1);
	struct quadgen *g;

	if (a < 0 || b < 0 || a == b || edges < 1 || rate <= 0 || rate > 4e6 || reverse < 0 || reverse > 1 ||
	    jitter < 0 || jitter > 0.9 || skip_every < 0 || glitch_every < 0 || glitch_us <= 0 ||
	    (dir != 1 && dir != -1)) {
		sb_add(r, "{\"ok\": false, \"error\": \"quadrature needs a, b (D2..D13, different), edges>=1, "
			  "0<rate<=4e6 edges/s, 0<=reverse<=1, 0<=jitter<=0.9, skip_every>=0, glitch_every>=0, "
			  "glitch_us>0, dir 1|-1\"}");
		return;
	}
	if (!pty_plugged() || is_out(a) || is_out(b) || loop_partner(a) >= 0 || loop_partner(b) >= 0) {
		sb_add(r, "{\"ok\": false, \"error\": \"pins are not free inputs (output, jumpered or unplugged)\"}");
		return;
	}
	g = find(a, b); /* the same pair again: it goes on from its position */
	for (int i = 0; i < NQUAD; i++)
		if (&q[i] != g && q[i].active && (q[i].a == a || q[i].b == a || q[i].a == b || q[i].b == b)) {
			sb_add(r, "{\"ok\": false, \"error\": \"a pin belongs to another running generator\"}");
			return;
		}
	for (int i = 0; i < NQUAD && !g; i++)
		if (!q[i].used)
			g = &q[i];
	for (int i = 0; i < NQUAD && !g; i++)
		if (!q[i].active)
			g = &q[i];
	if (!g) {
		sb_add(r, "{\"ok\": false, \"error\": \"all %d generators are running\"}", NQUAD);
		return;
	}
	if (!g->used || g->a != a || g->b != b) {
		g->position = 0; /* a new pair starts at 0 with its pins low */
		g->reversals = g->skips = g->glitches = g->edges = 0;
		g->max_late_c = 0;
		g->lv[0] = g->lv[1] = -1;
	}
	g->pend_c[0] = g->pend_c[1] = 0;
	g->max_irq_c = g->irq_waits = 0;
	g->max_irq_pc = 0;
	g->max_irq_i = 1;
	g->used = g->active = 1;
	g->a = a;
	g->b = b;
	g->dir = (int)dir;
	g->left = (unsigned long long)edges;
	g->period_c = (double)F_CPU / rate;
	g->jitter = jitter;
	g->reverse = reverse;
	g->skip_every = (unsigned long)skip_every;
	g->glitch_every = (unsigned long)glitch_every;
	g->glitch_c = (uint64_t)llround(glitch_us * CYC_PER_US);
	g->since_skip = g->since_glitch = 0;
	g->glitch_pin = -1;
	g->rng = (uint64_t)seed * 0x9E3779B97F4A7C15ULL | 1u;
	g->next_t = avr->cycle + 16;
	put_levels(g);
	apply_circuit();
	recompute_next_event();
	sb_add(r, "{\"ok\": true, \"position\": %lld}", g->position);
}

/* {"cmd": "quadrature_status"}: every generator's ground truth */
void cmd_quadrature_status(struct jobj *o, struct sbuf *r)
{
	int first = 1;
	sb_add(r, "{\"ok\": true, \"sim_us\": %.3f, \"generators\": [", (double)avr->cycle / CYC_PER_US);
	for (int i = 0; i < NQUAD; i++) {
		struct quadgen *g = &q[i];
		if (!g->used)
			continue;
		sb_add(r, "%s{\"a\": %d, \"b\": %d, \"active\": %s, \"position\": %lld, \"edges\": %llu, "
			  "\"left\": %llu, \"reversals\": %llu, \"skips\": %llu, \"glitches\": %llu, "
			  "\"max_late_us\": %.3f, \"max_irq_latency_us\": %.3f, \"max_irq_latency_pc\": %u, "
			  "\"max_irq_latency_interrupts_on\": %s, \"irq_latency_edges\": %llu}",
		       first ? "" : ", ", g->a, g->b, g->active ? "true" : "false", g->position, g->edges, g->left,
		       g->reversals, g->skips, g->glitches, (double)g->max_late_c / CYC_PER_US,
		       (double)g->max_irq_c / CYC_PER_US, (unsigned)g->max_irq_pc, g->max_irq_i ? "true" : "false",
		       g->irq_waits);
		first = 0;
	}
	sb_add(r, "]}");
}

void quadrature_status(struct sbuf *r)
{
	int running = 0;
	long long edges = 0;
	for (int i = 0; i < NQUAD; i++) {
		running += q[i].active;
		edges += (long long)q[i].edges;
	}
	sb_add(r, ", \"quadrature_active\": %d, \"quadrature_edges\": %lld", running, edges);
}

/* {"cmd": "quadrature_stop"}: every generator stops where it is (pins held) */
void cmd_quadrature_stop(struct jobj *o, struct sbuf *r)
{
	for (int i = 0; i < NQUAD; i++) {
		if (q[i].active && q[i].glitch_pin >= 0) {
			put_levels(&q[i]);
			q[i].glitch_pin = -1;
		}
		q[i].active = 0;
	}
	apply_circuit();
	recompute_next_event();
	sb_add(r, "{\"ok\": true}");
}

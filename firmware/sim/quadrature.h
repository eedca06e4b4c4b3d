/* quadrature.h - quadrature signal generators on pin pairs (see quadrature.c). */
#ifndef VIRTUAL_UNO_QUADRATURE_H
#define VIRTUAL_UNO_QUADRATURE_H

#include <stdint.h>

#include "json.h"

/* for the event list (pacing.c) */
int quadrature_running(void);
void schedule_quadrature(void);
int run_quadrature(uint64_t now);
/* the CPU entered interrupt vector `vector` at `cycle` (pacing.c's run loop): the
 * generators' pins it answers stop waiting (their max_irq_latency_us) */
void quadrature_vector_taken(unsigned vector, uint64_t cycle);

/* control commands (control.c's table) */
void cmd_quadrature(struct jobj *o, struct sbuf *r);
void cmd_quadrature_status(struct jobj *o, struct sbuf *r);
void cmd_quadrature_stop(struct jobj *o, struct sbuf *r);
void quadrature_status(struct sbuf *r); /* its part of "status": ", key: value..." */

#endif

/* steps.h - step pulse logs and limit-switch triggers for stepper tests (see steps.c). */
#ifndef VIRTUAL_UNO_STEPS_H
#define VIRTUAL_UNO_STEPS_H

#include <stdint.h>

struct jobj;
struct sbuf;

/* A pin rose at cycle t (circuit.c's capture calls it for every rise). */
void steps_rise(int p, uint64_t t);

/* Control commands (rows of control.c's table). */
void cmd_step_log(struct jobj *o, struct sbuf *r);
void cmd_steps(struct jobj *o, struct sbuf *r);
void cmd_limit_at(struct jobj *o, struct sbuf *r);

/* Its part of "status": ", step_logs: {pin: steps logged}". */
void steps_status(struct sbuf *r);

#endif

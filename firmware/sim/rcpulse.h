/* rcpulse.h - RC pulse sources on single pins (see rcpulse.c). */
#ifndef VIRTUAL_UNO_RCPULSE_H
#define VIRTUAL_UNO_RCPULSE_H

#include <stdint.h>

#include "json.h"

/* for the event list (pacing.c) */
int rcpulse_running(void);
void schedule_rcpulse(void);
int run_rcpulse(uint64_t now);

/* control commands (control.c's table) */
void cmd_rcpulse(struct jobj *o, struct sbuf *r);
void cmd_rcpulse_status(struct jobj *o, struct sbuf *r);
void cmd_rcpulse_stop(struct jobj *o, struct sbuf *r);

#endif

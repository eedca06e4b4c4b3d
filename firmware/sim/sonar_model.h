/* sonar_model.h - HC-SR04 style ultrasonic rangers on pin pairs (see sonar_model.c). */
#ifndef VIRTUAL_UNO_SONAR_MODEL_H
#define VIRTUAL_UNO_SONAR_MODEL_H

#include <stdint.h>

#include "json.h"

/* circuit.c's record_level: every level change of pin p at cycle t */
void sonar_model_edge(int p, int level, uint64_t t);

/* for the event list (pacing.c) */
void schedule_sonar_model(void);
int run_sonar_model(uint64_t now);

/* control commands (control.c's table) */
void cmd_sonar(struct jobj *o, struct sbuf *r);
void cmd_sonar_status(struct jobj *o, struct sbuf *r);

#endif

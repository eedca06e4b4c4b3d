/* circuit.h - what is wired to the simulated Uno's pins (see circuit.c). */
#ifndef VIRTUAL_UNO_CIRCUIT_H
#define VIRTUAL_UNO_CIRCUIT_H

#include <stdint.h>

#include "i2c_eeprom.h"

#define NEDGE 32

extern const char *const fixture_names[];
extern int drive_level[NPINS];  /* -1 released, 0/1 driven from outside */
extern int analog_mv[8];
extern int adc_sent[9];
extern double temperature_c;
extern i2c_eeprom_t i2c_ee;

/* pulse generator (D2, D3) */
struct pulsegen { int active, level; unsigned long remaining, done; uint64_t high_c, low_c, next_t; };
extern struct pulsegen gen[2];

/* pulse capture */
struct capture {
	uint64_t rise_t, prev_rise_t; int level, have_rise;
	double high_us[NEDGE], period_us[NEDGE];
	double rise_us[NEDGE];   /* simulated time of the rise that started high_us[i] */
	uint64_t edge_t; int have_edge;   /* last level change */
	unsigned nh, np, hi_next, pe_next;
	unsigned long rises, falls;
	unsigned long highs, periods; /* high times / periods recorded since the last clear */
};
extern struct capture cap[NPINS];

int loop_partner(int p);
int is_out(int p);
int port_bit(int p);
int pin_level(int p);
void apply_circuit(void);
void update_analog(void);

void setup_r2r(void);
void circuit_attach(void);      /* pin, port, ADC and TWI hooks, once at start */
void circuit_after_reset(void);

/* pulse generator, for the event list */
int pulses_running(void);
void start_pulses(int p, unsigned long count, uint64_t high_c, uint64_t low_c);
void stop_pulses(void);
void schedule_pulses(void);
int run_pulses(uint64_t now);

#endif

/* circuit.h - what is wired to the simulated Uno's pins (see circuit.c). */
#ifndef VIRTUAL_UNO_CIRCUIT_H
#define VIRTUAL_UNO_CIRCUIT_H

#include <stdint.h>

#include "json.h"

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

/* the control channel: stimuli and reports on the circuit's own state */
const char *fixture_name(void);
void circuit_set_analog(int ch, int mv);    /* channel 0..7 (Uno: A0..A5, 6-7 unused), 0..15 (Mega) */
void circuit_set_temperature(double celsius);
void circuit_drive(int p, int level);        /* -1 released, 0/1 driven from outside */
/* the same, several pins at one instant: the caller calls apply_circuit() after the last */
void circuit_set_driven(int p, int level);
int circuit_adc_mv(int ch);                  /* the last mV the ADC was given */
unsigned long pulses_done(int p);            /* pulses D2/D3 finished so far */
const uint8_t *circuit_i2c_eeprom(void);     /* the I2C EEPROM's 256 bytes */
void circuit_pulse_stats(int p, struct sbuf *r); /* the "pulse_stats" reply */
void circuit_clear_pulse_stats(int p);
void circuit_status(struct sbuf *r);         /* its part of "status": ", key: value..." */

#endif

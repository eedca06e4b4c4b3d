/* wire.h - UART0 <-> host: the modelled wire, line faults, the 16U2 bridge
 * and firmware time measurement (see wire.c). */
#ifndef VIRTUAL_UNO_WIRE_H
#define VIRTUAL_UNO_WIRE_H

#include <stddef.h>
#include <stdint.h>

#include "json.h"

void wire_attach(void);      /* UART hooks, once at start */
void wire_after_reset(void);

/* for bridges.c: the first tick after t of a bridge clock; a byte reaches the host side */
uint64_t bridge_boundary(uint64_t t, uint64_t period);
void wire_to_host(uint8_t b, uint64_t due);

/* for pty.c */
size_t host_rx_room(void);
void host_bytes_in(const uint8_t *buf, size_t n);
int wire_has_output(void);
void wire_unplug(void);

/* for pacing.c */
int wire_idle(void);
int wire_only_delivering(void);
void wire_time_base_reset(void);
void wire_schedule_events(void);
int wire_run_events(uint64_t now);
void wire_events_done(void);
void flush_out(void);                /* everything, due or not (unplug) */
uint64_t output_decided_at(void);    /* cycle that tells whether the newest byte ends a burst */
void output_service(uint64_t wc);    /* write what is due by wall cycle wc */
uint64_t output_wake_cycle(int *punctual); /* when output_service next writes, UINT64_MAX: never */

/* for the control channel and the other modules: the wire's state is its own */
unsigned host_rx_queued(void);
uint64_t wire_last_host_byte(void); /* cycle the last host byte entered the UART */
void wire_lost_to_host(void);       /* a bridge model's queue was full: counted in lost.to_host */
void wire_discarded(unsigned long n);   /* host bytes thrown away (no board to take them) */
void wire_set_byte_time(unsigned baud); /* 10 bit times at baud */
void wire_faults(double *drop, double *insert, double *flip);
void wire_set_faults(double drop, double insert, double flip); /* per board->host byte */
void wire_firmware_cycles(struct sbuf *r, int clear);          /* the "firmware_cycles" reply */
void wire_status(struct sbuf *r); /* its part of "status": ", key: value..." */

#endif

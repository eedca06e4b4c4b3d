/* wire.h - UART0 <-> host: the modelled wire, line faults, the 16U2 bridge
 * and firmware time measurement (see wire.c). */
#ifndef VIRTUAL_UNO_WIRE_H
#define VIRTUAL_UNO_WIRE_H

#include <stddef.h>
#include <stdint.h>

#define NSAMPLES 256

extern uint64_t byte_cycles;    /* 10 bit times at --baud */

/* line faults (per board->host byte) */
extern double fault_drop, fault_insert, fault_flip;
extern unsigned long faults_dropped, faults_inserted, faults_flipped;

/* statistics for the control channel's status */
extern unsigned long pty_writes; /* write() calls to the pty master (batching statistics) */
extern unsigned long bytes_to_host, bytes_from_host, bytes_discarded;
extern unsigned long lost_to_board, lost_to_host; /* a harness queue was full: never expected */
extern unsigned long bridge_full_releases; /* 16U2 releases because > 96 bytes waited */
extern uint64_t last_host_byte_t;   /* cycle the last host byte entered the UART */
unsigned host_rx_queued(void);

/* firmware time measurement: the last NSAMPLES request -> first reply byte times */
extern uint64_t fw_samples[NSAMPLES];
extern unsigned fw_nsamples, fw_next;
extern uint64_t fw_last;

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

#endif

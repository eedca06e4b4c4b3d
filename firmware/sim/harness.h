/*
 * harness.h - what every part of the virtual Uno shares: the simulated MCU,
 * the command-line options, the PRNG, logging and the MCU-level actions
 * (resets, the ready line) that the other parts trigger.
 *
 * The harness is one process and one thread (simavr is not thread safe):
 *   pacing.c   time base, run-ahead, the event list, the run function and the
 *              wait on every descriptor (the main loop)
 *   wire.c     UART0 <-> host: the modelled wire, line faults, the 16U2
 *              bridge, firmware time measurement
 *   bridges.c  the FTDI and CH340 USB bridge models
 *   pty.c      the port the host opens (auto-reset on open, back-pressure)
 *              and the cable (unplug/replug)
 *   circuit.c  fixtures, driven levels, analog and temperature inputs, R2R
 *              ladders, the I2C EEPROM, pulse generator and pulse capture
 *   quadrature.c  quadrature signal generators (encoders) on pin pairs
 *   control.c  the JSON-lines control socket: a name -> handler table
 *   json.c     the small JSON reader and reply buffer control.c uses
 *   main.c     options, simavr set-up, resets and MCUSR, bootloader, ready line
 * Every .c file includes this header first (it sets _GNU_SOURCE before any
 * system header); the other headers assume it.  See README.md next to this file.
 *
 * Each module owns its state (static) and exposes functions for what others
 * need of it, and reports its own part of the control channel's "status"
 * (pacing_status, pty_status, harness_status, wire_status, circuit_status,
 * quadrature_status).
 * What stays shared is declared here: the options (read-only outside main.c,
 * which parses them), the simulated core (avr) and its run flags (halted,
 * reset_seen), which main.c's resets and pacing.c's loop change instruction by
 * instruction (a function call there would cost every simulated instruction).
 */
#ifndef VIRTUAL_UNO_HARNESS_H
#define VIRTUAL_UNO_HARNESS_H

#define _GNU_SOURCE
#include <signal.h>
#include <stdint.h>
#include <sys/types.h>

#include "sim_avr.h"

#define F_CPU 16000000ULL
#define CYC_PER_US 16ULL
#define NPINS 20

/* UART0 control register B and the bits the harness looks at */
#define UCSR0B_ADDR 0xC1
#define RXEN0_BIT 0x10
#define UDRIE0_BIT 0x20

/* MCUSR (data address 0x54) and its reset flags, see main.c */
#define MCUSR_ADDR 0x54
#define MCUSR_PORF 0x01
#define MCUSR_EXTRF 0x02

enum fixture { FIX_OPEN, FIX_LOOPBACK, FIX_R2R };
/* --usb-bridge: the Uno's 16U2 (wire.c), an FTDI or a CH340 (bridges.c) */
enum usb_bridge { BRIDGE_NONE, BRIDGE_16U2, BRIDGE_FTDI, BRIDGE_CH340 };

/* options: main.c parses them into its own copy; every other module reads */
struct harness_options {
	const char *elf;
	const char *bootloader;     /* optiboot .hex: reset into the boot section */
	int id;                     /* board ID written to the EEPROM, -1: leave it */
	unsigned baud;
	enum fixture fixture;
	double r2r_tol;
	int fast;
	int reset_on_open;
	unsigned boot_delay_ms;
	enum usb_bridge usb_bridge; /* --usb-bridge, parsed by bridges.c's bridge_parse */
	int exit_with_parent;
	pid_t parent_pid;           /* for --exit-with-parent */
	uint64_t seed;
	int mega2560;               /* --board mega2560: the ATmega2560 core (first stage: the
	                               link, the ADC, the pins the Uno fixture's ports reach) */
};
extern const struct harness_options *const opt;

/* the MCU */
extern avr_t *avr;
extern int halted;              /* SLEEP with I=0: core stopped until reset */
extern volatile int reset_seen; /* set by our wrapper around avr->reset */

void logf_(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* PRNG (xorshift64*), deterministic from --seed */
uint64_t rng_swap(uint64_t state); /* a new state (0: 1), the old one back */
uint64_t rng_next(void);
double rng_unit(void);

/* resets (main.c) */
void reset_avr(uint8_t flags);
void after_reset(void);
void reset_and_run(uint8_t flags);
void reset_held(uint8_t flags);  /* reset_and_run without a new time base */
void power_on_reset(void);
void update_extint_strict(void);
void announce_when_listening(void);

struct sbuf;
void harness_status(struct sbuf *r); /* its part of "status": ", key: value..." */

#endif

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
 *   control.c  the JSON-lines control socket: a name -> handler table
 *   json.c     the small JSON reader and reply buffer control.c uses
 *   main.c     options, simavr set-up, resets and MCUSR, bootloader, ready line
 * Every .c file includes this header first (it sets _GNU_SOURCE before any
 * system header); the other headers assume it.  See README.md next to this file.
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

/* options (main.c parses them) */
extern const char *opt_elf;
extern const char *opt_bootloader; /* optiboot .hex: reset into the boot section */
extern int opt_id;
extern unsigned opt_baud;
extern enum fixture opt_fixture;
extern double opt_r2r_tol;
extern int opt_fast;
extern int opt_reset_on_open;
extern unsigned opt_boot_delay_ms;
extern int opt_16u2;
extern int opt_exit_with_parent;
extern pid_t orig_ppid;
extern uint64_t opt_seed;

/* the MCU */
extern avr_t *avr;
extern volatile sig_atomic_t quit_flag;
extern int halted;              /* SLEEP with I=0: core stopped until reset */
extern volatile int reset_seen; /* set by our wrapper around avr->reset */
extern unsigned long reset_count;
extern int announced;           /* ready line printed (after the firmware's RXEN0) */

void logf_(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* PRNG (xorshift64*), deterministic from --seed */
extern uint64_t rng_state;
uint64_t rng_next(void);
double rng_unit(void);

/* resets (main.c) */
void reset_avr(uint8_t flags);
void after_reset(void);
void reset_and_run(uint8_t flags);
void power_on_reset(void);
void update_extint_strict(void);
void announce_when_listening(void);

#endif

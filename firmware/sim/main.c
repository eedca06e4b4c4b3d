/*
 * main.c - a virtual Arduino Uno: simavr ATmega328P at 16 MHz, paced to the
 * wall clock (pacing.c), with UART0 bridged to its own pseudo-terminal, an
 * optional model of the Uno's ATmega16U2 USB bridge and line faults (wire.c),
 * test circuitry (circuit.c) and a JSON-lines control socket (control.c).
 * See README.md next to this file.
 *
 * This file: the command line, setting simavr up, resets and the reset cause
 * in MCUSR, the bootloader image, the INT0/INT1 emulation switch and the
 * ready line.
 */
#include "harness.h"
#include "board_map.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <unistd.h>

#include "avr_eeprom.h"
#include "avr_extint.h"
#include "avr_uart.h"
#include "sim_elf.h"
#include "sim_hex.h"
#include "sim_io.h"

#include "bridges.h"
#include "circuit.h"
#include "control.h"
#include "pacing.h"
#include "pty.h"
#include "spi_device.h"
#include "trace.h"
#include "wire.h"

#define ANNOUNCE_MAX_CYCLES (250000ULL * 16) /* announce anyway if RXEN0 stays off 250 ms */

/* ------------------------------------------------------------------ options */
static struct harness_options options = {
	.id = -1, .baud = 115200, .fixture = FIX_OPEN, .r2r_tol = 1.0, .boot_delay_ms = 500, .seed = 1,
};
const struct harness_options *const opt = &options; /* read-only outside this file */
static double opt_fault_drop, opt_fault_insert, opt_fault_flip; /* given to wire.c */

/* ------------------------------------------------------------------ state */
avr_t *avr;
static int json_fd = -1;
int halted;
volatile int reset_seen;
static void (*orig_reset)(avr_t *);
static unsigned long reset_count;
static int announced; /* ready line printed (after the firmware's RXEN0) */

void logf_(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	fprintf(stderr, "virtual-uno: ");
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
	va_end(ap);
}

static uint64_t rng_state;

uint64_t rng_swap(uint64_t state)
{
	uint64_t old = rng_state;
	rng_state = state ? state : 1;
	return old;
}

uint64_t rng_next(void)
{
	uint64_t x = rng_state;
	x ^= x >> 12; x ^= x << 25; x ^= x >> 27;
	rng_state = x;
	return x * 0x2545F4914F6CDD1DULL;
}
double rng_unit(void) { return (double)(rng_next() >> 11) / 9007199254740992.0; }

/* ------------------------------------------------------------------ INT0/INT1 */
/* simavr 1.6 emulates the low-level INT0/INT1 trigger ("strict" mode, on by
 * default) with a cycle timer that fires on EVERY cycle while the pin is low,
 * once a pin notification saw it low with ISC = 00 (the reset value) - even
 * when the interrupt is not enabled in EIMSK.  An unconnected D2/D3 is low
 * here, so that timer ran for good: every instruction paid for an
 * avr_ioctl() and a sleeping firmware advanced one cycle per wake-up (about
 * 70 % of a core at 8,000 requests/s, and simulated time fell behind).  Turn
 * the strict mode on only while the firmware really uses the level trigger
 * (EIMSK bit set, ISCn1:0 = 00); checked after every slice and reset. */
#define EIMSK_ADDR 0x3D
#define EICRA_ADDR 0x69
#define EICRB_ADDR 0x6A /* the ATmega2560's INT4-INT7 (its D2/D3 are INT4/INT5) */
static int extint_strict[2] = {-1, -1};

void update_extint_strict(void)
{
	/* the board's counter interrupts 0/1: INT0/INT1 (Uno), INT4/INT5 (Mega) */
	int first = options.mega2560 ? 4 : 0;
	uint8_t eimsk = avr->data[EIMSK_ADDR];
	uint8_t eicr = avr->data[options.mega2560 ? EICRB_ADDR : EICRA_ADDR];
	for (int n = 0; n < 2; n++) {
		int want = ((eimsk >> (first + n)) & 1) && ((eicr >> (2 * n)) & 3) == 0;
		if (want != extint_strict[n]) {
			extint_strict[n] = want;
			avr_extint_set_strict_lvl_trig(avr, (uint8_t)(first + n), (uint8_t)want);
		}
	}
}

/* ------------------------------------------------------------------ resets */
/* MCUSR and its reset flags, as on silicon: a power-on reset leaves only PORF,
 * an external (DTR) reset adds EXTRF to what was there, and the watchdog's
 * WDRF is set by simavr's watchdog module itself.  Optiboot decides on EXTRF
 * alone whether to wait for avrdude or start the application. */
static uint8_t next_reset_flags; /* set by reset_avr(); 0: a reset from inside simavr */
static uint8_t mcusr_before_reset;

static void my_reset_wrapper(avr_t *a)
{
	if (orig_reset)
		orig_reset(a);
	/* avr_reset() has cleared the I/O registers and set pc = reset_pc (the boot
	 * section in --bootloader mode, like the BOOTRST fuse) */
	if (next_reset_flags == MCUSR_PORF)
		a->data[MCUSR_ADDR] = MCUSR_PORF;
	else if (next_reset_flags)
		a->data[MCUSR_ADDR] = mcusr_before_reset | next_reset_flags;
	next_reset_flags = 0;
	reset_seen = 1;
}

void reset_avr(uint8_t flags)
{
	mcusr_before_reset = avr->data[MCUSR_ADDR];
	next_reset_flags = flags;
	avr_reset(avr);
}

static void logger(avr_t *a, const int level, const char *fmt, va_list ap)
{
	if (level <= LOG_WARNING) {
		fprintf(stderr, "simavr: ");
		vfprintf(stderr, fmt, ap);
	}
}

void after_reset(void)
{
	reset_seen = 0;
	halted = 0;
	extint_strict[0] = extint_strict[1] = -1; /* re-apply after every reset */
	update_extint_strict();
	wire_after_reset();
	circuit_after_reset();
	recompute_next_event();
}

void reset_and_run(uint8_t flags)
{
	reset_held(flags);
	rebase();
}

/* A reset that runs the firmware from its start (the time base is the caller's). */
void reset_held(uint8_t flags)
{
	reset_avr(flags);
	avr->state = cpu_Running;
	reset_count++;
	after_reset();
}

void power_on_reset(void)
{
	reset_and_run(MCUSR_PORF);
}

/* ------------------------------------------------------------------ bootloader */
/* --bootloader HEX: the image goes to its real flash addresses (optiboot: 0x7C00
 * for a 1 KiB boot section) and every reset starts there, as with the BOOTRST
 * fuse programmed.  The rest of the flash is erased (0xFF) unless --elf put an
 * application at 0.  The bootloader writes the application with SPM (simavr's
 * self-programming module) and leaves through a watchdog reset. */
static int load_bootloader(const char *path)
{
	ihex_chunk_p chunks = NULL;
	int count = access(path, R_OK) == 0 ? read_ihex_chunks(path, &chunks) : -1;
	if (count <= 0) {
		logf_("cannot read bootloader hex %s", path);
		return -1;
	}
	uint32_t boot = avr->flashend + 1;
	for (int i = 0; i < count; i++) {
		if (chunks[i].baseaddr + chunks[i].size > avr->flashend + 1) {
			logf_("bootloader %s: %u bytes at 0x%04X run past the end of flash",
			      path, chunks[i].size, chunks[i].baseaddr);
			free_ihex_chunks(chunks);
			return -1;
		}
		memcpy(avr->flash + chunks[i].baseaddr, chunks[i].data, chunks[i].size);
		if (chunks[i].baseaddr < boot)
			boot = chunks[i].baseaddr;
	}
	free_ihex_chunks(chunks);
	avr->reset_pc = boot;
	avr->pc = boot;
	avr->codeend = avr->flashend; /* the application is whatever gets flashed */
	avr->data[MCUSR_ADDR] = MCUSR_PORF;
	return 0;
}

/* ------------------------------------------------------------------ status */
static const char *state_name(void)
{
	if (!pty_plugged()) return "off";
	if (pty_holding_reset()) return "reset";
	if (halted) return "halted";
	if (avr->state == cpu_Sleeping) return "sleeping";
	if (avr->state == cpu_Running) return "running";
	return "stopped";
}

void harness_status(struct sbuf *r)
{
	sb_add(r, ", \"state\": \"%s\", \"id\": ", state_name());
	if (options.id >= 0) sb_add(r, "%d", options.id); else sb_add(r, "null");
	sb_add(r, ", \"baud\": %u, \"fixture\": \"%s\", \"usb_bridge\": \"%s\", \"fast\": %s, "
		  "\"reset_on_open\": %s, \"resets\": %lu, \"pc\": %u",
	       options.baud, fixture_name(), bridge_name(options.usb_bridge), options.fast ? "true" : "false",
	       options.reset_on_open ? "true" : "false", reset_count, (unsigned)avr->pc);
}

/* ------------------------------------------------------------------ setup */
static void on_signal(int sig) { pacing_quit(); }

/* The ready line goes out once the firmware has switched its UART receiver on
 * (RXEN0), not at power-up: a host that writes a request the moment it learns
 * the port would otherwise lose it to a receiver that is still off (simavr
 * drops input while RXEN0 is clear, as silicon does).  A firmware that never
 * enables its receiver is announced after ANNOUNCE_MAX_CYCLES (250 ms) of
 * simulated time, or when it halts. */
void announce_when_listening(void)
{
	if (announced)
		return;
	if (pty_plugged() && !halted && !(avr->data[UCSR0B_ADDR] & RXEN0_BIT) &&
	    avr->cycle < ANNOUNCE_MAX_CYCLES)
		return;
	announced = 1;
	char line[1024], idtxt[16];
	if (options.id >= 0)
		snprintf(idtxt, sizeof(idtxt), "%d", options.id);
	else
		snprintf(idtxt, sizeof(idtxt), "null");
	int n = snprintf(line, sizeof(line),
			 "{\"port\": \"%s\", \"control\": \"%s\", \"pid\": %d, \"id\": %s, \"baud\": %u}\n",
			 pty_port(), control_path(), (int)getpid(), idtxt, options.baud);
	if (write(json_fd, line, (size_t)n) != n) { /* parent gone: keep running until signalled */ }
}

static void usage(void)
{
	fprintf(stderr,
		"usage: virtual-uno --elf PATH|--bootloader HEX [--elf PATH] [--id N] [--baud 115200|1000000] [--fixture open|loopback|r2r]\n"
		"       [--board uno|mega2560]\n"
		"       [--r2r-tolerance PCT] [--fast] [--reset-on-open] [--boot-delay-ms MS]\n"
		"       [--usb-bridge none|16u2|ftdi|ch340] [--ftdi-latency-ms MS] [--fault-drop P] [--fault-insert P] [--fault-flip P]\n"
		"       [--seed N] [--control SOCKET_PATH] [--exit-with-parent]\n");
}

static int parse_args(int argc, char **argv)
{
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i];
		const char *v = i + 1 < argc ? argv[i + 1] : NULL;
#define NEEDV() do { if (!v) { logf_("%s needs a value", a); return -1; } i++; } while (0)
		if (!strcmp(a, "--elf")) { NEEDV(); options.elf = v; }
		else if (!strcmp(a, "--bootloader")) { NEEDV(); options.bootloader = v; options.reset_on_open = 1; }
		else if (!strcmp(a, "--id")) { NEEDV(); long n = strtol(v, NULL, 0); if (n < 0 || n > 0xFFFF) { logf_("--id must be 0..65535"); return -1; } options.id = (int)n; }
		else if (!strcmp(a, "--baud")) { NEEDV(); options.baud = (unsigned)strtoul(v, NULL, 0); if (options.baud < 300 || options.baud > 2000000) { logf_("bad --baud"); return -1; } }
		else if (!strcmp(a, "--fixture")) {
			NEEDV();
			if (!strcmp(v, "open")) options.fixture = FIX_OPEN;
			else if (!strcmp(v, "loopback")) options.fixture = FIX_LOOPBACK;
			else if (!strcmp(v, "r2r")) options.fixture = FIX_R2R;
			else { logf_("bad --fixture %s", v); return -1; }
		}
		else if (!strcmp(a, "--r2r-tolerance")) { NEEDV(); options.r2r_tol = atof(v); }
		else if (!strcmp(a, "--board")) {
			NEEDV();
			if (!strcmp(v, "uno")) options.mega2560 = 0;
			else if (!strcmp(v, "mega2560")) options.mega2560 = 1;
			else { logf_("bad --board %s (uno or mega2560)", v); return -1; }
		}
		else if (!strcmp(a, "--fast")) options.fast = 1;
		else if (!strcmp(a, "--reset-on-open")) options.reset_on_open = 1;
		else if (!strcmp(a, "--exit-with-parent")) options.exit_with_parent = 1;
		else if (!strcmp(a, "--boot-delay-ms")) { NEEDV(); options.boot_delay_ms = (unsigned)strtoul(v, NULL, 0); }
		else if (!strcmp(a, "--usb-bridge")) {
			NEEDV();
			if (bridge_parse(v, &options.usb_bridge) < 0) { logf_("bad --usb-bridge %s", v); return -1; }
		}
		else if (!strcmp(a, "--ftdi-latency-ms")) { NEEDV(); if (bridge_set_latency_ms(strtol(v, NULL, 0)) < 0) { logf_("--ftdi-latency-ms must be 1..255"); return -1; } }
		else if (!strcmp(a, "--fault-drop")) { NEEDV(); opt_fault_drop = atof(v); }
		else if (!strcmp(a, "--fault-insert")) { NEEDV(); opt_fault_insert = atof(v); }
		else if (!strcmp(a, "--fault-flip")) { NEEDV(); opt_fault_flip = atof(v); }
		else if (!strcmp(a, "--seed")) { NEEDV(); options.seed = strtoull(v, NULL, 0); }
		else if (!strcmp(a, "--control")) { NEEDV(); control_set_path(v); }
		else if (!strcmp(a, "-h") || !strcmp(a, "--help")) { usage(); exit(0); }
		else { logf_("unknown argument %s", a); usage(); return -1; }
	}
	if (!options.elf && !options.bootloader) { logf_("--elf or --bootloader is required"); usage(); return -1; }
	return 0;
}

int main(int argc, char **argv)
{
	/* simavr prints to stdout; keep stdout for the single JSON line only. */
	json_fd = dup(1);
	dup2(2, 1);
	setvbuf(stdout, NULL, _IONBF, 0);

	if (parse_args(argc, argv) < 0) return 2;
	options.parent_pid = getppid();
	rng_swap(options.seed * 0x9E3779B97F4A7C15ULL + 1);
	wire_set_faults(opt_fault_drop, opt_fault_insert, opt_fault_flip);
	setup_r2r();
	wire_set_byte_time(options.baud);

	struct sigaction sa = {.sa_handler = on_signal};
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);
	prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);

	avr_global_logger_set(logger);
	elf_firmware_t fw;
	memset(&fw, 0, sizeof(fw));
	if (options.elf && (access(options.elf, R_OK) != 0 || elf_read_firmware(options.elf, &fw) != 0)) {
		logf_("cannot read firmware ELF %s", options.elf);
		return 2;
	}
	const char *mcu = options.mega2560 ? "atmega2560" : "atmega328p";
	if (options.mega2560 && options.fixture == FIX_R2R) {
		logf_("--fixture r2r is the Uno's (A0-A5 ladders); the Mega has open and loopback");
		return 2;
	}
	board_map_select(options.mega2560);
	avr = avr_make_mcu_by_name(mcu);
	if (!avr) { logf_("simavr does not know %s", mcu); return 2; }
	avr_init(avr);
	avr->log = LOG_WARNING;
	if (options.elf)
		avr_load_firmware(avr, &fw);
	if (options.bootloader && load_bootloader(options.bootloader) < 0)
		return 2;
	avr->frequency = (uint32_t)F_CPU;
	avr->vcc = 5000;
	avr->avcc = 5000;
	avr->aref = 5000;
	avr->run = my_run;
	orig_reset = avr->reset;
	avr->reset = my_reset_wrapper;

	uint32_t flags = 0; /* no stdio echo, no usleep(1) on UCSR0A polling */
	avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);

	if (options.id >= 0) {
		uint8_t idb[2] = {(uint8_t)(options.id >> 8), (uint8_t)options.id};
		avr_eeprom_desc_t d = {.ee = idb, .offset = 0, .size = 2};
		avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
	}

	circuit_attach();
	spi_device_attach();
	wire_attach();

	if (setup_control() < 0) return 2;
	if (open_pty() < 0) return 2;
	pacing_start();
	after_reset();
	rebase();

	trace_open();
	run_paced();
	trace_close();

	close_control();
	if (pty_fd() >= 0) close(pty_fd());
	return 0;
}

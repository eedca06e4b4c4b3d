/*
 * virtual_uno.c - a virtual Arduino Uno: simavr ATmega328P at 16 MHz, paced to
 * the wall clock, with UART0 bridged to its own pseudo-terminal, an optional
 * model of the Uno's ATmega16U2 USB bridge, line faults, test circuitry
 * (jumpers, R2R ladders, I2C EEPROM, analog sources, pulse generator, pulse
 * capture) and a JSON-lines control socket.  See README.md next to this file.
 *
 * Design notes (why things are the way they are):
 *
 * - One thread.  simavr is not thread safe, so the pty, the control socket and
 *   the simulation are all served from one loop.  The loop runs the AVR in
 *   slices of SLICE_CYCLES, then compares simulated time with the wall clock;
 *   when the simulation is ahead by more than LEAD_MAX_CYCLES it waits in
 *   ppoll() on all file descriptors until the wall clock catches up, so a host
 *   byte or a control request wakes it at once.
 * - Own run function (my_run) instead of avr_callback_run_raw: when the
 *   firmware executes SLEEP, the stock callback would usleep() and then jump
 *   the cycle counter to the next simavr timer whatever happened meanwhile.
 *   Ours waits on the file descriptors and advances the cycle counter only to
 *   the simulated equivalent of the wall time at which it woke up, so host
 *   bytes reach a sleeping firmware immediately and an idle firmware costs no
 *   CPU.  A SLEEP with interrupts disabled halts the core (as on real silicon)
 *   instead of simavr's avr_terminate().
 * - Own event list (not simavr cycle timers) for bridge timing, injection and
 *   the pulse generator, because avr_reset() cancels all simavr cycle timers
 *   (a watchdog reset would silently kill ours).  Events are checked after
 *   every instruction and bound every sleep.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "avr_adc.h"
#include "avr_eeprom.h"
#include "avr_extint.h"
#include "avr_ioport.h"
#include "avr_twi.h"
#include "avr_uart.h"
#include "i2c_eeprom.h"
#include "sim_avr.h"
#include "sim_core.h"
#include "sim_elf.h"
#include "sim_hex.h"
#include "sim_io.h"
#include "sim_irq.h"
#include "sim_time.h"

#define F_CPU 16000000ULL
#define CYC_PER_US 16ULL
#define SLICE_CYCLES 128ULL             /* 8 us of simulated time between pacing checks */
#define LEAD_MAX_CYCLES (30ULL * 16)    /* let simulation run at most ~30 us ahead of wall */
#ifndef RUNAHEAD_CYCLES
#define RUNAHEAD_CYCLES (2000ULL * 16)  /* idle link: run ahead in slices of up to 2 ms */
#endif
#define ANNOUNCE_MAX_CYCLES (250000ULL * 16) /* announce anyway if RXEN0 stays off 250 ms */
#define LAG_REBASE_CYCLES (50000ULL * 16) /* > 50 ms behind: give up catching up, rebase */
#define TICK_16U2_CYCLES 65536ULL       /* 16U2 Timer0 overflow: clk/256 * 256 = 4.096 ms */
#define USB_FRAME_CYCLES 16000ULL       /* USB full-speed 1 ms frame */
#define NEARLY_FULL_16U2 96             /* arduino-usbserial: release when MORE than this wait */
#define OUT_HOLD_NS 5000ULL             /* max wall time a board->host byte waits for a batched write */
#define MAX_CLIENTS 16
#define RING 8192
#define NSAMPLES 256
#define NEDGE 32
#define NPINS 20

/* ------------------------------------------------------------------ options */
static const char *opt_elf;
static const char *opt_bootloader; /* optiboot .hex: reset into the boot section */
static int opt_id = -1;
static unsigned opt_baud = 115200;
static enum { FIX_OPEN, FIX_LOOPBACK, FIX_R2R } opt_fixture = FIX_OPEN;
static double opt_r2r_tol = 1.0;
static int opt_fast;
static int opt_reset_on_open;
static unsigned opt_boot_delay_ms = 500;
static int opt_16u2;
static int opt_exit_with_parent;
static pid_t orig_ppid;
static uint64_t last_parent_check_ns;
static double fault_drop, fault_insert, fault_flip;
static uint64_t opt_seed = 1;
static char ctl_path[600];
static char ctl_dir[512];
static const char *fixture_names[] = {"open", "loopback", "r2r"};

/* ------------------------------------------------------------------ state */
static avr_t *avr;
static i2c_eeprom_t i2c_ee;
static volatile sig_atomic_t quit_flag;
static int json_fd = -1;

static int master_fd = -1;
static char pty_name[128];
static int plugged = 1;         /* cable in: AVR powered, pty exists */
static int slave_open;          /* host holds the port open */
static uint64_t last_hup_check_ns;
static int holding_reset;       /* DTR auto-reset: held in reset until hold_until_ns */
static uint64_t hold_until_ns;
static int halted;              /* SLEEP with I=0: core stopped until reset */
static volatile int reset_seen; /* set by our wrapper around avr->reset */
static void (*orig_reset)(avr_t *);
static unsigned long reset_count, open_count;

static int listen_fd = -1;
static struct client { int fd; char buf[4096]; size_t len; } clients[MAX_CLIENTS];

/* pacing */
static uint64_t wall_base_ns, cycle_base, start_ns;
static int64_t max_lag_cycles;
static unsigned long rebase_count;
static int io_ready;
static uint64_t last_io_ns;

/* byte rings with timestamps */
struct tbyte { uint8_t b; uint64_t t; };
struct ring { struct tbyte d[RING]; unsigned head, tail; };
static inline int ring_empty(struct ring *r) { return r->head == r->tail; }
static inline unsigned ring_len(struct ring *r) { return (r->head - r->tail) & (RING - 1); }
static inline int ring_push(struct ring *r, uint8_t b, uint64_t t)
{
	unsigned n = (r->head + 1) & (RING - 1);
	if (n == r->tail)
		return 0;
	r->d[r->head].b = b;
	r->d[r->head].t = t;
	r->head = n;
	return 1;
}
static inline struct tbyte *ring_peek(struct ring *r) { return &r->d[r->tail]; }
static inline void ring_pop(struct ring *r) { r->tail = (r->tail + 1) & (RING - 1); }
static inline void ring_clear(struct ring *r) { r->head = r->tail = 0; }

static struct ring host_rx;     /* host->board bytes waiting for injection (t = earliest) */
static struct ring wire_tx;     /* board->host bytes on the wire (t = end of stop bit) */
static struct ring bridge_buf;  /* 16U2: bytes waiting for tick / 96 bytes (t unused) */
static struct ring usb_out;     /* 16U2: released bytes waiting for USB frame (t = frame) */
static uint8_t out_buf[RING];   /* bytes ready for the pty master */
static size_t out_len;
static uint64_t out_first_ns;   /* wall time the oldest unwritten byte entered out_buf */
static unsigned long pty_writes; /* write() calls to the pty master (batching statistics) */
static uint64_t byte_cycles;    /* 10 bit times at --baud */
static uint64_t next_inject_ok; /* earliest cycle for next injection (wire spacing) */
static int uart_xoff;
static uint64_t tick_at;        /* 16U2 next tick event, 0 = none */
static unsigned long bytes_to_host, bytes_from_host, bytes_discarded;
static unsigned long lost_to_board, lost_to_host; /* a harness queue was full: never expected */
static unsigned long host_rx_stalls;  /* times the harness stopped reading the pty (queue full) */
static int host_rx_stalled;
static unsigned long bridge_full_releases; /* 16U2 releases because > 96 bytes waited */
static unsigned long runahead_jumps;  /* host stimulus while running ahead: time base moved */
static uint64_t runahead_jump_cycles;
static int announced;                 /* ready line printed (after the firmware's RXEN0) */
static uint64_t last_host_byte_t;   /* cycle the last host byte entered the UART */
static unsigned long faults_dropped, faults_inserted, faults_flipped;

/* firmware time measurement */
static int fw_pending;
static uint64_t fw_start;
static uint64_t fw_samples[NSAMPLES];
static unsigned fw_nsamples, fw_next;
static uint64_t fw_last;

/* PRNG (xorshift64*), deterministic from --seed */
static uint64_t rng_state;
static uint64_t rng_next(void)
{
	uint64_t x = rng_state;
	x ^= x >> 12; x ^= x << 25; x ^= x >> 27;
	rng_state = x;
	return x * 0x2545F4914F6CDD1DULL;
}
static double rng_unit(void) { return (double)(rng_next() >> 11) / 9007199254740992.0; }

/* circuit */
static int drive_level[NPINS];  /* -1 released, 0/1 driven from outside */
static int analog_mv[8];
static int adc_sent[9];
static double temperature_c = 25.0;
static double r2r_res[6][4];    /* per ladder: Ra (B0-N0), Rg (N0-GND), Rs (N0-OUT), Rb (B1-OUT) */
static double r2r_mv[6];
static int in_circuit, circuit_again;
static uint8_t sh_ddr[3], sh_port[3];   /* shadows, index 0=B 1=C 2=D */
static const char port_names[3] = {'B', 'C', 'D'};
static const uint8_t addr_pin[3] = {0x23, 0x26, 0x29};
static const uint8_t addr_ddr[3] = {0x24, 0x27, 0x2A};
static const uint8_t addr_port[3] = {0x25, 0x28, 0x2B};
static avr_irq_t *pin_irq[NPINS];
static avr_irq_t *adc_irq_base;
static avr_irq_t *port_irq_base[3];   /* per port: base of its IOPORT IRQs */

/* pulse generator (D2, D3) */
struct pulsegen { int active, level; unsigned long remaining, done; uint64_t high_c, low_c, next_t; };
static struct pulsegen gen[2];

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
static struct capture cap[NPINS];

static uint64_t next_event = UINT64_MAX;

/* ------------------------------------------------------------------ helpers */
static void logf_(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	fprintf(stderr, "virtual-uno: ");
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
	va_end(ap);
}

static uint64_t now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ULL + (uint64_t)ts.tv_nsec;
}

static uint64_t wall_cycles(uint64_t ns)
{
	return cycle_base + (ns - wall_base_ns) * CYC_PER_US / 1000ULL;
}

static void rebase(void)
{
	wall_base_ns = now_ns();
	cycle_base = avr ? avr->cycle : 0;
}

/* Room left in the host->board queue.  When it is full the harness stops
 * reading the pty (build_pollfds no longer asks for POLLIN): the kernel's pty
 * buffer fills and the host's write() blocks, as a real USB bridge NAKs OUT
 * packets while its buffer is full.  Nothing is dropped for want of room. */
static size_t host_rx_room(void)
{
	return RING - 1 - ring_len(&host_rx);
}

/* Idle link: nothing waits to go either way, no pulse train runs.  Then the
 * simulation may run up to RUNAHEAD_CYCLES ahead of the wall clock instead of
 * LEAD_MAX_CYCLES, so a firmware's periodic tick (100 us in the project
 * firmware, a busy loop in Arduino sketches) costs one wait per ~2 ms instead
 * of one per tick.  Whatever the firmware sends meanwhile makes the link busy
 * again and is delivered at its simulated time (the harness waits for the
 * wall clock before handing it over), so board-initiated timing is kept.
 * Not while the UART receiver is off (boot, reset): bytes that would be lost
 * to it on a real board must be lost here too. */
#define UCSR0B_RXEN0(a) ((a)->data[0xC1] & 0x10)
static int link_idle(void)
{
	/* and the receiver on: while the firmware boots, a host byte must meet the
	 * receiver-off window in wall time, as on a real board (no run-ahead) */
	return avr && UCSR0B_RXEN0(avr) && ring_empty(&host_rx) && ring_empty(&wire_tx) && !out_len &&
	       ring_empty(&bridge_buf) && ring_empty(&usb_out) && !gen[0].active &&
	       !gen[1].active && !holding_reset;
}

static uint64_t lead_allowed(void)
{
	return link_idle() ? RUNAHEAD_CYCLES : LEAD_MAX_CYCLES;
}

/* A host stimulus (pty bytes, a control command that changes the circuit)
 * arrives at wall time W while the simulation may be running ahead of W.  It
 * cannot be applied in the simulated past, and applying it in the simulated
 * future would delay the firmware's answer by the lead.  Instead the time base
 * moves: "now" in simulated time becomes W.  The simulated clock thus gains
 * at most RUNAHEAD_CYCLES per idle-to-busy transition caused by the host
 * (counted in status: runahead_jumps, runahead_jump_us); latency measured by
 * the host is unaffected. */
static void catch_up_wall(void)
{
	if (!avr || opt_fast)
		return;
	uint64_t wc = wall_cycles(now_ns());
	if (avr->cycle > wc + LEAD_MAX_CYCLES) {
		runahead_jumps++;
		runahead_jump_cycles += avr->cycle - wc;
		rebase();
	}
}

static int pin_port(int p) { return p < 8 ? 2 : (p < 14 ? 0 : 1); }
static int pin_bit(int p) { return p < 8 ? p : (p < 14 ? p - 8 : p - 14); }

/* ------------------------------------------------------------------ circuit */
static int loop_partner(int p)
{
	if (opt_fixture != FIX_LOOPBACK || p < 2 || p > 13)
		return -1;
	return (p % 2 == 0) ? p + 1 : p - 1;
}

static int is_out(int p) { return (sh_ddr[pin_port(p)] >> pin_bit(p)) & 1; }
static int port_bit(int p) { return (sh_port[pin_port(p)] >> pin_bit(p)) & 1; }

/* Output of R2R ladder k (mV) from the real (toleranced) resistor network. */
static double r2r_output(int k)
{
	const double vcc = 5000.0, rpu = 35000.0;
	int pins[2] = {2 + 2 * k, 3 + 2 * k}; /* B0, B1 */
	double g[2], v[2];
	for (int i = 0; i < 2; i++) {
		int p = pins[i];
		double rbranch = i == 0 ? r2r_res[k][0] : r2r_res[k][3];
		if (is_out(p)) {
			g[i] = 1.0 / rbranch; v[i] = port_bit(p) ? vcc : 0.0;
		} else if (drive_level[p] >= 0) {
			g[i] = 1.0 / rbranch; v[i] = drive_level[p] ? vcc : 0.0;
		} else if (port_bit(p)) {           /* input with pull-up */
			g[i] = 1.0 / (rbranch + rpu); v[i] = vcc;
		} else {                            /* high impedance: branch open */
			g[i] = 0.0; v[i] = 0.0;
		}
	}
	double ga = g[0], gb = g[1], gg = 1.0 / r2r_res[k][1], gs = 1.0 / r2r_res[k][2];
	double det = (ga + gg + gs) * (gs + gb) - gs * gs;
	return ((ga + gg + gs) * gb * v[1] + gs * ga * v[0]) / det;
}

/* The level an input pin sees from the outside world. */
static int input_level(int p)
{
	if ((p == 2 || p == 3) && gen[p - 2].active)
		return gen[p - 2].level;
	if (drive_level[p] >= 0)
		return drive_level[p];
	int q = loop_partner(p);
	if (q >= 0) {
		if (is_out(q))
			return port_bit(q);
		if (port_bit(q))
			return 1;
	}
	if (port_bit(p))
		return 1; /* internal pull-up */
	if (opt_fixture == FIX_R2R && p >= 14)
		return r2r_mv[p - 14] > 2500.0;
	return 0;
}

static int pin_level(int p)
{
	if (p < 2) /* UART pins: report the PIN register */
		return (avr->data[addr_pin[2]] >> p) & 1;
	return is_out(p) ? port_bit(p) : input_level(p);
}

static int pin_managed(int p)
{
	return p >= 2; /* D0/D1 belong to the UART */
}

static void send_adc(int ch, int mv)
{
	if (adc_sent[ch] == mv)
		return;
	adc_sent[ch] = mv;
	avr_raise_irq(adc_irq_base + (ch == 8 ? ADC_IRQ_TEMP : ADC_IRQ_ADC0 + ch), (uint32_t)mv);
}

static void update_analog(void)
{
	for (int ch = 0; ch < 8; ch++) {
		int mv = analog_mv[ch];
		if (opt_fixture == FIX_R2R && ch < 6) {
			r2r_mv[ch] = r2r_output(ch);
			mv = (int)lround(r2r_mv[ch]);
		}
		send_adc(ch, mv);
	}
	send_adc(8, (int)lround(314.0 + (temperature_c - 25.0) * 1.0));
}

/* Recompute every input pin from the circuit and push it into simavr.
 * The external pull mask makes simavr's own port logic (which re-raises pin
 * IRQs on every PORT/DDR write) keep our level instead of its pull-up guess. */
static void apply_circuit(void)
{
	if (in_circuit) {
		circuit_again = 1;
		return;
	}
	in_circuit = 1;
	int rounds = 0;
	do {
		circuit_again = 0;
		if (opt_fixture == FIX_R2R)
			update_analog();
		for (int pi = 0; pi < 3; pi++) {
			uint8_t mask = 0, value = 0;
			for (int p = 0; p < NPINS; p++) {
				if (pin_port(p) != pi || !pin_managed(p) || is_out(p))
					continue;
				mask |= (uint8_t)(1 << pin_bit(p));
				if (input_level(p))
					value |= (uint8_t)(1 << pin_bit(p));
			}
			avr_ioport_external_t ext = {.name = (unsigned)port_names[pi], .mask = mask, .value = value};
			avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port_names[pi]), &ext);
			for (int p = 0; p < NPINS; p++) {
				if (pin_port(p) != pi || !pin_managed(p) || is_out(p))
					continue;
				uint32_t lv = (uint32_t)((value >> pin_bit(p)) & 1);
				/* raise only real changes: the first raise of a simavr IRQ always
				 * notifies, and a spurious "low" confuses simavr's INT0/INT1
				 * level-trigger emulation (endless INTF1) */
				if ((pin_irq[p]->value & 1) != lv)
					avr_raise_irq(pin_irq[p], lv);
			}
		}
	} while (circuit_again && ++rounds < 4);
	in_circuit = 0;
}

static void ddr_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	int pi = (int)(intptr_t)param;
	sh_ddr[pi] = (uint8_t)value;
	apply_circuit();
}

static void port_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	int pi = (int)(intptr_t)param;
	sh_port[pi] = (uint8_t)value;
	apply_circuit();
}

static void capture_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	int p = (int)(intptr_t)param;
	struct capture *c = &cap[p];
	int level = value & 1;
	uint64_t t = avr->cycle;
	if (level == c->level)
		return;
	c->level = level;
	c->edge_t = t;
	c->have_edge = 1;
	if (level) {
		if (c->have_rise) {
			c->period_us[c->pe_next] = (double)(t - c->rise_t) / CYC_PER_US;
			c->pe_next = (c->pe_next + 1) % NEDGE;
			if (c->np < NEDGE) c->np++;
			c->periods++;
		}
		c->rise_t = t;
		c->have_rise = 1;
		c->rises++;
	} else {
		if (c->have_rise) {
			c->high_us[c->hi_next] = (double)(t - c->rise_t) / CYC_PER_US;
			c->rise_us[c->hi_next] = (double)c->rise_t / CYC_PER_US;
			c->hi_next = (c->hi_next + 1) % NEDGE;
			if (c->nh < NEDGE) c->nh++;
			c->highs++;
		}
		c->falls++;
	}
}

static void read_shadows(void)
{
	for (int pi = 0; pi < 3; pi++) {
		sh_ddr[pi] = avr->data[addr_ddr[pi]];
		sh_port[pi] = avr->data[addr_port[pi]];
	}
}

static void setup_r2r(void)
{
	uint64_t saved = rng_state;
	rng_state = opt_seed * 0x9E3779B97F4A7C15ULL + 0x1234567ULL;
	if (!rng_state) rng_state = 1;
	const double nominal[4] = {20000.0, 20000.0, 10000.0, 20000.0};
	for (int k = 0; k < 6; k++)
		for (int i = 0; i < 4; i++)
			r2r_res[k][i] = nominal[i] * (1.0 + (2.0 * rng_unit() - 1.0) * opt_r2r_tol / 100.0);
	rng_state = saved;
}

/* ------------------------------------------------------------------ events */
static void schedule(uint64_t t)
{
	if (t < next_event)
		next_event = t;
}

static void recompute_next_event(void)
{
	next_event = UINT64_MAX;
	if (!ring_empty(&host_rx) && !uart_xoff) {
		uint64_t t = ring_peek(&host_rx)->t;
		schedule(t > next_inject_ok ? t : next_inject_ok);
	}
	if (!ring_empty(&wire_tx))
		schedule(ring_peek(&wire_tx)->t);
	if (tick_at)
		schedule(tick_at);
	if (!ring_empty(&usb_out))
		schedule(ring_peek(&usb_out)->t);
	for (int i = 0; i < 2; i++)
		if (gen[i].active)
			schedule(gen[i].next_t);
}

static uint64_t next_boundary(uint64_t t, uint64_t period)
{
	return (t / period + 1) * period;
}

#define UCSR0B_ADDR 0xC1
#define UDRIE0_BIT 0x20

/* Board->host bytes collect in out_buf and go to the pty in one write() when
 * the wire falls idle or a 16U2 frame is released (run_events), when the
 * firmware goes to sleep (sleep_for) or the harness is about to wait
 * (wait_fds), or from the main loop once the oldest has waited OUT_HOLD_NS
 * of wall time (simulation running behind).  A byte is handed over no
 * earlier than before (when simulated time reaches its modelled arrival) and
 * at most a few microseconds later; one write() per byte cost ~5 us of
 * syscall and kernel pty work each. */
static void to_host(uint8_t b)
{
	if (!out_len)
		out_first_ns = now_ns();
	if (out_len < sizeof(out_buf))
		out_buf[out_len++] = b;
	else
		lost_to_host++; /* host not reading and 8 KiB already waiting */
}

static void flush_out(void)
{
	if (!out_len)
		return;
	if (master_fd < 0 || !slave_open) {
		bytes_discarded += out_len;
		out_len = 0;
		return;
	}
	ssize_t n = write(master_fd, out_buf, out_len);
	pty_writes++;
	if (n > 0) {
		bytes_to_host += (unsigned long)n;
		memmove(out_buf, out_buf + n, out_len - (size_t)n);
		out_len -= (size_t)n;
	}
	if (out_len) /* pty full (host not reading): retry on POLLOUT or after OUT_HOLD_NS */
		out_first_ns = now_ns();
}

static void release_16u2(uint64_t now)
{
	uint64_t frame = next_boundary(now, USB_FRAME_CYCLES);
	while (!ring_empty(&bridge_buf)) {
		if (!ring_push(&usb_out, ring_peek(&bridge_buf)->b, frame))
			lost_to_host++;
		ring_pop(&bridge_buf);
	}
}

/* A byte has fully left the AVR's TX pin: apply line faults, hand it to the bridge. */
static void byte_off_wire(uint8_t b, uint64_t now)
{
	uint8_t bytes[2];
	int n = 0;
	if (fault_drop > 0 && rng_unit() < fault_drop) {
		faults_dropped++;
	} else {
		if (fault_flip > 0 && rng_unit() < fault_flip) {
			b ^= (uint8_t)(1u << (rng_next() % 8));
			faults_flipped++;
		}
		bytes[n++] = b;
	}
	if (fault_insert > 0 && rng_unit() < fault_insert) {
		bytes[n++] = (uint8_t)rng_next();
		faults_inserted++;
	}
	for (int i = 0; i < n; i++) {
		if (!opt_16u2) {
			to_host(bytes[i]);
		} else {
			if (!ring_push(&bridge_buf, bytes[i], now))
				lost_to_host++;
			/* Arduino-usbserial.c sends when (TIFR0 & TOV0) || BufferCount >
			 * BUFFER_NEARLY_FULL (96): the 97th waiting byte, not the 96th */
			if (ring_len(&bridge_buf) > NEARLY_FULL_16U2) {
				bridge_full_releases++;
				release_16u2(now);
			} else if (!tick_at) {
				tick_at = next_boundary(now, TICK_16U2_CYCLES);
			}
		}
	}
}

static void run_events(void)
{
	uint64_t now = avr->cycle;
	int progress = 1;
	while (progress) {
		progress = 0;
		/* host -> board injection, one byte per 10 bit times */
		if (!ring_empty(&host_rx) && !uart_xoff) {
			struct tbyte *tb = ring_peek(&host_rx);
			uint64_t due = tb->t > next_inject_ok ? tb->t : next_inject_ok;
			if (due <= now) {
				uint8_t b = tb->b;
				ring_pop(&host_rx);
				avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT), b);
				bytes_from_host++;
				last_host_byte_t = now;
				next_inject_ok = now + byte_cycles;
				progress = 1;
			}
		}
		if (!ring_empty(&wire_tx) && ring_peek(&wire_tx)->t <= now) {
			uint8_t b = ring_peek(&wire_tx)->b;
			ring_pop(&wire_tx);
			byte_off_wire(b, now);
			progress = 1;
		}
		if (tick_at && tick_at <= now) {
			tick_at = 0;
			release_16u2(now);
			progress = 1;
		}
		while (!ring_empty(&usb_out) && ring_peek(&usb_out)->t <= now) {
			to_host(ring_peek(&usb_out)->b);
			ring_pop(&usb_out);
			progress = 1;
		}
		for (int i = 0; i < 2; i++) {
			struct pulsegen *g = &gen[i];
			if (g->active && g->next_t <= now) {
				if (!g->level) {
					g->level = 1;
					g->next_t += g->high_c;
				} else {
					g->level = 0;
					g->done++;
					if (--g->remaining == 0)
						g->active = 0;
					else
						g->next_t += g->low_c;
				}
				apply_circuit();
				progress = 1;
			}
		}
	}
	recompute_next_event();
	/* The end of a burst goes out at once (nothing more on the wire and the
	 * firmware's UDRE interrupt off, i.e. it has nothing more queued), as does
	 * a 16U2 release (a whole USB frame's worth at once): batching must not
	 * delay the last byte of a reply. */
	if (out_len && (opt_16u2 || (ring_empty(&wire_tx) && !(avr->data[UCSR0B_ADDR] & UDRIE0_BIT))))
		flush_out();
}

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
static int extint_strict[2] = {-1, -1};

static void update_extint_strict(void)
{
	uint8_t eimsk = avr->data[EIMSK_ADDR], eicra = avr->data[EICRA_ADDR];
	for (int n = 0; n < 2; n++) {
		int want = ((eimsk >> n) & 1) && ((eicra >> (2 * n)) & 3) == 0;
		if (want != extint_strict[n]) {
			extint_strict[n] = want;
			avr_extint_set_strict_lvl_trig(avr, (uint8_t)n, (uint8_t)want);
		}
	}
}

/* ------------------------------------------------------------------ UART hooks */
/* Firmware time starts when the firmware reads the last byte of a host burst
 * from UDR0: simavr's own UDR0 read callback is wrapped (simavr allows one per
 * address), and a read that takes the last byte out of simavr's receive FIFO
 * while no host byte waits for injection starts the measurement. */
#define UDR0_ADDR 0xC6
static avr_io_read_t udr_read_orig;

static uint8_t udr_read_hook(avr_t *a, avr_io_addr_t addr, void *param)
{
	avr_uart_t *u = param;
	int had = u->input.read != u->input.write; /* simavr FIFO not empty */
	uint8_t v = udr_read_orig(a, addr, param);
	if (had && u->input.read == u->input.write && ring_empty(&host_rx)) {
		fw_pending = 1;
		fw_start = a->cycle;
	}
	return v;
}

static void wrap_udr_read(void)
{
	int io = AVR_DATA_TO_IO(UDR0_ADDR);
	udr_read_orig = avr->io[io].r.c;
	if (!udr_read_orig) {
		logf_("simavr registered no UDR0 read callback: firmware_cycles disabled");
		return;
	}
	avr->io[io].r.c = udr_read_hook;
}

static void uart_out_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	uint64_t now = avr->cycle;
	if (fw_pending) {
		fw_last = now - fw_start;
		fw_samples[fw_next] = fw_last;
		fw_next = (fw_next + 1) % NSAMPLES;
		if (fw_nsamples < NSAMPLES) fw_nsamples++;
		fw_pending = 0;
	}
	/* The byte leaves the TX pin one frame (10 bit times) after it starts;
	 * back-to-back bytes queue behind each other like in the shift register. */
	uint64_t start = now;
	if (!ring_empty(&wire_tx)) {
		unsigned last = (wire_tx.head - 1) & (RING - 1);
		uint64_t prev_end = wire_tx.d[last].t;
		if (prev_end > start) start = prev_end;
	}
	if (!ring_push(&wire_tx, (uint8_t)value, start + byte_cycles))
		lost_to_host++;
	schedule(start + byte_cycles);
}

static void uart_xon_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	if (value) { uart_xoff = 0; recompute_next_event(); }
}

static void uart_xoff_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	uart_xoff = value ? 1 : 0;
	recompute_next_event();
}

/* ------------------------------------------------------------------ run / sleep */
static struct pollfd pfds[MAX_CLIENTS + 2];
static int npfds;

static void build_pollfds(void)
{
	npfds = 0;
	if (master_fd >= 0 && slave_open && !holding_reset) {
		pfds[npfds].fd = master_fd; /* back-pressure: no POLLIN while host_rx is full */
		pfds[npfds].events = (host_rx_room() ? POLLIN : 0) | (out_len ? POLLOUT : 0);
		npfds++;
	} else if (master_fd >= 0 && slave_open) {
		pfds[npfds].fd = master_fd;  /* still read (and discard) while held in reset */
		pfds[npfds].events = POLLIN;
		npfds++;
	}
	if (listen_fd >= 0) {
		pfds[npfds].fd = listen_fd;
		pfds[npfds].events = POLLIN;
		npfds++;
	}
	for (int i = 0; i < MAX_CLIENTS; i++)
		if (clients[i].fd >= 0) {
			pfds[npfds].fd = clients[i].fd;
			pfds[npfds].events = POLLIN;
			npfds++;
		}
}

/* Wait up to timeout_ns for any descriptor; returns >0 if one is ready. */
static int wait_fds(uint64_t timeout_ns)
{
	flush_out(); /* never wait with board->host bytes held back */
	build_pollfds();
	if (master_fd >= 0 && !slave_open && timeout_ns > 5000000ULL)
		timeout_ns = 5000000ULL; /* look for the host opening the port every 5 ms */
	struct timespec ts = {.tv_sec = (time_t)(timeout_ns / 1000000000ULL),
			      .tv_nsec = (long)(timeout_ns % 1000000000ULL)};
	int r = ppoll(pfds, (nfds_t)npfds, &ts, NULL);
	return r;
}

/* Called when the firmware sleeps; returns how many cycles to advance. */
static uint64_t sleep_for(uint64_t how_long)
{
	flush_out(); /* a sleeping firmware sends nothing more for now */
	uint64_t target = avr->cycle + 1 + how_long;
	if (next_event < target)
		target = next_event > avr->cycle ? next_event : avr->cycle + 1;
	if (opt_fast) {
		uint64_t t = now_ns();
		if (t - last_io_ns > 200000ULL)
			io_ready = 1;
		return target - avr->cycle;
	}
	for (;;) {
		uint64_t t = now_ns();
		uint64_t wc = wall_cycles(t);
		/* idle link: sleep through the tick in simulated time only, as long as
		 * the lead stays within RUNAHEAD_CYCLES; once it would not, wait until
		 * the wall clock reaches the target (lead back to 0), so waits come in
		 * slices of ~2 ms instead of one per timer tick */
		if (wc >= target || (target - wc <= RUNAHEAD_CYCLES && link_idle()))
			return target - avr->cycle;
		uint64_t wait_ns = (target - wc) * 1000ULL / CYC_PER_US;
		int r = wait_fds(wait_ns);
		if (quit_flag)
			r = 1;
		if (r != 0) {
			io_ready = 1;
			wc = wall_cycles(now_ns());
			if (wc <= avr->cycle)
				return 1;
			if (wc > target)
				wc = target;
			return wc - avr->cycle;
		}
		if (master_fd >= 0 && !slave_open) {
			/* woke from the 5 ms cap: let the main loop look for the host opening the port */
			io_ready = 1;
			wc = wall_cycles(now_ns());
			if (wc <= avr->cycle)
				return 1;
			return (wc < target ? wc : target) - avr->cycle;
		}
	}
}

static void my_run(avr_t *a)
{
	avr_flashaddr_t new_pc = a->pc;
	if (a->state == cpu_Running)
		new_pc = avr_run_one(a);
	avr_cycle_count_t sleep = avr_cycle_timer_process(a);
	a->pc = new_pc;
	if (a->state == cpu_Sleeping) {
		if (!a->sreg[S_I]) {
			halted = 1; /* like silicon: asleep forever (until reset) */
			return;
		}
		a->cycle += sleep_for(sleep);
	}
	if ((a->state == cpu_Running || a->state == cpu_Sleeping) && a->interrupt_state)
		avr_service_interrupts(a);
}

/* MCUSR (data address 0x54) and its reset flags, as on silicon: a power-on reset
 * leaves only PORF, an external (DTR) reset adds EXTRF to what was there, and the
 * watchdog's WDRF is set by simavr's watchdog module itself.  Optiboot decides on
 * EXTRF alone whether to wait for avrdude or start the application. */
#define MCUSR_ADDR 0x54
#define MCUSR_PORF 0x01
#define MCUSR_EXTRF 0x02
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

static void reset_avr(uint8_t flags)
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

/* ------------------------------------------------------------------ reset / pty */
static void after_reset(void)
{
	reset_seen = 0;
	halted = 0;
	extint_strict[0] = extint_strict[1] = -1; /* re-apply after every reset */
	update_extint_strict();
	fw_pending = 0;
	uart_xoff = 0;
	ring_clear(&host_rx);
	ring_clear(&wire_tx);
	/* avr_reset() zeroes DDRx/PORTx but not the values cached in their IRQs; a
	 * firmware that then writes the value it had before the reset would raise no
	 * notification and the shadows would stay at 0.  Align the caches. */
	for (int pi = 0; pi < 3; pi++) {
		if (!port_irq_base[pi])
			continue;
		port_irq_base[pi][IOPORT_IRQ_DIRECTION_ALL].value = avr->data[addr_ddr[pi]];
		port_irq_base[pi][IOPORT_IRQ_REG_PORT].value = avr->data[addr_port[pi]];
	}
	read_shadows();
	for (int ch = 0; ch < 9; ch++)
		adc_sent[ch] = -1;
	apply_circuit();
	update_analog();
	for (int p = 0; p < NPINS; p++)
		cap[p].level = pin_level(p);
	recompute_next_event();
}

static void reset_and_run(uint8_t flags)
{
	reset_avr(flags);
	avr->state = cpu_Running;
	reset_count++;
	after_reset();
	rebase();
}

static void power_on_reset(void)
{
	reset_avr(MCUSR_PORF);
	avr->state = cpu_Running;
	reset_count++;
	after_reset();
	rebase();
}

static int open_pty(void)
{
	int fd = posix_openpt(O_RDWR | O_NOCTTY);
	if (fd < 0 || grantpt(fd) < 0 || unlockpt(fd) < 0) {
		logf_("cannot create pseudo-terminal: %s", strerror(errno));
		if (fd >= 0) close(fd);
		return -1;
	}
	const char *name = ptsname(fd);
	snprintf(pty_name, sizeof(pty_name), "%s", name ? name : "");
	struct termios tio;
	if (tcgetattr(fd, &tio) == 0) {
		cfmakeraw(&tio);
		tcsetattr(fd, TCSANOW, &tio);
	}
	/* Open and close the slave once: configures it raw and makes the master
	 * report POLLHUP until the host opens the port (used to detect the open). */
	int s = open(pty_name, O_RDWR | O_NOCTTY);
	if (s >= 0) {
		if (tcgetattr(s, &tio) == 0) {
			cfmakeraw(&tio);
			tcsetattr(s, TCSANOW, &tio);
		}
		close(s);
	}
	fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
	master_fd = fd;
	slave_open = 0;
	last_hup_check_ns = 0;
	return 0;
}

static void on_slave_open(void)
{
	slave_open = 1;
	open_count++;
	if (opt_reset_on_open && plugged) {
		reset_avr(MCUSR_EXTRF);
		avr->state = cpu_Running;
		reset_count++;
		after_reset();
		holding_reset = 1;
		hold_until_ns = now_ns() + (uint64_t)opt_boot_delay_ms * 1000000ULL;
	}
}

static void check_slave(void)
{
	if (master_fd < 0 || slave_open)
		return;
	struct pollfd p = {.fd = master_fd, .events = POLLIN};
	if (poll(&p, 1, 0) >= 0 && !(p.revents & POLLHUP))
		on_slave_open();
}

static void read_master(void)
{
	uint8_t buf[512];
	for (;;) {
		size_t want = sizeof(buf);
		if (!holding_reset && plugged) {
			size_t room = host_rx_room();
			if (!room) {
				if (!host_rx_stalled) host_rx_stalls++;
				host_rx_stalled = 1;
				return;
			}
			if (room < want) want = room;
		}
		ssize_t n = read(master_fd, buf, want);
		if (n > 0) {
			if (holding_reset || !plugged) {
				bytes_discarded += (unsigned long)n;
				continue;
			}
			host_rx_stalled = 0;
			catch_up_wall(); /* a host stimulus: never stamped in the simulation's future */
			uint64_t t = avr->cycle;
			if (opt_16u2)
				t = next_boundary(t, USB_FRAME_CYCLES);
			for (ssize_t i = 0; i < n; i++)
				if (!ring_push(&host_rx, buf[i], t))
					lost_to_board++;
			recompute_next_event();
			continue;
		}
		if (n < 0 && (errno == EAGAIN || errno == EINTR))
			return;
		/* EIO (or EOF): the host closed the port */
		slave_open = 0;
		return;
	}
}

/* ------------------------------------------------------------------ JSON */
struct jval { char key[32]; int type; double num; char str[256]; }; /* type: 0 none 1 num 2 str 3 null 4 bool */
struct jobj { struct jval v[24]; int n; };

static const char *skip_ws(const char *s) { while (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\n') s++; return s; }

static const char *parse_str(const char *s, char *out, size_t cap)
{
	size_t n = 0;
	if (*s != '"') return NULL;
	s++;
	while (*s && *s != '"') {
		char c = *s++;
		if (c == '\\' && *s) {
			char e = *s++;
			c = e == 'n' ? '\n' : e == 't' ? '\t' : e;
		}
		if (n + 1 < cap) out[n++] = c;
	}
	if (*s != '"') return NULL;
	out[n] = 0;
	return s + 1;
}

static int parse_json(const char *s, struct jobj *o)
{
	o->n = 0;
	s = skip_ws(s);
	if (*s++ != '{') return -1;
	s = skip_ws(s);
	if (*s == '}') return 0;
	for (;;) {
		if (o->n >= 24) return -1;
		struct jval *v = &o->v[o->n];
		memset(v, 0, sizeof(*v));
		s = skip_ws(s);
		s = parse_str(s, v->key, sizeof(v->key));
		if (!s) return -1;
		s = skip_ws(s);
		if (*s++ != ':') return -1;
		s = skip_ws(s);
		if (*s == '"') {
			s = parse_str(s, v->str, sizeof(v->str));
			if (!s) return -1;
			v->type = 2;
		} else if (!strncmp(s, "null", 4)) {
			v->type = 3; s += 4;
		} else if (!strncmp(s, "true", 4)) {
			v->type = 4; v->num = 1; s += 4;
		} else if (!strncmp(s, "false", 5)) {
			v->type = 4; v->num = 0; s += 5;
		} else {
			char *end;
			v->num = strtod(s, &end);
			if (end == s) return -1;
			v->type = 1; s = end;
		}
		o->n++;
		s = skip_ws(s);
		if (*s == ',') { s++; continue; }
		if (*s == '}') return 0;
		return -1;
	}
}

static struct jval *jget(struct jobj *o, const char *k)
{
	for (int i = 0; i < o->n; i++)
		if (!strcmp(o->v[i].key, k))
			return &o->v[i];
	return NULL;
}

struct sbuf { char *d; size_t len, cap; };
static void sb_add(struct sbuf *b, const char *fmt, ...)
{
	va_list ap;
	for (;;) {
		va_start(ap, fmt);
		int n = vsnprintf(b->d + b->len, b->cap - b->len, fmt, ap);
		va_end(ap);
		if (n >= 0 && (size_t)n < b->cap - b->len) { b->len += (size_t)n; return; }
		b->cap = b->cap * 2 + (size_t)n + 64;
		b->d = realloc(b->d, b->cap);
	}
}

static void sb_json_str(struct sbuf *b, const char *s)
{
	sb_add(b, "\"");
	for (; *s; s++) {
		if (*s == '"' || *s == '\\') sb_add(b, "\\%c", *s);
		else if ((unsigned char)*s < 0x20) sb_add(b, "\\u%04x", *s);
		else sb_add(b, "%c", *s);
	}
	sb_add(b, "\"");
}

/* ------------------------------------------------------------------ control */
static int get_num(struct jobj *o, const char *k, double *out)
{
	struct jval *v = jget(o, k);
	if (!v || (v->type != 1 && v->type != 4)) return 0;
	*out = v->num;
	return 1;
}

/* pin: integer 0..19 or "D0".."D13", "A0".."A5" */
static int get_pin(struct jobj *o, const char *k)
{
	struct jval *v = jget(o, k);
	if (!v) return -1;
	if (v->type == 1) {
		int p = (int)v->num;
		return (p >= 0 && p < NPINS) ? p : -1;
	}
	if (v->type == 2) {
		char c = v->str[0];
		int n = atoi(v->str + 1);
		if ((c == 'D' || c == 'd') && n >= 0 && n < 14) return n;
		if ((c == 'A' || c == 'a') && n >= 0 && n < 6) return 14 + n;
	}
	return -1;
}

static const char *state_name(void)
{
	if (!plugged) return "off";
	if (holding_reset) return "reset";
	if (halted) return "halted";
	if (avr->state == cpu_Sleeping) return "sleeping";
	if (avr->state == cpu_Running) return "running";
	return "stopped";
}

static void sb_bytes(struct sbuf *b, const uint8_t *d, int n)
{
	sb_add(b, "[");
	for (int i = 0; i < n; i++) sb_add(b, "%s%u", i ? "," : "", d[i]);
	sb_add(b, "]");
}

static void do_unplug(void)
{
	if (!plugged) return;
	flush_out(); /* bytes that already reached the host side go out first */
	plugged = 0;
	holding_reset = 0;
	if (master_fd >= 0) close(master_fd);
	master_fd = -1;
	slave_open = 0;
	out_len = 0;
	ring_clear(&bridge_buf);
	ring_clear(&usb_out);
	tick_at = 0;
	for (int i = 0; i < 2; i++) gen[i].active = 0;
}

static int do_replug(void)
{
	if (plugged) return 0;
	char old_name[sizeof(pty_name)];
	snprintf(old_name, sizeof(old_name), "%s", pty_name);
	if (open_pty() < 0) return -1;
	if (!strcmp(old_name, pty_name)) {
		/* the kernel reused the number: take another one so the host cannot
		 * mistake the new port for the old (a stale path must stay dead) */
		int first = master_fd;
		if (open_pty() < 0) { master_fd = first; snprintf(pty_name, sizeof(pty_name), "%s", old_name); }
		else close(first);
	}
	plugged = 1;
	power_on_reset();
	return 0;
}

static void handle_command(struct jobj *o, struct sbuf *r)
{
	struct jval *cv = jget(o, "cmd");
	if (!cv) cv = jget(o, "command");
	if (!cv || cv->type != 2) { sb_add(r, "{\"ok\": false, \"error\": \"missing cmd\"}"); return; }
	const char *cmd = cv->str;
	double x;
	static const char *const observers[] = {"status", "pin", "pulse_stats", "firmware_cycles",
						 "eeprom_i2c", "eeprom", "peek", "ping", NULL};
	int observes = 0;
	for (int i = 0; observers[i]; i++)
		observes |= !strcmp(cmd, observers[i]);
	if (!observes)
		catch_up_wall(); /* a stimulus takes effect at the simulated "now" of its wall time */

	if (!strcmp(cmd, "status")) {
		uint64_t t = now_ns();
		int64_t lag = plugged && !opt_fast ? (int64_t)wall_cycles(t) - (int64_t)avr->cycle : 0;
		sb_add(r, "{\"ok\": true, \"cycle\": %llu, \"sim_us\": %.3f, \"wall_us\": %.3f, "
			  "\"lag_us\": %.3f, \"max_lag_us\": %.3f, \"rebases\": %lu, \"port\": ",
		       (unsigned long long)avr->cycle, (double)avr->cycle / CYC_PER_US,
		       (double)(t - start_ns) / 1000.0, (double)lag / CYC_PER_US,
		       (double)max_lag_cycles / CYC_PER_US, rebase_count);
		sb_json_str(r, plugged ? pty_name : "");
		sb_add(r, ", \"plugged\": %s, \"host_open\": %s, \"state\": \"%s\", \"id\": ",
		       plugged ? "true" : "false", slave_open ? "true" : "false", state_name());
		if (opt_id >= 0) sb_add(r, "%d", opt_id); else sb_add(r, "null");
		sb_add(r, ", \"baud\": %u, \"fixture\": \"%s\", \"usb_bridge\": \"%s\", \"fast\": %s, "
			  "\"reset_on_open\": %s, \"resets\": %lu, \"opens\": %lu, "
			  "\"bytes_to_host\": %lu, \"bytes_from_host\": %lu, \"bytes_discarded\": %lu, \"pty_writes\": %lu, "
			  "\"faults\": {\"drop\": %g, \"insert\": %g, \"flip\": %g, \"dropped\": %lu, "
			  "\"inserted\": %lu, \"flipped\": %lu}, \"pulses_active\": %s, "
			  "\"pulses_done\": {\"2\": %lu, \"3\": %lu}, \"temperature_c\": %g, \"pc\": %u, "
			  "\"last_host_byte_us\": %.3f, \"lost\": {\"to_board\": %lu, \"to_host\": %lu}, "
			  "\"host_rx_stalls\": %lu, \"host_rx_queued\": %u, \"bridge_full_releases\": %lu, "
			  "\"runahead_jumps\": %lu, \"runahead_jump_us\": %.3f}",
		       opt_baud, fixture_names[opt_fixture], opt_16u2 ? "16u2" : "none",
		       opt_fast ? "true" : "false", opt_reset_on_open ? "true" : "false",
		       reset_count, open_count, bytes_to_host, bytes_from_host, bytes_discarded, pty_writes,
		       fault_drop, fault_insert, fault_flip, faults_dropped, faults_inserted,
		       faults_flipped, (gen[0].active || gen[1].active) ? "true" : "false",
		       gen[0].done, gen[1].done, temperature_c, (unsigned)avr->pc,
		       (double)last_host_byte_t / CYC_PER_US, lost_to_board, lost_to_host,
		       host_rx_stalls, ring_len(&host_rx), bridge_full_releases, runahead_jumps,
		       (double)runahead_jump_cycles / CYC_PER_US);
		return;
	}
	if (!strcmp(cmd, "set_analog")) {
		double ch, mv;
		if (!get_num(o, "channel", &ch) || !get_num(o, "mv", &mv) || ch < 0 || ch > 7 || mv < 0 || mv > 5500) {
			sb_add(r, "{\"ok\": false, \"error\": \"set_analog needs channel 0..7 and mv 0..5500\"}");
			return;
		}
		analog_mv[(int)ch] = (int)lround(mv);
		update_analog();
		sb_add(r, "{\"ok\": true, \"r2r_override\": %s}",
		       (opt_fixture == FIX_R2R && ch < 6) ? "true" : "false");
		return;
	}
	if (!strcmp(cmd, "set_temperature")) {
		if (!get_num(o, "celsius", &x) || x < -60 || x > 150) {
			sb_add(r, "{\"ok\": false, \"error\": \"set_temperature needs celsius -60..150\"}");
			return;
		}
		temperature_c = x;
		update_analog();
		sb_add(r, "{\"ok\": true, \"mv\": %.1f}", 314.0 + (x - 25.0));
		return;
	}
	if (!strcmp(cmd, "drive")) {
		int p = get_pin(o, "pin");
		struct jval *lv = jget(o, "level");
		if (p < 2 || !lv || (lv->type != 3 && lv->type != 1 && lv->type != 4)) {
			sb_add(r, "{\"ok\": false, \"error\": \"drive needs pin (D2..D13, A0..A5) and level 0|1|null\"}");
			return;
		}
		if (loop_partner(p) >= 0 && lv->type != 3) {
			sb_add(r, "{\"ok\": false, \"error\": \"pin is jumpered in the loopback fixture\"}");
			return;
		}
		drive_level[p] = lv->type == 3 ? -1 : (lv->num != 0);
		apply_circuit();
		sb_add(r, "{\"ok\": true, \"output\": %s}", is_out(p) ? "true" : "false");
		return;
	}
	if (!strcmp(cmd, "pin")) {
		int p = get_pin(o, "pin");
		if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
		sb_add(r, "{\"ok\": true, \"pin\": %d, \"ddr\": %d, \"port\": %d, \"level\": %d",
		       p, is_out(p), port_bit(p), pin_level(p));
		if (p >= 14) {
			int ch = p - 14;
			sb_add(r, ", \"mv\": %d", adc_sent[ch]);
		}
		sb_add(r, "}");
		return;
	}
	if (!strcmp(cmd, "pulses")) {
		int p = get_pin(o, "pin");
		double cnt, hi, lo;
		if ((p != 2 && p != 3) || !get_num(o, "count", &cnt) || !get_num(o, "high_us", &hi) ||
		    !get_num(o, "low_us", &lo) || cnt < 1 || hi < 1 || lo < 1) {
			sb_add(r, "{\"ok\": false, \"error\": \"pulses needs pin 2|3, count>=1, high_us>=1, low_us>=1\"}");
			return;
		}
		if (!plugged || is_out(p) || loop_partner(p) >= 0) {
			sb_add(r, "{\"ok\": false, \"error\": \"pin is not a free input (output, jumpered or unplugged)\"}");
			return;
		}
		struct pulsegen *g = &gen[p - 2];
		g->active = 1;
		g->level = 0;
		g->remaining = (unsigned long)cnt;
		g->high_c = (uint64_t)llround(hi * CYC_PER_US);
		g->low_c = (uint64_t)llround(lo * CYC_PER_US);
		g->next_t = avr->cycle + 16;
		recompute_next_event();
		sb_add(r, "{\"ok\": true, \"done_before\": %lu}", g->done);
		return;
	}
	if (!strcmp(cmd, "pulse_stats") || !strcmp(cmd, "clear_pulse_stats")) {
		int p = get_pin(o, "pin");
		if (p < 0) { sb_add(r, "{\"ok\": false, \"error\": \"bad pin\"}"); return; }
		struct capture *c = &cap[p];
		if (cmd[0] == 'c') {
			int lvl = c->level;
			memset(c, 0, sizeof(*c));
			c->level = lvl;
			sb_add(r, "{\"ok\": true}");
			return;
		}
		sb_add(r, "{\"ok\": true, \"pin\": %d, \"count\": %lu, \"falls\": %lu, \"level\": %d, "
			  "\"highs\": %lu, \"periods\": %lu, \"high_us\": [",
		       p, c->rises, c->falls, c->level, c->highs, c->periods);
		for (unsigned i = 0; i < c->nh; i++) {
			unsigned idx = (c->hi_next + NEDGE - c->nh + i) % NEDGE;
			sb_add(r, "%s%.3f", i ? ", " : "", c->high_us[idx]);
		}
		sb_add(r, "], \"rise_us\": [");
		for (unsigned i = 0; i < c->nh; i++) {
			unsigned idx = (c->hi_next + NEDGE - c->nh + i) % NEDGE;
			sb_add(r, "%s%.3f", i ? ", " : "", c->rise_us[idx]);
		}
		if (c->have_edge)
			sb_add(r, "], \"last_edge_us\": %.3f", (double)c->edge_t / CYC_PER_US);
		else
			sb_add(r, "], \"last_edge_us\": null");
		sb_add(r, ", \"period_us\": [");
		for (unsigned i = 0; i < c->np; i++) {
			unsigned idx = (c->pe_next + NEDGE - c->np + i) % NEDGE;
			sb_add(r, "%s%.3f", i ? ", " : "", c->period_us[idx]);
		}
		sb_add(r, "]}");
		return;
	}
	if (!strcmp(cmd, "set_faults")) {
		double v;
		if (get_num(o, "drop", &v)) fault_drop = v;
		if (get_num(o, "insert", &v)) fault_insert = v;
		if (get_num(o, "flip", &v)) fault_flip = v;
		if (get_num(o, "seed", &v)) { rng_state = (uint64_t)v * 0x9E3779B97F4A7C15ULL + 1; }
		sb_add(r, "{\"ok\": true, \"drop\": %g, \"insert\": %g, \"flip\": %g}", fault_drop, fault_insert, fault_flip);
		return;
	}
	if (!strcmp(cmd, "unplug")) {
		do_unplug();
		sb_add(r, "{\"ok\": true}");
		return;
	}
	if (!strcmp(cmd, "replug")) {
		if (do_replug() < 0) { sb_add(r, "{\"ok\": false, \"error\": \"cannot create pty\"}"); return; }
		sb_add(r, "{\"ok\": true, \"port\": ");
		sb_json_str(r, pty_name);
		sb_add(r, "}");
		return;
	}
	if (!strcmp(cmd, "reset")) {
		if (!plugged) { sb_add(r, "{\"ok\": false, \"error\": \"unplugged\"}"); return; }
		holding_reset = 0;
		power_on_reset();
		sb_add(r, "{\"ok\": true}");
		return;
	}
	if (!strcmp(cmd, "firmware_cycles")) {
		sb_add(r, "{\"ok\": true, \"samples\": [");
		for (unsigned i = 0; i < fw_nsamples; i++) {
			unsigned idx = (fw_next + NSAMPLES - fw_nsamples + i) % NSAMPLES;
			sb_add(r, "%s%llu", i ? ", " : "", (unsigned long long)fw_samples[idx]);
		}
		sb_add(r, "], \"last\": ");
		if (fw_nsamples) sb_add(r, "%llu", (unsigned long long)fw_last); else sb_add(r, "null");
		sb_add(r, ", \"cycles_per_us\": %llu}", CYC_PER_US);
		if (jget(o, "clear")) fw_nsamples = 0;
		return;
	}
	if (!strcmp(cmd, "eeprom_i2c") || !strcmp(cmd, "eeprom")) {
		double off = 0, len = 16;
		get_num(o, "offset", &off);
		get_num(o, "length", &len);
		int size = cmd[6] == '_' ? 256 : 1024;
		if (off < 0 || len < 0 || off + len > size) {
			sb_add(r, "{\"ok\": false, \"error\": \"range outside 0..%d\"}", size);
			return;
		}
		uint8_t buf[1024];
		if (size == 256) {
			memcpy(buf, i2c_ee.ee + (int)off, (size_t)len);
		} else {
			avr_eeprom_desc_t d = {.ee = buf, .offset = (uint16_t)off, .size = (uint32_t)len};
			/* simavr's eeprom ioctl returns -1 even on success: ignore the result */
			if (len > 0)
				avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);
			if (d.ee != buf) /* some simavr versions return a pointer instead of copying */
				memcpy(buf, d.ee, (size_t)len);
		}
		sb_add(r, "{\"ok\": true, \"offset\": %d, \"bytes\": ", (int)off);
		sb_bytes(r, buf, (int)len);
		sb_add(r, "}");
		return;
	}
	if (!strcmp(cmd, "ping")) { sb_add(r, "{\"ok\": true}"); return; }
	if (!strcmp(cmd, "peek")) { /* debugging aid: read data-space bytes (registers, I/O, RAM) */
		double a = 0, len = 1;
		get_num(o, "addr", &a);
		get_num(o, "length", &len);
		if (a < 0 || len < 1 || a + len > avr->ramend + 1) { sb_add(r, "{\"ok\": false, \"error\": \"bad range\"}"); return; }
		sb_add(r, "{\"ok\": true, \"bytes\": ");
		sb_bytes(r, avr->data + (int)a, (int)len);
		sb_add(r, "}");
		return;
	}
	sb_add(r, "{\"ok\": false, \"error\": \"unknown cmd: ");
	for (const char *s = cmd; *s; s++) if (*s != '"' && *s != '\\' && (unsigned char)*s >= 0x20) sb_add(r, "%c", *s);
	sb_add(r, "\"}");
}

static void client_close(struct client *c)
{
	close(c->fd);
	c->fd = -1;
	c->len = 0;
}

static void client_read(struct client *c)
{
	ssize_t n = read(c->fd, c->buf + c->len, sizeof(c->buf) - 1 - c->len);
	if (n <= 0) {
		if (n < 0 && (errno == EAGAIN || errno == EINTR)) return;
		client_close(c);
		return;
	}
	c->len += (size_t)n;
	for (;;) {
		char *nl = memchr(c->buf, '\n', c->len);
		if (!nl) {
			if (c->len >= sizeof(c->buf) - 1) client_close(c); /* line too long */
			return;
		}
		*nl = 0;
		struct sbuf r = {.d = malloc(1024), .len = 0, .cap = 1024};
		struct jobj o;
		if (parse_json(c->buf, &o) < 0)
			sb_add(&r, "{\"ok\": false, \"error\": \"bad JSON object\"}");
		else
			handle_command(&o, &r);
		sb_add(&r, "\n");
		/* replies are small; a blocking write keeps the protocol simple */
		int fl = fcntl(c->fd, F_GETFL);
		fcntl(c->fd, F_SETFL, fl & ~O_NONBLOCK);
		size_t off = 0;
		while (off < r.len) {
			ssize_t w = send(c->fd, r.d + off, r.len - off, MSG_NOSIGNAL);
			if (w <= 0) break;
			off += (size_t)w;
		}
		fcntl(c->fd, F_SETFL, fl);
		free(r.d);
		size_t used = (size_t)(nl - c->buf) + 1;
		memmove(c->buf, c->buf + used, c->len - used);
		c->len -= used;
		if (off < r.len) { client_close(c); return; }
		run_events(); /* commands may change timing state */
	}
}

/* Handle ready descriptors after a ppoll (wait_fds) or poll with 0 timeout. */
static void service_io(void)
{
	last_io_ns = now_ns();
	for (int i = 0; i < npfds; i++) {
		if (!pfds[i].revents) continue;
		int fd = pfds[i].fd;
		if (fd == master_fd && master_fd >= 0) {
			if (pfds[i].revents & POLLIN)
				read_master();
			if (pfds[i].revents & (POLLHUP | POLLERR)) {
				if (master_fd >= 0) read_master();
				slave_open = 0;
			}
			if (pfds[i].revents & POLLOUT) flush_out();
		} else if (fd == listen_fd) {
			int c = accept4(listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
			if (c >= 0) {
				int placed = 0;
				for (int k = 0; k < MAX_CLIENTS; k++)
					if (clients[k].fd < 0) { clients[k].fd = c; clients[k].len = 0; placed = 1; break; }
				if (!placed) close(c);
			}
		} else {
			for (int k = 0; k < MAX_CLIENTS; k++)
				if (clients[k].fd == fd) { client_read(&clients[k]); break; }
		}
		pfds[i].revents = 0;
	}
	npfds = 0;
	uint64_t t = now_ns();
	if (opt_exit_with_parent && t - last_parent_check_ns > 200000000ULL) {
		/* launcher died without stopping us (SIGKILL): do not linger */
		last_parent_check_ns = t;
		if (getppid() != orig_ppid)
			quit_flag = 1;
	}
	if (master_fd >= 0 && !slave_open && t - last_hup_check_ns > 2000000ULL) {
		last_hup_check_ns = t;
		check_slave();
	}
	if (holding_reset && t >= hold_until_ns) {
		holding_reset = 0;
		reset_and_run(MCUSR_EXTRF); /* DTR released: an external reset */
	}
	run_events();
}

static void poll_io(uint64_t timeout_ns)
{
	int r = wait_fds(timeout_ns);
	if (r < 0) npfds = 0;
	service_io();
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

/* ------------------------------------------------------------------ setup */
static void on_signal(int sig) { quit_flag = 1; }

/* The ready line goes out once the firmware has switched its UART receiver on
 * (RXEN0), not at power-up: a host that writes a request the moment it learns
 * the port would otherwise lose it to a receiver that is still off (simavr
 * drops input while RXEN0 is clear, as silicon does).  A firmware that never
 * enables its receiver is announced after ANNOUNCE_MAX_CYCLES (250 ms) of
 * simulated time, or when it halts. */
#define RXEN0_BIT 0x10
static void announce_when_listening(void)
{
	if (plugged && !halted && !(avr->data[UCSR0B_ADDR] & RXEN0_BIT) &&
	    avr->cycle < ANNOUNCE_MAX_CYCLES)
		return;
	announced = 1;
	char line[1024], idtxt[16];
	if (opt_id >= 0)
		snprintf(idtxt, sizeof(idtxt), "%d", opt_id);
	else
		snprintf(idtxt, sizeof(idtxt), "null");
	int n = snprintf(line, sizeof(line),
			 "{\"port\": \"%s\", \"control\": \"%s\", \"pid\": %d, \"id\": %s, \"baud\": %u}\n",
			 pty_name, ctl_path, (int)getpid(), idtxt, opt_baud);
	if (write(json_fd, line, (size_t)n) != n) { /* parent gone: keep running until signalled */ }
}

static void usage(void)
{
	fprintf(stderr,
		"usage: virtual-uno --elf PATH|--bootloader HEX [--elf PATH] [--id N] [--baud 115200|1000000] [--fixture open|loopback|r2r]\n"
		"       [--r2r-tolerance PCT] [--fast] [--reset-on-open] [--boot-delay-ms MS]\n"
		"       [--usb-bridge none|16u2] [--fault-drop P] [--fault-insert P] [--fault-flip P]\n"
		"       [--seed N] [--control SOCKET_PATH] [--exit-with-parent]\n");
}

static int parse_args(int argc, char **argv)
{
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i];
		const char *v = i + 1 < argc ? argv[i + 1] : NULL;
#define NEEDV() do { if (!v) { logf_("%s needs a value", a); return -1; } i++; } while (0)
		if (!strcmp(a, "--elf")) { NEEDV(); opt_elf = v; }
		else if (!strcmp(a, "--bootloader")) { NEEDV(); opt_bootloader = v; opt_reset_on_open = 1; }
		else if (!strcmp(a, "--id")) { NEEDV(); long n = strtol(v, NULL, 0); if (n < 0 || n > 0xFFFF) { logf_("--id must be 0..65535"); return -1; } opt_id = (int)n; }
		else if (!strcmp(a, "--baud")) { NEEDV(); opt_baud = (unsigned)strtoul(v, NULL, 0); if (opt_baud < 300 || opt_baud > 2000000) { logf_("bad --baud"); return -1; } }
		else if (!strcmp(a, "--fixture")) {
			NEEDV();
			if (!strcmp(v, "open")) opt_fixture = FIX_OPEN;
			else if (!strcmp(v, "loopback")) opt_fixture = FIX_LOOPBACK;
			else if (!strcmp(v, "r2r")) opt_fixture = FIX_R2R;
			else { logf_("bad --fixture %s", v); return -1; }
		}
		else if (!strcmp(a, "--r2r-tolerance")) { NEEDV(); opt_r2r_tol = atof(v); }
		else if (!strcmp(a, "--fast")) opt_fast = 1;
		else if (!strcmp(a, "--reset-on-open")) opt_reset_on_open = 1;
		else if (!strcmp(a, "--exit-with-parent")) opt_exit_with_parent = 1;
		else if (!strcmp(a, "--boot-delay-ms")) { NEEDV(); opt_boot_delay_ms = (unsigned)strtoul(v, NULL, 0); }
		else if (!strcmp(a, "--usb-bridge")) {
			NEEDV();
			if (!strcmp(v, "none")) opt_16u2 = 0;
			else if (!strcmp(v, "16u2")) opt_16u2 = 1;
			else { logf_("bad --usb-bridge %s", v); return -1; }
		}
		else if (!strcmp(a, "--fault-drop")) { NEEDV(); fault_drop = atof(v); }
		else if (!strcmp(a, "--fault-insert")) { NEEDV(); fault_insert = atof(v); }
		else if (!strcmp(a, "--fault-flip")) { NEEDV(); fault_flip = atof(v); }
		else if (!strcmp(a, "--seed")) { NEEDV(); opt_seed = strtoull(v, NULL, 0); }
		else if (!strcmp(a, "--control")) { NEEDV(); snprintf(ctl_path, sizeof(ctl_path), "%s", v); }
		else if (!strcmp(a, "-h") || !strcmp(a, "--help")) { usage(); exit(0); }
		else { logf_("unknown argument %s", a); usage(); return -1; }
	}
	if (!opt_elf && !opt_bootloader) { logf_("--elf or --bootloader is required"); usage(); return -1; }
	return 0;
}

static int setup_control(void)
{
	if (!ctl_path[0]) {
		const char *tmp = getenv("TMPDIR");
		snprintf(ctl_dir, sizeof(ctl_dir), "%s/virtual-uno-XXXXXX", tmp && *tmp ? tmp : "/tmp");
		if (!mkdtemp(ctl_dir)) { logf_("mkdtemp: %s", strerror(errno)); return -1; }
		snprintf(ctl_path, sizeof(ctl_path), "%s/ctl.sock", ctl_dir);
	}
	struct sockaddr_un sa = {.sun_family = AF_UNIX};
	if (strlen(ctl_path) >= sizeof(sa.sun_path)) { logf_("control path too long"); return -1; }
	strcpy(sa.sun_path, ctl_path);
	unlink(ctl_path);
	listen_fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (listen_fd < 0 || bind(listen_fd, (struct sockaddr *)&sa, sizeof(sa)) < 0 || listen(listen_fd, 8) < 0) {
		logf_("control socket %s: %s", ctl_path, strerror(errno));
		return -1;
	}
	return 0;
}

int main(int argc, char **argv)
{
	/* simavr prints to stdout; keep stdout for the single JSON line only. */
	json_fd = dup(1);
	dup2(2, 1);
	setvbuf(stdout, NULL, _IONBF, 0);

	if (parse_args(argc, argv) < 0) return 2;
	orig_ppid = getppid();
	for (int i = 0; i < MAX_CLIENTS; i++) clients[i].fd = -1;
	for (int p = 0; p < NPINS; p++) drive_level[p] = -1;
	rng_state = opt_seed * 0x9E3779B97F4A7C15ULL + 1;
	if (!rng_state) rng_state = 1;
	setup_r2r();
	byte_cycles = (uint64_t)llround(10.0 * (double)F_CPU / (double)opt_baud);

	struct sigaction sa = {.sa_handler = on_signal};
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);
	prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);

	avr_global_logger_set(logger);
	elf_firmware_t fw;
	memset(&fw, 0, sizeof(fw));
	if (opt_elf && (access(opt_elf, R_OK) != 0 || elf_read_firmware(opt_elf, &fw) != 0)) {
		logf_("cannot read firmware ELF %s", opt_elf);
		return 2;
	}
	avr = avr_make_mcu_by_name("atmega328p");
	if (!avr) { logf_("simavr does not know atmega328p"); return 2; }
	avr_init(avr);
	avr->log = LOG_WARNING;
	if (opt_elf)
		avr_load_firmware(avr, &fw);
	if (opt_bootloader && load_bootloader(opt_bootloader) < 0)
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

	if (opt_id >= 0) {
		uint8_t idb[2] = {(uint8_t)(opt_id >> 8), (uint8_t)opt_id};
		avr_eeprom_desc_t d = {.ee = idb, .offset = 0, .size = 2};
		avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
	}

	i2c_eeprom_init(avr, &i2c_ee, 0xA0, 0x01, NULL, 256);
	i2c_eeprom_attach(avr, &i2c_ee, AVR_IOCTL_TWI_GETIRQ(0));

	avr_irq_t *uirq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), 0);
	avr_irq_register_notify(uirq + UART_IRQ_OUTPUT, uart_out_hook, NULL);
	wrap_udr_read();
	avr_irq_register_notify(uirq + UART_IRQ_OUT_XON, uart_xon_hook, NULL);
	avr_irq_register_notify(uirq + UART_IRQ_OUT_XOFF, uart_xoff_hook, NULL);

	adc_irq_base = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, 0);
	for (int pi = 0; pi < 3; pi++) {
		avr_irq_t *base = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port_names[pi]), 0);
		port_irq_base[pi] = base;
		avr_irq_register_notify(base + IOPORT_IRQ_DIRECTION_ALL, ddr_hook, (void *)(intptr_t)pi);
		avr_irq_register_notify(base + IOPORT_IRQ_REG_PORT, port_hook, (void *)(intptr_t)pi);
	}
	for (int p = 0; p < NPINS; p++) {
		pin_irq[p] = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port_names[pin_port(p)]), pin_bit(p));
		avr_irq_register_notify(pin_irq[p], capture_hook, (void *)(intptr_t)p);
	}

	if (setup_control() < 0) return 2;
	if (open_pty() < 0) return 2;
	start_ns = now_ns();
	after_reset();
	rebase();

	last_io_ns = now_ns();
	while (!quit_flag) {
		if (!announced)
			announce_when_listening();
		if (!plugged || holding_reset || halted) {
			uint64_t to = 20000000ULL;
			if (holding_reset) {
				uint64_t t = now_ns();
				to = hold_until_ns > t ? hold_until_ns - t : 0;
			}
			poll_io(to);
			if (!plugged || holding_reset || halted)
				rebase(); /* simulated time does not run while off/held */
			continue;
		}
		uint64_t end = avr->cycle + SLICE_CYCLES;
		io_ready = 0;
		while (avr->cycle < end && !io_ready && !halted) {
			avr->run(avr);
			if (avr->cycle >= next_event)
				run_events();
			if (reset_seen) /* e.g. watchdog reset inside simavr */
				after_reset();
			if (avr->state != cpu_Running && avr->state != cpu_Sleeping) {
				halted = 1;
				break;
			}
		}
		if (quit_flag) break;
		update_extint_strict();
		uint64_t t = now_ns();
		if (io_ready) {
			poll_io(0);
			t = now_ns();
		}
		if (out_len && t - out_first_ns >= OUT_HOLD_NS)
			flush_out();
		if (opt_fast) {
			if (t - last_io_ns > 200000ULL) poll_io(0);
			continue;
		}
		uint64_t wc = wall_cycles(t);
		if (avr->cycle > wc + lead_allowed()) {
			poll_io((avr->cycle - wc) * 1000ULL / CYC_PER_US);
		} else {
			int64_t lag = (int64_t)wc - (int64_t)avr->cycle;
			if (lag > max_lag_cycles) max_lag_cycles = lag;
			if (lag > (int64_t)LAG_REBASE_CYCLES) { rebase(); rebase_count++; }
			/* running ahead on an idle link: look for host bytes every 20 us */
			uint64_t every = avr->cycle > wc + LEAD_MAX_CYCLES ? 20000ULL : 100000ULL;
			if (t - last_io_ns > every) poll_io(0);
		}
	}

	for (int i = 0; i < MAX_CLIENTS; i++)
		if (clients[i].fd >= 0) close(clients[i].fd);
	if (listen_fd >= 0) close(listen_fd);
	unlink(ctl_path);
	if (ctl_dir[0]) rmdir(ctl_dir);
	if (master_fd >= 0) close(master_fd);
	return 0;
}

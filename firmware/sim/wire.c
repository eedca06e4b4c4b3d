/*
 * wire.c - UART0 to the host: the modelled wire (10 bit times a byte each
 * way), line faults, the optional model of the Uno's ATmega16U2 USB bridge and
 * firmware time measurement on the UART.  The pty the host opens: pty.c.
 */
#include "harness.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "avr_uart.h"
#include "sim_io.h"
#include "sim_irq.h"

#include "bridges.h"
#include "pacing.h"
#include "pty.h"
#include "trace.h"
#include "wire.h"

#define TICK_16U2_CYCLES 65536ULL       /* 16U2 Timer0 overflow: clk/256 * 256 = 4.096 ms */
#define USB_FRAME_CYCLES 16000ULL       /* USB full-speed 1 ms frame */
#define NEARLY_FULL_16U2 96             /* arduino-usbserial: release when MORE than this wait */
#define OUT_HOLD_BYTES 8                /* a due board->host byte waits at most 8 byte times for a batched write */
#define RING 8192


static double fault_drop, fault_insert, fault_flip;

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
static struct ring to_pty;      /* bytes that reached the host side (t = due: simulated arrival) */
static int out_blocked;         /* the last write() was short: the pty is full */
static unsigned long pty_writes; /* write() calls to the pty master (batching statistics) */
static uint64_t byte_cycles;    /* 10 bit times at --baud */
static uint64_t next_inject_ok; /* earliest cycle for next injection (wire spacing) */
static int uart_xoff;
static uint64_t tick_at;        /* 16U2 next tick event, 0 = none */
static unsigned long bytes_to_host, bytes_from_host, bytes_discarded;
static unsigned long lost_to_board, lost_to_host; /* a harness queue was full: never expected */
static unsigned long bridge_full_releases; /* 16U2 releases because > 96 bytes waited */
static uint64_t last_host_byte_t;   /* cycle the last host byte entered the UART */
static unsigned long faults_dropped, faults_inserted, faults_flipped;

/* firmware time measurement: the last NSAMPLES request -> first reply byte times */
#define NSAMPLES 256
static int fw_pending;
static uint64_t fw_start;
static uint64_t fw_samples[NSAMPLES];
static unsigned fw_nsamples, fw_next;
static uint64_t fw_last;

/* Room left in the host->board queue.  When it is full the harness stops
 * reading the pty (pty_pollfds no longer asks for POLLIN): the kernel's pty
 * buffer fills and the host's write() blocks, as a real USB bridge NAKs OUT
 * packets while its buffer is full.  Nothing is dropped for want of room. */
size_t host_rx_room(void)
{
	return RING - 1 - ring_len(&host_rx);
}

unsigned host_rx_queued(void)
{
	return ring_len(&host_rx);
}

/* Nothing waits to go either way (see link_idle in pacing.c). */
int wire_idle(void)
{
	return ring_empty(&to_pty) && wire_only_delivering();
}

/* Nothing on its way but bytes for the host that wait for their due times
 * (to_pty): the simulation has nothing more to compute for them. */
int wire_only_delivering(void)
{
	return ring_empty(&host_rx) && ring_empty(&wire_tx) && ring_empty(&bridge_buf) && ring_empty(&usb_out)
	       && bridge_model_empty();
}

/* The first tick after t (strictly) of a bridge clock with this period: the
 * USB frames and the 16U2's Timer0 keep wall time across time base moves
 * (pacing.c: bridge_clock_offset). */
uint64_t bridge_boundary(uint64_t t, uint64_t period)
{
	int64_t phase = ((int64_t)t - bridge_clock_phase()) % (int64_t)period;
	if (phase < 0)
		phase += (int64_t)period;
	return t - (uint64_t)phase + period;
}

/* ------------------------------------------------------------------ to the host */
/* A board->host byte reaches the host side at a simulated time, its *due*
 * time: the end of its stop bit, or (16U2) the USB frame that carries it.
 * It waits in to_pty until the wall clock has reached that time too, so the
 * host never sees a byte earlier than the modelled link would deliver it,
 * however far the simulation runs ahead (pacing.c).  Then bytes go to the pty
 * in as few write()s as cost no latency (one write() per byte cost ~5 us of
 * syscall and kernel pty work each; a reply split over two writes also wakes
 * the host twice):
 *  - a burst goes out whole once its last byte is due: the burst has ended
 *    when no further byte follows within 2 byte times (the next byte due
 *    in to_pty, on the wire, or the firmware still sending: UDRIE0 set);
 *  - while a burst goes on (a stream, pipelined replies back to back), what
 *    is due goes out once its oldest byte has waited OUT_HOLD_BYTES byte times
 *    (a reply of up to 9 bytes still goes in one write).
 * pacing.c waits for output_wake_cycle() and spins the last few
 * microseconds to a reply's end (a wait in ppoll() oversleeps by ~20 us here). */
void wire_to_host(uint8_t b, uint64_t due)
{
	if (!ring_push(&to_pty, b, due))
		lost_to_host++; /* host not reading and 8 KiB already waiting */
}

static inline uint64_t to_pty_due(unsigned i) /* i = 0: the oldest byte */
{
	return to_pty.d[(to_pty.tail + i) & (RING - 1)].t;
}

/* The bytes of to_pty due by wall cycle wc. */
static unsigned due_count(uint64_t wc)
{
	unsigned n = 0, len = ring_len(&to_pty);
	while (n < len && to_pty_due(n) <= wc)
		n++;
	return n;
}

/* Is byte i of to_pty the last of its burst: does no byte follow within 2
 * byte times (waiting, on the wire, or about to be sent: UDRIE0 set while
 * simulated time has not passed the gap yet)?  A 16U2 frame ends with its
 * last byte. */
static int burst_ends_at(unsigned i)
{
	uint64_t t = to_pty_due(i);
	uint64_t gap = usb_bridge_on() ? 0 : 2 * byte_cycles; /* the firmware may pause between bytes */
	if (i + 1 < ring_len(&to_pty))
		return to_pty_due(i + 1) > t + gap;
	if (usb_bridge_on())
		return 1;
	if (!ring_empty(&wire_tx))
		return ring_peek(&wire_tx)->t > t + gap;
	return avr->cycle >= t + gap || !(avr->data[UCSR0B_ADDR] & UDRIE0_BIT);
}

/* Write the first n bytes of to_pty (fewer if the pty is full). */
static void write_out(unsigned n)
{
	if (!n)
		return;
	if (pty_fd() < 0 || !pty_host_open()) {
		bytes_discarded += n;
		while (n--)
			ring_pop(&to_pty);
		out_blocked = 0;
		return;
	}
	if (baud_mismatch(n)) { /* counted there: garbled on a real link */
		while (n--)
			ring_pop(&to_pty);
		out_blocked = 0;
		return;
	}
	uint8_t buf[RING];
	for (unsigned i = 0; i < n; i++)
		buf[i] = to_pty.d[(to_pty.tail + i) & (RING - 1)].b;
	uint64_t before = trace_on ? trace_clock() : 0;
	ssize_t w = write(pty_fd(), buf, n);
	pty_writes++;
	if (trace_on)
		trace_event_at_('W', (uint64_t)w, before);
	out_blocked = w < (ssize_t)n; /* pty full (host not reading): retry on POLLOUT */
	if (w > 0) {
		bytes_to_host += (unsigned long)w;
		to_pty.tail = (to_pty.tail + (unsigned)w) & (RING - 1);
	}
}

/* Hand the host what is due by wall cycle wc, by the rules above. */
void output_service(uint64_t wc)
{
	if (ring_empty(&to_pty))
		return;
	if (opt->fast)
		wc = UINT64_MAX; /* unpaced: no wall clock to wait for */
	unsigned due = due_count(wc);
	if (!due)
		return;
	if (out_blocked || to_pty_due(0) + OUT_HOLD_BYTES * byte_cycles <= wc) {
		write_out(due);
		return;
	}
	for (unsigned i = due; i-- > 0;)
		if (burst_ends_at(i)) { /* every burst that ended, whole */
			write_out(i + 1);
			return;
		}
}

/* The cycle at which output_service will next write (UINT64_MAX: nothing
 * waits; it may lie in the past).  *punctual: it is the end of a burst while
 * the host has nothing more queued for the board, i.e. a reply the host is
 * likely waiting for (pacing.c then spins rather than sleeps up to it; the
 * partial writes of long bursts and replies to pipelined requests do not
 * need that precision and would keep the harness spinning). */
uint64_t output_wake_cycle(int *punctual)
{
	*punctual = 0;
	if (ring_empty(&to_pty) || out_blocked)
		return UINT64_MAX;
	uint64_t held = to_pty_due(0) + OUT_HOLD_BYTES * byte_cycles;
	unsigned len = ring_len(&to_pty);
	for (unsigned i = 0; i < len && to_pty_due(i) < held; i++)
		if (burst_ends_at(i)) {
			*punctual = ring_empty(&host_rx);
			return to_pty_due(i);
		}
	return held;
}

/* The simulated cycle the simulation must reach to know whether the newest
 * byte for the host ends its burst (0: known already).  The firmware's UDRE
 * interrupt often stays on past a reply's last byte, so only simulated time
 * passing the gap tells; pacing.c lets the simulation run that far ahead, or
 * the end of every reply would wait for the next wait to end. */
uint64_t output_decided_at(void)
{
	if (ring_empty(&to_pty) || usb_bridge_on() || !ring_empty(&wire_tx))
		return 0;
	uint64_t t = to_pty.d[(to_pty.head - 1) & (RING - 1)].t + 2 * byte_cycles;
	return avr->cycle < t && (avr->data[UCSR0B_ADDR] & UDRIE0_BIT) ? t : 0;
}

/* Write everything waiting, due or not (the cable is about to be pulled). */
void flush_out(void)
{
	write_out(ring_len(&to_pty));
}

static void release_16u2(uint64_t now)
{
	uint64_t frame = bridge_boundary(now, USB_FRAME_CYCLES);
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
		if (bridge_model_take(bytes[i], now)) {
			/* an FTDI or CH340 model (bridges.c) holds it */
		} else if (opt->usb_bridge != BRIDGE_16U2) {
			trace_event('T', bytes[i]);
			wire_to_host(bytes[i], now);
		} else {
			if (!ring_push(&bridge_buf, bytes[i], now))
				lost_to_host++;
			/* Arduino-usbserial.c sends when (TIFR0 & TOV0) || BufferCount >
			 * BUFFER_NEARLY_FULL (96): the 97th waiting byte, not the 96th */
			if (ring_len(&bridge_buf) > NEARLY_FULL_16U2) {
				bridge_full_releases++;
				release_16u2(now);
			} else if (!tick_at) {
				tick_at = bridge_boundary(now, TICK_16U2_CYCLES);
			}
		}
	}
}

/* ------------------------------------------------------------------ events */
void wire_schedule_events(void)
{
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
	bridge_model_schedule();
}

/* One pass over the wire's due events; returns whether any was. */
int wire_run_events(uint64_t now)
{
	int progress = 0;
	/* host -> board injection, one byte per 10 bit times */
	if (!ring_empty(&host_rx) && !uart_xoff) {
		struct tbyte *tb = ring_peek(&host_rx);
		uint64_t due = tb->t > next_inject_ok ? tb->t : next_inject_ok;
		if (due <= now) {
			uint8_t b = tb->b;
			ring_pop(&host_rx);
			avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT), b);
			bytes_from_host++;
			trace_event('I', b);
			last_host_byte_t = now;
			next_inject_ok = now + byte_cycles;
			progress = 1;
		}
	}
	if (!ring_empty(&wire_tx) && ring_peek(&wire_tx)->t <= now) {
		uint8_t b = ring_peek(&wire_tx)->b;
		uint64_t t = ring_peek(&wire_tx)->t;
		ring_pop(&wire_tx);
		byte_off_wire(b, t);
		progress = 1;
	}
	if (tick_at && tick_at <= now) {
		tick_at = 0;
		release_16u2(now);
		progress = 1;
	}
	while (!ring_empty(&usb_out) && ring_peek(&usb_out)->t <= now) {
		wire_to_host(ring_peek(&usb_out)->b, ring_peek(&usb_out)->t);
		ring_pop(&usb_out);
		progress = 1;
	}
	return progress | bridge_model_run(now);
}

/* After the events: bytes that just reached the host side may already be due
 * (simulation behind the wall clock, or a burst that just ended). */
void wire_events_done(void)
{
	if (!ring_empty(&to_pty))
		output_service(wall_cycles(now_ns()));
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
	trace_event('O', value);
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

void wire_attach(void)
{
	avr_irq_t *uirq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), 0);
	avr_irq_register_notify(uirq + UART_IRQ_OUTPUT, uart_out_hook, NULL);
	wrap_udr_read();
	avr_irq_register_notify(uirq + UART_IRQ_OUT_XON, uart_xon_hook, NULL);
	avr_irq_register_notify(uirq + UART_IRQ_OUT_XOFF, uart_xoff_hook, NULL);
}

void wire_after_reset(void)
{
	fw_pending = 0;
	uart_xoff = 0;
	ring_clear(&host_rx);
	ring_clear(&wire_tx);
}

/* Bytes the host wrote: queued for injection at the simulated "now" (16U2: at
 * the next USB frame), never stamped in the simulation's future. */
void host_bytes_in(const uint8_t *buf, size_t n)
{
	uint64_t t = stimulus_cycle(); /* the wall's now, or the simulation's on a busy link */
	if (usb_bridge_on())
		t = bridge_boundary(t, USB_FRAME_CYCLES);
	for (size_t i = 0; i < n; i++)
		if (!ring_push(&host_rx, buf[i], t))
			lost_to_board++;
	recompute_next_event();
}

/* The simulation gave up catching up with the wall clock (rebase): host bytes
 * stamped at the wall's "now" ahead of the simulation would otherwise wait
 * for the whole lag again; they take effect at the simulated now. */
void wire_time_base_reset(void)
{
	for (unsigned i = host_rx.tail; i != host_rx.head; i = (i + 1) & (RING - 1))
		if (host_rx.d[i].t > avr->cycle)
			host_rx.d[i].t = avr->cycle;
	recompute_next_event();
}

int wire_has_output(void)
{
	return out_blocked && !ring_empty(&to_pty);
}

/* The cable is pulled: what was still on its way to the host is gone. */
void wire_unplug(void)
{
	ring_clear(&to_pty);
	out_blocked = 0;
	ring_clear(&bridge_buf);
	ring_clear(&usb_out);
	tick_at = 0;
	bridge_model_clear();
}

/* ------------------------------------------------------------------ state, for the other modules */
uint64_t wire_last_host_byte(void) { return last_host_byte_t; }
void wire_lost_to_host(void) { lost_to_host++; }
void wire_discarded(unsigned long n) { bytes_discarded += n; }

void wire_set_byte_time(unsigned baud)
{
	byte_cycles = (uint64_t)llround(10.0 * (double)F_CPU / (double)baud);
}

void wire_faults(double *drop, double *insert, double *flip)
{
	*drop = fault_drop;
	*insert = fault_insert;
	*flip = fault_flip;
}

void wire_set_faults(double drop, double insert, double flip)
{
	fault_drop = drop;
	fault_insert = insert;
	fault_flip = flip;
}

void wire_firmware_cycles(struct sbuf *r, int clear)
{
	sb_add(r, "{\"ok\": true, \"samples\": [");
	for (unsigned i = 0; i < fw_nsamples; i++) {
		unsigned idx = (fw_next + NSAMPLES - fw_nsamples + i) % NSAMPLES;
		sb_add(r, "%s%llu", i ? ", " : "", (unsigned long long)fw_samples[idx]);
	}
	sb_add(r, "], \"last\": ");
	if (fw_nsamples) sb_add(r, "%llu", (unsigned long long)fw_last); else sb_add(r, "null");
	sb_add(r, ", \"cycles_per_us\": %llu}", CYC_PER_US);
	if (clear) fw_nsamples = 0;
}

void wire_status(struct sbuf *r)
{
	sb_add(r, ", \"bytes_to_host\": %lu, \"bytes_from_host\": %lu, \"bytes_discarded\": %lu, "
		  "\"pty_writes\": %lu, \"faults\": {\"drop\": %g, \"insert\": %g, \"flip\": %g, "
		  "\"dropped\": %lu, \"inserted\": %lu, \"flipped\": %lu}, \"last_host_byte_us\": %.3f, "
		  "\"lost\": {\"to_board\": %lu, \"to_host\": %lu}, \"host_rx_queued\": %u, "
		  "\"bridge_full_releases\": %lu",
	       bytes_to_host, bytes_from_host, bytes_discarded, pty_writes, fault_drop, fault_insert,
	       fault_flip, faults_dropped, faults_inserted, faults_flipped,
	       (double)last_host_byte_t / CYC_PER_US, lost_to_board, lost_to_host, host_rx_queued(),
	       bridge_full_releases);
}

/*
 * wire.c - UART0 to the host: the modelled wire (10 bit times a byte each
 * way), line faults, the optional model of the Uno's ATmega16U2 USB bridge and
 * firmware time measurement on the UART.  The pty the host opens: pty.c.
 */
#include "harness.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "avr_uart.h"
#include "sim_io.h"
#include "sim_irq.h"

#include "pacing.h"
#include "pty.h"
#include "wire.h"

#define TICK_16U2_CYCLES 65536ULL       /* 16U2 Timer0 overflow: clk/256 * 256 = 4.096 ms */
#define USB_FRAME_CYCLES 16000ULL       /* USB full-speed 1 ms frame */
#define NEARLY_FULL_16U2 96             /* arduino-usbserial: release when MORE than this wait */
#define OUT_HOLD_NS 5000ULL             /* max wall time a board->host byte waits for a batched write */
#define RING 8192


double fault_drop, fault_insert, fault_flip;

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
unsigned long pty_writes;
uint64_t byte_cycles;
static uint64_t next_inject_ok; /* earliest cycle for next injection (wire spacing) */
static int uart_xoff;
static uint64_t tick_at;        /* 16U2 next tick event, 0 = none */
unsigned long bytes_to_host, bytes_from_host, bytes_discarded;
unsigned long lost_to_board, lost_to_host;
unsigned long bridge_full_releases;
uint64_t last_host_byte_t;
unsigned long faults_dropped, faults_inserted, faults_flipped;

/* firmware time measurement */
static int fw_pending;
static uint64_t fw_start;
uint64_t fw_samples[NSAMPLES];
unsigned fw_nsamples, fw_next;
uint64_t fw_last;

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
	return ring_empty(&host_rx) && ring_empty(&wire_tx) && !out_len && ring_empty(&bridge_buf) &&
	       ring_empty(&usb_out);
}

static uint64_t next_boundary(uint64_t t, uint64_t period)
{
	return (t / period + 1) * period;
}

/* ------------------------------------------------------------------ to the host */
/* Board->host bytes collect in out_buf and go to the pty in one write() when
 * the wire falls idle or a 16U2 frame is released (wire_events_done), when the
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

void flush_out(void)
{
	if (!out_len)
		return;
	if (master_fd < 0 || !slave_open) {
		bytes_discarded += out_len;
		out_len = 0;
		return;
	}
	if (baud_mismatch(out_len)) {
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

void flush_out_if_held(uint64_t t)
{
	if (out_len && t - out_first_ns >= OUT_HOLD_NS)
		flush_out();
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
	return progress;
}

/* The end of a burst goes out at once (nothing more on the wire and the
 * firmware's UDRE interrupt off, i.e. it has nothing more queued), as does
 * a 16U2 release (a whole USB frame's worth at once): batching must not
 * delay the last byte of a reply. */
void wire_events_done(void)
{
	if (out_len && (opt_16u2 || (ring_empty(&wire_tx) && !(avr->data[UCSR0B_ADDR] & UDRIE0_BIT))))
		flush_out();
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
	catch_up_wall(); /* a host stimulus: never stamped in the simulation's future */
	uint64_t t = avr->cycle;
	if (opt_16u2)
		t = next_boundary(t, USB_FRAME_CYCLES);
	for (size_t i = 0; i < n; i++)
		if (!ring_push(&host_rx, buf[i], t))
			lost_to_board++;
	recompute_next_event();
}

int wire_has_output(void)
{
	return out_len != 0;
}

/* The cable is pulled: what was still on its way to the host is gone. */
void wire_unplug(void)
{
	out_len = 0;
	ring_clear(&bridge_buf);
	ring_clear(&usb_out);
	tick_at = 0;
}

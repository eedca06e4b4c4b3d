/*
 * bridges.c - models of the USB bridges on Nano-class clones (issue 29 item 4):
 * how long a byte the board sent waits in the bridge before the host can read
 * it.  The Uno's ATmega16U2 model (4.096 ms tick, 96 bytes) is in wire.c; the
 * figures and their sources: docs/boards.md.
 *
 * FTDI (FT232R, FT231X) under Linux's ftdi_sio: a byte that enters the chip's
 * empty receive buffer starts the latency timer (16 ms by default, settable
 * 1..255 ms: --ftdi-latency-ms or the control channel's set_latency_timer, the
 * way the host's sysfs latency_timer or ASYNC_LOW_LATENCY set it on a real
 * chip); what waits goes to the host when the timer expires or at once when a
 * 62-byte packet (64 bytes less 2 status bytes) has filled, in the next 1 ms
 * USB frame.
 *
 * CH340/CH341 with Linux's ch341 driver (which sets the bit that turns the
 * chip's 32-byte packet buffering off): no published latency figure was found,
 * so the model is an assumption, documented as such: every byte goes to the
 * host in the next 1 ms USB frame.
 *
 * Host->board bytes go at the next USB frame for every bridge (wire.c:
 * host_bytes_in); nothing here holds them.
 */
#include "harness.h"

#include <stdio.h>
#include <string.h>

#include "bridges.h"
#include "json.h"
#include "pacing.h"
#include "trace.h"
#include "wire.h"

#define USB_FRAME_CYCLES 16000ULL /* USB full-speed 1 ms frame */
#define FTDI_PACKET 62            /* 64-byte bulk packet less the 2 modem-status bytes */
#define CYCLES_PER_MS 16000ULL
#define QUEUE 8192

/* The model is opt->usb_bridge (BRIDGE_FTDI or BRIDGE_CH340; main.c parses it
 * with bridge_parse); everything else here is the model's own state. */
static unsigned ftdi_latency_ms = 16; /* --ftdi-latency-ms, set_latency_timer */
static unsigned long ftdi_timer_releases, ftdi_full_releases;

/* How long bytes waited in the model, in simulated cycles: from the UART's stop
 * bit of the first byte of a release to the USB frame that carries it (the
 * figure the docs give for each model, free of the host's and the machine's
 * speed). */
static struct { unsigned long n; uint64_t min, max, sum; } hold;
static uint64_t first_t; /* FTDI: when the oldest held byte came */

static void hold_add(uint64_t cycles)
{
	if (!hold.n || cycles < hold.min) hold.min = cycles;
	if (cycles > hold.max) hold.max = cycles;
	hold.sum += cycles;
	hold.n++;
}

/* bytes with the time they reach the host side */
static struct { uint8_t b[QUEUE]; uint64_t t[QUEUE]; unsigned head, tail; } out;
static unsigned held;       /* FTDI: bytes at the tail of `out` still held (t unset) */
static uint64_t timer_at;   /* FTDI: latency timer expiry, 0 = not running */

static unsigned out_len(void) { return (out.head - out.tail) & (QUEUE - 1); }

static int out_push(uint8_t b, uint64_t t)
{
	unsigned n = (out.head + 1) & (QUEUE - 1);
	if (n == out.tail)
		return 0;
	out.b[out.head] = b;
	out.t[out.head] = t;
	out.head = n;
	return 1;
}

static const char *const names[] = {
	[BRIDGE_NONE] = "none", [BRIDGE_16U2] = "16u2", [BRIDGE_FTDI] = "ftdi", [BRIDGE_CH340] = "ch340",
};

int usb_bridge_on(void)
{
	return opt->usb_bridge != BRIDGE_NONE;
}

const char *bridge_name(enum usb_bridge b)
{
	return names[b];
}

int bridge_parse(const char *name, enum usb_bridge *b)
{
	for (unsigned i = 0; i < sizeof(names) / sizeof(names[0]); i++)
		if (!strcmp(name, names[i])) {
			*b = (enum usb_bridge)i;
			return 0;
		}
	return -1;
}

/* The hold statistics start again, so they describe the new setting only. */
int bridge_set_latency_ms(long ms)
{
	if (ms < 1 || ms > 255)
		return -1;
	ftdi_latency_ms = (unsigned)ms;
	hold.n = 0;
	hold.min = hold.max = hold.sum = 0;
	return 0;
}

/* FTDI: the held bytes go out in the next USB frame. */
static void ftdi_release(uint64_t now)
{
	uint64_t frame = bridge_boundary(now, USB_FRAME_CYCLES);
	hold_add(frame - first_t);
	for (unsigned i = out.head - held; held; held--, i++)
		out.t[i & (QUEUE - 1)] = frame;
	timer_at = 0;
}

int bridge_model_take(uint8_t b, uint64_t now)
{
	if (opt->usb_bridge != BRIDGE_FTDI && opt->usb_bridge != BRIDGE_CH340)
		return 0;
	trace_event('B', b);
	if (opt->usb_bridge == BRIDGE_CH340) {
		uint64_t frame = bridge_boundary(now, USB_FRAME_CYCLES);
		if (!out_push(b, frame))
			wire_lost_to_host();
		hold_add(frame - now);
		return 1;
	}
	if (!out_push(b, UINT64_MAX)) {
		wire_lost_to_host();
		return 1;
	}
	if (!held++) {
		first_t = now;
		timer_at = now + (uint64_t)ftdi_latency_ms * CYCLES_PER_MS;
	}
	if (held >= FTDI_PACKET) {
		ftdi_full_releases++;
		ftdi_release(now);
	}
	return 1;
}

void bridge_model_schedule(void)
{
	if (timer_at)
		schedule(timer_at);
	if (out_len() > held)
		schedule(out.t[out.tail]);
}

int bridge_model_run(uint64_t now)
{
	int progress = 0;
	if (timer_at && timer_at <= now) {
		ftdi_timer_releases++;
		ftdi_release(now);
		progress = 1;
	}
	while (out_len() > held && out.t[out.tail] <= now) {
		wire_to_host(out.b[out.tail], out.t[out.tail]);
		out.tail = (out.tail + 1) & (QUEUE - 1);
		progress = 1;
	}
	return progress;
}

int bridge_model_empty(void)
{
	return out_len() == 0;
}

void bridge_model_clear(void)
{
	out.head = out.tail = 0;
	held = 0;
	timer_at = 0;
}

void bridge_status(struct sbuf *r)
{
	sb_add(r, ", \"bridge\": {\"model\": \"%s\", \"latency_ms\": %u, \"timer_releases\": %lu, "
		  "\"full_releases\": %lu, \"holds\": %lu, \"hold_min_us\": %.3f, \"hold_max_us\": %.3f, "
		  "\"hold_mean_us\": %.3f}",
	       bridge_name(opt->usb_bridge), ftdi_latency_ms, ftdi_timer_releases, ftdi_full_releases, hold.n,
	       (double)hold.min / CYC_PER_US, (double)hold.max / CYC_PER_US,
	       hold.n ? (double)hold.sum / (double)hold.n / CYC_PER_US : 0.0);
}

/*
 * spi_device.c - an MCP3008 (8-channel 10-bit ADC) on the Uno's SPI pins: D11
 * MOSI, D12 MISO, D13 SCK and a chip select the test names, with ground truth.
 *
 * simavr's SPI unit reports each byte the AVR sends (SPI_IRQ_OUTPUT, when the
 * byte's 8 clocks are over) and takes the byte clocked in meanwhile
 * (SPI_IRQ_INPUT), which is SPDR when the firmware reads it.  The device is
 * modelled bit by bit, as the datasheet's serial interface (MCP3008, fig. 6-1):
 * with CS low, the first 1 on MOSI is the start bit; the next four are
 * SGL/DIFF, D2, D1, D0; one clock samples (MISO high-impedance: read 0 here),
 * the next a null bit (0), then B9..B0 MSB first, then B1..B9 LSB first, then
 * zeros until CS rises.  CS high resets it and MISO is high-impedance (0).
 * The bit order on the wire is the AVR's (SPCR DORD): with LSB first, a
 * byte's bits reach the device in reverse order and its answer likewise.
 *
 * A channel's code is round(1024 * v / vref) clamped to 0-1023; differential
 * pairs (CH0-CH1, ...: D2-D0 pick the pair and which is IN+) read
 * IN+ - IN-, 0 when negative, as the real part.
 *
 * Ground truth for the tests ({"cmd": "spi_device_status"}): the chip select's
 * falling and rising edges, the bytes exchanged under each chip select (the
 * last 16 transactions, up to 64 bytes each), bytes clocked with CS high
 * (the device ignores them), conversions made, and the SPI unit's settings at
 * the last byte (CPOL, CPHA, DORD, clock divider from SPCR/SPSR).
 */
#include "harness.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "avr_ioport.h"
#include "avr_spi.h"
#include "sim_io.h"
#include "sim_irq.h"

#include "json.h"
#include "spi_device.h"

#define SPCR_ADDR 0x4C
#define SPSR_ADDR 0x4D
#define NFRAMES 16
#define FRAME_MAX 64

struct frame { uint8_t mosi[FRAME_MAX], miso[FRAME_MAX]; int n; };

static int cs_pin = -1;          /* -1: no device on the bus */
static int cs_low;
static unsigned long cs_falls, cs_rises, bytes_total, bytes_outside_cs, conversions;
static double volts[8], vref = 5.0;
static struct frame frames[NFRAMES];
static unsigned frame_next, frames_total; /* frames_total: transactions begun */
static int last_spcr = -1, last_spsr = -1;
/* the serial interface: bits since the start bit (-1: waiting for it) */
static int bit_index = -1;
static unsigned config_bits, code;
static avr_irq_t *spi_irq;

static unsigned channel_code(unsigned cfg)
{
	int single = (cfg >> 3) & 1, sel = cfg & 7;
	double v;
	if (single)
		v = volts[sel];
	else {
		/* D2 D1 pick the pair CH(2k)/CH(2k+1); D0 = 0: CH(2k) is IN+ */
		int plus = (sel & 6) | (sel & 1), minus = (sel & 6) | ((sel & 1) ^ 1);
		v = volts[plus] - volts[minus];
	}
	double c = floor(1024.0 * v / vref + 0.5);
	if (c < 0) c = 0;
	if (c > 1023) c = 1023;
	return (unsigned)c;
}

/* one clock: the bit on MOSI in, the bit the device drives on MISO out */
static int clock_bit(int mosi)
{
	int out = 0;
	if (bit_index < 0) {
		if (mosi)
			bit_index = 0; /* the start bit */
		return 0;
	}
	bit_index++;
	if (bit_index <= 4) {
		config_bits = (config_bits << 1) | (unsigned)mosi;
		if (bit_index == 4) {
			code = channel_code(config_bits & 0xF);
			conversions++;
		}
		return 0;
	}
	/* 5: sample (high-impedance), 6: null bit, 7-16: B9..B0, 17-25: B1..B9 */
	if (bit_index >= 7 && bit_index <= 16)
		out = (code >> (16 - bit_index)) & 1;
	else if (bit_index >= 17 && bit_index <= 25)
		out = (code >> (bit_index - 16)) & 1;
	return out;
}

static uint8_t exchange(uint8_t mosi, int lsb_first)
{
	uint8_t miso = 0;
	for (int i = 0; i < 8; i++) {
		int shift = lsb_first ? i : 7 - i;
		miso |= (uint8_t)(clock_bit((mosi >> shift) & 1) << shift);
	}
	return miso;
}

static void spi_out_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	uint8_t mosi = (uint8_t)value, miso = 0;
	last_spcr = avr->data[SPCR_ADDR];
	last_spsr = avr->data[SPSR_ADDR];
	bytes_total++;
	if (cs_pin >= 0 && cs_low) {
		miso = exchange(mosi, (last_spcr >> 5) & 1);
		struct frame *f = &frames[(frame_next + NFRAMES - 1) % NFRAMES];
		if (f->n < FRAME_MAX) {
			f->mosi[f->n] = mosi;
			f->miso[f->n] = miso;
			f->n++;
		}
	} else {
		bytes_outside_cs++;
	}
	avr_raise_irq(spi_irq + SPI_IRQ_INPUT, miso);
}

/* The chip select as the device sees it: the pin's PORT level while it is an
 * output, high otherwise (the 10 k pull-up the wiring in docs/sensors.md puts on
 * CS, so a released or not yet configured pin deselects the part).  `ddr` is the
 * port's direction register when the caller has it fresher than the data space. */
static void cs_update(int ddr)
{
	if (cs_pin < 0)
		return;
	int portb = cs_pin >= 8, bit = cs_pin & 7;
	if (ddr < 0)
		ddr = avr->data[portb ? 0x24 : 0x2A];
	int out = (ddr >> bit) & 1, level = (avr->data[portb ? 0x25 : 0x2B] >> bit) & 1;
	int low = out && !level;
	if (low == cs_low)
		return;
	cs_low = low;
	bit_index = -1;
	config_bits = 0;
	if (low) {
		cs_falls++;
		frames[frame_next].n = 0;
		frame_next = (frame_next + 1) % NFRAMES;
		frames_total++;
	} else {
		cs_rises++;
	}
}

static void cs_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	if ((int)(intptr_t)param == cs_pin)
		cs_update(-1);
}

static void ddr_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	int portb = (int)(intptr_t)param;
	if (cs_pin >= 0 && (cs_pin >= 8) == portb)
		cs_update((int)(value & 0xFF));
}

void spi_device_attach(void)
{
	/* simavr names the ATmega328P's SPI unit 0 (older) or '0' (AVR_SPIX_DECLARE) */
	spi_irq = avr_io_getirq(avr, AVR_IOCTL_SPI_GETIRQ(0), 0);
	if (!spi_irq)
		spi_irq = avr_io_getirq(avr, AVR_IOCTL_SPI_GETIRQ('0'), 0);
	if (!spi_irq) {
		logf_("simavr has no SPI unit on this MCU: no SPI device model");
		return;
	}
	avr_irq_register_notify(spi_irq + SPI_IRQ_OUTPUT, spi_out_hook, NULL);
	for (int pin = 2; pin <= 10; pin++) {
		char port = pin < 8 ? 'D' : 'B';
		avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), pin < 8 ? pin : pin - 8);
		avr_irq_register_notify(irq, cs_hook, (void *)(intptr_t)pin);
	}
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), IOPORT_IRQ_DIRECTION_ALL), ddr_hook,
				(void *)(intptr_t)0);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_DIRECTION_ALL), ddr_hook,
				(void *)(intptr_t)1);
}

/* {"cmd": "spi_device", "cs": 10, "vref": 5.0, "ch0": 1.25, ...}: an MCP3008 with
 * its chip select on `cs` (2-10; -1 removes it); channels not named keep their
 * voltage; the counters restart. */
void cmd_spi_device(struct jobj *o, struct sbuf *r)
{
	double v;
	char key[8];
	if (get_num(o, "cs", &v)) {
		if (v != -1 && (v < 2 || v > 10)) {
			sb_add(r, "{\"ok\": false, \"error\": \"cs must be 2-10 (or -1: no device)\"}");
			return;
		}
		cs_pin = (int)v;
		cs_low = 0;
		cs_update(-1);
		cs_falls = cs_rises = bytes_total = bytes_outside_cs = conversions = 0;
		frame_next = frames_total = 0;
		memset(frames, 0, sizeof frames);
		bit_index = -1;
	}
	if (get_num(o, "vref", &v)) {
		if (!(v > 0)) {
			sb_add(r, "{\"ok\": false, \"error\": \"vref must be positive\"}");
			return;
		}
		vref = v;
	}
	for (int ch = 0; ch < 8; ch++) {
		snprintf(key, sizeof key, "ch%d", ch);
		if (get_num(o, key, &v))
			volts[ch] = v;
	}
	sb_add(r, "{\"ok\": true}");
}

void cmd_spi_device_status(struct jobj *o, struct sbuf *r)
{
	unsigned n = frames_total < NFRAMES ? frames_total : NFRAMES;
	sb_add(r, "{\"ok\": true, \"cs\": %d, \"cs_low\": %s, \"cs_falls\": %lu, \"cs_rises\": %lu, "
		  "\"bytes\": %lu, \"bytes_outside_cs\": %lu, \"conversions\": %lu, \"transactions\": %u, ",
	       cs_pin, cs_low ? "true" : "false", cs_falls, cs_rises, bytes_total, bytes_outside_cs,
	       conversions, frames_total);
	if (last_spcr >= 0) {
		int spr = last_spcr & 3, x2 = last_spsr & 1;
		/* SPR 0-3: /4, /16, /64, /128; SPI2X halves */
		int divider = (spr == 3 ? 128 : 4 << (2 * spr)) >> x2;
		sb_add(r, "\"spe\": %d, \"master\": %d, \"lsb_first\": %d, \"cpol\": %d, \"cpha\": %d, "
			  "\"clock_hz\": %d, ",
		       (last_spcr >> 6) & 1, (last_spcr >> 4) & 1, (last_spcr >> 5) & 1, (last_spcr >> 3) & 1,
		       (last_spcr >> 2) & 1, (int)(F_CPU / (unsigned)divider));
	}
	sb_add(r, "\"frames\": [");
	for (unsigned i = 0; i < n; i++) {
		struct frame *f = &frames[(frame_next + NFRAMES - n + i) % NFRAMES];
		sb_add(r, "%s{\"mosi\": ", i ? ", " : "");
		sb_bytes(r, f->mosi, f->n);
		sb_add(r, ", \"miso\": ");
		sb_bytes(r, f->miso, f->n);
		sb_add(r, "}");
	}
	sb_add(r, "]}");
}

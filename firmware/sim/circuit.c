/*
 * circuit.c - test circuitry around the simulated Uno: the fixtures (open,
 * loopback jumpers, R2R ladders), levels driven from outside, analog and
 * temperature inputs, the I2C EEPROM, the pulse generator on D2/D3 and pulse
 * capture on every pin.  Input levels are recomputed on every DDR/PORT change
 * and pushed into simavr (see README.md, "Test circuitry").
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "avr_adc.h"
#include "avr_ioport.h"
#include "avr_timer.h"
#include "avr_twi.h"
#include "sim_io.h"
#include "sim_irq.h"

#include "board_map.h"
#include "circuit.h"
#include "sonar_model.h"
#include "pacing.h"
#include "steps.h"

#include "i2c_eeprom.h"
#include "mpu6050.h"

#define NEDGE 32
#define ADC_SLOTS 17 /* ADC0-15 (the Mega's; the Uno uses 0-7) and the temperature */
#define ADC_SLOT_TEMP (ADC_SLOTS - 1)

static const char *const fixture_names[] = {"open", "loopback", "r2r"};
static int drive_level[NPINS];  /* -1 released, 0/1 driven from outside */
static int analog_mv[ADC_SLOTS - 1];
static int adc_sent[ADC_SLOTS]; /* the last slot: the temperature sensor */
static double temperature_c = 25.0;
static i2c_eeprom_t i2c_ee;
static double r2r_res[6][4];    /* per ladder: Ra (B0-N0), Rg (N0-GND), Rs (N0-OUT), Rb (B1-OUT) */
static double r2r_mv[6];
static int in_circuit, circuit_again;
static uint8_t sh_ddr[NPORTS_MAX], sh_port[NPORTS_MAX]; /* shadows, by board_map port index */
#define port_names (board->port_names)
#define addr_pin(pi) (board->addr_pin[pi])
#define addr_ddr(pi) (board->addr_pin[pi] + 1u)
#define addr_port(pi) (board->addr_pin[pi] + 2u)
static avr_irq_t *pin_irq[NPINS];
static avr_irq_t *adc_irq_base;
static avr_irq_t *port_irq_base[NPORTS_MAX];   /* per port: base of its IOPORT IRQs */


extern const char *const fixture_names[];
extern int drive_level[NPINS];  /* -1 released, 0/1 driven from outside */
extern int analog_mv[ADC_SLOTS - 1];
extern int adc_sent[ADC_SLOTS];
extern double temperature_c;
extern i2c_eeprom_t i2c_ee;

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


static int pin_port(int p) { return board->pin_port[p]; }
static int pin_bit(int p) { return board->pin_bit[p]; }

int loop_partner(int p)
{
	if (opt->fixture != FIX_LOOPBACK || p < 2 || p > board->last_jumpered)
		return -1;
	return (p % 2 == 0) ? p + 1 : p - 1;
}

int is_out(int p) { return (sh_ddr[pin_port(p)] >> pin_bit(p)) & 1; }
int port_bit(int p) { return (sh_port[pin_port(p)] >> pin_bit(p)) & 1; }

/* ------------------------------------------------------------------ compare outputs
 * On silicon, while a timer's COMnx bits connect its compare output OCnx, the
 * output drives the pin (if its DDR bit is set) and the PORT bit does not; the
 * PORT bit drives it again once COMnx is cleared.  simavr 1.6 raises the pin's
 * IRQ from the compare output, but also from every PORTx write with the PORT
 * bit, and in a PWM mode it raises the pin at BOTTOM without setting the PORT
 * bit: writing any other pin of port B (D8-D13) dropped D9 to 0 in the middle
 * of a servo pulse.  The harness therefore tracks each compare output's level
 * from the timer's own IRQ and takes a connected pin's level from it: for
 * capture, for a loopback partner, for the R2R ladders and the `pin` command.
 * A write of COMnx itself moves the pin to the compare output's level or back to
 * the PORT bit at that instant (tccr_write).  (Not modelled: the PIN register bit
 * the firmware would read.) */
#define oc_pins (board->oc)  /* board_map.c */
#define N_OC_PINS (board->n_oc)
static int oc_of[NPINS];      /* 1 + index in oc_pins, 0: no compare output */
static int oc_level[NPINS];   /* the compare output's level, connected or not */

/* Whether the timer's compare output drives pin p now (COMnx set, DDR output). */
static int oc_drives(int p)
{
	int k = oc_of[p];
	if (!k || !avr || !is_out(p))
		return 0;
	const struct oc_pin *o = &oc_pins[k - 1];
	return (avr->data[o->tccr] >> o->shift) & 3;
}

/* The level an output pin drives: its compare output's or its PORT bit. */
static int out_level(int p)
{
	return oc_drives(p) ? oc_level[p] : port_bit(p);
}

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
			g[i] = 1.0 / rbranch; v[i] = out_level(p) ? vcc : 0.0;
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
			return out_level(q);
		if (port_bit(q))
			return 1;
	}
	if (port_bit(p))
		return 1; /* internal pull-up */
	if (opt->fixture == FIX_R2R && p >= 14)
		return r2r_mv[p - 14] > 2500.0;
	return 0;
}

int pin_level(int p)
{
	if (p < 2) /* UART pins: report the PIN register */
		return (avr->data[addr_pin(board->uart_port)] >> pin_bit(p)) & 1;
	return is_out(p) ? out_level(p) : input_level(p);
}

static int pin_managed(int p)
{
	return p >= 2; /* D0/D1 belong to the UART */
}

/* simavr 1.6 keeps 8 input voltages (adc_values[8]): its ADC8-ADC15 IRQs are dropped
 * and a conversion of ADC8-15 (the ATmega2560's MUX5 = 1, mux 0x20-0x27) reads past the
 * array.  The harness gives those mux entries the voltage as a fixed "reference" source
 * instead (ADC_MUX_REF converts mux.src mV), so A8-A15 read what the fixture applies. */
static avr_adc_t *find_adc(void)
{
	for (avr_io_t *io = avr->io_port; io; io = io->next)
		if (io->kind && !strcmp(io->kind, "adc"))
			return (avr_adc_t *)io;
	return NULL;
}

static void send_adc(int ch, int mv)
{
	if (adc_sent[ch] == mv)
		return;
	adc_sent[ch] = mv;
	if (ch >= 8 && ch < 16) {
		avr_adc_t *adc = find_adc();
		if (adc)
			adc->muxmode[0x20 + ch - 8] = (avr_adc_mux_t){.kind = ADC_MUX_REF, .src = (unsigned)mv};
		return;
	}
	avr_raise_irq(adc_irq_base + (ch == ADC_SLOT_TEMP ? ADC_IRQ_TEMP : ADC_IRQ_ADC0 + ch), (uint32_t)mv);
}

void update_analog(void)
{
	for (int ch = 0; ch < board->adc_channels; ch++) {
		int mv = analog_mv[ch];
		if (opt->fixture == FIX_R2R && ch < 6) {
			r2r_mv[ch] = r2r_output(ch);
			mv = (int)lround(r2r_mv[ch]);
		}
		send_adc(ch, mv);
	}
	send_adc(ADC_SLOT_TEMP, (int)lround(314.0 + (temperature_c - 25.0) * 1.0));
}

/* Recompute every input pin from the circuit and push it into simavr.
 * The external pull mask makes simavr's own port logic (which re-raises pin
 * IRQs on every PORT/DDR write) keep our level instead of its pull-up guess. */
void apply_circuit(void)
{
	if (in_circuit) {
		circuit_again = 1;
		return;
	}
	in_circuit = 1;
	int rounds = 0;
	do {
		circuit_again = 0;
		if (opt->fixture == FIX_R2R)
			update_analog();
		for (int pi = 0; pi < board->nports; pi++) {
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

static void record_level(int p, int level)
{
	struct capture *c = &cap[p];
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
		steps_rise(p, t);
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
	sonar_model_edge(p, level, t);
}

/* Every raise of a pin's IRQ: a PORT/DDR write, the circuit, a compare output.
 * A pin its compare output drives keeps that output's level whatever raised it. */
static void capture_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	int p = (int)(intptr_t)param;
	record_level(p, oc_drives(p) ? oc_level[p] : (int)(value & 1));
}

/* A write of TCCRnA (registered beside the timer's own writer, which runs first
 * and stores the value): connecting or disconnecting a compare output changes
 * what drives its pin at that instant, with no pin IRQ raised.  The firmware's
 * duty PWM holds a pin at 0 % or 100 % by writing its PORT bit while the output
 * is still connected and then clearing COMnx. */
static void tccr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
	(void)param;
	a->data[addr] = v;
	for (int k = 0; k < N_OC_PINS; k++) {
		const struct oc_pin *o = &oc_pins[k];
		if (o->tccr == addr && oc_of[o->pin] && is_out(o->pin))
			record_level(o->pin, (v >> o->shift) & 3 ? oc_level[o->pin] : port_bit(o->pin));
	}
	apply_circuit();
}

/* A timer's compare output changed (simavr raises it whatever COMnx says). */
static void oc_hook(avr_irq_t *irq, uint32_t value, void *param)
{
	int p = (int)(intptr_t)param;
	oc_level[p] = (int)(value & 1);
	if (oc_drives(p)) {
		record_level(p, oc_level[p]);
		apply_circuit(); /* a loopback partner or an R2R ladder sees the new level */
	}
}

static void read_shadows(void)
{
	for (int pi = 0; pi < board->nports; pi++) {
		sh_ddr[pi] = avr->data[addr_ddr(pi)];
		sh_port[pi] = avr->data[addr_port(pi)];
	}
}

void setup_r2r(void)
{
	uint64_t saved = rng_swap(opt->seed * 0x9E3779B97F4A7C15ULL + 0x1234567ULL);
	const double nominal[4] = {20000.0, 20000.0, 10000.0, 20000.0};
	for (int k = 0; k < 6; k++)
		for (int i = 0; i < 4; i++)
			r2r_res[k][i] = nominal[i] * (1.0 + (2.0 * rng_unit() - 1.0) * opt->r2r_tol / 100.0);
	rng_swap(saved);
}

void circuit_attach(void)
{
	for (int p = 0; p < NPINS; p++) drive_level[p] = -1;
	i2c_eeprom_init(avr, &i2c_ee, 0xA0, 0x01, NULL, 256);
	i2c_eeprom_attach(avr, &i2c_ee, AVR_IOCTL_TWI_GETIRQ(0));
	mpu6050_attach();
	adc_irq_base = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, 0);
	for (int pi = 0; pi < board->nports; pi++) {
		avr_irq_t *base = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port_names[pi]), 0);
		port_irq_base[pi] = base;
		avr_irq_register_notify(base + IOPORT_IRQ_DIRECTION_ALL, ddr_hook, (void *)(intptr_t)pi);
		avr_irq_register_notify(base + IOPORT_IRQ_REG_PORT, port_hook, (void *)(intptr_t)pi);
	}
	for (int p = 0; p < NPINS; p++) {
		pin_irq[p] = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port_names[pin_port(p)]), pin_bit(p));
		avr_irq_register_notify(pin_irq[p], capture_hook, (void *)(intptr_t)p);
	}
	for (int k = 0; k < N_OC_PINS; k++) {
		const struct oc_pin *o = &oc_pins[k];
		avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_TIMER_GETIRQ(o->timer), TIMER_IRQ_OUT_COMP + o->comp);
		if (!irq)
			continue;
		oc_of[o->pin] = k + 1;
		avr_irq_register_notify(irq, oc_hook, (void *)(intptr_t)o->pin);
	}
	static const uint8_t tccrs[] = {0x44, 0x80, 0xB0};
	for (int k = 0; k < 3; k++)
		avr_register_io_write(avr, tccrs[k], tccr_write, NULL);
}

void circuit_after_reset(void)
{
	/* avr_reset() zeroes DDRx/PORTx but not the values cached in their IRQs; a
	 * firmware that then writes the value it had before the reset would raise no
	 * notification and the shadows would stay at 0.  Align the caches. */
	for (int pi = 0; pi < board->nports; pi++) {
		if (!port_irq_base[pi])
			continue;
		port_irq_base[pi][IOPORT_IRQ_DIRECTION_ALL].value = avr->data[addr_ddr(pi)];
		port_irq_base[pi][IOPORT_IRQ_REG_PORT].value = avr->data[addr_port(pi)];
	}
	read_shadows();
	for (int p = 0; p < NPINS; p++)
		oc_level[p] = 0; /* OCnx are cleared by a reset */
	for (int ch = 0; ch < ADC_SLOTS; ch++)
		adc_sent[ch] = -1;
	apply_circuit();
	update_analog();
	for (int p = 0; p < NPINS; p++)
		cap[p].level = pin_level(p);
}

/* ------------------------------------------------------------------ pulse generator */
int pulses_running(void)
{
	return gen[0].active || gen[1].active;
}

void start_pulses(int p, unsigned long count, uint64_t high_c, uint64_t low_c)
{
	struct pulsegen *g = &gen[p - 2];
	g->active = 1;
	g->level = 0;
	g->remaining = count;
	g->high_c = high_c;
	g->low_c = low_c;
	g->next_t = avr->cycle + 16;
	recompute_next_event();
}

void stop_pulses(void)
{
	for (int i = 0; i < 2; i++) gen[i].active = 0;
}

void schedule_pulses(void)
{
	for (int i = 0; i < 2; i++)
		if (gen[i].active)
			schedule(gen[i].next_t);
}

/* One pass over the pulse generators' due edges; returns whether any was. */
int run_pulses(uint64_t now)
{
	int progress = 0;
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
	return progress;
}

/* ------------------------------------------------------------------ control channel */
const char *fixture_name(void) { return fixture_names[opt->fixture]; }

void circuit_set_analog(int ch, int mv)
{
	analog_mv[ch] = mv;
	update_analog();
}

void circuit_set_temperature(double celsius)
{
	temperature_c = celsius;
	update_analog();
}

void circuit_drive(int p, int level)
{
	drive_level[p] = level;
	apply_circuit();
}

void circuit_set_driven(int p, int level) { drive_level[p] = level; }

int circuit_adc_mv(int ch) { return adc_sent[ch]; }
unsigned long pulses_done(int p) { return gen[p - 2].done; }
const uint8_t *circuit_i2c_eeprom(void) { return i2c_ee.ee; }

static void sb_ring(struct sbuf *r, const double *values, unsigned next, unsigned count)
{
	for (unsigned i = 0; i < count; i++) {
		unsigned idx = (next + NEDGE - count + i) % NEDGE;
		sb_add(r, "%s%.3f", i ? ", " : "", values[idx]);
	}
}

void circuit_pulse_stats(int p, struct sbuf *r)
{
	struct capture *c = &cap[p];
	sb_add(r, "{\"ok\": true, \"pin\": %d, \"count\": %lu, \"falls\": %lu, \"level\": %d, "
		  "\"highs\": %lu, \"periods\": %lu, \"high_us\": [",
	       p, c->rises, c->falls, c->level, c->highs, c->periods);
	sb_ring(r, c->high_us, c->hi_next, c->nh);
	sb_add(r, "], \"rise_us\": [");
	sb_ring(r, c->rise_us, c->hi_next, c->nh);
	if (c->have_edge)
		sb_add(r, "], \"last_edge_us\": %.3f", (double)c->edge_t / CYC_PER_US);
	else
		sb_add(r, "], \"last_edge_us\": null");
	sb_add(r, ", \"period_us\": [");
	sb_ring(r, c->period_us, c->pe_next, c->np);
	sb_add(r, "]}");
}

void circuit_clear_pulse_stats(int p)
{
	struct capture *c = &cap[p];
	int lvl = c->level;
	memset(c, 0, sizeof(*c));
	c->level = lvl;
}

void circuit_status(struct sbuf *r)
{
	sb_add(r, ", \"pulses_active\": %s, \"pulses_done\": {\"2\": %lu, \"3\": %lu}, "
		  "\"temperature_c\": %g",
	       pulses_running() ? "true" : "false", gen[0].done, gen[1].done, temperature_c);
}

/*
 * testfw.c - tiny ATmega328P firmware used only to test the virtual Uno harness.
 *
 * It is NOT the project firmware.  It exists so the harness (pty bridge,
 * pacing, fixtures, 16U2 model, control channel) can be tested before and
 * independently of the real firmware.
 *
 * Protocol (host -> board):
 *   byte < 0x80           echoed back unchanged (interrupt driven, sleeps in between)
 *   0x81 arg              pin mode: arg = pin << 2 | mode (mode 0 input, 1 input pull-up,
 *                         2 output low, 3 output high); pin 0..19 (D0..D13, A0..A5).  Reply 0x81.
 *   0x82 pin              digital read; reply 0 or 1
 *   0x83 ch               ADC read (ch 0..7, 8 = temperature sensor with 1.1 V ref); reply lo, hi
 *   0x84 addr             read internal EEPROM byte; reply byte
 *   0x85 value            write value to I2C EEPROM (7-bit 0x50) at address 0x10; reply 0x85,
 *                         or (unexpected TWSR status | step 1..4) when a step failed
 *   0x86 x                start "servo" pulses: Timer1 fast PWM, 20 ms period,
 *                         OC1A (D9) 1500 us high, OC1B (D10) 1000 us high; reply 0x86
 *   0x87 pin              INT0 (pin 2) / INT1 (pin 3) rising edge count; reply lo, hi
 *   0x88 x                watchdog reset (enables WDT 15 ms, spins with interrupts off)
 *   0x8A x                uptime in Timer0 overflows (1.024 ms each); reply lo, hi
 *   0x8B x                reply MCUSR value captured at boot
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <stdint.h>

#ifndef BAUD
#define BAUD 115200UL
#endif

static volatile uint8_t rx_buf[64];
static volatile uint8_t rx_head, rx_tail;
static volatile uint8_t tx_buf[64];
static volatile uint8_t tx_head, tx_tail;
static volatile uint16_t int_count[2];
static volatile uint16_t ticks;
static uint8_t boot_mcusr __attribute__((section(".noinit")));

/* Clear the watchdog as early as possible, so a watchdog reset does not loop. */
void early_init(void) __attribute__((naked, used, section(".init3")));
void early_init(void)
{
	boot_mcusr = MCUSR;
	MCUSR = 0;
	wdt_disable();
}

ISR(USART_RX_vect)
{
	uint8_t c = UDR0;
	uint8_t n = (uint8_t)((rx_head + 1) & 63);
	if (n != rx_tail) {
		rx_buf[rx_head] = c;
		rx_head = n;
	}
}

ISR(USART_UDRE_vect)
{
	if (tx_head == tx_tail) {
		UCSR0B &= (uint8_t)~_BV(UDRIE0);
		return;
	}
	UDR0 = tx_buf[tx_tail];
	tx_tail = (uint8_t)((tx_tail + 1) & 63);
}

ISR(INT0_vect) { int_count[0]++; }
ISR(INT1_vect) { int_count[1]++; }
ISR(TIMER0_OVF_vect) { ticks++; }

static void put(uint8_t c)
{
	uint8_t n = (uint8_t)((tx_head + 1) & 63);
	while (n == tx_tail) {
	}
	tx_buf[tx_head] = c;
	tx_head = n;
	UCSR0B |= _BV(UDRIE0);
}

static int get(void)
{
	int c = -1;
	cli();
	if (rx_head != rx_tail) {
		c = rx_buf[rx_tail];
		rx_tail = (uint8_t)((rx_tail + 1) & 63);
	}
	sei();
	return c;
}

static uint8_t get_wait(void)
{
	int c;
	while ((c = get()) < 0) {
	}
	return (uint8_t)c;
}

static void pin_regs(uint8_t pin, volatile uint8_t **ddr, volatile uint8_t **port,
		     volatile uint8_t **pinr, uint8_t *mask)
{
	if (pin < 8) {
		*ddr = &DDRD; *port = &PORTD; *pinr = &PIND; *mask = (uint8_t)_BV(pin);
	} else if (pin < 14) {
		*ddr = &DDRB; *port = &PORTB; *pinr = &PINB; *mask = (uint8_t)_BV(pin - 8);
	} else {
		*ddr = &DDRC; *port = &PORTC; *pinr = &PINC; *mask = (uint8_t)_BV(pin - 14);
	}
}

static uint16_t adc_read(uint8_t ch)
{
	if (ch == 8)
		ADMUX = _BV(REFS1) | _BV(REFS0) | 8; /* internal 1.1 V, temperature */
	else
		ADMUX = _BV(REFS0) | (ch & 7); /* AVCC */
	ADCSRA = _BV(ADEN) | _BV(ADSC) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);
	while (ADCSRA & _BV(ADSC)) {
	}
	uint16_t v = ADCL;
	v |= (uint16_t)ADCH << 8;
	return v;
}

static uint8_t twi_wait(void)
{
	uint16_t guard = 0;
	while (!(TWCR & _BV(TWINT))) {
		if (++guard == 0)
			return 0xff;
	}
	return TWSR & 0xF8;
}

/* returns 0 on success, else the unexpected TWSR status (for harness debugging) */
static uint8_t i2c_write(uint8_t value)
{
	uint8_t st, bad = 0;
	TWBR = 72; /* 100 kHz */
	TWSR = 0;
	TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN);
	if ((st = twi_wait()) != 0x08 && !bad) bad = st | 1;
	TWDR = 0xA0;
	TWCR = _BV(TWINT) | _BV(TWEN);
	if ((st = twi_wait()) != 0x18 && !bad) bad = st | 2;
	TWDR = 0x10;
	TWCR = _BV(TWINT) | _BV(TWEN);
	if ((st = twi_wait()) != 0x28 && !bad) bad = st | 3;
	TWDR = value;
	TWCR = _BV(TWINT) | _BV(TWEN);
	if ((st = twi_wait()) != 0x28 && !bad) bad = st | 4;
	TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN);
	return bad;
}

static void command(uint8_t op)
{
	uint8_t arg = get_wait();
	volatile uint8_t *ddr, *port, *pinr;
	uint8_t mask;
	switch (op) {
	case 0x81: {
		uint8_t pin = arg >> 2, mode = arg & 3;
		pin_regs(pin, &ddr, &port, &pinr, &mask);
		if (mode & 2)
			*ddr |= mask;
		else
			*ddr &= (uint8_t)~mask;
		if (mode & 1)
			*port |= mask;
		else
			*port &= (uint8_t)~mask;
		put(0x81);
		break;
	}
	case 0x82:
		pin_regs(arg, &ddr, &port, &pinr, &mask);
		put((*pinr & mask) ? 1 : 0);
		break;
	case 0x83: {
		uint16_t v = adc_read(arg);
		put((uint8_t)v);
		put((uint8_t)(v >> 8));
		break;
	}
	case 0x84:
		EEAR = arg;
		EECR |= _BV(EERE);
		put(EEDR);
		break;
	case 0x85:
		{
			uint8_t bad = i2c_write(arg);
			put(bad ? bad : 0x85);
		}
		break;
	case 0x86:
		DDRB |= _BV(PB1) | _BV(PB2);
		ICR1 = 40000 - 1;   /* 20 ms at clk/8 */
		OCR1A = 3000 - 1;   /* 1500 us */
		OCR1B = 2000 - 1;   /* 1000 us */
		TCCR1A = _BV(COM1A1) | _BV(COM1B1) | _BV(WGM11);
		TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);
		put(0x86);
		break;
	case 0x87: {
		uint16_t v;
		cli();
		v = int_count[arg == 3 ? 1 : 0];
		sei();
		put((uint8_t)v);
		put((uint8_t)(v >> 8));
		break;
	}
	case 0x88:
		cli();
		wdt_enable(WDTO_15MS);
		for (;;) {
		}
	case 0x8A: {
		uint16_t v;
		cli();
		v = ticks;
		sei();
		put((uint8_t)v);
		put((uint8_t)(v >> 8));
		break;
	}
	case 0x8B:
		put(boot_mcusr);
		break;
	default:
		break;
	}
}

int main(void)
{
#if BAUD == 115200UL
	UCSR0A = _BV(U2X0);
	UBRR0 = 16;
#else
	UCSR0A = _BV(U2X0);
	UBRR0 = (uint16_t)(F_CPU / 8 / BAUD - 1);
#endif
	UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
	UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);

	/* INT0/INT1 on rising edges, for the pulse generator test. */
	EICRA = _BV(ISC01) | _BV(ISC00) | _BV(ISC11) | _BV(ISC10);
	EIMSK = _BV(INT0) | _BV(INT1);

	/* Timer0 overflow every 1.024 ms: an uptime counter. */
	TCCR0B = _BV(CS01) | _BV(CS00);
	TIMSK0 = _BV(TOIE0);

	set_sleep_mode(SLEEP_MODE_IDLE);
	sei();
	for (;;) {
		int c = get();
		if (c < 0) {
			cli();
			if (rx_head == rx_tail) {
				sleep_enable();
				sei();
				sleep_cpu();
				sleep_disable();
			}
			sei();
			continue;
		}
		if (c < 0x80)
			put((uint8_t)c);
		else
			command((uint8_t)c);
	}
}

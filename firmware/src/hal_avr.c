/*
 * hal_avr.c - hal.h for the ATmega328P on an Arduino Uno: pins, ADC, EEPROM,
 * TWI, Timer1 servo PWM, external and pin-change interrupts, sleep, reset.
 * (UART: uart.c; time: clock.c.)
 *
 * Pin map: D2-D7 = PD2-PD7, D8-D13 = PB0-PB5, A0-A5 = PC0-PC5.
 */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <util/delay.h>

#include "analog.h"
#include "counter.h"
#include "encoder.h"
#include "gpio.h"
#include "aio_protocol.h"
#include "hal.h"
#include "pins.h"
#include "pwm.h"
#include "stream.h"

#define TWI_STEP_TICKS 20u /* 2 ms */

uint8_t hal_irq_save(void)
{
    uint8_t s = SREG;
    cli();
    return s;
}

void hal_irq_restore(uint8_t state) { SREG = state; }

/* ---------------------------------------------------------------- system */

void hal_wait(void)
{
    set_sleep_mode(SLEEP_MODE_IDLE);
    sleep_enable();
    sleep_cpu(); /* the 100 us tick wakes it at the latest */
    sleep_disable();
}

void hal_system_reset(void)
{
    cli();
    wdt_disable(); /* restart it with the short timeout (simavr 1.6 does not
                      rescale a running watchdog) */
    wdt_enable(WDTO_15MS);
    for (;;) {
    }
}

uint16_t hal_eeprom_read_u16(uint16_t address)
{
    const uint8_t *p = (const uint8_t *)address;
    return (uint16_t)((uint16_t)eeprom_read_byte(p) << 8 | eeprom_read_byte(p + 1));
}

void hal_eeprom_write_u16(uint16_t address, uint16_t value)
{
    uint8_t *p = (uint8_t *)address;
    eeprom_update_byte(p, (uint8_t)(value >> 8));
    eeprom_update_byte(p + 1, (uint8_t)value);
}

/* ---------------------------------------------------------------- pins */

static volatile uint8_t *port_of(uint8_t pin) { return pin < 8u ? &PORTD : &PORTB; }
static volatile uint8_t *ddr_of(uint8_t pin) { return pin < 8u ? &DDRD : &DDRB; }
/* A byte table (pins_bit holds 16-bit masks): the GPIO WRITE path looks it up
 * once per request. */
static const uint8_t port_bit[8] = {0x01u, 0x02u, 0x04u, 0x08u, 0x10u, 0x20u, 0x40u, 0x80u};
static uint8_t bit_of(uint8_t pin) { return port_bit[pin & 7u]; }

void hal_pin_mode(uint8_t pin, uint8_t mode)
{
    volatile uint8_t *port = port_of(pin), *ddr = ddr_of(pin);
    uint8_t bit = bit_of(pin), s = hal_irq_save();
    if (mode == HAL_OUT_HIGH || mode == HAL_IN_PULLUP)
        *port |= bit;
    else
        *port &= (uint8_t)~bit;
    if (mode >= HAL_OUT_LOW)
        *ddr |= bit;
    else
        *ddr &= (uint8_t)~bit;
    hal_irq_restore(s);
}

/* Inlined into the GPIO WRITE handler (LTO): the hot request. */
__attribute__((always_inline)) inline void hal_pin_write(uint8_t pin, uint8_t level)
{
    volatile uint8_t *port = port_of(pin);
    uint8_t bit = bit_of(pin), s = hal_irq_save();
    if (level)
        *port |= bit;
    else
        *port &= (uint8_t)~bit;
    hal_irq_restore(s);
}

/* Inlined into the interrupt vectors (LTO): the encoders read it every edge. */
__attribute__((always_inline)) inline uint16_t hal_pin_levels(void) { return (uint16_t)((PIND & 0xFCu) | (uint16_t)(PINB & 0x3Fu) << 8); }

void hal_edge_watch(uint16_t mask)
{
    uint8_t s = hal_irq_save();
    PCMSK2 = (uint8_t)(mask & 0xFCu);
    PCMSK0 = (uint8_t)((mask >> 8) & 0x3Fu);
    PCICR = (uint8_t)((PCMSK2 ? _BV(PCIE2) : 0) | (PCMSK0 ? _BV(PCIE0) : 0));
    hal_irq_restore(s);
}

/* The pin interrupts' C calls go through these trampolines, which save the
 * registers the C ABI lets a call clobber (as clock.c's clock_slow_call): a
 * vector that makes no C call itself saves only the registers it uses, so
 * the encoders' path (encoder.h, inlined) costs ~17 pushes less an edge. */
#define ISR_TRAMPOLINE(name, target)                                                              \
    __asm__(".section .text." #name ",\"ax\",@progbits\n.global " #name "\n" #name ":\n"          \
            "\tpush r0\n\tpush r18\n\tpush r19\n\tpush r20\n\tpush r21\n\tpush r22\n\tpush r23\n" \
            "\tpush r24\n\tpush r25\n\tpush r26\n\tpush r27\n\tpush r30\n\tpush r31\n"           \
            "\tcall " #target "\n"                                                                \
            "\tpop r31\n\tpop r30\n\tpop r27\n\tpop r26\n\tpop r25\n\tpop r24\n\tpop r23\n"      \
            "\tpop r22\n\tpop r21\n\tpop r20\n\tpop r19\n\tpop r18\n\tpop r0\n\tret\n\t.text\n")
#define ISR_CALL(name) __asm__ volatile("call " #name ::: "memory")

void isr_gpio(void) __attribute__((used, externally_visible, noinline));
void isr_gpio(void) { gpio_pin_change(hal_pin_levels()); }
ISR_TRAMPOLINE(isr_gpio_call, isr_gpio);

/* Both users of the vectors: the encoders (first: their next edge may be
 * close) and the GPIO watches, each on its own pins.  (The watches read the
 * levels a few cycles later: the same change, latched as before.) */
ISR(PCINT0_vect)
{
    encoder_pin_change(hal_pin_levels());
    if (gpio_watch)
        ISR_CALL(isr_gpio_call);
}
ISR(PCINT2_vect, ISR_ALIASOF(PCINT0_vect));

void hal_softpwm_low(uint8_t mask)
{
    uint8_t s = hal_irq_save();
    PORTD &= (uint8_t)~mask;
    hal_irq_restore(s);
}

/* ---------------------------------------------------------------- ADC */

#define ADC_PRESCALE (_BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0)) /* 128: 125 kHz */
#define ADMUX_AVCC _BV(REFS0)
#define ADMUX_TEMP (_BV(REFS1) | _BV(REFS0) | 8u)

static uint16_t convert(void)
{
    ADCSRA = _BV(ADEN) | _BV(ADIF) | ADC_PRESCALE | _BV(ADSC);
    while (ADCSRA & _BV(ADSC)) {
    }
    return ADC;
}

uint16_t hal_adc_convert(uint8_t channel)
{
    uint16_t v;
    if (channel == HAL_ADC_TEMPERATURE) {
        ADMUX = ADMUX_TEMP;
        (void)convert(); /* let the reference and the multiplexer settle */
        v = convert();
        ADMUX = ADMUX_AVCC;
        return v;
    }
    ADMUX = (uint8_t)(ADMUX_AVCC | (channel & 7u));
    return convert();
}

void hal_adc_start(uint8_t channel, uint8_t clock_shift)
{
    ADMUX = (uint8_t)(ADMUX_AVCC | (channel & 7u));
    ADCSRA = (uint8_t)(_BV(ADEN) | _BV(ADIF) | _BV(ADIE) | (clock_shift & 7u) | _BV(ADSC));
}

/* Interrupts stay enabled while the sample is completed so the UART
 * receiver is never held up. */
ISR(ADC_vect, ISR_NOBLOCK)
{
    uint16_t v = ADC;
    ADCSRA = _BV(ADEN) | ADC_PRESCALE; /* ADIE off until the next start */
    analog_adc_done(v);
}

/* ---------------------------------------------------------------- TWI */

static uint8_t twi_fast;

/* Waits for TWINT, at most 2 ms. */
static uint8_t twi_wait(void)
{
    uint16_t start = hal_ticks();
    while (!(TWCR & _BV(TWINT)))
        if ((uint16_t)(hal_ticks() - start) > TWI_STEP_TICKS)
            return 0;
    return 1;
}

/* A byte and its acknowledge take 9 SCL periods; TWINT cannot legitimately
 * come earlier.  Waiting that long before polling costs nothing on the
 * hardware and keeps us from acting on a stale TWINT/TWSR in emulators
 * (simavr 1.6 leaves TWINT readable as set while the byte is on the bus). */
static uint8_t twi_byte_wait(void)
{
    if (twi_fast)
        _delay_us(23);
    else
        _delay_us(91);
    return twi_wait();
}

void hal_twi_init(uint8_t fast)
{
    PORTC |= _BV(PORTC4) | _BV(PORTC5); /* internal pull-ups on SDA/SCL */
    TWSR = 0;
    TWBR = fast ? 12u : 72u; /* (16 MHz / f - 16) / 2 */
    twi_fast = fast;
    TWCR = _BV(TWEN);
}

void hal_twi_reset(void)
{
    TWCR = 0;
    TWCR = _BV(TWEN);
}

uint8_t hal_twi_start(void)
{
    uint8_t st;
    TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN);
    if (!twi_wait())
        return HAL_TWI_TIMEOUT;
    st = TWSR & 0xF8u;
    return (st == 0x08u || st == 0x10u) ? HAL_TWI_OK : HAL_TWI_TIMEOUT;
}

uint8_t hal_twi_write(uint8_t byte)
{
    uint8_t st;
    TWDR = byte;
    TWCR = _BV(TWINT) | _BV(TWEN);
    if (!twi_byte_wait())
        return HAL_TWI_TIMEOUT;
    st = TWSR & 0xF8u;
    if (st == 0x18u || st == 0x28u || st == 0x40u)
        return HAL_TWI_OK;
    if (st == 0x20u || st == 0x30u || st == 0x48u)
        return HAL_TWI_NACK;
    return HAL_TWI_TIMEOUT; /* arbitration lost or bus error: reset the unit */
}

uint8_t hal_twi_read(bool ack, uint8_t *byte)
{
    uint8_t st;
    TWCR = (uint8_t)(_BV(TWINT) | _BV(TWEN) | (ack ? _BV(TWEA) : 0));
    if (!twi_byte_wait())
        return HAL_TWI_TIMEOUT;
    st = TWSR & 0xF8u;
    *byte = TWDR;
    return (st == 0x50u || st == 0x58u) ? HAL_TWI_OK : HAL_TWI_TIMEOUT;
}

void hal_twi_stop(void)
{
    uint16_t start = hal_ticks();
    TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN);
    while (TWCR & _BV(TWSTO))
        if ((uint16_t)(hal_ticks() - start) > TWI_STEP_TICKS) {
            hal_twi_reset();
            return;
        }
}

/* ---------------------------------------------------------------- Timer1 servo */
/*
 * Fast PWM with TOP = ICR1 (mode 14), clk/8: 0.5 us per count, 20 ms period,
 * the output goes high at BOTTOM and low at the compare match.
 *
 * Widths: hal_servo_set() writes OCR1x at once.  The hardware double-buffers
 * OCR1x and loads them at BOTTOM, so a new width starts with the next period
 * and a running pulse is neither cut short nor stretched; the other channel
 * is never touched.
 *
 * Connecting and disconnecting an output (width 0 <-> width) is done in the
 * channel's compare-match interrupt, right after its pulse ended (or where it
 * would have), so no pulse is ever cut short or started in the middle.
 *
 * simavr 1.6 models mode 14 with its phase-correct PWM code, which reads
 * OCR1x only when the timer is (re)configured, i.e. when the clock select
 * changes, and which then starts a new period at that instant.  So after a
 * width change the overflow interrupt runs once: just after BOTTOM (both
 * pulses running, every compare match at least 1000 us away) it stops and
 * restarts the clock, then writes TCNT1 back to the count it should have,
 * which moves simavr's period back in phase (its TCNT1 write re-phases all
 * events).  On silicon the clock is off for two CPU cycles and TCNT1 gets
 * (within one count) the value it has anyway: at most 0.5 us once per change.
 */
#define SERVO_COUNTS_PER_US 2u
#define SERVO_IDLE_OCR (AIO_PULSE_MIN_US * SERVO_COUNTS_PER_US - 1u)
#define SERVO_TCCR1B_STOP (_BV(WGM13) | _BV(WGM12))
#define SERVO_TCCR1B_RUN (_BV(WGM13) | _BV(WGM12) | _BV(CS11))
/* The re-phasing must happen before the earliest compare match (1000 us). */
#define SERVO_REPHASE_LIMIT (AIO_PULSE_MIN_US * SERVO_COUNTS_PER_US - 200u)

static volatile uint8_t servo_want; /* COM1A1 / COM1B1 wanted */

static uint8_t com_bit(uint8_t pin) { return pin == 9u ? _BV(COM1A1) : _BV(COM1B1); }
static uint8_t ocie_bit(uint8_t pin) { return pin == 9u ? _BV(OCIE1A) : _BV(OCIE1B); }

/* Interrupts off (16-bit registers share the TEMP byte). */
void hal_servo_set(uint8_t pin, uint16_t us)
{
    uint8_t s = hal_irq_save();
    if (us) {
        uint16_t ocr = (uint16_t)(us * SERVO_COUNTS_PER_US - 1u);
        if (pin == 9u)
            OCR1A = ocr;
        else
            OCR1B = ocr;
        servo_want |= com_bit(pin);
        TIFR1 = _BV(TOV1);
        TIMSK1 |= _BV(TOIE1); /* re-phase once (simavr) */
    } else {
        servo_want &= (uint8_t)~com_bit(pin);
    }
    if ((TCCR1A ^ servo_want) & com_bit(pin)) {
        /* connect or disconnect right after the running pulse */
        TIFR1 = ocie_bit(pin); /* OCF1x sit at the same bit positions */
        TIMSK1 |= ocie_bit(pin);
    }
    hal_irq_restore(s);
}

void hal_servo_attach(uint8_t pin, uint16_t us)
{
    uint8_t s = hal_irq_save();
    if (!(TCCR1B & (_BV(CS12) | _BV(CS11) | _BV(CS10)))) {
        TCCR1A = 0; /* normal mode while setting up: OCR1x are written at once */
        TCCR1B = 0;
        TIMSK1 = 0;
        OCR1A = SERVO_IDLE_OCR;
        OCR1B = SERVO_IDLE_OCR;
        ICR1 = AIO_SERVO_PERIOD_US * SERVO_COUNTS_PER_US - 1u;
        TCNT1 = 0;
        TCCR1A = _BV(WGM11);
        TCCR1B = SERVO_TCCR1B_RUN;
    }
    hal_irq_restore(s);
    hal_pin_mode(pin, HAL_OUT_LOW);
    hal_servo_set(pin, us);
}

void hal_servo_detach(uint8_t pin)
{
    uint8_t s = hal_irq_save();
    servo_want &= (uint8_t)~com_bit(pin);
    TCCR1A &= (uint8_t)~com_bit(pin);
    TIMSK1 &= (uint8_t)~ocie_bit(pin);
    if (!(TCCR1A & (_BV(COM1A1) | _BV(COM1B1))) && !servo_want) {
        TCCR1B = 0; /* both detached: stop the timer */
        TIMSK1 = 0;
    }
    hal_irq_restore(s);
}

/* Just after BOTTOM: restart the clock and put TCNT1 back (see above).  The
 * asm keeps a fixed 12 cycles between the TCNT1 read and the TCNT1 write;
 * the count written back is the one read plus 2 (12 cycles = 1.5 counts),
 * within half a count of the true one. */
ISR(TIMER1_OVF_vect)
{
    uint16_t n;
    if (TCNT1 >= SERVO_REPHASE_LIMIT)
        return; /* held up too long: try again at the next BOTTOM */
    __asm__ volatile("lds %A0, %[tl]\n\t"
                     "lds %B0, %[th]\n\t"
                     "sts %[tb], %[stop]\n\t"
                     "sts %[tb], %[run]\n\t"
                     "adiw %0, 2\n\t"
                     "sts %[th], %B0\n\t"
                     "sts %[tl], %A0\n\t"
                     : "=&w"(n)
                     : [tl] "n"(_SFR_MEM_ADDR(TCNT1L)), [th] "n"(_SFR_MEM_ADDR(TCNT1H)),
                       [tb] "n"(_SFR_MEM_ADDR(TCCR1B)), [stop] "r"((uint8_t)SERVO_TCCR1B_STOP),
                       [run] "r"((uint8_t)SERVO_TCCR1B_RUN)
                     : "memory");
    TIMSK1 &= (uint8_t)~_BV(TOIE1);
}

/* Just after a pulse ended (or where it would have): apply the wanted
 * connection of the output. */
ISR(TIMER1_COMPA_vect)
{
    TCCR1A = (uint8_t)((TCCR1A & ~_BV(COM1A1)) | (servo_want & _BV(COM1A1)));
    TIMSK1 &= (uint8_t)~_BV(OCIE1A);
}

ISR(TIMER1_COMPB_vect)
{
    TCCR1A = (uint8_t)((TCCR1A & ~_BV(COM1B1)) | (servo_want & _BV(COM1B1)));
    TIMSK1 &= (uint8_t)~_BV(OCIE1B);
}

/* ---------------------------------------------------------------- duty PWM */
/*
 * Duty-cycle PWM (duty.c): fast PWM, the output high from BOTTOM to the
 * compare match.  Timer0 mode 3 (TOP 0xFF), Timer1 mode 14 (TOP ICR1),
 * Timer2 mode 7 (TOP OCR2A = the tick's 199: clock.c keeps counting its
 * ticks, the compare A match is at the same count in both modes).
 *
 * simavr 1.6 reads OCR1x in mode 14 only when Timer1 is (re)configured
 * (see Timer1 servo above): after a new OCR1x the clock is stopped and
 * restarted and TCNT1 written back, which re-phases simavr's period.  On
 * silicon the counter loses a few counts once (a phase step of under 1 us,
 * the duty is unchanged).
 */
#define DUTY1_STOP (_BV(WGM13) | _BV(WGM12))
#define DUTY1_FIX 10u /* cycles (= counts at clk/1) from the TCNT1 read to its write */

void hal_duty_timer(uint8_t timer, uint8_t cs, uint16_t top)
{
    uint8_t s = hal_irq_save();
    if (timer == 0u) {
        TCCR0A = cs ? (uint8_t)(_BV(WGM01) | _BV(WGM00)) : 0u;
        TCCR0B = cs;
    } else if (timer == 1u) {
        TCCR1B = 0;
        TCCR1A = 0;
        TIMSK1 = 0;
        if (cs) {
            ICR1 = top;
            TCNT1 = 0;
            TCCR1A = _BV(WGM11);
            TCCR1B = (uint8_t)(DUTY1_STOP | cs);
        }
    } else if (cs) {
        TCCR2A = (uint8_t)(_BV(WGM21) | _BV(WGM20));
        TCCR2B = (uint8_t)(_BV(WGM22) | _BV(CS21));
    } else {
        TCCR2A = _BV(WGM21);
        TCCR2B = _BV(CS21);
        OCR2B = 0xFFu; /* see clock_init */
    }
    hal_irq_restore(s);
}

static void duty1_rephase(void)
{
    uint16_t n = TCNT1, top = ICR1;
    uint8_t run = TCCR1B;
    TCCR1B = DUTY1_STOP;
    TCCR1B = run;
    n = (uint16_t)(n + DUTY1_FIX);
    if (n > top || n < DUTY1_FIX)
        n = (uint16_t)(n - top - 1u);
    TCNT1 = n;
}

void hal_duty_output(uint8_t pin, uint8_t how, uint16_t ocr)
{
    volatile uint8_t *tccra = pin == 5u || pin == 6u ? &TCCR0A : pin == 3u ? &TCCR2A : &TCCR1A;
    uint8_t com = pin == 6u ? _BV(COM0A1)
                  : pin == 5u ? _BV(COM0B1)
                  : pin == 9u ? _BV(COM1A1)
                  : pin == 10u ? _BV(COM1B1)
                               : _BV(COM2B1);
    uint8_t s = hal_irq_save();
    if (how == HAL_DUTY_PWM) {
        if (pin == 6u)
            OCR0A = (uint8_t)ocr;
        else if (pin == 5u)
            OCR0B = (uint8_t)ocr;
        else if (pin == 3u)
            OCR2B = (uint8_t)ocr;
        else {
            if (pin == 9u)
                OCR1A = ocr;
            else
                OCR1B = ocr;
            duty1_rephase();
        }
        *tccra |= com;
    } else {
        hal_pin_write(pin, how == HAL_DUTY_HIGH);
        *tccra &= (uint8_t)~com;
        if (pin == 3u)
            OCR2B = 0xFFu; /* see clock_init */
    }
    hal_irq_restore(s);
}

/* ---------------------------------------------------------------- Timer0 alarms */
/*
 * Timer0 counts at 0.5 us while an alarm runs; an alarm is its compare unit
 * plus a count of half timer periods still to wait: a delay d is a first
 * step (FIRST, below 256 counts; OCR0x += step) and then WRAPS(d) steps of 128, so
 * OCR0x always changes (simavr 1.6 fires at once when OCR0x is rewritten
 * with the count it holds).  The compare pins stay disconnected (COM0x = 0).
 */
#define HALF 128u
/* The first step of a delay of d >= 1 counts, and the 128-count steps after it. */
#define FIRST(d) ((uint8_t)(SHORT_FIRST(d) < MIN_FIRST && (d) > HALF ? SHORT_FIRST(d) + HALF : SHORT_FIRST(d)))
#define WRAPS(d) ((uint16_t)(((d) - FIRST(d)) >> 7)) /* d up to 120,000 (60 ms) */
#define SHORT_FIRST(d) ((((d) - 1u) & (HALF - 1u)) + 1u)
/* A first step is written after the interrupt's entry and the edge's work: one
 * shorter than this may already have passed when OCR0x is written, and its match
 * would come a whole timer period (128 us) late.  So a delay with wraps starts
 * with a step of MIN_FIRST to HALF + MIN_FIRST - 1 counts (below 256: the 8-bit
 * OCR0x still tells it apart); a short delay alone is spun for (SPIN_COUNTS). */
#define MIN_FIRST 64u
/* An edge due this close to the running alarm is waited for in it (the
 * interrupt's exit and entry take about that long) ... */
#define SPIN_COUNTS 12u
/* ... and goes out as many cycles after its count as through the interrupt. */
#define SPIN_ALIGN 20u

static uint16_t pwm_wraps;

/* Timer0 runs only while an alarm does (simavr then has no timer events to
 * serve for it).  Interrupts disabled. */
static void fine_timer_run(void)
{
    if (!(TCCR0B & _BV(CS01)))
        TCCR0B = _BV(CS01);
}

static void fine_timer_idle(void)
{
    if (!(TIMSK0 & (_BV(OCIE0A) | _BV(OCIE0B))))
        TCCR0B = 0;
}

void hal_softpwm_start(uint16_t delay)
{
    uint8_t s = hal_irq_save();
    fine_timer_run();
    OCR0A = (uint8_t)(TCNT0 + FIRST(delay));
    pwm_wraps = WRAPS(delay);
    TIFR0 = _BV(OCF0A);
    TIMSK0 |= _BV(OCIE0A);
    hal_irq_restore(s);
}

/* The edge goes out first, at a fixed distance from the match; then the next
 * one is scheduled from this match (OCR0A), not from now.  An edge due
 * within SPIN_COUNTS of the time this takes is waited for here. */
ISR(TIMER0_COMPA_vect)
{
    uint16_t delay;
    uint8_t base;

    if (pwm_wraps) {
        pwm_wraps--;
        OCR0A = (uint8_t)(OCR0A + HALF);
        return;
    }
    for (;;) {
        PORTD = (uint8_t)((PORTD | pwm_soft_set) & pwm_soft_keep);
        delay = pwm_soft_edge();
        if (!delay) {
            TIMSK0 &= (uint8_t)~_BV(OCIE0A);
            fine_timer_idle();
            return;
        }
        base = OCR0A;
        OCR0A = (uint8_t)(base + FIRST(delay));
        pwm_wraps = WRAPS(delay);
        if (delay >= 256u) {
            sei(); /* no match for 128 us: plan ahead with interrupts on */
            pwm_soft_plan();
            return; /* the epilogue's RETI ends the nesting */
        }
        if ((uint8_t)(TCNT0 - base) + SPIN_COUNTS < delay)
            return;
        while ((uint8_t)(TCNT0 - base) < (uint8_t)delay) {
        }
        TIFR0 = _BV(OCF0A); /* its match is this very edge */
        __builtin_avr_delay_cycles(SPIN_ALIGN);
    }
}

static uint8_t stream_first;
static uint16_t stream_wraps, stream_left;

void hal_stream_timer_start(uint32_t period)
{
    uint8_t s = hal_irq_save();
    fine_timer_run();
    stream_first = FIRST(period);
    stream_wraps = WRAPS(period);
    stream_left = stream_wraps;
    OCR0B = (uint8_t)(TCNT0 + stream_first);
    TIFR0 = _BV(OCF0B);
    TIMSK0 |= _BV(OCIE0B);
    hal_irq_restore(s);
}

void hal_stream_timer_stop(void)
{
    uint8_t s = hal_irq_save();
    TIMSK0 &= (uint8_t)~_BV(OCIE0B);
    fine_timer_idle();
    hal_irq_restore(s);
}

/* Interrupts enabled from the first instruction (a PWM edge must not wait);
 * no other COMPB can come for a step (at least one count after the OCR0B
 * write; a stream period is 500 counts or more, and the sample takes far
 * less than a step of 128). */
ISR(TIMER0_COMPB_vect, ISR_NOBLOCK)
{
    if (stream_left) {
        stream_left--;
        OCR0B = (uint8_t)(OCR0B + HALF);
        return;
    }
    stream_left = stream_wraps; /* before the match it schedules */
    OCR0B = (uint8_t)(OCR0B + stream_first);
    stream_alarm();
}

/* ---------------------------------------------------------------- INT0/INT1 */

/* A stale INTFn flag fires once right after enabling; the caller clears the
 * count afterwards.  (No EIFR write: simavr 1.6 mishandles it and then keeps
 * re-entering the INT0/INT1 vectors when both are enabled.) */
void hal_counter_enable(uint8_t index, uint8_t rising)
{
    uint8_t shift = (uint8_t)(index * 2u), s = hal_irq_save();
    EICRA = (uint8_t)((EICRA & ~(3u << shift)) | ((rising ? 3u : 2u) << shift));
    EIMSK |= (uint8_t)(1u << index);
    hal_irq_restore(s);
}

void hal_counter_disable(uint8_t index)
{
    uint8_t s = hal_irq_save();
    EIMSK &= (uint8_t)~(1u << index);
    hal_irq_restore(s);
}

/* Any change (ISCn = 01) for an encoder; which user an interrupt has is in
 * int_encoder (the pin roles keep a counter and an encoder off one pin). */
static volatile uint8_t int_encoder;

void hal_encoder_int(uint8_t index, uint8_t on)
{
    uint8_t shift = (uint8_t)(index * 2u), bit = (uint8_t)(1u << index), s = hal_irq_save();
    if (on) {
        EICRA = (uint8_t)((EICRA & ~(3u << shift)) | (1u << shift));
        int_encoder |= bit;
        EIMSK |= bit;
    } else {
        EIMSK &= (uint8_t)~bit;
        int_encoder &= (uint8_t)~bit;
    }
    hal_irq_restore(s);
}

void isr_counter0(void) __attribute__((used, externally_visible, noinline));
void isr_counter0(void) { counter_event(0); }
ISR_TRAMPOLINE(isr_counter0_call, isr_counter0);
void isr_counter1(void) __attribute__((used, externally_visible, noinline));
void isr_counter1(void) { counter_event(1); }
ISR_TRAMPOLINE(isr_counter1_call, isr_counter1);

ISR(INT0_vect)
{
    if (int_encoder & 1u)
        encoder_int(0, hal_pin_levels());
    else
        ISR_CALL(isr_counter0_call);
}

ISR(INT1_vect)
{
    if (int_encoder & 2u)
        encoder_int(1, hal_pin_levels());
    else
        ISR_CALL(isr_counter1_call);
}

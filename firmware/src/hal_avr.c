/*
 * hal_avr.c - hal.h for the ATmega328P on an Arduino Uno: pins, ADC, EEPROM,
 * Timer0 alarms, external and pin-change interrupts, sleep, reset.
 * (UART: uart.c; time: clock.c; TWI: hal_avr_twi.c; servo and duty-cycle PWM
 * timers: hal_avr_pwm.c.)
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
#include "i2cblock.h"
#include "pulse.h"
#include "gpio.h"
#include "aio_protocol.h"
#include "hal.h"
#include "hal_board.h"
#include "pins.h"
#include "pwm.h"
#include "stream.h"

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

static volatile uint8_t *port_of(uint8_t pin) { return hal_board_port(pin); }
static volatile uint8_t *ddr_of(uint8_t pin) { return hal_board_ddr(pin); }
/* A byte table (pins_bit holds 16-bit masks): the GPIO WRITE path looks it up
 * once per request.  In RAM on purpose (8 bytes): in flash (AIO_FLASH) the lookups
 * became lpm sequences in the hot paths, +192 B of code, and four steppers at
 * 10,000 steps/s beside pipelined writes fell to 7,500 (benchmarks.motors_steppers). */
static const uint8_t port_bit[8] = {0x01u, 0x02u, 0x04u, 0x08u, 0x10u, 0x20u, 0x40u, 0x80u};
static uint8_t bit_of(uint8_t pin) { return port_bit[HAL_BOARD_BIT_INDEX(pin)]; }

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
__attribute__((always_inline)) inline uint16_t hal_pin_levels(void) { return HAL_BOARD_LEVELS(); }

void hal_edge_watch(uint16_t mask)
{
    uint8_t s = hal_irq_save();
    hal_board_edge_watch(mask);
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
#if AIO_WITH_PULSE
void isr_pulse(void) __attribute__((used, externally_visible, noinline));
void isr_pulse(void) { pulse_edges(hal_pin_levels()); }
ISR_TRAMPOLINE(isr_pulse_call, isr_pulse);
#endif

/* Both users of the vectors: the encoders (first: their next edge may be
 * close) and the GPIO watches, each on its own pins.  (The watches read the
 * levels a few cycles later: the same change, latched as before.) */
ISR(HAL_PCINT_A_vect)
{
    encoder_pin_change(hal_pin_levels());
#if AIO_WITH_PULSE
    if (pulse_active) /* pulse.h: a call only while a pulse input is in use */
        ISR_CALL(isr_pulse_call);
#endif
    if (gpio_watch)
        ISR_CALL(isr_gpio_call);
}
ISR(HAL_PCINT_B_vect, ISR_ALIASOF(HAL_PCINT_A_vect));

/* A port without a step pin in the mask is not written at all (most ticks of a
 * slow stepper have none). */
void hal_step_pins(uint16_t mask, uint8_t level)
{
    uint8_t s;
    if (!mask)
        return;
    s = hal_irq_save();
    hal_board_step_pins(mask, level);
    hal_irq_restore(s);
}

void hal_softpwm_low(uint8_t mask)
{
    uint8_t s = hal_irq_save();
    HAL_SOFTPWM_PORT &= (uint8_t)~mask;
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
    HAL_ADC_SELECT(channel);
    ADMUX = (uint8_t)(ADMUX_AVCC | HAL_ADC_MUX(channel));
    return convert();
}

void hal_adc_start(uint8_t channel, uint8_t clock_shift)
{
    HAL_ADC_SELECT(channel);
    ADMUX = (uint8_t)(ADMUX_AVCC | HAL_ADC_MUX(channel));
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

/* ---------------------------------------------------------------- SPI */
#if AIO_WITH_SPI
/* SPCR: SPE, MSTR, DORD, CPOL, CPHA, SPR1:0; SPSR: SPI2X.  clock n divides
 * by 2**(n + 1): SPR = n >> 1 with SPI2X for even n (/2, /8, /32), and /128
 * is SPR = 3 without SPI2X.  The pins' directions are spi.c's (hal_pin_mode). */
void hal_spi_on(uint8_t mode, uint8_t clock, uint8_t lsb_first)
{
    uint8_t spr = clock >= 6u ? 3u : (uint8_t)(clock >> 1);
    SPCR = (uint8_t)(_BV(SPE) | _BV(MSTR) | (lsb_first ? _BV(DORD) : 0u) | (uint8_t)(mode << CPHA) | spr);
    SPSR = (clock < 6u && !(clock & 1u)) ? _BV(SPI2X) : 0u;
}

void hal_spi_off(void) { SPCR = 0; }

uint8_t hal_spi_exchange(uint8_t out, uint8_t *in)
{
    if (!(SPCR & _BV(MSTR)))
        return HAL_SPI_MODE_FAULT;
    SPDR = out;
    /* SPIF comes after 8 SPI clocks, or at once on a mode fault (MSTR cleared) */
    while (!(SPSR & _BV(SPIF)))
        ;
    *in = SPDR;
    return (SPCR & _BV(MSTR)) ? HAL_SPI_OK : HAL_SPI_MODE_FAULT;
}
#endif

#if AIO_WITH_I2C_STREAM
void hal_twi_go(uint8_t action, uint8_t arg)
{
    uint8_t n = 0;
    switch (action) {
    case HAL_TWI_GO_START:
        TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN) | _BV(TWIE);
        break;
    case HAL_TWI_GO_WRITE:
        TWDR = arg;
        TWCR = _BV(TWINT) | _BV(TWEN) | _BV(TWIE);
        break;
    case HAL_TWI_GO_READ:
        TWCR = (uint8_t)(_BV(TWINT) | _BV(TWEN) | _BV(TWIE) | (arg ? _BV(TWEA) : 0));
        break;
    case HAL_TWI_GO_STOP:
        TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN);
        while ((TWCR & _BV(TWSTO)) && ++n) /* a STOP takes 5-10 us; bounded */
            ;
        if (TWCR & _BV(TWSTO))
            hal_twi_reset();
        break;
    default:
        hal_twi_reset();
        break;
    }
}

ISR(TWI_vect) { i2cblock_twi((uint8_t)(TWSR & 0xF8u), TWDR); }
#endif

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
        HAL_SOFTPWM_PORT = (uint8_t)((HAL_SOFTPWM_PORT | pwm_soft_set) & pwm_soft_keep);
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
static volatile uint8_t alarm_running, alarms_missed; /* TIMER0_COMPB_vect below */

void hal_stream_timer_start(uint32_t period)
{
    uint8_t s = hal_irq_save();
    fine_timer_run();
    stream_first = FIRST(period);
    stream_wraps = WRAPS(period);
    stream_left = stream_wraps;
    alarms_missed = 0;
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

/* The period's bookkeeping runs with interrupts off (a few cycles: a soft
 * PWM edge waits at most that), the sample with them on.  A period that ends
 * while the last one's sample is still being taken (only when other
 * interrupts take the whole CPU: no other COMPB comes for a step of 128
 * counts otherwise) does not nest a second sample into the first: it is
 * counted and taken when the first returns (stream_alarm drops it, marked as
 * a sequence gap, if the first is still converting).  Nested, each period
 * pushed another frame until the stack ran into the variables
 * (tests/e2e/test_interrupt_overload.py). */
void isr_stream_alarm(void) __attribute__((used, externally_visible, noinline));
void isr_stream_alarm(void)
{
    alarm_running = 1;
    for (;;) {
        sei();
        stream_alarm();
        cli();
        if (!alarms_missed)
            break;
        alarms_missed--;
    }
    alarm_running = 0;
}
ISR_TRAMPOLINE(isr_stream_alarm_call, isr_stream_alarm);

/* The vector itself makes no C call (the trampoline saves what the sample's
 * code may clobber, once a period), so the steps between periods save only the
 * few registers they use: interrupts are off for them. */
ISR(TIMER0_COMPB_vect)
{
    if (stream_left) {
        stream_left--;
        OCR0B = (uint8_t)(OCR0B + HALF);
        return;
    }
    stream_left = stream_wraps; /* before the match it schedules */
    OCR0B = (uint8_t)(OCR0B + stream_first);
    if (alarm_running)
        alarms_missed++;
    else
        ISR_CALL(isr_stream_alarm_call);
}

/* ---------------------------------------------------------------- INT0/INT1 */

/* A stale INTFn flag fires once right after enabling; the caller clears the
 * count afterwards.  (No EIFR write: simavr 1.6 mishandles it and then keeps
 * re-entering the INT0/INT1 vectors when both are enabled.) */
void hal_counter_enable(uint8_t index, uint8_t rising)
{
    uint8_t shift = (uint8_t)(index * 2u), s = hal_irq_save();
    HAL_EICR = (uint8_t)((HAL_EICR & ~(3u << shift)) | ((rising ? 3u : 2u) << shift));
    EIMSK |= (uint8_t)(1u << (index + HAL_INT_FIRST));
    hal_irq_restore(s);
}

void hal_counter_disable(uint8_t index)
{
    uint8_t s = hal_irq_save();
    EIMSK &= (uint8_t)~(1u << (index + HAL_INT_FIRST));
    hal_irq_restore(s);
}

/* Any change (ISCn = 01) for an encoder; which user an interrupt has is in
 * int_encoder (the pin roles keep a counter and an encoder off one pin). */
static volatile uint8_t int_encoder;

void hal_encoder_int(uint8_t index, uint8_t on)
{
    uint8_t shift = (uint8_t)(index * 2u), bit = (uint8_t)(1u << index), s = hal_irq_save();
    uint8_t ebit = (uint8_t)(1u << (index + HAL_INT_FIRST));
    if (on) {
        HAL_EICR = (uint8_t)((HAL_EICR & ~(3u << shift)) | (1u << shift));
        int_encoder |= bit;
        EIMSK |= ebit;
    } else {
        EIMSK &= (uint8_t)~ebit;
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

#if AIO_WITH_ENCODER && defined(__AVR_ATmega328P__)
/* The Uno's INT0/INT1: encoder_step() (encoder.h, the reference the host tests
 * run) written out in assembly, on a slot pointer instead of one inlined copy
 * per slot, the levels as two port bytes instead of a 16-bit word, and 9
 * registers saved instead of 11: ~95 cycles an edge instead of ~150 (issue 27;
 * benchmarks/sensors_encoders.py measures the ceiling and the harness's
 * edge-to-vector wait).  The counter's path is the trampoline call as in C,
 * with r1 cleared for it. */
#include <stddef.h>

#include "clock.h"
#define ENC_ASM_OPERANDS(index)                                                                    \
    [slot] "i"(&encoder_int_slot[index]), [size] "M"(sizeof(encoder_slot_t)),                      \
        [base] "i"(encoder_slots), [use] "i"(&int_encoder), [bit] "I"(index),                      \
        [pind] "I"(_SFR_IO_ADDR(PIND)), [pinb] "I"(_SFR_IO_ADDR(PINB)),                            \
        [st] "I"(offsetof(encoder_slot_t, state)), [fr] "I"(offsetof(encoder_slot_t, fresh)),      \
        [mv] "I"(offsetof(encoder_slot_t, moved)), [el] "I"(offsetof(encoder_slot_t, edge_low)),  \
        [es] "I"(offsetof(encoder_slot_t, edge_sub)), [inv] "I"(offsetof(encoder_slot_t, invalid)), \
        [ma] "I"(offsetof(encoder_slot_t, mask_a)), [mb] "I"(offsetof(encoder_slot_t, mask_b)),   \
        [tab] "I"(offsetof(encoder_slot_t, table)), [t0] "i"(&clock_ticks),                         \
        [tcnt] "i"(_SFR_MEM_ADDR(TCNT2)), [tifr] "I"(_SFR_IO_ADDR(TIFR2)), [ocf] "I"(OCF2A),       \
        [half] "M"(100) /* clock.c's TICK_COUNTS / 2 */
#define ENC_ASM_BODY(counter)                                                                              \
    "push r24\n\tin r24, __SREG__\n\tpush r24\n\t"                                                \
    "lds r24, %[use]\n\tsbrc r24, %[bit]\n\trjmp 1f\n\t"                                           \
    "push r1\n\tclr r1\n\tcall " #counter "\n\tpop r1\n\trjmp 9f\n"                                \
    "1:\n\tlds r24, %[slot]\n\tcpi r24, 0xFF\n\tbrne 0f\n\trjmp 9f\n0:\n\t"                                       \
    "push r0\n\tpush r1\n\tpush r25\n\tpush r26\n\tpush r27\n\tpush r30\n\tpush r31\n\t"         \
    "ldi r25, %[size]\n\tmul r24, r25\n\tmovw r30, r0\n\t"                                          \
    "subi r30, lo8(-(%[base]))\n\tsbci r31, hi8(-(%[base]))\n\t"                                     \
    /* r26 = position: A ^ B in bit 0, B in bit 1 */                                              \
    "in r24, %[pind]\n\tin r25, %[pinb]\n\tldi r26, 0\n\t"                                          \
    "ldd r27, Z+%[ma]\n\tand r27, r24\n\tbrne 2f\n\tldd r27, Z+%[ma]+1\n\tand r27, r25\n\tbreq 3f\n" \
    "2:\n\tldi r26, 1\n"                                                                            \
    "3:\n\tldd r27, Z+%[mb]\n\tand r27, r24\n\tbrne 4f\n\tldd r27, Z+%[mb]+1\n\tand r27, r25\n\tbreq 5f\n" \
    "4:\n\tldi r27, 3\n\teor r26, r27\n"                                                             \
    /* r27 = table[state | position] (lpm: Z to the table, then back to the slot) */               \
    "5:\n\tldd r27, Z+%[st]\n\tor r27, r26\n\tldd r24, Z+%[tab]\n\tldd r25, Z+%[tab]+1\n\t"        \
    "movw r0, r30\n\tmovw r30, r24\n\tadd r30, r27\n\tldi r27, 0\n\tadc r31, r27\n\t"              \
    "lpm r27, Z\n\tmovw r30, r0\n\t"                                                               \
    "sbrs r27, 5\n\trjmp 8f\n\t"                                                                   \
    "lsl r26\n\tlsl r26\n\tmov r24, r27\n\tandi r24, 0x10\n\tor r24, r26\n\tstd Z+%[st], r24\n\t"  \
    "sbrs r27, 3\n\trjmp 6f\n\t"                                                                   \
    "ldd r24, Z+%[inv]\n\tldd r25, Z+%[inv]+1\n\tadiw r24, 1\n\tstd Z+%[inv], r24\n\tstd Z+%[inv]+1, r25\n" \
    "6:\n\tandi r27, 7\n\tsubi r27, 2\n\tbreq 8f\n\t"                                              \
    "mov r26, r27\n\tlsl r26\n\tsbc r26, r26\n\t"                                                   \
    "ldd r24, Z+%[mv]\n\tldd r25, Z+%[mv]+1\n\tadd r24, r27\n\tadc r25, r26\n\t"                     \
    "std Z+%[mv], r24\n\tstd Z+%[mv]+1, r25\n\t"                                                    \
    /* hal_stamp(): the tick count's low half, +1 if its interrupt is pending */                   \
    "lds r24, %[t0]\n\tlds r25, %[t0]+1\n\tlds r26, %[tcnt]\n\t"                                     \
    "sbis %[tifr], %[ocf]\n\trjmp 7f\n\tcpi r26, %[half]\n\tbrsh 7f\n\tadiw r24, 1\n"                 \
    "7:\n\tstd Z+%[el], r24\n\tstd Z+%[el]+1, r25\n\tstd Z+%[es], r26\n\tldi r24, 1\n\tstd Z+%[fr], r24\n" \
    "8:\n\tpop r31\n\tpop r30\n\tpop r27\n\tpop r26\n\tpop r25\n\tpop r1\n\tpop r0\n"           \
    "9:\n\tpop r24\n\tout __SREG__, r24\n\tpop r24\n\treti\n\t"
_Static_assert(sizeof(encoder_slot_t) < 256u, "one mul for the slot's address");

ISR(HAL_INT_A_vect, ISR_NAKED) { __asm__ volatile(ENC_ASM_BODY(isr_counter0_call) : : ENC_ASM_OPERANDS(0)); }
ISR(HAL_INT_B_vect, ISR_NAKED) { __asm__ volatile(ENC_ASM_BODY(isr_counter1_call) : : ENC_ASM_OPERANDS(1)); }
#else
ISR(HAL_INT_A_vect)
{
    if (int_encoder & 1u)
        encoder_int(0, hal_pin_levels());
    else
        ISR_CALL(isr_counter0_call);
}

ISR(HAL_INT_B_vect)
{
    if (int_encoder & 2u)
        encoder_int(1, hal_pin_levels());
    else
        ISR_CALL(isr_counter1_call);
}
#endif

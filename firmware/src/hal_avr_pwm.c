/*
 * hal_avr_pwm.c - hal.h's hardware PWM for the ATmega328P on an Arduino Uno:
 * servo pulses on Timer1 (D9/D10) and duty-cycle PWM on Timers 0-2 (duty.c's
 * D3, D5, D6, D9, D10).  Split from hal_avr.c (pins, ADC, EEPROM, TWI,
 * Timer0 alarms, pin interrupts) by idea: these sections set up and re-phase
 * the PWM timers and touch no other part of the HAL's state.
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "aio_protocol.h"
#include "hal.h"
#include "hal_board.h"

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

static uint8_t com_bit(uint8_t pin) { return pin == HAL_SERVO_PIN_A ? _BV(COM1A1) : _BV(COM1B1); }
static uint8_t ocie_bit(uint8_t pin) { return pin == HAL_SERVO_PIN_A ? _BV(OCIE1A) : _BV(OCIE1B); }

/* Interrupts off (16-bit registers share the TEMP byte). */
void hal_servo_set(uint8_t pin, uint16_t us)
{
    uint8_t s = hal_irq_save();
    if (us) {
        uint16_t ocr = (uint16_t)(us * SERVO_COUNTS_PER_US - 1u);
        if (pin == HAL_SERVO_PIN_A)
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


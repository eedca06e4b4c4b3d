/*
 * clock.c - timebase on Timer2: CTC, prescaler 8 (0.5 us), OCR2A = 199, so
 * one compare interrupt every 100 us.  The interrupt keeps the tick and
 * millisecond counts and, while armed or watching, runs app_tick().  It runs
 * with interrupts enabled (only the multi-byte stores are atomic), so it
 * never delays a software PWM edge.
 *
 * Timer0 counts at 0.5 us for the edge and stream alarms while one runs
 * (hal_avr.c).
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "analog.h"
#include "app.h"
#include "clock.h"
#include "hal.h"
#include "failsafe.h"
#include "stepper.h"

#define TICK_COUNTS 200u /* timer counts per tick */

volatile uint32_t clock_ticks;
static volatile uint16_t millis;
static uint8_t ms_div;
static volatile uint8_t in_slow;

void clock_init(void)
{
    TCCR2A = _BV(WGM21);
    OCR2A = TICK_COUNTS - 1u;
    OCR2B = 0xFFu; /* never matches (above TOP): simavr 1.6 drives OC2B (D3, INT1)
                      on compare B matches even while COM2B is 0 */
    TCNT2 = 0;
    TIFR2 = _BV(OCF2A);
    TIMSK2 = _BV(OCIE2A);
    TCCR2B = _BV(CS21);
    TCCR0A = 0; /* normal mode, no output compare pins; started by an alarm */
}

/* The slow part (failsafe check, watched analog channels: app_tick) runs
 * only while the failsafe is armed or a channel is watched.  It
 * is reached through clock_slow_call, which saves the registers the C ABI
 * lets clock_slow() clobber: the interrupt itself then makes no C call and
 * saves only the registers it uses. */
void clock_slow(void) __attribute__((used, externally_visible, noinline));
void clock_slow(void)
{
    if (in_slow)
        return;
    in_slow = 1;
    app_tick();
    in_slow = 0;
}

__asm__(".section .text.clock_slow_call,\"ax\",@progbits\n"
        ".global clock_slow_call\n"
        "clock_slow_call:\n"
        "\tpush r0\n\tpush r18\n\tpush r19\n\tpush r20\n\tpush r21\n\tpush r22\n"
        "\tpush r23\n\tpush r24\n\tpush r25\n\tpush r26\n\tpush r27\n\tpush r30\n"
        "\tpush r31\n"
        "\tcall clock_slow\n"
        "\tpop r31\n\tpop r30\n\tpop r27\n\tpop r26\n\tpop r25\n\tpop r24\n"
        "\tpop r23\n\tpop r22\n\tpop r21\n\tpop r20\n\tpop r19\n\tpop r18\n"
        "\tpop r0\n"
        "\tret\n"
        "\t.text\n");

#if AIO_WITH_STEPPER
/* The same for the steppers (stepper.c), called first on every tick while
 * one moves, so their step pulses keep to the tick. */
__asm__(".section .text.clock_step_call,\"ax\",@progbits\n"
        ".global clock_step_call\n"
        "clock_step_call:\n"
        "\tpush r0\n\tpush r18\n\tpush r19\n\tpush r20\n\tpush r21\n\tpush r22\n"
        "\tpush r23\n\tpush r25\n\tpush r26\n\tpush r27\n\tpush r30\n"
        "\tpush r31\n"
        "\tcall stepper_tick\n"
        "\tpop r31\n\tpop r30\n\tpop r27\n\tpop r26\n\tpop r25\n"
        "\tpop r23\n\tpop r22\n\tpop r21\n\tpop r20\n\tpop r19\n\tpop r18\n"
        "\tpop r0\n"
        "\tret\n"
        "\t.text\n");

/* The tick's stepper check: call them while one moves. */
#define TICK_STEPPERS                                                                    \
    "lds r24, %[stepping]\n\t"                                                           \
    "tst r24\n\t"                                                                        \
    "breq 8f\n\t"                                                                        \
    "push r1\n\t"                                                                        \
    "clr r1\n\t"                                                                         \
    "call clock_step_call\n\t"                                                           \
    "pop r1\n\t"                                                                         \
    "8:\n\t"
#define STEPPING_OPERAND , [stepping] "i"(&stepper_active)
#else /* an image without steppers (protocol/profiles.py): nothing to call */
#define TICK_STEPPERS ""
#define STEPPING_OPERAND
#endif

/* Hand-written, ~40 cycles a tick (the compiled one took ~75): interrupts
 * are enabled as soon as the tick is counted (11 cycles in), so a software PWM
 * edge waits at most that; no other TIMER2_COMPA can come within 100 us.
 * Interrupt handlers read the tick count too (hal_micros, hal_stamp: change
 * events, counter reports, encoder and pulse edges), and the hardware clears
 * OCF2A on entry, so an interrupt nested before the count was stored would
 * read the old count with no pending flag to correct it: 100 us early (seen as
 * +100 us RC pulse widths under encoder load, benchmarks/sensors_pulse.py).
 * Hence the count is stored before sei.  The low byte's overflow (once in 256
 * ticks, every 25.6 ms) carries into the upper bytes with interrupts still
 * off, about 20 cycles; every other tick stores one byte, which is atomic.  millis and ms_div are read by the main loop
 * only.  r1 is cleared only for the C call (an interrupted MUL may leave it
 * nonzero). */
ISR(TIMER2_COMPA_vect, ISR_NAKED)
{
    __asm__ volatile(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "lds r24, %[t0]\n\t"
        "subi r24, 0xFF\n\t"
        "breq 6f\n\t"
        "sts %[t0], r24\n\t"
        "sei\n\t"
        "rjmp 1f\n\t"
        "6:\n\t"
        "sts %[t0], r24\n\t"
        "lds r24, %[t0]+1\n\t"
        "subi r24, 0xFF\n\t"
        "sts %[t0]+1, r24\n\t"
        "brne 7f\n\t"
        "lds r24, %[t0]+2\n\t"
        "subi r24, 0xFF\n\t"
        "sts %[t0]+2, r24\n\t"
        "brne 7f\n\t"
        "lds r24, %[t0]+3\n\t"
        "subi r24, 0xFF\n\t"
        "sts %[t0]+3, r24\n\t"
        "7:\n\t"
        "sei\n\t"
        "1:\n\t"
        "lds r24, %[div]\n\t"
        "subi r24, 0xFF\n\t"
        "cpi r24, 10\n\t"
        "brlo 2f\n\t"
        "lds r24, %[ms]\n\t"
        "subi r24, 0xFF\n\t"
        "sts %[ms], r24\n\t"
        "brne 3f\n\t"
        "lds r24, %[ms]+1\n\t"
        "subi r24, 0xFF\n\t"
        "sts %[ms]+1, r24\n\t"
        "3:\n\t"
        "ldi r24, 0\n\t"
        "2:\n\t"
        "sts %[div], r24\n\t"
        TICK_STEPPERS
        "lds r24, %[armed]\n\t"
        "tst r24\n\t"
        "brne 5f\n\t"
        "lds r24, %[watching]\n\t"
        "tst r24\n\t"
        "breq 4f\n\t"
        "5:\n\t"
        "push r1\n\t"
        "clr r1\n\t"
        "call clock_slow_call\n\t"
        "pop r1\n\t"
        "4:\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        :
        : [t0] "i"(&clock_ticks), [div] "i"(&ms_div), [ms] "i"(&millis), [armed] "i"(&failsafe_is_armed),
          [watching] "i"(&analog_watching)
          STEPPING_OPERAND);
}

uint16_t hal_ticks(void)
{
    /* the low half only (little-endian): loading all of a volatile uint32_t
     * would read four bytes */
    const volatile uint16_t *low = (const volatile uint16_t *)(const volatile void *)&clock_ticks;
    uint8_t s = SREG;
    uint16_t t;
    cli();
    t = *low;
    SREG = s;
    return t;
}

uint16_t hal_millis(void)
{
    uint8_t s = SREG;
    uint16_t t;
    cli();
    t = millis;
    SREG = s;
    return t;
}

/* Inlined into the encoder interrupts (LTO): called on every counting edge. */
__attribute__((always_inline)) inline void hal_stamp(uint16_t *ticks, uint8_t *sub)
{
    /* the low half only, by bytes (little-endian; char access may alias) */
    const volatile uint8_t *b = (const volatile uint8_t *)&clock_ticks;
    uint16_t t = (uint16_t)(b[0] | (uint16_t)b[1] << 8);
    uint8_t c = TCNT2;
    if ((TIFR2 & _BV(OCF2A)) && c < TICK_COUNTS / 2u)
        t++; /* the tick has passed but its interrupt has not run yet */
    *ticks = t;
    *sub = c;
}

uint32_t hal_stamp_us(uint16_t ticks, uint8_t sub)
{
    uint8_t s = SREG;
    uint32_t now;
    cli();
    now = clock_ticks;
    SREG = s;
    /* signed: a stamp may be one tick ahead of clock_ticks (its interrupt pending) */
    now -= (uint32_t)(int32_t)(int16_t)(uint16_t)((uint16_t)now - ticks);
    return now * 100u + sub / 2u;
}

uint32_t hal_micros(void)
{
    uint8_t s = SREG, c;
    uint32_t t;
    cli();
    t = clock_ticks;
    c = TCNT2;
    if ((TIFR2 & _BV(OCF2A)) && c < TICK_COUNTS / 2u)
        t++; /* the tick has passed but its interrupt has not run yet */
    SREG = s;
    return t * 100u + c / 2u;
}

/*
 * clock.c - timebase on Timer2: CTC, prescaler 8 (0.5 us), OCR2A = 199, so
 * one compare interrupt every 100 us.  The interrupt keeps the tick and
 * millisecond counts and, while armed, runs the failsafe check.  It runs
 * with interrupts enabled (only the multi-byte stores are atomic), so it
 * never delays a software PWM edge.
 *
 * Timer0 runs free at 0.5 us a count for the edge and stream alarms
 * (hal_avr.c).
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "app.h"
#include "clock.h"
#include "hal.h"
#include "failsafe.h"

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
    TCCR0A = 0; /* normal mode, no output compare pins */
    TCCR0B = _BV(CS01);
}

/* The slow part (failsafe check) runs only while the failsafe is armed.  It
 * is reached through clock_slow_call, which saves the registers the C ABI
 * lets clock_slow() clobber: the interrupt itself then makes no C call and
 * saves only the registers it uses. */
void clock_slow(void) __attribute__((used, externally_visible, noinline));
void clock_slow(void)
{
    if (in_slow)
        return;
    in_slow = 1;
    failsafe_tick();
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

/* Interrupts are enabled from the first instruction; the counts are stored
 * with them disabled for a few cycles, so an interrupt that reads them (a
 * stream sample's time stamp) never sees half an update.  No other
 * TIMER2_COMPA can come within 100 us. */
ISR(TIMER2_COMPA_vect, ISR_NOBLOCK)
{
    uint32_t t = clock_ticks + 1u;
    cli();
    clock_ticks = t;
    sei();
    if (++ms_div >= 10u) {
        uint16_t m = millis + 1u;
        ms_div = 0;
        cli();
        millis = m;
        sei();
    }
    if (failsafe_armed())
        __asm__ volatile("call clock_slow_call" ::: "memory"); /* r1 is 0 here */
}

uint16_t hal_ticks(void)
{
    uint8_t s = SREG;
    uint16_t t;
    cli();
    t = (uint16_t)clock_ticks;
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

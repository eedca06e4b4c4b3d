/*
 * clock.c - timebase on Timer2: CTC, prescaler 8 (0.5 us), OCR2A = 199, so
 * one compare interrupt every 100 us.  The interrupt keeps the tick and
 * millisecond counts, runs the software PWM first (timing-critical), then
 * with interrupts enabled again the stream sampling and the failsafe check.
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "app.h"
#include "clock.h"
#include "hal.h"
#include "pwm.h"
#include "stream.h"
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
}

/* The slow part (stream sampling, failsafe check) runs with interrupts
 * enabled again, and only while a stream runs or the failsafe is armed.  It
 * is reached through clock_slow_call, which saves the registers the C ABI
 * lets clock_slow() clobber: the interrupt itself then makes no C call and
 * saves only the registers it uses (about 110 cycles instead of 160 per
 * tick, every 100 us, measured in simavr). */
void clock_slow(void) __attribute__((used, externally_visible, noinline));
void clock_slow(void)
{
    if (in_slow)
        return;
    in_slow = 1;
    sei();
    stream_tick();
    failsafe_tick();
    cli();
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

ISR(TIMER2_COMPA_vect)
{
    clock_ticks++;
    if (++ms_div >= 10u) {
        ms_div = 0;
        millis++;
    }
    pwm_tick();
    if (stream_running() || failsafe_armed())
        __asm__ volatile("call clock_slow_call" ::: "memory"); /* r1 is 0 here */
}

/* Only the low half (little-endian): reading all of a volatile uint32_t would
 * cost the receive interrupt four loads and four more saved registers. */
uint16_t clock_ticks_isr(void)
{
    const volatile uint8_t *p = (const volatile uint8_t *)&clock_ticks;
    return (uint16_t)(p[0] | (uint16_t)p[1] << 8);
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

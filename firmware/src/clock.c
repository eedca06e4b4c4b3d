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

static volatile uint32_t ticks;
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

ISR(TIMER2_COMPA_vect)
{
    ticks++;
    if (++ms_div >= 10u) {
        ms_div = 0;
        millis++;
    }
    pwm_tick();
    if (in_slow)
        return;
    in_slow = 1;
    sei();
    stream_tick();
    failsafe_tick();
    cli();
    in_slow = 0;
}

uint16_t clock_ticks_isr(void) { return (uint16_t)ticks; }

uint16_t hal_ticks(void)
{
    uint8_t s = SREG;
    uint16_t t;
    cli();
    t = (uint16_t)ticks;
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
    t = ticks;
    c = TCNT2;
    if ((TIFR2 & _BV(OCF2A)) && c < TICK_COUNTS / 2u)
        t++; /* the tick has passed but its interrupt has not run yet */
    SREG = s;
    return t * 100u + c / 2u;
}

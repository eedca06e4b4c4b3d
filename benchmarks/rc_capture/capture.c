/* capture.c - Timer1 input capture on ICP1 (D8): the hardware copies TCNT1 (clk/8, 0.5 us) into
 * ICR1 at the edge; the vector only reads it, so its own latency does not matter.  Timer2's
 * vector stands for every other interrupt (~300 cycles every 25 us, the encoder's worst). */
#include <avr/io.h>
#include <avr/interrupt.h>
#include <util/delay_basic.h>
volatile uint16_t widths[64];
volatile uint8_t n;
static volatile uint16_t rise;
ISR(TIMER1_CAPT_vect) {
    uint16_t c = ICR1;
    if (TCCR1B & _BV(ICES1)) { rise = c; TCCR1B &= ~_BV(ICES1); }
    else { if (n < 64) widths[n++] = c - rise; TCCR1B |= _BV(ICES1); }
}
ISR(TIMER2_COMPA_vect) { _delay_loop_1(100); } /* ~300 cycles of another vector */
int main(void) {
    TCCR1A = 0; TCCR1B = _BV(ICES1) | _BV(CS11); TIMSK1 = _BV(ICIE1);
    TCCR2A = _BV(WGM21); OCR2A = 49; TCCR2B = _BV(CS21); TIMSK2 = _BV(OCIE2A); /* every 25 us */
    sei();
    for (;;) {}
}

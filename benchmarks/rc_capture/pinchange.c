/* pinchange.c - today's path in miniature: PCINT0 on D8 stamps TCNT1 when its vector runs,
 * late by whatever vector ran at the edge (Timer2's, ~300 cycles every 25 us). */
#include <avr/io.h>
#include <avr/interrupt.h>
#include <util/delay_basic.h>
volatile uint16_t widths[64];
volatile uint8_t n;
static volatile uint16_t rise;
ISR(PCINT0_vect) {
    uint16_t c = TCNT1;
    if (PINB & 1) rise = c; else if (n < 64) widths[n++] = c - rise;
}
ISR(TIMER2_COMPA_vect) { _delay_loop_1(100); }
int main(void) {
    TCCR1A = 0; TCCR1B = _BV(CS11);
    PCICR = _BV(PCIE0); PCMSK0 = 1;
    TCCR2A = _BV(WGM21); OCR2A = 49; TCCR2B = _BV(CS21); TIMSK2 = _BV(OCIE2A);
    sei();
    for (;;) {}
}

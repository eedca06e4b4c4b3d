/*
 * hal_board_uno.h - hal_board.h for the Arduino Uno R3 (ATmega328P).
 *
 * Pin map: D2-D7 = PD2-PD7, D8-D13 = PB0-PB5, A0-A5 = PC0-PC5 (SDA A4, SCL A5).
 * Every digital pin has a pin-change interrupt (PCINT0: port B, PCINT2: port D);
 * counters 0/1 are INT0 (D2) and INT1 (D3); servo PWM is Timer1's D9 (OC1A) and D10.
 */
#ifndef HAL_BOARD_UNO_H
#define HAL_BOARD_UNO_H

#include <avr/io.h>
#include <stdint.h>

#define HAL_USART_RX_vect USART_RX_vect
#define HAL_USART_UDRE_vect USART_UDRE_vect

static inline volatile uint8_t *hal_board_port(uint8_t pin) { return pin < 8u ? &PORTD : &PORTB; }
static inline volatile uint8_t *hal_board_ddr(uint8_t pin) { return pin < 8u ? &DDRD : &DDRB; }
/* The bit within its port: the Uno's pins are in port order (D8 = PB0). */
#define HAL_BOARD_BIT_INDEX(pin) ((pin) & 7u)

#define HAL_BOARD_LEVELS() ((uint16_t)((PIND & 0xFCu) | (uint16_t)(PINB & 0x3Fu) << 8))

/* Interrupts disabled. */
static inline void hal_board_edge_watch(uint16_t mask)
{
    PCMSK2 = (uint8_t)(mask & 0xFCu);
    PCMSK0 = (uint8_t)((mask >> 8) & 0x3Fu);
    PCICR = (uint8_t)((PCMSK2 ? _BV(PCIE2) : 0) | (PCMSK0 ? _BV(PCIE0) : 0));
}

/* Interrupts disabled; a port without a pin in the mask is not written. */
static inline void hal_board_step_pins(uint16_t mask, uint8_t level)
{
    uint8_t d = (uint8_t)mask, b = (uint8_t)(mask >> 8);
    if (level) {
        PORTD |= d;
        PORTB |= b;
    } else {
        PORTD &= (uint8_t)~d;
        PORTB &= (uint8_t)~b;
    }
}

#define HAL_PCINT_A_vect PCINT0_vect
#define HAL_PCINT_B_vect PCINT2_vect

#define HAL_SOFTPWM_PORT PORTD

#define HAL_INT_FIRST 0u
#define HAL_EICR EICRA
#define HAL_INT_A_vect INT0_vect
#define HAL_INT_B_vect INT1_vect

/* Channels 0-7 (8 is the temperature sensor, hal_avr.c). */
#define HAL_ADC_MUX(channel) ((channel) & 7u)
#define HAL_ADC_SELECT(channel) (void)0

#define HAL_SERVO_PIN_A 9u

#define HAL_TWI_PULLUPS() (PORTC |= _BV(PORTC4) | _BV(PORTC5))

#endif /* HAL_BOARD_UNO_H */

/*
 * hal_board_mega2560.h - hal_board.h for the Arduino Mega 2560 (ATmega2560).
 *
 * First stage of the port (issue 29): the portable modules still carry pins as 16-bit
 * masks (bit n = Dn), so this map covers D0-D15 of the Mega's header; D16-D53 need the
 * masks widened (notes/w4-mega.md).  Pin map (the Arduino core's pins_arduino.h):
 *   D0 PE0, D1 PE1 (the host link), D2 PE4 (INT4), D3 PE5 (INT5), D4 PG5, D5 PE3,
 *   D6 PH3, D7 PH4, D8 PH5, D9 PH6, D10-D13 PB4-PB7 (PCINT4-7), D14 PJ1 (PCINT10),
 *   D15 PJ0 (PCINT9); A0-A7 PF0-PF7, A8-A15 PK0-PK7 (ADC8-15 through MUX5);
 *   SDA D20 = PD1, SCL D21 = PD0; Timer1's OC1A = D11, OC1B = D12.
 * Only D10-D15 have pin-change interrupts among D0-D15; counters 0/1 are INT4 (D2) and
 * INT5 (D3).  Every port's PINx, DDRx, PORTx are consecutive addresses.
 */
#ifndef HAL_BOARD_MEGA2560_H
#define HAL_BOARD_MEGA2560_H

#include <avr/io.h>
#include <stdint.h>

#define HAL_USART_RX_vect USART0_RX_vect
#define HAL_USART_UDRE_vect USART0_UDRE_vect

/* PORTx of D0-D15 (PINx is 2 below it, DDRx 1 below). */
static volatile uint8_t *const hal_board_ports[16] = {
    &PORTE, &PORTE, &PORTE, &PORTE, &PORTG, &PORTE, &PORTH, &PORTH,
    &PORTH, &PORTH, &PORTB, &PORTB, &PORTB, &PORTB, &PORTJ, &PORTJ,
};
static const uint8_t hal_board_bits[16] = {0, 1, 4, 5, 5, 3, 3, 4, 5, 6, 4, 5, 6, 7, 1, 0};

static inline volatile uint8_t *hal_board_port(uint8_t pin) { return hal_board_ports[pin & 15u]; }
static inline volatile uint8_t *hal_board_ddr(uint8_t pin) { return hal_board_ports[pin & 15u] - 1; }
#define HAL_BOARD_BIT_INDEX(pin) (hal_board_bits[(pin) & 15u])

static inline uint16_t hal_board_levels(void)
{
    uint8_t e = PINE, h = PINH, b = PINB, j = PINJ;
    uint16_t v = (uint16_t)((e >> 4 & 1u) << 2 | (e >> 5 & 1u) << 3 | (PING >> 5 & 1u) << 4 |
                            (e >> 3 & 1u) << 5 | (h >> 3 & 0x0Fu) << 6);
    v |= (uint16_t)((uint16_t)(b & 0xF0u) << 6);     /* PB4-7 -> D10-D13 */
    v |= (uint16_t)((uint16_t)(j >> 1 & 1u) << 14);  /* PJ1 -> D14 */
    v |= (uint16_t)((uint16_t)(j & 1u) << 15);       /* PJ0 -> D15 */
    return v;
}
#define HAL_BOARD_LEVELS() hal_board_levels()

/* Interrupts disabled.  Pins without a pin-change interrupt (D2-D9) are not watched. */
static inline void hal_board_edge_watch(uint16_t mask)
{
    PCMSK0 = (uint8_t)((mask >> 6) & 0xF0u);
    PCMSK1 = (uint8_t)((mask >> 14 & 1u) << 2 | (mask >> 15 & 1u) << 1);
    PCICR = (uint8_t)((PCMSK0 ? _BV(PCIE0) : 0) | (PCMSK1 ? _BV(PCIE1) : 0));
}

/* Interrupts disabled. */
static inline void hal_board_step_pins(uint16_t mask, uint8_t level)
{
    uint8_t pin, bit;
    for (pin = 2; pin < 16u; pin++) {
        if (!(mask >> pin & 1u))
            continue;
        bit = (uint8_t)(1u << hal_board_bits[pin]);
        if (level)
            *hal_board_ports[pin] |= bit;
        else
            *hal_board_ports[pin] &= (uint8_t)~bit;
    }
}

#define HAL_PCINT_A_vect PCINT0_vect
#define HAL_PCINT_B_vect PCINT1_vect

/* No soft PWM pins in this stage (its masks stay 0); port A (D22-D29) is its target. */
#define HAL_SOFTPWM_PORT PORTA

#define HAL_INT_FIRST 4u
#define HAL_EICR EICRB
#define HAL_INT_A_vect INT4_vect
#define HAL_INT_B_vect INT5_vect

/* Channels 0-15: MUX2:0 in ADMUX, MUX5 in ADCSRB for 8-15. */
#define HAL_ADC_MUX(channel) ((channel) & 7u)
#define HAL_ADC_SELECT(channel) (ADCSRB = ((channel) & 8u) ? _BV(MUX5) : 0u)

#define HAL_SERVO_PIN_A 11u

#define HAL_TWI_PULLUPS() (PORTD |= _BV(PORTD0) | _BV(PORTD1))

#endif /* HAL_BOARD_MEGA2560_H */

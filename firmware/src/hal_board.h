/*
 * hal_board.h - the board's wiring for the AVR HAL: which port bit is which Arduino
 * pin, which vectors and external interrupts serve them, where the TWI pins are.
 *
 * hal_avr*.c and uart.c are written for the AVR peripherals the ATmega328P and the
 * ATmega2560 share (USART0, Timers 0-2, TWI, SPI, ADC); what differs between the boards
 * is only this wiring, so each board has one header and the Makefile's BOARD= picks it
 * (-DAIO_BUILD_<BOARD>).  Each header defines the same names:
 *   HAL_USART_RX_vect, HAL_USART_UDRE_vect   USART0's vectors
 *   hal_board_port/ddr(pin), hal_board_bit(pin)   the pin's PORTx/DDRx and bit
 *   HAL_BOARD_LEVELS()                        bit n = level of Dn (n < 16)
 *   hal_board_edge_watch(mask)                pin-change interrupts on these pins
 *   hal_board_step_pins(mask, level)          many outputs at once
 *   HAL_PCINT_A_vect, HAL_PCINT_B_vect        the pin-change vectors in use
 *   HAL_SOFTPWM_PORT                          the port soft PWM's masks are bits of
 *   HAL_INT_FIRST, HAL_EICR, HAL_INT_A/B_vect counters 0/1: their INTn and control register
 *   HAL_ADC_MUX(channel)                      ADMUX/ADCSRB for an analog input
 *   HAL_SERVO_PIN_A                           the OC1A pin (the other servo pin is OC1B)
 *   HAL_TWI_PULLUPS()                         internal pull-ups on SDA and SCL
 */
#ifndef HAL_BOARD_H
#define HAL_BOARD_H

#if defined(AIO_BUILD_MEGA2560)
#include "hal_board_mega2560.h"
#else
#include "hal_board_uno.h"
#endif

#endif /* HAL_BOARD_H */

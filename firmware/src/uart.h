/* uart.h - USART0: RX interrupt into a FIFO, interrupt-driven TX buffer. */
#ifndef UART_H
#define UART_H

#include <stdint.h>

void uart_init(void);
uint8_t uart_rx_available(void);

#endif

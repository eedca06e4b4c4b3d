/*
 * uart.c - USART0 for the ATmega328P (implements the UART part of hal.h).
 *
 * RX: every byte goes from the interrupt into a 128-byte FIFO; a full FIFO
 * or a hardware data overrun sets the overflow flag.
 * TX: a ring of AIO_TX_BUFFER_SIZE bytes emptied by the UDRE interrupt.
 * Producers (main loop and interrupts) reserve room for a whole frame with
 * interrupts disabled for a few cycles, copy it with interrupts enabled and
 * commit; the UDRE interrupt sees the bytes once no reservation is open, so
 * frames never interleave and copying never blocks the receiver.
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "aio_protocol.h"
#include "clock.h"
#include "hal.h"
#include "uart.h"

#ifndef BAUD
#define BAUD 115200UL
#endif

#if BAUD == 115200UL
#define UBRR_VALUE 16u
#elif BAUD == 1000000UL
#define UBRR_VALUE 1u
#else
#define UBRR_VALUE ((F_CPU + 4UL * BAUD) / (8UL * BAUD) - 1UL)
#endif

#define RX_SIZE AIO_RX_FIFO_SIZE
#define TX_SIZE AIO_TX_BUFFER_SIZE

static uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head, rx_tail; /* free-running, count = head - tail */
static volatile uint8_t rx_overflow;
static volatile uint16_t rx_tick;

static uint8_t tx_buf[TX_SIZE];
static volatile uint8_t tx_tail;   /* next byte to send */
static volatile uint8_t tx_resv;   /* end of the reserved bytes */
static volatile uint8_t tx_used;   /* reserved bytes not yet sent */
static volatile uint8_t tx_ready;  /* committed bytes not yet sent */
static volatile uint8_t tx_open;   /* open reservations */
static volatile uint8_t tx_started;

void uart_init(void)
{
    /* U2X0 before UBRR0: the order does not matter on silicon, but simavr 1.6
     * computes its byte time only when UBRR0 is written, from the U2X0 it
     * sees then (U2X0 set afterwards would leave it at half the baud rate). */
    UCSR0A = _BV(U2X0);
    UBRR0 = UBRR_VALUE;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1 */
    UCSR0B = _BV(RXCIE0) | _BV(RXEN0) | _BV(TXEN0);
}

ISR(USART_RX_vect)
{
    uint8_t st = UCSR0A;
    uint8_t b = UDR0;
    uint8_t head = rx_head;
    rx_tick = clock_ticks_isr();
    if (st & _BV(DOR0))
        rx_overflow = 1;
    if ((uint8_t)(head - rx_tail) >= RX_SIZE) {
        rx_overflow = 1;
        return;
    }
    rx_buf[head % RX_SIZE] = b;
    rx_head = (uint8_t)(head + 1u);
}

uint8_t uart_rx_available(void) { return rx_head != rx_tail || rx_overflow; }

int16_t hal_rx_get(void)
{
    uint8_t tail = rx_tail, b;
    if (rx_head == tail)
        return -1;
    b = rx_buf[tail % RX_SIZE];
    rx_tail = (uint8_t)(tail + 1u);
    return b;
}

bool hal_rx_take_overflow(void)
{
    uint8_t s;
    if (!rx_overflow)
        return false;
    s = SREG;
    cli();
    rx_overflow = 0;
    rx_tail = rx_head;
    SREG = s;
    return true;
}

uint16_t hal_rx_last_tick(void)
{
    uint8_t s = SREG;
    uint16_t t;
    cli();
    t = rx_tick;
    SREG = s;
    return t;
}

ISR(USART_UDRE_vect)
{
    if (!tx_ready) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UCSR0A = _BV(U2X0) | _BV(TXC0); /* clear TXC0 */
    UDR0 = tx_buf[tx_tail];
    tx_tail = (uint8_t)(tx_tail + 1u == TX_SIZE ? 0u : tx_tail + 1u);
    tx_ready--;
    tx_used--;
}

uint8_t hal_tx_free(void) { return (uint8_t)(TX_SIZE - tx_used); }

bool hal_tx_send(const uint8_t *frame, uint8_t len)
{
    uint8_t s = SREG, start, i;
    cli();
    if ((uint8_t)(TX_SIZE - tx_used) < len) {
        SREG = s;
        return false;
    }
    if (tx_used == 0 && (UCSR0A & _BV(UDRE0))) {
        /* Transmitter idle and nothing queued or reserved: the first byte goes
         * straight into UDR0, no round trip through the UDRE interrupt. */
        UCSR0A = _BV(U2X0) | _BV(TXC0); /* clear TXC0 */
        UDR0 = *frame++;
        tx_started = 1;
        if (--len == 0) {
            SREG = s;
            return true;
        }
    }
    start = tx_resv;
    i = (uint8_t)(TX_SIZE - start); /* room before the wrap */
    tx_resv = len < i ? (uint8_t)(start + len) : (uint8_t)(len - i);
    tx_used = (uint8_t)(tx_used + len);
    tx_open++;
    SREG = s;

    for (i = 0; i < len; i++) {
        tx_buf[start] = frame[i];
        start = (uint8_t)(start + 1u == TX_SIZE ? 0u : start + 1u);
    }

    cli();
    if (--tx_open == 0) {
        tx_ready = tx_used;
        tx_started = 1;
        UCSR0B |= _BV(UDRIE0);
    }
    SREG = s;
    return true;
}

bool hal_tx_idle(void) { return tx_used == 0 && (!tx_started || (UCSR0A & _BV(TXC0))); }

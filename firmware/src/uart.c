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
#define TX_SIZE AIO_TX_BUFFER_SIZE /* capacity: at most this many bytes queued */

_Static_assert(RX_SIZE == 128u, "the receive interrupt masks its index with 0x7F");
_Static_assert(TX_SIZE <= 255u, "tx counts are 8-bit");

static uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head, rx_tail; /* free-running, count = head - tail */
static volatile uint8_t rx_overflow;      /* nonzero: overflowed */
static volatile uint16_t rx_tick;

/* The ring itself has 256 bytes so its 8-bit indices wrap by themselves; no
 * more than TX_SIZE of them are ever in use (tx_used), so the buffering
 * behaviour is that of a TX_SIZE buffer. */
static uint8_t tx_buf[256];
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

/* Hand-written: ~60 cycles a byte including entry and exit (the compiled
 * version took ~87): five registers saved, no r0/r1 set-up.  Status before
 * data (DOR0 belongs to the byte in UDR0); records the tick of the arrival
 * (low half of clock_ticks; main reads rx_tick with interrupts disabled). */
ISR(USART_RX_vect, ISR_NAKED)
{
    __asm__ volatile(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "push r25\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "lds r25, %[ucsra]\n\t"
        "lds r24, %[udr]\n\t"
        "sbrc r25, %[dor]\n\t"
        "sts %[ovf], r25\n\t"
        "lds r25, %[tk]\n\t"
        "sts %[rxt], r25\n\t"
        "lds r25, %[tk]+1\n\t"
        "sts %[rxt]+1, r25\n\t"
        "lds r30, %[head]\n\t"
        "lds r25, %[tail]\n\t"
        "mov r31, r30\n\t"
        "sub r31, r25\n\t"
        "sbrc r31, 7\n\t"          /* head - tail >= 128: full */
        "rjmp 1f\n\t"
        "mov r25, r30\n\t"
        "subi r25, 0xFF\n\t"
        "sts %[head], r25\n\t"
        "andi r30, 0x7F\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[buf]))\n\t"
        "sbci r31, hi8(-(%[buf]))\n\t"
        "st Z, r24\n\t"
        "2:\n\t"
        "pop r31\n\t"
        "pop r30\n\t"
        "pop r25\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        "1:\n\t"
        "ldi r25, 1\n\t"
        "sts %[ovf], r25\n\t"
        "rjmp 2b\n\t"
        :
        : [ucsra] "n"(_SFR_MEM_ADDR(UCSR0A)), [udr] "n"(_SFR_MEM_ADDR(UDR0)), [dor] "n"(DOR0),
          [ovf] "i"(&rx_overflow), [tk] "i"(&clock_ticks), [rxt] "i"(&rx_tick),
          [head] "i"(&rx_head), [tail] "i"(&rx_tail), [buf] "i"(rx_buf));
}

uint8_t uart_rx_available(void) { return rx_head != rx_tail || rx_overflow; }

/* Inlined into the main loop's burst loop (LTO). */
__attribute__((always_inline)) inline int16_t hal_rx_get(void)
{
    uint8_t tail = rx_tail, b;
    if (rx_head == tail)
        return -1;
    b = rx_buf[tail & (RX_SIZE - 1u)];
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

/* Hand-written: ~50 cycles a byte including entry and exit. */
ISR(USART_UDRE_vect, ISR_NAKED)
{
    __asm__ volatile(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "lds r24, %[ready]\n\t"
        "tst r24\n\t"
        "breq 1f\n\t"
        "dec r24\n\t"
        "sts %[ready], r24\n\t"
        "ldi r24, %[a_val]\n\t"
        "sts %[ucsra], r24\n\t"      /* clear TXC0 */
        "lds r30, %[tail]\n\t"
        "mov r24, r30\n\t"
        "inc r24\n\t"
        "sts %[tail], r24\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[buf]))\n\t"
        "sbci r31, hi8(-(%[buf]))\n\t"
        "ld r24, Z\n\t"
        "sts %[udr], r24\n\t"
        "lds r24, %[used]\n\t"
        "dec r24\n\t"
        "sts %[used], r24\n\t"
        "2:\n\t"
        "pop r31\n\t"
        "pop r30\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        "1:\n\t"
        "lds r24, %[ucsrb]\n\t"
        "andi r24, %[not_udrie]\n\t"
        "sts %[ucsrb], r24\n\t"
        "rjmp 2b\n\t"
        :
        : [ucsra] "n"(_SFR_MEM_ADDR(UCSR0A)), [ucsrb] "n"(_SFR_MEM_ADDR(UCSR0B)),
          [udr] "n"(_SFR_MEM_ADDR(UDR0)), [a_val] "n"(_BV(U2X0) | _BV(TXC0)),
          [not_udrie] "n"((uint8_t)~_BV(UDRIE0)), [ready] "i"(&tx_ready), [tail] "i"(&tx_tail),
          [used] "i"(&tx_used), [buf] "i"(tx_buf));
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
    tx_resv = (uint8_t)(start + len); /* wraps at 256 with the ring */
    tx_used = (uint8_t)(tx_used + len);
    if (len <= 8u) {
        /* Short frame (every GPIO/PWM reply): copying it takes about as long
         * as the reservation dance, so do it all in this critical section.
         * An open reservation of an interrupted producer commits it later. */
        for (i = 0; i < len; i++)
            tx_buf[(uint8_t)(start + i)] = frame[i];
        if (tx_open == 0) {
            tx_ready = tx_used;
            tx_started = 1;
            UCSR0B |= _BV(UDRIE0);
        }
        SREG = s;
        return true;
    }
    tx_open++;
    SREG = s;

    for (i = 0; i < len; i++)
        tx_buf[(uint8_t)(start + i)] = frame[i];

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

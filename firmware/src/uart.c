/*
 * uart.c - USART0 for the ATmega328P (implements the UART part of hal.h).
 *
 * RX: every byte goes from the interrupt into a FIFO of 128 bytes (a
 * 256-aligned ring of 256, so the 8-bit indices are address bytes); a full
 * FIFO or a hardware data overrun sets the overflow flag.  The parser reads
 * whole frames in place (hal_rx_view).  The indices both interrupts use are
 * kept in the general purpose I/O registers (RX_HEAD, RX_STOP, TX_TAIL
 * below): at 2 Mbaud the two interrupts are half of the firmware's work per
 * pipelined request.
 * TX: a 256-aligned ring holding at most AIO_TX_BUFFER_SIZE bytes, emptied by
 * the UDRE interrupt.  Producers (main loop and interrupts) reserve room for
 * a whole frame with interrupts disabled for a few cycles, copy it with
 * interrupts enabled and commit; the UDRE interrupt sees the bytes once no
 * reservation is open, so frames never interleave and copying never blocks
 * the receiver.  The main loop can also claim the free room and build its
 * replies there (hal_tx_claim/hal_tx_publish): no copy at all.
 * Filler (low-latency mode, hal_tx_pad): when the ring is empty the UDRE
 * interrupt sends AIO_FILLER while tx_filler counts down, so filler lies
 * between frames only and takes no buffer.
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "aio_protocol.h"

/* The two rings take the bottom of RAM, 0x100-0x2FF, in .noinit (not zeroed at boot: the
 * indices say what is valid); the Makefile starts .data at 0x300 above them.  Left among
 * the other variables, their 256-byte alignment opened a hole below them that nothing
 * filled (up to 255 bytes: the linker places .bss in order), RAM the stack needs. */
#define AIO_RING_PLACEMENT __attribute__((section(".noinit.rings"), aligned(256)))
#include "hal.h"
#include "hal_board.h"
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

_Static_assert(RX_SIZE == 128u, "the tail is RX_STOP ^ 0x80: 128 of an 8-bit ring");
_Static_assert(TX_SIZE <= 255u, "tx counts are 8-bit");

/* 256 bytes, 256-aligned, of which at most RX_SIZE are in use: the 8-bit
 * indices wrap by themselves and are the low address byte (hal.h: the ring
 * handed to the parser has HAL_RX_RING bytes). */
static uint8_t rx_buf[HAL_RX_RING] AIO_RING_PLACEMENT;
static volatile uint8_t rx_overflow; /* nonzero: overflowed */

/* The indices the interrupts use live in the general purpose I/O registers:
 * `in`/`out` take one cycle where `lds`/`sts` take two, and the interrupts
 * compare them with `cpse`, which leaves SREG alone, so they need not save
 * it.  Nothing else in the firmware uses these registers; uart_init sets
 * them (a watchdog reset need not clear them).
 *   RX_HEAD: next free FIFO byte, written by the receive interrupt only.
 *   RX_STOP: the head at which the FIFO is full, tail + RX_SIZE, written by
 *            the main loop only; the tail is RX_STOP ^ 0x80 (RX_SIZE = 128 of
 *            an 8-bit ring), count = head - tail.
 *   TX_TAIL: next byte to send, written by the UDRE interrupt (and by a
 *            producer that sends the first byte itself, interrupts off). */
#define RX_HEAD GPIOR1
#define RX_STOP GPIOR2
#define TX_TAIL GPIOR0
#define rx_tail() ((uint8_t)(RX_STOP ^ 0x80u))

/* The ring itself has 256 bytes so its 8-bit indices wrap by themselves; no
 * more than TX_SIZE of them are ever in use (tx_resv - TX_TAIL), so the
 * buffering behaviour is that of a TX_SIZE buffer.  The UDRE interrupt owns
 * TX_TAIL and sends up to tx_commit; producers own tx_resv and tx_commit. */
static uint8_t tx_buf[256] AIO_RING_PLACEMENT; /* index = low address byte */
static volatile uint8_t tx_commit; /* end of the bytes ready to send */
static volatile uint8_t tx_resv;   /* end of the reserved bytes */
static volatile uint8_t tx_open;   /* open reservations */
static volatile uint8_t tx_started;
static volatile uint8_t tx_filler; /* filler bytes to send once the ring is empty */

_Static_assert(AIO_FILLER == 0u, "the UDRE interrupt sends a cleared register as filler");

void uart_init(void)
{
    /* U2X0 before UBRR0: the order does not matter on silicon, but simavr 1.6
     * computes its byte time only when UBRR0 is written, from the U2X0 it
     * sees then (U2X0 set afterwards would leave it at half the baud rate). */
    RX_HEAD = 0;
    RX_STOP = RX_SIZE; /* tail 0: empty */
    TX_TAIL = 0;       /* tx_commit = tx_resv = 0 (.bss): nothing to send */
    UCSR0A = _BV(U2X0);
    UBRR0 = UBRR_VALUE;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1 */
    UCSR0B = _BV(RXCIE0) | _BV(RXEN0) | _BV(TXEN0);
}

/* Hand-written: 31 cycles a byte from the vector to reti (the compiled
 * version took ~87, the first hand-written one 41): three registers saved and
 * no SREG, since nothing here changes a flag (the full check is `cpse`, the
 * store `st Z+`, whose carry into ZH is dropped: the ring is 256-aligned).
 * Status before data (DOR0 belongs to the byte in UDR0); the byte is always
 * read, which clears RXC0.  No time stamp: the main loop stamps bytes when it
 * takes them (a later stamp only lengthens the quiet period it measures,
 * never shortens it). */
ISR(HAL_USART_RX_vect, ISR_NAKED)
{
    __asm__ volatile(
        "push r24\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "lds r31, %[ucsra]\n\t"
        "lds r24, %[udr]\n\t"
        "sbrc r31, %[dor]\n\t"
        "rjmp 3f\n\t"              /* overrun: out of line */
        "4:\n\t"
        "in r30, %[head]\n\t"
        "in r31, %[stop]\n\t"
        "cpse r30, r31\n\t"         /* head == tail + 128: full */
        "rjmp 1f\n\t"
        "ldi r31, 0x80\n\t"
        "sts %[ovf], r31\n\t"
        "rjmp 2f\n\t"
        "1:\n\t"
        "ldi r31, hi8(%[buf])\n\t"  /* Z = &rx_buf[head] */
        "st Z+, r24\n\t"
        "out %[head], r30\n\t"      /* head + 1, wrapped at 256 */
        "2:\n\t"
        "pop r31\n\t"
        "pop r30\n\t"
        "pop r24\n\t"
        "reti\n\t"
        "3:\n\t"
        "sts %[ovf], r31\n\t"       /* DOR0 set: nonzero */
        "rjmp 4b\n\t"
        :
        : [ucsra] "n"(_SFR_MEM_ADDR(UCSR0A)), [udr] "n"(_SFR_MEM_ADDR(UDR0)), [dor] "n"(DOR0),
          [ovf] "i"(&rx_overflow), [head] "I"(_SFR_IO_ADDR(RX_HEAD)), [stop] "I"(_SFR_IO_ADDR(RX_STOP)),
          [buf] "i"(rx_buf));
}

uint8_t uart_rx_available(void) { return RX_HEAD != rx_tail() || rx_overflow; }

/* Inlined into the main loop's burst loop (LTO). */
__attribute__((always_inline)) inline int16_t hal_rx_get(void)
{
    uint8_t stop = RX_STOP, tail = (uint8_t)(stop ^ 0x80u), b;
    if (RX_HEAD == tail)
        return -1;
    b = rx_buf[tail];
    RX_STOP = (uint8_t)(stop + 1u);
    return b;
}

__attribute__((always_inline)) inline hal_rx_view_t hal_rx_view(void)
{
    hal_rx_view_t v;
    v.ring = rx_buf;
    v.tail = rx_tail();
    v.count = (uint8_t)(RX_HEAD - v.tail);
    return v;
}

/* Only the main loop moves the tail (and the overflow flush, with interrupts
 * disabled, also in the main loop). */
__attribute__((always_inline)) inline void hal_rx_consume(uint8_t n) { RX_STOP = (uint8_t)(RX_STOP + n); }

bool hal_rx_take_overflow(void)
{
    uint8_t s;
    if (!rx_overflow)
        return false;
    s = SREG;
    cli();
    rx_overflow = 0;
    RX_STOP = (uint8_t)(RX_HEAD ^ 0x80u); /* tail = head: empty */
    SREG = s;
    return true;
}

/* Hand-written: 28 cycles a byte from the vector to reti (the first
 * hand-written one took 38): it only moves TX_TAIL towards tx_commit, with
 * three registers saved and no SREG (`cpse`, `ld Z+`: no flag changes).  Once
 * the ring is empty it counts tx_filler down, sending filler (r1 is not
 * trusted to be zero in an interrupt: r30 is cleared), and then turns itself
 * off; those paths change flags and save SREG.  TXC0 is cleared when a frame
 * is queued. */
ISR(HAL_USART_UDRE_vect, ISR_NAKED)
{
    __asm__ volatile(
        "push r24\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "in r30, %[tail]\n\t"
        "lds r31, %[commit]\n\t"
        "cpse r30, r31\n\t"
        "rjmp 1f\n\t"
        "in r31, __SREG__\n\t"      /* empty: filler or off */
        "lds r24, %[filler]\n\t"
        "tst r24\n\t"
        "breq 3f\n\t"
        "dec r24\n\t"
        "sts %[filler], r24\n\t"
        "clr r30\n\t"
        "sts %[udr], r30\n\t"
        "rjmp 4f\n\t"
        "3:\n\t"
        "lds r24, %[ucsrb]\n\t"
        "andi r24, %[not_udrie]\n\t"
        "sts %[ucsrb], r24\n\t"
        "4:\n\t"
        "out __SREG__, r31\n\t"
        "rjmp 2f\n\t"
        "1:\n\t"
        "ldi r31, hi8(%[buf])\n\t"  /* 256-aligned: Z = &tx_buf[tail] */
        "ld r24, Z+\n\t"
        "sts %[udr], r24\n\t"
        "out %[tail], r30\n\t"      /* tail + 1, wrapped at 256 */
        "2:\n\t"
        "pop r31\n\t"
        "pop r30\n\t"
        "pop r24\n\t"
        "reti\n\t"
        :
        : [ucsrb] "n"(_SFR_MEM_ADDR(UCSR0B)), [udr] "n"(_SFR_MEM_ADDR(UDR0)),
          [not_udrie] "n"((uint8_t)~_BV(UDRIE0)), [tail] "I"(_SFR_IO_ADDR(TX_TAIL)), [commit] "i"(&tx_commit),
          [buf] "i"(tx_buf), [filler] "i"(&tx_filler));
}

/* Bytes reserved and not yet sent. */
static inline uint8_t tx_used(void) { return (uint8_t)(tx_resv - TX_TAIL); }

uint8_t hal_tx_free(void) { return (uint8_t)(TX_SIZE - tx_used()); }

/* Interrupts disabled: the reserved bytes are complete, let the UDRE
 * interrupt send them (unless another producer's copy is still open: its
 * commit then covers these bytes too). */
static inline __attribute__((always_inline)) void tx_commit_all(void)
{
    if (tx_open == 0) {
        tx_commit = tx_resv;
        UCSR0B |= _BV(UDRIE0);
    }
}

/* Copies len (>= 1) bytes into the ring from index start.  The ring is
 * 256-aligned, so stepping the low address byte alone wraps it. */
static inline __attribute__((always_inline)) void tx_copy(uint8_t start, const uint8_t *src, uint8_t len)
{
    uint8_t *d = tx_buf + start;
    __asm__ volatile("1:\n\t"
                     "ld __tmp_reg__, X+\n\t"
                     "st Z, __tmp_reg__\n\t"
                     "inc r30\n\t"
                     "dec %[n]\n\t"
                     "brne 1b\n\t"
                     : "+x"(src), "+z"(d), [n] "+r"(len)
                     :
                     : "memory");
}

bool hal_tx_send(const uint8_t *frame, uint8_t len)
{
    uint8_t s = SREG, start;
    if (!len)
        return true;
    cli();
    start = tx_resv;
    if ((uint8_t)(TX_SIZE - (uint8_t)(start - TX_TAIL)) < len) {
        SREG = s;
        return false;
    }
    UCSR0A = _BV(U2X0) | _BV(TXC0); /* clear TXC0: set again once all of it is out */
    tx_started = 1;
    if (start == TX_TAIL && (UCSR0A & _BV(UDRE0))) {
        /* Transmitter idle and nothing queued or reserved: the first byte goes
         * straight into UDR0, no round trip through the UDRE interrupt. */
        UDR0 = *frame++;
        if (--len == 0) {
            SREG = s;
            return true;
        }
    }
    tx_resv = (uint8_t)(start + len); /* wraps at 256 with the ring */
    if (len <= 8u) {
        /* Short frame (every GPIO/PWM reply): copying it takes about as long
         * as the reservation dance, so do it all in this critical section. */
        tx_copy(start, frame, len);
        tx_commit_all();
        SREG = s;
        return true;
    }
    tx_open++;
    SREG = s;
    tx_copy(start, frame, len);
    cli();
    tx_open--;
    tx_commit_all();
    SREG = s;
    return true;
}

static uint8_t claim_start, claim_size;

uint8_t *hal_tx_claim(uint8_t need, uint8_t want, uint8_t *room)
{
    uint8_t s = SREG, start, n, to_end;
    cli();
    start = tx_resv;
    n = (uint8_t)(TX_SIZE - (uint8_t)(start - TX_TAIL));
    to_end = (uint8_t)(0u - start); /* 0 = the whole ring */
    if (to_end && to_end < n)
        n = to_end;
    if (n > want)
        n = want;
    if (tx_open || n < need) {
        SREG = s;
        return 0;
    }
    tx_resv = (uint8_t)(start + n);
    tx_open++;
    claim_start = start;
    claim_size = n;
    SREG = s;
    *room = n;
    return tx_buf + start;
}

void hal_tx_publish(uint8_t len)
{
    uint8_t s = SREG, from, to, end;
    cli();
    /* Frames interrupts queued behind the claim (each complete: an interrupt
     * producer runs to its end before the main loop resumes) move down to
     * follow the published bytes.  They move with interrupts on: a 1 kHz
     * stream sample queued there took 43-62 us to move with them off, and an
     * encoder's edge waited that long (the harness's max_irq_latency_us).  The
     * claim keeps tx_open, so none of these bytes is committed meanwhile; a
     * frame an interrupt appends while they move is moved by the next round. */
    from = (uint8_t)(claim_start + claim_size);
    to = (uint8_t)(claim_start + len);
    if (from != to) {
        while (from != (end = tx_resv)) {
            SREG = s;
            do
                tx_buf[to++] = tx_buf[from++];
            while (from != end);
            cli();
        }
        tx_resv = to;
    }
    if (tx_resv != claim_start) {
        UCSR0A = _BV(U2X0) | _BV(TXC0); /* clear TXC0: set again once all of it is out */
        tx_started = 1;
        if (TX_TAIL == claim_start && tx_commit == claim_start && (UCSR0A & _BV(UDRE0))) {
            /* transmitter idle: the first byte straight into UDR0 */
            UDR0 = tx_buf[claim_start];
            TX_TAIL = (uint8_t)(claim_start + 1u);
        }
    }
    tx_open--;
    tx_commit_all();
    SREG = s;
}

void hal_tx_pad(uint8_t n)
{
    uint8_t s = SREG;
    cli();
    tx_filler = n;
    if (n)
        UCSR0B |= _BV(UDRIE0);
    SREG = s;
}

bool hal_tx_idle(void) { return tx_resv == TX_TAIL && (!tx_started || (UCSR0A & _BV(TXC0))); }

/*
 * parser.h - the main frame parser: a state machine fed one byte at a time.
 *
 * CT -> DT -> data (length from the generated request table, plus the
 * variable part announced by a length byte) -> checksum.  A request it
 * delivers holds every data byte of its frame (rq.len of them, the fixed
 * part plus the declared variable part); a frame declaring more than
 * AIO_REQUEST_DATA_MAX is read to its checksum and refused with
 * VALUE_OUT_OF_RANGE (no discarding: the line is still in sync).  Framing errors make
 * it report one error and then discard bytes until the line has been quiet
 * for AIO_INTER_BYTE_GAP_MS.  No hardware access: times are passed in as
 * 100 us ticks.
 */
#ifndef PARSER_H
#define PARSER_H

#include <stdint.h>

#include "aio.h"
#include "crc16_table.h"

enum { PARSER_NONE = 0, PARSER_REQUEST, PARSER_ERROR };

/* Ticks of quiet after which a started frame is incomplete, and after which
 * discarding ends: more than the 10 ms gap. */
#define PARSER_GAP_TICKS ((uint16_t)(AIO_INTER_BYTE_GAP_MS * 10u + 1u))

/* The framing in force, both ways: 0 = XOR byte (the paper's, after every
 * boot), 1 = CRC-16/CCITT-FALSE, big-endian (SET_FRAMING, protocol.md 7.7). */
extern uint8_t parser_crc;

/* One step of CRC-16/CCITT-FALSE (polynomial 0x1021, unreflected; start at
 * 0xFFFF), from a 256-entry table in flash: two `lpm` and a few XORs, about
 * 15 AVR cycles a byte (the table-free byte-wise form took about 45 as
 * compiled: 16-bit shifts by 12 and 5 are long on the AVR). */
static inline uint16_t parser_crc16(uint16_t crc, uint8_t b)
{
    return (uint16_t)((uint16_t)(crc << 8) ^ crc16_table[(uint8_t)((crc >> 8) ^ b)]);
}

/* Appends the check bytes of the framing in force to the `len` bytes of
 * `frame` (room for AIO_CHECK_MAX more); returns the frame's whole length.
 * Safe in interrupts (events are sealed there). */
uint8_t parser_seal(uint8_t *frame, uint8_t len);

typedef struct {
    uint8_t state;
    uint8_t fixed;       /* fixed data bytes of the current request */
    int8_t len_pos;      /* index of its length byte, or -1 */
    uint8_t idx;         /* data bytes kept; AIO_REQUEST_DATA_MAX + 1: more were sent */
    uint16_t left;       /* data bytes still expected */
    uint8_t sum;         /* running XOR */
    uint16_t crc;        /* running CRC-16 (CRC framing) */
    uint16_t last_tick;  /* when the last byte was received */
    aio_request_t rq;    /* valid after PARSER_REQUEST */
    uint8_t err_ct;      /* valid after PARSER_ERROR: CT|0x80, DT, code */
    uint8_t err_dt;
    uint8_t err_code;
} parser_t;

void parser_init(parser_t *p);
/* One received byte, with the tick at which it arrived. */
uint8_t parser_feed(parser_t *p, uint8_t byte, uint16_t tick);
/* A whole fixed-size request at the front of the receive FIFO (a ring of
 * HAL_RX_RING = 256 bytes, `count` of them from index `tail`), parsed in place
 * while the parser is between frames: returns its length in bytes, the
 * request in p->rq, or 0 when the bytes are not (yet) one complete
 * fixed-size request with a good checksum within the ring (not across its
 * end); feed them one at a time then (parser_feed gives every error its
 * reply). */
uint8_t parser_take(parser_t *p, const uint8_t *ring, uint8_t tail, uint8_t count);
/* No byte available: checks the inter-byte gap and the end of discarding. */
uint8_t parser_poll(parser_t *p, uint16_t now);
/* Start discarding until quiet (after an RX overflow), counting from tick. */
void parser_discard(parser_t *p, uint16_t tick);
/* Whether the parser is between frames (no frame started, not discarding). */
uint8_t parser_idle(const parser_t *p);

/* Request framing from the generated table: 1 and fills fixed/len_pos if
 * (ct, dt) is a request, else 0. */
uint8_t parser_lookup(uint8_t ct, uint8_t dt, uint8_t *fixed, int8_t *len_pos);
uint8_t parser_known_class(uint8_t ct);

#endif /* PARSER_H */

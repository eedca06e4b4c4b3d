/*
 * aio.h - types shared by the parser, the dispatcher and the class modules.
 */
#ifndef AIO_H
#define AIO_H

#include <stdint.h>

#include "aio_protocol.h"
#ifdef AIO_BUILD_MEGA2560
#include "board_pins_mega2560.h" /* the Mega's pin checks replace the Uno's */
#endif

/* Constant tables the AVR build keeps in flash only (read with lpm, one cycle more than
 * from RAM): a `static const` table is otherwise copied into RAM at boot, and RAM is what
 * the stack needs (at least 400 B left at its deepest: docs/firmware-profiles.md). */
#ifdef __AVR__
#define AIO_FLASH __flash
#else
#define AIO_FLASH
#endif

/* Largest request data: I2C WRITE, 3 fixed bytes + 32. */
#define AIO_REQUEST_DATA_MAX (3u + AIO_MAX_BLOB)
/* Largest reply data: I2C READ, 3 fixed bytes + 32. */
#define AIO_REPLY_DATA_MAX (3u + AIO_MAX_BLOB)
/* Check bytes at the end of a frame: 1 (XOR, the paper's) or 2 (CRC-16 framing,
 * SET_FRAMING); AIO_CHECK_MAX is the larger. */
#define AIO_CHECK_MAX 2u
/* Largest frame the board sends: CT DT data check. */
#define AIO_FRAME_MAX (AIO_REPLY_DATA_MAX + 2u + AIO_CHECK_MAX)

/* A complete request with a good checksum and known tags. */
typedef struct {
    uint8_t ct;
    uint8_t dt;
    uint8_t len;                         /* data bytes in the frame (fixed + variable) */
    uint8_t data[AIO_REQUEST_DATA_MAX];  /* the first AIO_REQUEST_DATA_MAX of them */
} aio_request_t;

/* The data part of a success reply; CT, DT and CS are added by the dispatcher. */
typedef struct {
    uint8_t len;
    uint8_t data[AIO_REPLY_DATA_MAX];
} aio_reply_t;

/* A class sub-parser: handles one request of its class, returns 0 (success,
 * reply filled in) or an error code of section 4. */
typedef uint8_t (*aio_handler_t)(const aio_request_t *rq, aio_reply_t *rp);

static inline uint16_t aio_be16(const uint8_t *p) { return (uint16_t)((uint16_t)p[0] << 8 | p[1]); }

static inline uint8_t *aio_put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v >> 8);
    p[1] = (uint8_t)v;
    return p + 2;
}

static inline uint8_t *aio_put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
    return p + 4;
}

/* Reply that echoes the request's data unchanged. */
static inline __attribute__((always_inline)) uint8_t aio_echo(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t i;
    for (i = 0; i < rq->len && i < AIO_REPLY_DATA_MAX; i++)
        rp->data[i] = rq->data[i];
    rp->len = i;
    return 0;
}

#endif /* AIO_H */

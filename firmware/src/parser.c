/*
 * parser.c - the main frame parser (see parser.h).
 *
 * Per byte this is one switch on the state and a few 8-bit operations: the
 * request framing comes from a small table indexed by CT and DT built from
 * the generated AIO_REQUEST_TABLE (no compare chains per byte), the data
 * bytes are counted down in `left`.
 */
#include "parser.h"

#include "hal.h"

enum { ST_IDLE = 0, ST_DT, ST_DATA, ST_CS, ST_CS2, ST_DISCARD };

uint8_t parser_crc;

uint8_t parser_seal(uint8_t *frame, uint8_t len)
{
    uint8_t i, cs = 0;
    uint16_t crc = 0xFFFFu;
    if (parser_crc) {
        for (i = 0; i < len; i++)
            crc = parser_crc16(crc, frame[i]);
        frame[len] = (uint8_t)(crc >> 8);
        frame[len + 1u] = (uint8_t)crc;
        return (uint8_t)(len + 2u);
    }
    for (i = 0; i < len; i++)
        cs ^= frame[i];
    frame[len] = cs;
    return (uint8_t)(len + 1u);
}

/* frame[ct][dt]: 0 = no such request, else FR_KNOWN | data_len | (len_pos + 1) << 4.
 * Column 0 (no request has DT 0) marks a known class.  A CT or DT outside the
 * table is a compile error in the initializer. */
#define FR_KNOWN 0x80u
#define FR_ROWS 14u /* up to CT 0x0D (SPI) */
#define FR_COLS 13u /* up to DT 0x0C (MISC READ_BOARD_DESCRIPTION) */
#define FR_ENC(data_len, lpos) ((uint8_t)(FR_KNOWN | (data_len) | (uint8_t)((lpos) + 1) << 4))

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Woverride-init"
/* In flash (lpm, one cycle more than lds): in RAM its 132 bytes pushed .data
 * past 256 B, which moved the 256-aligned UART rings up and left a 246-byte
 * hole below them (RAM 1184 -> 1542 B with the encoder class's row). */
static const AIO_FLASH uint8_t frame_table[FR_ROWS][FR_COLS] = {
#define AIO_X(CLASS, NAME, ct_, dt_, data_len, lpos) \
    [ct_][0] = FR_KNOWN, [ct_][dt_] = FR_ENC(data_len, lpos),
    AIO_REQUEST_TABLE(AIO_X)
#undef AIO_X
};
#pragma GCC diagnostic pop

/* The encoding holds data_len 0..15 and len_pos -1..6. */
static inline void frame_table_check(void)
{
#define AIO_X(CLASS, NAME, ct_, dt_, data_len, lpos) \
    _Static_assert((data_len) < 16 && (lpos) >= -1 && (lpos) < 7 && (dt_) != 0, "frame table encoding");
    AIO_REQUEST_TABLE(AIO_X)
#undef AIO_X
}

uint8_t parser_lookup(uint8_t ct, uint8_t dt, uint8_t *fixed, int8_t *len_pos)
{
    uint8_t e;
    (void)frame_table_check;
    if (ct >= FR_ROWS || dt >= FR_COLS || dt == 0)
        return 0;
    e = frame_table[ct][dt];
    if (!e)
        return 0;
    *fixed = e & 0x0Fu;
    *len_pos = (int8_t)(((e >> 4) & 0x07u) - 1);
    return 1;
}

uint8_t parser_known_class(uint8_t ct) { return ct < FR_ROWS && frame_table[ct][0]; }

void parser_init(parser_t *p)
{
    p->state = ST_IDLE;
    p->idx = 0;
    p->left = 0;
    p->sum = 0;
    p->crc = 0xFFFFu;
    p->last_tick = 0;
    parser_crc = 0; /* every boot starts in the paper's framing */
}

static uint8_t fail(parser_t *p, uint8_t ct, uint8_t dt, uint8_t code)
{
    p->err_ct = (uint8_t)(ct | AIO_ERROR_FLAG);
    p->err_dt = dt;
    p->err_code = code;
    p->state = ST_DISCARD;
    return PARSER_ERROR;
}

void parser_discard(parser_t *p, uint16_t tick)
{
    p->state = ST_DISCARD;
    p->last_tick = tick;
}

uint8_t parser_idle(const parser_t *p) { return p->state == ST_IDLE; }

uint8_t parser_feed(parser_t *p, uint8_t byte, uint16_t tick)
{
    uint8_t i;
    p->last_tick = tick;
    switch (p->state) {
    case ST_DATA:
        i = p->idx;
        if (i < AIO_REQUEST_DATA_MAX) {
            p->rq.data[i] = byte;
            if ((int8_t)i == p->len_pos) /* len_pos < AIO_REQUEST_DATA_MAX */
                p->left = (uint16_t)(p->left + byte);
            p->idx = (uint8_t)(i + 1u);
        } else {
            p->idx = AIO_REQUEST_DATA_MAX + 1u; /* more than a request holds: refused */
        }
        p->sum ^= byte;
        if (parser_crc)
            p->crc = parser_crc16(p->crc, byte);
        if (--p->left == 0)
            p->state = ST_CS;
        return PARSER_NONE;
    case ST_IDLE:
        if (!parser_known_class(byte))
            return fail(p, byte, 0, AIO_ERR_UNKNOWN_CLASS);
        p->rq.ct = byte;
        p->sum = byte;
        p->crc = parser_crc16(0xFFFFu, byte);
        p->state = ST_DT;
        return PARSER_NONE;
    case ST_DT: {
        uint8_t e = (byte < FR_COLS && byte != 0) ? frame_table[p->rq.ct][byte] : 0;
        if (!e)
            return fail(p, p->rq.ct, byte, AIO_ERR_UNKNOWN_DESCRIPTOR);
        p->rq.dt = byte;
        p->sum ^= byte;
        p->crc = parser_crc16(p->crc, byte);
        p->fixed = e & 0x0Fu;
        p->len_pos = (int8_t)(((e >> 4) & 0x07u) - 1);
        p->left = p->fixed;
        p->idx = 0;
        p->state = p->fixed ? ST_DATA : ST_CS;
        return PARSER_NONE;
    }
    case ST_CS:
        if (parser_crc) {
            /* CRC framing: the high byte now, the low byte next (a wrong high
             * byte fails at once; discarding swallows the low one) */
            if (byte != (uint8_t)(p->crc >> 8))
                return fail(p, p->rq.ct, p->rq.dt, AIO_ERR_BAD_CHECKSUM);
            p->state = ST_CS2;
            return PARSER_NONE;
        }
        if ((uint8_t)(p->sum ^ byte) != 0)
            return fail(p, p->rq.ct, p->rq.dt, AIO_ERR_BAD_CHECKSUM);
        if (p->idx > AIO_REQUEST_DATA_MAX) { /* a whole frame, but not a request: no handler sees it */
            fail(p, p->rq.ct, p->rq.dt, AIO_ERR_VALUE_OUT_OF_RANGE);
            p->state = ST_IDLE;
            return PARSER_ERROR;
        }
        p->rq.len = p->idx;
        p->state = ST_IDLE;
        return PARSER_REQUEST;
    case ST_CS2:
        if (byte != (uint8_t)p->crc)
            return fail(p, p->rq.ct, p->rq.dt, AIO_ERR_BAD_CHECKSUM);
        p->rq.len = p->idx;
        p->state = ST_IDLE;
        return PARSER_REQUEST;
    default: /* ST_DISCARD: every byte restarts the quiet period */
        return PARSER_NONE;
    }
}

_Static_assert(HAL_RX_RING == 256u, "the FIFO's 8-bit indices wrap with its ring");

/* The pipelined case: while the host keeps requests in flight the FIFO holds
 * whole frames, and checking one in place costs a table lookup and a loop
 * over its bytes instead of a state transition per byte.  A frame that runs
 * across the end of the ring goes byte by byte (one in about 50). */
uint8_t parser_take(parser_t *p, const uint8_t *ring, uint8_t tail, uint8_t count)
{
    const uint8_t *f = ring + tail;
    uint8_t *d = p->rq.data;
    uint8_t ct, dt, e, data_len, last, i, b, sum, check = parser_crc;
    uint16_t crc;

    /* 8-bit arithmetic throughout (this runs once per pipelined request):
     * `last`, the index of the checksum byte, is below `tail` when the frame
     * would run across the end of the ring (tail <= 253, data_len <= 15). */
    if (p->state != ST_IDLE || count < 3u || tail > (uint8_t)(HAL_RX_RING - 3u))
        return 0;
    ct = f[0];
    dt = f[1];
    if (ct >= FR_ROWS || (uint8_t)(dt - 1u) >= FR_COLS - 1u)
        return 0;
    e = frame_table[ct][dt];
    if (!e || (e & 0x70u)) /* unknown, or with a variable part: byte by byte */
        return 0;
    data_len = e & 0x0Fu;
    /* `last`: the index of the last check byte (the second CRC byte in CRC
     * framing, `check` = 1) */
    last = (uint8_t)(tail + 2u + data_len + check);
    if (count <= (uint8_t)(data_len + 2u + check) || last < tail)
        return 0;
    f += 2;
    if (check) {
        crc = parser_crc16(parser_crc16(0xFFFFu, ct), dt);
        for (i = data_len; i; i--) {
            b = *f++;
            *d++ = b;
            crc = parser_crc16(crc, b);
        }
        if ((uint8_t)(crc >> 8) != ring[(uint8_t)(last - 1u)] || (uint8_t)crc != ring[last])
            return 0;
    } else {
        sum = (uint8_t)(ct ^ dt);
        for (i = data_len; i; i--) {
            b = *f++;
            *d++ = b;
            sum ^= b;
        }
        if (sum != ring[last])
            return 0;
    }
    p->rq.ct = ct;
    p->rq.dt = dt;
    p->rq.len = data_len;
    return (uint8_t)(data_len + 3u + check);
}

uint8_t parser_poll(parser_t *p, uint16_t now)
{
    if (p->state == ST_IDLE || (uint16_t)(now - p->last_tick) < PARSER_GAP_TICKS)
        return PARSER_NONE;
    if (p->state == ST_DISCARD) {
        p->state = ST_IDLE;
        return PARSER_NONE;
    }
    /* A frame was started and the line went quiet: the quiet period that
     * ends the discarding has already passed. */
    fail(p, p->rq.ct, p->state == ST_DT ? 0 : p->rq.dt, AIO_ERR_INCOMPLETE_FRAME);
    p->state = ST_IDLE;
    return PARSER_ERROR;
}

/*
 * parser.c - the main frame parser (see parser.h).
 */
#include "parser.h"

enum { ST_IDLE = 0, ST_DT, ST_DATA, ST_CS, ST_DISCARD };

uint8_t parser_lookup(uint8_t ct, uint8_t dt, uint8_t *fixed, int8_t *len_pos)
{
#define AIO_X(CLASS, NAME, ct_, dt_, data_len, lpos) \
    case ((uint16_t)(ct_) << 8 | (dt_)):             \
        *fixed = (data_len);                          \
        *len_pos = (lpos);                            \
        return 1;
    switch ((uint16_t)ct << 8 | dt) {
        AIO_REQUEST_TABLE(AIO_X)
    default:
        return 0;
    }
#undef AIO_X
}

uint8_t parser_known_class(uint8_t ct)
{
#define AIO_X(CLASS, NAME, ct_, dt_, data_len, lpos) || ct == (ct_)
    return 0 AIO_REQUEST_TABLE(AIO_X);
#undef AIO_X
}

void parser_init(parser_t *p)
{
    p->state = ST_IDLE;
    p->got = 0;
    p->need = 0;
    p->sum = 0;
    p->last_tick = 0;
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
    p->last_tick = tick;
    switch (p->state) {
    case ST_IDLE:
        if (!parser_known_class(byte))
            return fail(p, byte, 0, AIO_ERR_UNKNOWN_CLASS);
        p->rq.ct = byte;
        p->sum = byte;
        p->state = ST_DT;
        return PARSER_NONE;
    case ST_DT:
        if (!parser_lookup(p->rq.ct, byte, &p->fixed, &p->len_pos))
            return fail(p, p->rq.ct, byte, AIO_ERR_UNKNOWN_DESCRIPTOR);
        p->rq.dt = byte;
        p->sum ^= byte;
        p->need = p->fixed;
        p->got = 0;
        p->state = p->need ? ST_DATA : ST_CS;
        return PARSER_NONE;
    case ST_DATA:
        if (p->got < AIO_REQUEST_DATA_MAX)
            p->rq.data[p->got] = byte;
        if (p->len_pos >= 0 && p->got == (uint16_t)p->len_pos)
            p->need = (uint16_t)(p->fixed + byte);
        p->got++;
        p->sum ^= byte;
        if (p->got >= p->need)
            p->state = ST_CS;
        return PARSER_NONE;
    case ST_CS:
        if ((uint8_t)(p->sum ^ byte) != 0)
            return fail(p, p->rq.ct, p->rq.dt, AIO_ERR_BAD_CHECKSUM);
        p->rq.len = (uint8_t)(p->got < AIO_REQUEST_DATA_MAX ? p->got : AIO_REQUEST_DATA_MAX);
        p->state = ST_IDLE;
        return PARSER_REQUEST;
    default: /* ST_DISCARD: every byte restarts the quiet period */
        return PARSER_NONE;
    }
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

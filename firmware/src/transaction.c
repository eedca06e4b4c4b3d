/*
 * transaction.c - MISC TRANSACTION (extension, protocol.md 7.5).
 *
 * Request data: SEQ LEN items; reply data: SEQ LEN results.  SEQ is the host's
 * number for the transaction, echoed so that the host can tell apart two
 * transactions in flight with the same items.
 *
 * The items are request frames without checksums, back to back.  The whole
 * list is checked first (known tags from the parser's table, whole frames, no
 * RESET and no nested TRANSACTION, every possible result fits the reply), so a
 * refused list changes nothing; then each item goes through the ordinary
 * dispatcher (failsafe gate included) and its reply frame, without the
 * checksum, is appended to the results.  An item the board refuses leaves its
 * error reply there and the next item still runs.
 */
#include "transaction.h"

#include <string.h>

#include "dispatch.h"
#include "parser.h"

/* Reply data bytes of a request, from the generated table (the switch compiles
 * to a search in flash, no RAM table). */
static uint8_t reply_len(uint8_t ct, uint8_t dt)
{
    switch ((uint16_t)((uint16_t)ct << 8 | dt)) {
#define AIO_X(CLASS, NAME, ct_, dt_, data_len, lpos) \
    case (uint16_t)((ct_) << 8 | (dt_)): return AIO_REPLY_LEN_##CLASS##_##NAME;
        AIO_REQUEST_TABLE(AIO_X)
#undef AIO_X
    default: return 0;
    }
}

/* Bytes of the item at `item` (at most `left`), and of its result; 0 if the
 * item cannot be part of a transaction. */
static uint8_t measure(const uint8_t *item, uint8_t left, uint8_t *result)
{
    uint8_t fixed, len, ct, dt;
    int8_t lpos;

    if (left < 2)
        return 0;
    ct = item[0];
    dt = item[1];
    if (!parser_lookup(ct, dt, &fixed, &lpos))
        return 0;
    if (ct == AIO_CT_MISC &&
        (dt == AIO_DT_MISC_RESET || dt == AIO_DT_MISC_TRANSACTION || dt == AIO_DT_MISC_SET_FRAMING))
        return 0;
    len = (uint8_t)(2u + fixed);
    if (lpos >= 0) {
        if ((uint8_t)(2 + lpos) >= left)
            return 0;
        if (item[2 + lpos] > AIO_MAX_BLOB)
            return 0;
        len = (uint8_t)(len + item[2 + lpos]);
    }
    if (len > left)
        return 0;
    *result = (uint8_t)(2u + reply_len(ct, dt));
    if (ct == AIO_CT_I2C && dt == AIO_DT_I2C_READ)
        *result = (uint8_t)(*result + (item[4] > AIO_MAX_BLOB ? AIO_MAX_BLOB + 1u : item[4]));
    if (*result < 3u) /* an error reply: CT|0x80 DT CODE */
        *result = 3u;
    return len;
}

uint8_t transaction_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    const uint8_t *items = rq->data + 2;
    uint8_t count = rq->data[1], pos, len, result, out;
    uint16_t need = 0;
    aio_request_t item;
    uint8_t frame[AIO_FRAME_MAX];

    /* The items are the request's own bytes: never walk past what it holds. */
    if (count == 0 || count > AIO_MAX_BLOB || rq->len != (uint8_t)(count + 2u))
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    for (pos = 0; pos < count; pos = (uint8_t)(pos + len)) {
        len = measure(items + pos, (uint8_t)(count - pos), &result);
        if (!len)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        need += result;
    }
    if (need > AIO_MAX_BLOB)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    out = 2;
    for (pos = 0; pos < count; pos = (uint8_t)(pos + len)) {
        len = measure(items + pos, (uint8_t)(count - pos), &result);
        item.ct = items[pos];
        item.dt = items[pos + 1];
        item.len = (uint8_t)(len - 2u);
        memcpy(item.data, items + pos + 2, item.len);
        result = (uint8_t)(dispatch(&item, frame) - 1u - parser_crc); /* without the check bytes */
        memcpy(rp->data + out, frame, result);
        out = (uint8_t)(out + result);
    }
    rp->data[0] = rq->data[0];
    rp->data[1] = (uint8_t)(out - 2u);
    rp->len = out;
    return 0;
}

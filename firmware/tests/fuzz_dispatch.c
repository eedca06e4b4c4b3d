/*
 * fuzz_dispatch.c - libFuzzer target: every request of the generated table, straight
 * into the dispatcher, so every class's handler is reached with well-framed requests
 * from the first run (a class added to AIO_REQUEST_TABLE is covered without a change
 * here).  The request keeps the parser's contract (parser.h): rq.len is the fixed part
 * plus the declared variable part, within AIO_REQUEST_DATA_MAX.  Checks every reply:
 * at most AIO_FRAME_MAX bytes, a good checksum, the request's tags.
 *
 * The request is allocated to the bytes it holds, and at least the largest fixed part
 * of any request (handlers read their fixed fields before they look at the descriptor),
 * so ASan flags a handler that reads a variable part past rq->len ("a handler is never
 * safe only because of its caller", dispatch.c); its length byte is the input's, whether
 * or not that many bytes follow (the parser refuses such frames; a handler must not
 * trust the byte either).
 *
 * Input: records of one selector byte s, then the request's data bytes:
 *   s < 0xF0:  request table[s % entries], its fixed data from the input, then as many
 *              variable bytes as its length byte declares, as far as they fit and the
 *              input lasts
 *   0xF0..0xFF, t: a pause of t ticks, an ADC conversion completes, input pin t % 14
 *              toggles when s is odd
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "aio.h"
#include "app.h"
#include "dispatch.h"
#include "fake_hal.h"
#include "parser.h"

typedef struct {
    uint8_t ct, dt, fixed;
    int8_t lpos;
} entry_t;

static const entry_t table[] = {
#define AIO_X(CLASS, NAME, ct_, dt_, data_len, lpos) {(ct_), (dt_), (data_len), (lpos)},
    AIO_REQUEST_TABLE(AIO_X)
#undef AIO_X
};
#define ENTRIES (sizeof table / sizeof table[0])

/* The largest fixed part of a request. */
static uint8_t fixed_max(void)
{
    uint8_t m = 0, k;
    for (k = 0; k < ENTRIES; k++)
        if (table[k].fixed > m)
            m = table[k].fixed;
    return m;
}
#define FIXED_MAX ((size_t)fixed_max())

static void settle(void)
{
    while (app_step()) {
    }
    fake_tx_len = 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t i = 0;
    aio_request_t rq;
    uint8_t *exact;
    uint8_t frame[AIO_FRAME_MAX + 8], n, k, cs, s;
    const entry_t *e;

    fake_reset();
    app_init();
    while (i < size && !fake_reset_done) {
        s = data[i++];
        if (s >= 0xF0) {
            if (i >= size)
                break;
            fake_advance(data[i]);
            fake_adc_complete();
            if (s & 1u) {
                k = (uint8_t)(data[i] % 14u);
                fake_drive(k, (uint8_t)!fake_pin_level[k]);
            }
            i++;
            settle();
            continue;
        }
        e = &table[s % ENTRIES];
        memset(&rq, 0, sizeof rq);
        rq.ct = e->ct;
        rq.dt = e->dt;
        n = e->fixed;
        for (k = 0; k < n; k++)
            rq.data[k] = i < size ? data[i++] : 0;
        if (e->lpos >= 0) {
            uint8_t room = (uint8_t)(AIO_REQUEST_DATA_MAX - n), declared = rq.data[e->lpos];
            for (k = 0; k < declared && k < room && i < size; k++)
                rq.data[n + k] = data[i++];
            n = (uint8_t)(n + k);
        }
        rq.len = n;
        size_t held = offsetof(aio_request_t, data) + (n > FIXED_MAX ? n : FIXED_MAX);
        exact = malloc(held);
        if (!exact)
            abort();
        memcpy(exact, &rq, held);
        memset(frame, 0xCC, sizeof frame);
        n = dispatch((const aio_request_t *)(const void *)exact, frame);
        free(exact);
        if (n < 3u || n > AIO_FRAME_MAX || frame[AIO_FRAME_MAX] != 0xCC)
            abort(); /* a reply is CT DT (data) CHECK or an error reply, within the frame */
        if (parser_crc) { /* sealed in the framing in force (a SET_FRAMING may switch it) */
            uint16_t crc = 0xFFFFu;
            for (k = 0; k < n; k++)
                crc = parser_crc16(crc, frame[k]);
            cs = (uint8_t)(crc != 0u);
        } else {
            cs = 0;
            for (k = 0; k < n; k++)
                cs ^= frame[k];
        }
        if (cs || (frame[0] & 0x7Fu) != rq.ct || frame[1] != rq.dt)
            abort();
        settle();
    }
    return 0;
}

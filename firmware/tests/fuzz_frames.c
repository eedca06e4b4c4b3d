/*
 * fuzz_frames.c - libFuzzer target: whole frames with good checksums through the app.
 *
 * Random bytes almost never end in a good XOR checksum, so fuzz_parser rarely gets a
 * request past the parser; here the target appends it.  The input is records:
 *   n, then n bytes: a frame without its checksum (CT DT data; any length, any tags:
 *                    declared lengths over what a request holds included)
 *   0xFF, t:         a pause of t ticks (100 us), an ADC conversion completes
 *   0xFE, p:         input pin p % 14 toggles (pin-change interrupt)
 * Each frame also goes through a parser of its own, byte by byte, which must keep its
 * contract (parser.h): a request it delivers has known tags and holds every data byte of
 * its frame, rq.len = fixed part + declared variable part <= AIO_REQUEST_DATA_MAX (the
 * TRANSACTION over-read this target found began with a parser that delivered a request
 * cut to 35 of its 41 data bytes).
 */
#include <stddef.h>
#include <stdint.h>

#include <stdlib.h>

#include "app.h"
#include "fake_hal.h"
#include "parser.h"

static void settle(void)
{
    while (app_step()) {
    }
    fake_tx_len = 0;
}

static parser_t own;
static uint16_t own_tick;

/* The frame through the standalone parser; abort when a delivered request breaks the
 * contract. */
static void check_contract(const uint8_t *frame, uint8_t n)
{
    uint8_t k, fixed;
    int8_t lpos;

    for (k = 0; k < n; k++) {
        if (parser_feed(&own, frame[k], ++own_tick) != PARSER_REQUEST)
            continue;
        if (!parser_lookup(own.rq.ct, own.rq.dt, &fixed, &lpos))
            abort();
        if (own.rq.len > AIO_REQUEST_DATA_MAX ||
            own.rq.len != (uint8_t)(fixed + (lpos >= 0 ? own.rq.data[lpos] : 0u)))
            abort();
    }
    own_tick = (uint16_t)(own_tick + PARSER_GAP_TICKS + 1u); /* quiet: a cut frame ends */
    parser_poll(&own, own_tick);
    own_tick = (uint16_t)(own_tick + PARSER_GAP_TICKS + 1u);
    parser_poll(&own, own_tick);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t i = 0;
    uint8_t frame[256], n, k, cs;

    fake_reset();
    app_init();
    parser_init(&own);
    own_tick = 0;
    while (i < size && !fake_reset_done) {
        n = data[i++];
        if (n == 0xFF || n == 0xFE) {
            if (i >= size)
                break;
            if (n == 0xFF) {
                fake_advance(data[i++]);
                fake_adc_complete();
            } else {
                k = (uint8_t)(data[i++] % 14u);
                fake_drive(k, (uint8_t)!fake_pin_level[k]);
            }
            settle();
            continue;
        }
        if (n > size - i)
            n = (uint8_t)(size - i);
        cs = 0;
        for (k = 0; k < n; k++)
            cs ^= frame[k] = data[i + k];
        frame[n] = cs;
        i += n;
        check_contract(frame, (uint8_t)(n + 1u));
        fake_rx_push(frame, (uint32_t)n + 1u);
        settle();
        fake_advance(200); /* more than the inter-byte gap: a cut frame ends here */
        settle();
    }
    return 0;
}

/*
 * fuzz_frames.c - libFuzzer target: whole frames with good checksums through the app.
 *
 * Random bytes almost never end in a good XOR checksum, so fuzz_parser rarely gets a
 * request past the parser; here the target appends it.  The input is records:
 *   n, then n bytes: a frame without its checksum (CT DT data; any length, any tags:
 *                    declared lengths over what a request holds included)
 *   0xFF, t:         a pause of t ticks (100 us), an ADC conversion completes
 *   0xFE, p:         input pin p % 14 toggles (pin-change interrupt)
 * This path found the TRANSACTION over-read of issue 28.
 */
#include <stddef.h>
#include <stdint.h>

#include "app.h"
#include "fake_hal.h"

static void settle(void)
{
    while (app_step()) {
    }
    fake_tx_len = 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t i = 0;
    uint8_t frame[256], n, k, cs;

    fake_reset();
    app_init();
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
        fake_rx_push(frame, (uint32_t)n + 1u);
        settle();
        fake_advance(200); /* more than the inter-byte gap: a cut frame ends here */
        settle();
    }
    return 0;
}

/* fuzz_parser.c - libFuzzer target: arbitrary bytes (with pauses) through parser + dispatcher. */
#include <stddef.h>
#include <stdint.h>

#include "app.h"
#include "fake_hal.h"
#include "parser.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t i;
    fake_reset();
    app_init();
    /* the first byte picks the framing (bit 0: CRC-16, as after SET_FRAMING) */
    if (size && (data[0] & 1u))
        parser_crc = 1;
    for (i = size ? 1u : 0u; i < size; i++) {
        if (data[i] == 0xA5 && i + 1 < size) { /* escape: a pause of data[i+1] ticks */
            fake_advance(data[++i]);
            fake_adc_complete();
        } else {
            fake_rx_push(&data[i], 1);
        }
        while (app_step()) {
        }
        fake_tx_len = 0;
    }
    return 0;
}

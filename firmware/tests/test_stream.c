/*
 * test_stream.c - host tests of STREAM: timed samples (stream.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "counter.h"
#include "stream.h"

/* ------------------------------------------------------------ STREAM */
void test_stream(void)
{
    int i;
    board();
    CHECK(B(7, 1, 0, 0, 0x03, 0xE8), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* empty */
    CHECK(B(7, 1, 0x40, 0, 0x03, 0xE8), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(7, 1, 1, 0, 0x03, 0xE7), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 999 */
    CHECK(B(7, 1, 1, 0, 0x00, 0xF9), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 249 */
    CHECK(B(7, 1, 1, 0, 0x01, 0x13), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 275 */
    CHECK(B(7, 1, 1, 0, 0x00, 0xFA), B(0x87, 1, AIO_ERR_LINK_CAPACITY));     /* 250 at 115200 */
    /* 250 us: 4 channels fit 2 Mbaud, not 1 Mbaud; 6 channels every 500 us fit 1 Mbaud */
    EXPECT(stream_admit(8, 250, 2000000) && !stream_admit(8, 250, 1000000));
    EXPECT(stream_admit(12, 500, 1000000) && !stream_admit(12, 300, 1000000));
    /* the chain's ADC clock: 125 kHz (104 us a conversion) wherever it fits */
    EXPECT(stream_adc_clock(6, 1000) == 7 && stream_adc_clock(1, 250) == 7);
    EXPECT(stream_adc_clock(4, 250) == 5 && stream_adc_clock(6, 500) == 6);
    EXPECT(stream_adc_clock(6, 250) == 4 && stream_adc_clock(6, 100) == 0);
    CHECK(B(7, 1, 1, 0, 0xEA, 0x61), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 60001 */
    CHECK(B(7, 1, 1, 0, 0x04, 0x4D), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 1101 */
    CHECK(B(7, 1, 1, 0, 0x06, 0x40), B(0x87, 1, AIO_ERR_LINK_CAPACITY));     /* 1600 */
    CHECK(B(7, 1, 0x0F, 0, 0x08, 0xFC), B(0x87, 1, AIO_ERR_LINK_CAPACITY));  /* 4 ch 2300 */
    CHECK(B(7, 1, 0x0F, 0, 0x09, 0x60), B(7, 1, 0x0F, 0, 0x09, 0x60));      /* 4 ch 2400 */
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_STREAMING, 0, 0));
    /* 1 channel + levels + edges + counters, 3300 us (limit at 115200) */
    CHECK(B(7, 1, 0x01, 0x07, 0x0C, 0xE4), B(7, 1, 0x01, 0x07, 0x0C, 0xE4));
    CHECK(B(7, 1, 0x01, 0x07, 0x0C, 0x80), B(0x87, 1, AIO_ERR_LINK_CAPACITY)); /* 3200 */
    CHECK(B(2, 1, 8, 0), B(2, 1, 8, 0));
    CHECK(B(6, 1, 3, 1), B(6, 1, 3, 1));
    fake_adc[0] = 0x2AB;
    fake_drive(8, 1);
    counter_event(1);
    counter_event(1);
    fake_advance(33);
    EXPECT(fake_adc_pending == 0);
    fake_adc_complete();
    take();
    {
        uint8_t exp[] = {0x40, 0x01, 0x01, 0x07, 0, 0, 0, 0, 0, 0, 16,
                         0x02, 0xAB,             /* A0 */
                         0x01, 0x00,             /* levels: D8 */
                         0x01, 0x00, 0x00, 0x00, /* rose D8, fell none */
                         0, 0, 0, 0, 0, 0, 0, 2, /* counters */
                         0};
        uint32_t ts = fake_ticks * 100u;
        exp[6] = (uint8_t)(ts >> 24); exp[7] = (uint8_t)(ts >> 16);
        exp[8] = (uint8_t)(ts >> 8); exp[9] = (uint8_t)ts;
        exp[sizeof exp - 1] = xor_of(exp, sizeof exp - 1);
        EXPECT(outn == sizeof exp && !memcmp(out, exp, sizeof exp));
        if (outn != sizeof exp || memcmp(out, exp, sizeof exp)) {
            dump("expected", exp, sizeof exp);
            dump("got", out, outn);
        }
    }
    /* second sample: sequence 1, no new edges */
    fake_advance(33);
    fake_adc_complete();
    take();
    EXPECT(outn == 28 && out[4] == 0 && out[5] == 1 && out[15] == 0 && out[16] == 0);
    /* a full transmit buffer drops the sample, but uses its number */
    fake_tx_capacity = 10;
    fake_advance(33);
    fake_adc_complete();
    EXPECT(fake_tx_len == 0);
    fake_tx_capacity = 192;
    fake_advance(33);
    fake_adc_complete();
    take();
    EXPECT(outn == 28 && out[5] == 3);
    /* ANALOG READ during a stream, while a chain is running */
    fake_advance(33);
    EXPECT(fake_adc_pending == 0);
    fake_adc[1] = 0x111;
    send_frame(B(3, 2, 1));
    run();
    take();
    EXPECT(outn == 28 + 6 && out[0] == 0x40 && out[28] == 3 && out[31] == 0x01 && out[32] == 0x11);
    /* STOP: next sequence number; nothing after the reply */
    fake_advance(33); /* a sample is being converted */
    CHECK(B(7, 2), B(7, 2, 0, 5));
    fake_adc_complete();
    fake_advance(1000);
    fake_adc_complete();
    EXPECT(fake_tx_len == 0);
    CHECK(B(1, 6), B(1, 6, 0, 0, 0));
    /* replace: counters only (no ADC), restart at 0 */
    CHECK(B(7, 1, 0, 4, 0x27, 0x10), B(7, 1, 0, 4, 0x27, 0x10));
    for (i = 0; i < 3; i++)
        fake_advance(100);
    take();
    EXPECT(outn == 3 * 20 && out[5] == 0 && out[20 + 5] == 1 && out[40 + 5] == 2);
    CHECK(B(7, 2), B(7, 2, 0, 3));
    CHECK(B(4, 1, 0), B(4, 1, 0));
    CHECK(B(7, 1, 0x10, 0, 0x27, 0x10), B(0x87, 1, AIO_ERR_PIN_BUSY));
    /* 54 value bytes (A0-A3, levels, edges, counters, steppers, encoders) are over
     * AIO_STREAM_MAX_VALUES (48) */
    CHECK(B(7, 1, 0x0F, 0x1F, 0x27, 0x10), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    /* every flag's values, 46 bytes (levels, edges, counters, steppers, encoders; a full
     * 48 with I2C blocks: test_i2cblock.c): 11 + 46 + check */
    CHECK(B(7, 1, 0, 0x1F, 0x27, 0x10), B(7, 1, 0, 0x1F, 0x27, 0x10));
    fake_advance(100);
    take();
    EXPECT(outn == 11 + 46 + 1 && out[0] == AIO_CT_EVENT && out[10] == 46);
    CHECK(B(7, 2), B(7, 2, 0, 1));
}

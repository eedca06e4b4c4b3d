/*
 * test_analog.c - host tests of ANALOG: reads and the watched channels' ANALOG_CHANGE events (analog.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"

/* ------------------------------------------------------------ ANALOG */
void test_analog(void)
{
    board();
    fake_adc[0] = 0x3FF;
    fake_adc[5] = 0x123;
    CHECK(B(3, 2, 0), B(3, 2, 0, 0x03, 0xFF));
    CHECK(B(3, 2, 5), B(3, 2, 5, 0x01, 0x23));
    CHECK(B(3, 2, 6), B(0x83, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(3, 3), B(3, 3, 3, 0xFF, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0x23));
    CHECK(B(4, 1, 0), B(4, 1, 0));
    CHECK(B(3, 2, 4), B(0x83, 2, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 2, 5), B(0x83, 2, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 2, 3), B(3, 2, 3, 0, 0));
    CHECK(B(3, 3), B(3, 3, 3, 0xFF, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0x23));
}

/* ------------------------------------------------------------ ANALOG WATCH */
/* The tick starts a watched channel's conversion every 5 ticks; completes it. */
static void analog_sample(void)
{
    fake_advance(5);
    fake_adc_complete();
    take();
}

static void expect_analog_change(uint8_t ch, uint16_t value, uint16_t seq)
{
    uint8_t want[11] = {AIO_CT_EVENT, AIO_DT_EVENT_ANALOG_CHANGE, ch, (uint8_t)(value >> 8),
                        (uint8_t)value, (uint8_t)(seq >> 8), (uint8_t)seq};
    uint32_t t = hal_micros();
    memcpy(want + 7, (uint8_t[]){(uint8_t)(t >> 24), (uint8_t)(t >> 16), (uint8_t)(t >> 8), (uint8_t)t}, 4);
    EXPECT(outn == 12);
    EXPECT(!memcmp(out, want, 11) && out[11] == xor_of(out, 11));
}

void test_analog_watch(void)
{
    board();
    fake_adc[1] = 100;
    fake_adc[3] = 500;
    CHECK(B(3, 4, 6, 0, 10), B(0x83, 4, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(3, 4, 1, 0x04, 0x00), B(0x83, 4, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 1024 */
    CHECK(B(3, 4, 1, 0, 10), B(3, 4, 1, 0, 10, 0, 100)); /* the baseline comes back */
    EXPECT(fake_adc_pending < 0);
    fake_adc[1] = 110; /* inside the deadband (a move of exactly 10) */
    analog_sample();
    EXPECT(outn == 0);
    fake_adc[1] = 111;
    analog_sample();
    expect_analog_change(1, 111, 0);
    analog_sample(); /* no move: nothing */
    EXPECT(outn == 0);
    fake_adc[1] = 100; /* measured from the value reported last, 111 */
    analog_sample();
    expect_analog_change(1, 100, 1);
    /* two channels take turns; the sequence counts both */
    CHECK(B(3, 4, 3, 0x03, 0xFF), B(3, 4, 3, 0x03, 0xFF, 0x01, 0xF4));
    fake_adc[1] = 0;
    fake_adc[3] = 0;
    analog_sample(); /* channel 3: 500 -> 0 stays inside 1023 */
    EXPECT(outn == 0);
    analog_sample(); /* channel 1: 100 -> 0 */
    expect_analog_change(1, 0, 2);
    /* a blocking read waits for the watch conversion in flight, which still reports */
    fake_adc[1] = 300;
    fake_advance(5);
    EXPECT(fake_adc_pending == 3);
    fake_adc[3] = 0;
    CHECK(B(3, 2, 1), B(3, 2, 1, 0x01, 0x2C));
    fake_adc_complete();
    take();
    EXPECT(outn == 0);
    analog_sample();
    expect_analog_change(1, 300, 3);
    /* the ADC has one user: a stream of analog channels and a watch exclude each other */
    CHECK(B(7, 1, 1, 0, 0x27, 0x10), B(0x87, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(7, 1, 0, AIO_STREAM_LEVELS, 0x27, 0x10), B(7, 1, 0, AIO_STREAM_LEVELS, 0x27, 0x10));
    take();
    CHECK(B(3, 4, 3, 0, 0), B(3, 4, 3, 0, 0, 0, 0)); /* stop */
    CHECK(B(3, 4, 1, 0, 0), B(3, 4, 1, 0, 0, 0x01, 0x2C));
    fake_adc[1] = 0;
    analog_sample();
    EXPECT(outn == 0 && fake_adc_pending < 0); /* nothing watched: no conversion */
    CHECK(B(7, 1, 1, 0, 0x27, 0x10), B(7, 1, 1, 0, 0x27, 0x10));
    CHECK(B(3, 4, 0, 0, 10), B(0x83, 4, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 4, 0, 0, 0), B(3, 4, 0, 0, 0, 0, 0)); /* stopping is always accepted */
    CHECK(B(7, 2), B(7, 2, 0, 0));
    /* A4/A5 belong to the I2C bridge while it is on */
    CHECK(B(4, 1, 0), B(4, 1, 0));
    CHECK(B(3, 4, 4, 0, 10), B(0x83, 4, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 4, 0, 0, 10), B(3, 4, 0, 0, 10, 0, 0));
    /* A4 watched before the bridge went on stays silent while it is on */
    board();
    CHECK(B(3, 4, 4, 0, 10), B(3, 4, 4, 0, 10, 0, 0));
    CHECK(B(4, 1, 0), B(4, 1, 0));
    fake_adc[4] = 900;
    analog_sample();
    EXPECT(outn == 0);
}

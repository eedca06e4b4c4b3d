/*
 * test_pulse_in.c - host tests of the PULSE_IN class (pulse_in.c over the shared edge
 * timing of pulse.c) with the fake HAL: widths of the pulses the test drives (its own
 * clock is the oracle), signal loss after the timeout and the events, pin conflicts.
 * Run by tests/test_main.c (see host_check.h).
 */
#include "host_check.h"

static uint16_t be16(const uint8_t *p) { return (uint16_t)(p[0] << 8 | p[1]); }

/* A high pulse of `half_us` half-microseconds on `pin`, then `gap_us` low. */
static void pulse(uint8_t pin, uint32_t half_us, uint32_t gap_us)
{
    fake_drive(pin, 1);
    fake_fine_now += half_us;
    fake_drive(pin, 0);
    fake_fine_now += 2u * gap_us;
}

/* READ of slot s into width/age/lost; 0 when the reply is not a READ reply. */
static int read_in(uint8_t s, uint16_t *width, uint16_t *age, uint8_t *lost)
{
    send_frame(B(AIO_CT_PULSE_IN, AIO_DT_PULSE_IN_READ, s));
    run();
    take();
    checks++;
    /* events may come first: the reply is the last frame */
    if (outn < 2u + AIO_REPLY_LEN_PULSE_IN_READ + 1u) {
        failures++;
        printf("%s:%d: FAIL: read of slot %u (%u bytes)\n", __FILE__, __LINE__, s, outn);
        return 0;
    }
    {
        const uint8_t *r = out + outn - (2u + AIO_REPLY_LEN_PULSE_IN_READ + 1u);
        if (r[0] != AIO_CT_PULSE_IN || r[2] != s) {
            failures++;
            printf("%s:%d: FAIL: read of slot %u\n", __FILE__, __LINE__, s);
            return 0;
        }
        *width = be16(r + 3);
        *age = be16(r + 5);
        *lost = r[7];
    }
    return 1;
}

static void pulse_in_errors(void)
{
    board();
    CHECK(B(0x0C, 1, 6, 4, 0, 100), B(0x8C, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* slot 6 of 0-5 */
    CHECK(B(0x0C, 1, 0, 1, 0, 100), B(0x8C, 1, AIO_ERR_PIN_NOT_CAPABLE));    /* D1: the UART */
    CHECK(B(0x0C, 1, 0, 14, 0, 100), B(0x8C, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(0x0C, 1, 0, 4, 0, 0), B(0x8C, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* no timeout */
    CHECK(B(0x0C, 2, 0), B(0x8C, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(0x0C, 2, 6), B(0x8C, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    /* another user's pin: a GPIO output on D7, an encoder on D5/D6 */
    CHECK(B(2, 1, 7, 1), B(2, 1, 7, 1));
    CHECK(B(0x0C, 1, 0, 7, 0, 100), B(0x8C, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(0x0A, 1, 0, 5, 6, 4), B(0x0A, 1, 0, 5, 6, 4));
    CHECK(B(0x0C, 1, 0, 6, 0, 100), B(0x8C, 1, AIO_ERR_PIN_BUSY));
    /* another slot's pin; its own pin again */
    CHECK(B(0x0C, 1, 0, 4, 0, 100), B(0x0C, 1, 0, 4, 0, 100));
    CHECK(B(0x0C, 1, 1, 4, 0, 100), B(0x8C, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(0x0C, 1, 0, 4, 0, 50), B(0x0C, 1, 0, 4, 0, 50));
    EXPECT(fake_edge_watch & (1u << 4));
    /* a GPIO release ends it: the pin is free, its interrupt off */
    CHECK(B(2, 4, 4), B(2, 4, 4));
    CHECK(B(0x0C, 2, 0), B(0x8C, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    EXPECT(!(fake_edge_watch & (1u << 4)));
    EXPECT(fake_edge_watch & (1u << 5)); /* the encoder's stay */
    CHECK(B(0x0C, 9), B(0x8C, 9, AIO_ERR_UNKNOWN_DESCRIPTOR)); /* last: input is discarded after it */
}

/* Widths across the RC range on two inputs, exact to the fake clock's microsecond. */
static void pulse_in_widths(void)
{
    uint16_t width, age;
    uint8_t lost;
    uint32_t w;
    board();
    CHECK(B(0x0C, 1, 0, 4, 0, 100), B(0x0C, 1, 0, 4, 0, 100));
    CHECK(B(0x0C, 1, 5, 13, 0, 100), B(0x0C, 1, 5, 13, 0, 100));
    EXPECT(read_in(0, &width, &age, &lost) && width == 0 && lost == 1 && age == 65535u);
    /* the first pulse: a "back" event with its width */
    pulse(4, 2u * 1500u, 100);
    run();
    take();
    EXPECT(outn == 2u + AIO_REPLY_LEN_EVENT_PULSE_IN_SIGNAL + 1u && out[0] == AIO_CT_EVENT &&
           out[1] == AIO_DT_EVENT_PULSE_IN_SIGNAL && out[2] == 0 && be16(out + 3) == 1500u &&
           out[7] == 0);
    for (w = 1000; w <= 2000; w += 125) {
        pulse(4, 2u * w, 3000);
        pulse(13, 2u * (3000u - w) + 1u, 17000); /* and a half microsecond */
        EXPECT(read_in(0, &width, &age, &lost) && width == w && lost == 0 && age == (23000u - w) / 1000u);
        EXPECT(read_in(5, &width, &age, &lost) && width >= 3000u - w && width <= 3001u - w && lost == 0);
    }
    /* a pin already high at CONFIG starts no pulse: its rise was not seen */
    fake_drive(8, 1);
    CHECK(B(0x0C, 1, 2, 8, 0, 100), B(0x0C, 1, 2, 8, 0, 100));
    fake_fine_now += 2u * 700u;
    fake_drive(8, 0);
    EXPECT(read_in(2, &width, &age, &lost) && width == 0 && lost == 1);
    pulse(8, 2u * 1234u, 10);
    EXPECT(read_in(2, &width, &age, &lost) && width == 1234u && lost == 0);
}

/* Lost after the timeout (and not before), one event each way. */
static void pulse_in_loss(void)
{
    uint16_t width, age;
    uint8_t lost;
    int i;
    board();
    CHECK(B(0x0C, 1, 3, 9, 0, 60), B(0x0C, 1, 3, 9, 0, 60));
    for (i = 0; i < 5; i++)
        pulse(9, 2u * 1800u, 18000);
    run();
    take(); /* the "back" event */
    EXPECT(outn == 2u + AIO_REPLY_LEN_EVENT_PULSE_IN_SIGNAL + 1u && out[7] == 0);
    /* the last pulse ended 18 ms ago: 41 ms more is 59 ms, not lost */
    fake_fine_now += 2u * 41000u;
    run();
    take();
    EXPECT(outn == 0);
    fake_fine_now += 2u * 1000u;
    run();
    take();
    EXPECT(outn == 2u + AIO_REPLY_LEN_EVENT_PULSE_IN_SIGNAL + 1u && out[0] == AIO_CT_EVENT &&
           out[1] == AIO_DT_EVENT_PULSE_IN_SIGNAL && out[2] == 3 && be16(out + 3) == 1800u &&
           be16(out + 5) == 60u && out[7] == 1);
    run();
    take();
    EXPECT(outn == 0); /* once */
    EXPECT(read_in(3, &width, &age, &lost) && width == 1800u && lost == 1 && age == 60u);
    /* back */
    pulse(9, 2u * 1100u, 5);
    run();
    take();
    EXPECT(outn == 2u + AIO_REPLY_LEN_EVENT_PULSE_IN_SIGNAL + 1u && be16(out + 3) == 1100u && out[7] == 0);
    /* age saturates, no wrap (a minute and more) */
    for (i = 0; i < 70; i++) {
        fake_fine_now += 2u * 1000000u;
        run();
    }
    take();
    EXPECT(read_in(3, &width, &age, &lost) && age == 65535u && lost == 1);
}

/* The stream's PULSE_IN block: a count (the highest configured slot + 1 at START), then
 * per slot u16 width and u8 lost (1 for a slot without an input). */
static void pulse_in_stream(void)
{
    board();
    CHECK(B(0x0C, 1, 1, 4, 0, 30), B(0x0C, 1, 1, 4, 0, 30));
    CHECK(B(1, 8), B(1, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0x00, 0x10)); /* READ_PIN_ROLES: D4 */
    CHECK(B(7, 1, 0, 0x40, 0x27, 0x10), B(7, 1, 0, 0x40, 0x27, 0x10)); /* every 10 ms */
    pulse(4, 2u * 1234u + 1u, 10);
    run();
    take(); /* the "back" event */
    fake_advance(100);
    take();
    EXPECT(outn == 11u + 7u + 1u && out[0] == AIO_CT_EVENT && out[1] == AIO_DT_EVENT_STREAM_SAMPLE &&
           out[3] == 0x40 && out[10] == 7 && out[11] == 2 && be16(out + 12) == 0 && out[14] == 1 &&
           be16(out + 15) == 1234u && out[17] == 0);
    /* lost after 30 ms: the sample keeps the last width and says so */
    fake_advance(300);
    run();
    take();
    fake_advance(100);
    take();
    EXPECT(outn == 19u && be16(out + 15) == 1234u && out[17] == 1);
    CHECK(B(7, 2), B(7, 2, 0, 5));
    /* no input at all: a block of count 0 */
    CHECK(B(2, 4, 4), B(2, 4, 4));
    CHECK(B(7, 1, 0, 0x40, 0x27, 0x10), B(7, 1, 0, 0x40, 0x27, 0x10));
    fake_advance(100);
    take();
    EXPECT(outn == 11u + 1u + 1u && out[10] == 1 && out[11] == 0);
    CHECK(B(7, 2), B(7, 2, 0, 1));
}

void test_pulse_in(void)
{
    pulse_in_errors();
    pulse_in_widths();
    pulse_in_loss();
    pulse_in_stream();
}

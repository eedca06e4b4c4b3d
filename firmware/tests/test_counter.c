/*
 * test_counter.c - host tests of COUNTER: edge counting and the COUNTER_REPORT events (counter.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "counter.h"

/* ------------------------------------------------------------ COUNTER */
void test_counter(void)
{
    int i;
    board();
    CHECK(B(6, 2, 2), B(0x86, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(6, 1, 4, 0), B(0x86, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(6, 1, 2, 2), B(0x86, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(6, 1, 2, 1), B(6, 1, 2, 1));
    EXPECT(fake_counter_enabled[0] && fake_counter_rising[0]);
    for (i = 0; i < 1000; i++)
        counter_event(0);
    CHECK(B(6, 2, 2), B(6, 2, 2, 0, 0, 0x03, 0xE8));
    CHECK(B(6, 3, 2), B(6, 3, 2, 0, 0, 0x03, 0xE8));
    CHECK(B(6, 2, 2), B(6, 2, 2, 0, 0, 0, 0));
    counter_counts[1] = 0xFFFFFFFFu;
    CHECK(B(6, 1, 3, 0), B(6, 1, 3, 0)); /* config starts at 0 */
    counter_counts[1] = 0xFFFFFFFFu;
    counter_event(1); /* wraps */
    CHECK(B(6, 2, 3), B(6, 2, 3, 0, 0, 0, 0));
    CHECK(B(2, 1, 2, 1), B(0x82, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 4, 2), B(2, 4, 2));
    EXPECT(!fake_counter_enabled[0]);
    CHECK(B(6, 2, 2), B(0x86, 2, AIO_ERR_PIN_NOT_CONFIGURED));
}

/* COUNTER WATCH: a COUNTER_REPORT from the counter's interrupt every N counts */
void test_counter_reports(void)
{
    uint8_t i;
    board();
    CHECK(B(6, 4, 2, 0, 3), B(0x86, 4, AIO_ERR_PIN_NOT_CONFIGURED)); /* not a counter */
    CHECK(B(6, 4, 4, 0, 3), B(0x86, 4, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(6, 1, 2, AIO_EDGE_RISING), B(6, 1, 2, AIO_EDGE_RISING));
    CHECK(B(6, 4, 2, 0, 3), B(6, 4, 2, 0, 3));
    fake_fine_now = 2u * 777u;
    for (i = 0; i < 7; i++) {
        fake_drive(2, 1);
        fake_drive(2, 0);
        take();
        if (i == 2 || i == 5) {
            uint8_t want[12] = {AIO_CT_EVENT, AIO_DT_EVENT_COUNTER_REPORT, 2, 0, 0, 0,
                                (uint8_t)(i + 1), 0, 0, 0x03, 0x09, 0};
            want[11] = xor_of(want, 11);
            EXPECT(outn == 12 && !memcmp(out, want, 12));
        } else {
            EXPECT(outn == 0);
        }
    }
    CHECK(B(6, 4, 2, 0, 0), B(6, 4, 2, 0, 0)); /* stop */
    for (i = 0; i < 4; i++) {
        fake_drive(2, 1);
        fake_drive(2, 0);
    }
    take();
    EXPECT(outn == 0);
    CHECK(B(6, 2, 2), B(6, 2, 2, 0, 0, 0, 11));
    /* a new configuration ends the watch */
    CHECK(B(6, 4, 2, 0, 1), B(6, 4, 2, 0, 1));
    CHECK(B(6, 1, 2, AIO_EDGE_RISING), B(6, 1, 2, AIO_EDGE_RISING));
    fake_drive(2, 1);
    take();
    EXPECT(outn == 0);
}

/*
 * test_failsafe.c - host tests of FAILSAFE: the link watchdog and the safe states (failsafe.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"

/* ------------------------------------------------------------ FAILSAFE */
void test_failsafe(void)
{
    board();
    CHECK(B(8, 1, 0, 19), B(0x88, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 1, 0x27, 0x11), B(0x88, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 2, 1, 1, 0, 0), B(0x88, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(8, 2, 13, 4, 0, 0), B(0x88, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 2, 13, 1, 0, 2), B(0x88, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 2, 13, 2, 0x05, 0xDC), B(0x88, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(8, 2, 9, 2, 0x01, 0xF3), B(0x88, 2, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 499 us */
    CHECK(B(2, 1, 13, 3), B(2, 1, 13, 3));
    CHECK(B(5, 1, 9, 0x07, 0xD0), B(5, 1, 9, 0x07, 0xD0));
    CHECK(B(8, 2, 13, 1, 0, 0), B(8, 2, 13, 1, 0, 0));
    CHECK(B(8, 2, 9, 2, 0x05, 0xDC), B(8, 2, 9, 2, 0x05, 0xDC));
    CHECK(B(8, 1, 0, 50), B(8, 1, 0, 50));
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0));
    fake_advance(400); /* 40 ms: fed in time */
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0));
    EXPECT(fake_pin_level[13] == 1 && fake_servo_us[0] == 2000);
    fake_advance(520);
    EXPECT(fake_pin_level[13] == 0 && fake_servo_us[0] == 1500);
    take();
    EXPECT(outn == 3 && out[0] == 0x40 && out[1] == 0x02 && out[2] == 0x42);
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_TRIPPED, 0, 0));
    CHECK(B(2, 3, 13, 1), B(0x82, 3, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(2, 1, 13, 3), B(0x82, 1, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(2, 4, 13), B(0x82, 4, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(5, 2, 9, 0x07, 0xD0), B(0x85, 2, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(5, 1, 10, 0x07, 0xD0), B(0x85, 1, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(2, 2, 13), B(2, 2, 13, 0)); /* reads keep working */
    fake_advance(2000);
    take();
    EXPECT(outn == 0); /* fires once */
    CHECK(B(8, 3), B(8, 3));
    CHECK(B(1, 6), B(1, 6, 0, 0, 0));
    CHECK(B(2, 3, 13, 1), B(2, 3, 13, 1));
    /* ARM also clears the tripped state */
    CHECK(B(8, 1, 0, 20), B(8, 1, 0, 20));
    fake_advance(300);
    take();
    EXPECT(outn == 3 && fake_pin_level[13] == 0);
    CHECK(B(8, 1, 0, 20), B(8, 1, 0, 20));
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0));
    /* the tripped event waits for room in a full transmit buffer */
    fake_tx_capacity = 0;
    fake_advance(300);
    EXPECT(fake_tx_len == 0);
    fake_tx_capacity = 192;
    run();
    take();
    EXPECT(outn == 3 && out[0] == 0x40);
}

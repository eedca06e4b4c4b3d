/*
 * test_gpio.c - host tests of GPIO: set-ups, reads, writes, and the GPIO_CHANGE events of watched pins (gpio.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"

/* ------------------------------------------------------------ GPIO */
void test_gpio(void)
{
    board();
    CHECK(B(2, 1, 13, 0x03), B(2, 1, 13, 0x03)); /* output, high */
    EXPECT(fake_pin_mode[13] == 3 && fake_pin_level[13] == 1);
    CHECK(B(2, 2, 13), B(2, 2, 13, 1));
    CHECK(B(2, 3, 13, 0), B(2, 3, 13, 0));
    EXPECT(fake_pin_level[13] == 0);
    CHECK(B(2, 2, 13), B(2, 2, 13, 0));
    CHECK(B(2, 3, 13, 2), B(0x82, 3, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(2, 1, 7, 0x04), B(2, 1, 7, 0x04)); /* input with pull-up */
    EXPECT(fake_pin_mode[7] == 1);
    CHECK(B(2, 3, 7, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED));
    fake_drive(7, 0); /* the pull-up had it high */
    fake_drive(7, 1);
    fake_drive(7, 0);
    CHECK(B(2, 2, 7), B(2, 2, 7, AIO_GPIO_STATE_ROSE | AIO_GPIO_STATE_FELL));
    CHECK(B(2, 2, 7), B(2, 2, 7, 0)); /* cleared by the read */
    fake_drive(7, 1);
    CHECK(B(2, 2, 7), B(2, 2, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE));
    fake_drive(7, 0);
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00)); /* reconfiguring clears the edges */
    CHECK(B(2, 2, 7), B(2, 2, 7, 0));
    /* flags */
    CHECK(B(2, 1, 5, 0x05), B(0x82, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* output + pull-up */
    CHECK(B(2, 1, 5, 0x02), B(0x82, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* input + level */
    CHECK(B(2, 1, 5, 0x08), B(0x82, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    /* pins */
    CHECK(B(2, 1, 1, 1), B(0x82, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 1, 14, 1), B(0x82, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 2, 0xFF), B(0x82, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 2, 8), B(0x82, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(2, 4, 0), B(0x82, 4, AIO_ERR_PIN_NOT_CAPABLE));
    /* WRITE's refusals in their order: capability, value, role (its handler
     * admits good requests with one test and checks the others one by one) */
    CHECK(B(2, 3, 1, 2), B(0x82, 3, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 3, 14, 0), B(0x82, 3, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 3, 0xFF, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 3, 8, 2), B(0x82, 3, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(2, 3, 8, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(2, 3, 7, 0xFF), B(0x82, 3, AIO_ERR_VALUE_OUT_OF_RANGE)); /* an input */
    CHECK(B(2, 3, 13, 1), B(2, 3, 13, 1));
    EXPECT(fake_pin_level[13] == 1);
    /* one role per pin */
    CHECK(B(5, 1, 3, 0x05, 0xDC), B(5, 1, 3, 0x05, 0xDC));
    CHECK(B(2, 1, 3, 1), B(0x82, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 2, 3), B(0x82, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(2, 3, 3, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED)); /* a PWM pin */
    CHECK(B(2, 4, 3), B(2, 4, 3));
    CHECK(B(2, 1, 3, 1), B(2, 1, 3, 1));
    CHECK(B(2, 4, 3), B(2, 4, 3));
    EXPECT(fake_pin_mode[3] == 0);
    CHECK(B(2, 4, 3), B(2, 4, 3)); /* releasing a free pin */

    /* READ_PIN_ROLES: masks for input, output, PWM, counter, pulse input; bit n = Dn */
    board();
    CHECK(B(1, 8), B(1, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0));
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00));
    CHECK(B(2, 1, 13, 0x01), B(2, 1, 13, 0x01));
    CHECK(B(5, 1, 3, 0x05, 0xDC), B(5, 1, 3, 0x05, 0xDC));
    CHECK(B(5, 1, 9, 0x05, 0xDC), B(5, 1, 9, 0x05, 0xDC));
    CHECK(B(1, 8), B(1, 8, 0x00, 0x80, 0x20, 0x00, 0x02, 0x08, 0x00, 0x00, 0, 0));
    CHECK(B(2, 4, 9), B(2, 4, 9));
    CHECK(B(1, 8), B(1, 8, 0x00, 0x80, 0x20, 0x00, 0x00, 0x08, 0x00, 0x00, 0, 0));
}

/* GPIO_WATCH and the GPIO_CHANGE events sent from the pin-change interrupt */
static void expect_change(int line, uint8_t pin, uint8_t state, uint16_t seq, uint32_t us)
{
    uint8_t want[11] = {AIO_CT_EVENT, AIO_DT_EVENT_GPIO_CHANGE, pin, state,
                        (uint8_t)(seq >> 8), (uint8_t)seq, (uint8_t)(us >> 24),
                        (uint8_t)(us >> 16), (uint8_t)(us >> 8), (uint8_t)us, 0};
    want[10] = xor_of(want, 10);
    take();
    checks++;
    if (outn != 11 || memcmp(out, want, 11)) {
        failures++;
        printf("%s:%d: FAIL\n", __FILE__, line);
        dump("expected", want, 11);
        dump("got", out, outn);
    }
}

void test_gpio_changes(void)
{
    board();
    CHECK(B(2, 5, 7, 1), B(0x82, 5, AIO_ERR_PIN_NOT_CONFIGURED)); /* not an input */
    CHECK(B(2, 1, 13, 0x01), B(2, 1, 13, 0x01));
    CHECK(B(2, 5, 13, 1), B(0x82, 5, AIO_ERR_PIN_NOT_CONFIGURED)); /* an output */
    CHECK(B(2, 5, 1, 1), B(0x82, 5, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00));
    CHECK(B(2, 5, 7, 2), B(0x82, 5, AIO_ERR_VALUE_OUT_OF_RANGE));
    fake_drive(7, 1); /* not watched yet: no event */
    take();
    EXPECT(outn == 0);
    CHECK(B(2, 5, 7, 1), B(2, 5, 7, 1));
    fake_fine_now = 2u * 1234u;
    fake_drive(7, 0);
    expect_change(__LINE__, 7, AIO_GPIO_STATE_FELL, 0, 1234);
    fake_drive(7, 0); /* no change, no event */
    take();
    EXPECT(outn == 0);
    fake_fine_now = 2u * 5000u;
    fake_drive(7, 1);
    expect_change(__LINE__, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE, 1, 5000);
    /* the READ latch is independent of the events */
    CHECK(B(2, 2, 7), B(2, 2, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE | AIO_GPIO_STATE_FELL));
    /* a full transmit buffer drops the event; its sequence number is used up */
    fake_tx_capacity = 5;
    fake_drive(7, 0);
    take();
    EXPECT(outn == 0);
    fake_tx_capacity = 192;
    fake_drive(7, 1);
    expect_change(__LINE__, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE, 3, 5000);
    /* unsubscribe */
    CHECK(B(2, 5, 7, 0), B(2, 5, 7, 0));
    fake_drive(7, 0);
    take();
    EXPECT(outn == 0);
    /* reconfiguring or releasing ends the subscription */
    CHECK(B(2, 5, 7, 1), B(2, 5, 7, 1));
    CHECK(B(2, 1, 7, 0x04), B(2, 1, 7, 0x04));
    fake_drive(7, 1);
    take();
    EXPECT(outn == 0);
    CHECK(B(2, 5, 7, 1), B(2, 5, 7, 1));
    CHECK(B(2, 4, 7), B(2, 4, 7));
    fake_drive(7, 0);
    take();
    EXPECT(outn == 0);
}

/*
 * test_transaction.c - host tests of TRANSACTION: the whole-list check, then the items one by one (transaction.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "i2c.h"
#include "transaction.h"

/* ------------------------------------------------------------ TRANSACTION */
void test_transaction(void)
{
    board();
    CHECK(B(2, 1, 13, 0x01), B(2, 1, 13, 0x01));
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00));
    fake_drive(7, 1);
    /* write D13, read it back, read D7: back to back, every result in order */
    CHECK(B(1, 9, 0x5A, 10, 2, 3, 13, 0, 2, 2, 13, 2, 2, 7),
          B(1, 9, 0x5A, 12, 2, 3, 13, 0, 2, 2, 13, 0, 2, 2, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE));
    EXPECT(fake_pin_level[13] == 0);
    /* a refused item leaves its error reply; the next item still runs */
    CHECK(B(1, 9, 0x5A, 8, 2, 3, 7, 1, 2, 3, 13, 1),
          B(1, 9, 0x5A, 7, 0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED, 2, 3, 13, 1));
    EXPECT(fake_pin_level[13] == 1);
    /* the whole list is checked first: a refused list changes nothing */
    CHECK(B(1, 9, 0x5A, 0), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE));                  /* empty */
    CHECK(B(1, 9, 0x5A, 6, 2, 3, 13, 0, 2, 9), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* unknown */
    CHECK(B(1, 9, 0x5A, 6, 2, 3, 13, 0, 2, 2), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* cut */
    CHECK(B(1, 9, 0x5A, 6, 2, 3, 13, 0, 1, 1), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* reset */
    CHECK(B(1, 9, 0x5A, 8, 2, 3, 13, 0, 1, 9, 0, 0), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* nested */
    CHECK(B(1, 9, 0x5A, 10, 2, 3, 13, 0, 3, 3, 3, 3, 3, 3), /* 4 + 3 x 14 result bytes > 32 */
          B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE));
    EXPECT(fake_pin_level[13] == 1);
    /* variable-length items: an I2C write of two bytes (bus off: a per-item error) */
    CHECK(B(1, 9, 0x5A, 7, 4, 3, 0x50, 0, 2, 0xAA, 0xBB),
          B(1, 9, 0x5A, 3, 0x84, 3, AIO_ERR_I2C_NOT_CONFIGURED));
    /* A declared items length over 32 (issue 28: found by a libFuzzer target; SEQ 0): 40 item
     * bytes, an I2C write of 32 bytes and a GPIO read, so walking the list reaches past
     * the 35 data bytes a request holds.  The whole frame is consumed and refused; nothing
     * is read beyond the request (ASan) and the next frame is answered. */
    {
        static const uint8_t frame[] = {
            1, 9, 0x00, 0x28, 4, 3, 0x50, 0, 0x20, 0xED, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
            0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 2, 13, 0xB7};
        EXPECT(xor_of(frame, sizeof frame) == 0);
        fake_rx_push(frame, sizeof frame);
        run();
        take();
        EXPECT(outn == 4 && out[0] == 0x81 && out[1] == 9 && out[2] == AIO_ERR_VALUE_OUT_OF_RANGE);
        CHECK(B(2, 2, 13), B(2, 2, 13, 1));
    }
    /* the handler does not rely on the parser: a length byte over what the request holds
     * is refused before a byte past rq->len is read */
    {
        aio_request_t rq = {AIO_CT_MISC, AIO_DT_MISC_TRANSACTION, AIO_REQUEST_DATA_MAX, {0}};
        aio_reply_t rp;
        memset(rq.data + 2, 2, AIO_REQUEST_DATA_MAX - 2u); /* GPIO READ D2, back to back */
        rq.data[1] = 40;
        EXPECT(transaction_handle(&rq, &rp) == AIO_ERR_VALUE_OUT_OF_RANGE);
        rq.data[1] = AIO_REQUEST_DATA_MAX - 1u; /* one more than it holds */
        EXPECT(transaction_handle(&rq, &rp) == AIO_ERR_VALUE_OUT_OF_RANGE);
    }
    /* nor does I2C WRITE: a length byte of 32 with 2 data bytes sent writes nothing */
    {
        aio_request_t rq = {AIO_CT_I2C, AIO_DT_I2C_WRITE, 5, {0x50, 0x10, 32, 0xAA, 0xBB}};
        aio_reply_t rp;
        CHECK(B(4, 1, 0), B(4, 1, 0));
        fake_i2c_mem[0x10] = 0x11;
        EXPECT(i2c_handle(&rq, &rp) == AIO_ERR_VALUE_OUT_OF_RANGE);
        EXPECT(fake_i2c_mem[0x10] == 0x11);
        rq.data[2] = 2;
        EXPECT(i2c_handle(&rq, &rp) == 0 && fake_i2c_mem[0x10] == 0xAA);
    }
    /* six servo widths at once */
    board();
    {
        uint8_t pin;
        for (pin = 2; pin <= 7; pin++)
            CHECK(B(5, 1, pin, 0, 0), B(5, 1, pin, 0, 0));
    }
    CHECK(B(1, 9, 0x5A, 30, 5, 2, 2, 0x05, 0xDC, 5, 2, 3, 0x05, 0xDD, 5, 2, 4, 0x05, 0xDE, 5, 2, 5,
            0x05, 0xDF, 5, 2, 6, 0x05, 0xE0, 5, 2, 7, 0x05, 0xE1),
          B(1, 9, 0x5A, 30, 5, 2, 2, 0x05, 0xDC, 5, 2, 3, 0x05, 0xDD, 5, 2, 4, 0x05, 0xDE, 5, 2, 5,
            0x05, 0xDF, 5, 2, 6, 0x05, 0xE0, 5, 2, 7, 0x05, 0xE1));
}

/*
 * test_i2c.c - host tests of I2C: the bridge (i2c.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "i2c.h"

/* ------------------------------------------------------------ I2C */
void test_i2c(void)
{
    board();
    CHECK(B(4, 2, 0x50, 0, 1), B(0x84, 2, AIO_ERR_I2C_NOT_CONFIGURED));
    CHECK(B(4, 3, 0x50, 0, 0), B(0x84, 3, AIO_ERR_I2C_NOT_CONFIGURED));
    CHECK(B(4, 1, 2), B(0x84, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(4, 1, 1), B(4, 1, 1));
    CHECK(B(4, 3, 0x50, 0x10, 4, 0xDE, 0xAD, 0xBE, 0xEF), B(4, 3, 0x50, 0x10, 4));
    EXPECT(!memcmp(fake_i2c_mem + 0x10, "\xDE\xAD\xBE\xEF", 4));
    CHECK(B(4, 2, 0x50, 0x11, 3), B(4, 2, 0x50, 0x11, 3, 0xAD, 0xBE, 0xEF));
    CHECK(B(4, 3, 0x50, 0x20, 0), B(4, 3, 0x50, 0x20, 0));
    CHECK(B(4, 2, 0x51, 0, 1), B(0x84, 2, AIO_ERR_I2C_NACK_ADDRESS));
    CHECK(B(4, 3, 0x51, 0, 1, 9), B(0x84, 3, AIO_ERR_I2C_NACK_ADDRESS));
    CHECK(B(4, 3, 0x50, 0xF0, 1, 9), B(0x84, 3, AIO_ERR_I2C_NACK_DATA));
    CHECK(B(4, 2, 0x80, 0, 1), B(0x84, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(4, 2, 0x50, 0, 0), B(0x84, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(4, 2, 0x50, 0, 33), B(0x84, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    fake_i2c_stuck = true;
    CHECK(B(4, 2, 0x50, 0, 1), B(0x84, 2, AIO_ERR_I2C_TIMEOUT));
    EXPECT(fake_i2c_resets == 1);
    fake_i2c_stuck = false;
    /* 32 bytes each way */
    {
        uint8_t req[3 + 3 + 32], rep[5 + 32];
        int i;
        req[0] = 4; req[1] = 3; req[2] = 0x50; req[3] = 0x40; req[4] = 32;
        for (i = 0; i < 32; i++)
            req[5 + i] = (uint8_t)(i * 7);
        CHECK(req, 37, B(4, 3, 0x50, 0x40, 32));
        rep[0] = 4; rep[1] = 2; rep[2] = 0x50; rep[3] = 0x40; rep[4] = 32;
        memcpy(rep + 5, req + 5, 32);
        CHECK(B(4, 2, 0x50, 0x40, 32), rep, 37);
    }
    /* a length beyond 32 keeps the frame boundaries: 40 data bytes are skipped */
    {
        uint8_t req[5 + 40];
        memset(req, 0x5A, sizeof req);
        req[0] = 4; req[1] = 3; req[2] = 0x50; req[3] = 0; req[4] = 40;
        CHECK(req, sizeof req, B(0x84, 3, AIO_ERR_VALUE_OUT_OF_RANGE));
        CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    }
}

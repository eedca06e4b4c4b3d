/*
 * test_i2cblock.c - host tests of the I2C blocks read every stream period (i2cblock.c):
 * the TWI steps the state machine takes (recorded by the fake HAL's hal_twi_go), the
 * statuses a test answers with (i2cblock_twi, as the TWI interrupt would), and the
 * sample frames that come out.  Part of `make -C firmware test` (see host_check.h).
 */
#include <string.h>

#include "host_check.h"
#include "i2cblock.h"

/* Advances until the state machine issues `action` (bounded): 1 if it did. */
static int until(uint8_t action)
{
    for (int guard = 0; guard < 400; guard++) {
        if (fake_twi_action == action)
            return 1;
        fake_advance(1);
        run();
    }
    return 0;
}

/* Answers the step in flight with `status` (and a received byte). */
static void answer(uint8_t status, uint8_t data)
{
    fake_twi_action = 0xFFu;
    i2cblock_twi(status, data);
}

/* The last sample frame's values (after the 11-byte header), or NULL. */
static const uint8_t *sample_values(void)
{
    for (int guard = 0; guard < 50; guard++) {
        run();
        take();
        if (outn >= 12 && out[0] == 0x40 && out[1] == 0x01)
            return out + 11;
        fake_advance(1);
    }
    return NULL;
}

void test_i2cblock(void)
{
    const uint8_t *v;
    board();
    CHECK(B(4, 1, 1), B(4, 1, 1));
    CHECK(B(4, 4, 0, 0x68, 0x3B, 2), B(4, 4, 0, 0x68, 0x3B, 2));
    /* 10 ms, the blocks only */
    CHECK(B(7, 1, 0, AIO_STREAM_I2C, 0x27, 0x10), B(7, 1, 0, AIO_STREAM_I2C, 0x27, 0x10));
    CHECK(B(4, 2, 0x50, 0, 1), B(0x84, 2, AIO_ERR_I2C_STREAMING));

    /* a good read: START, SLA+W, REG, repeated START, SLA+R, 2 bytes (ACK, NACK), STOP */
    EXPECT(until(HAL_TWI_GO_START));
    answer(0x08, 0);
    EXPECT(fake_twi_action == HAL_TWI_GO_WRITE && fake_twi_arg == 0xD0);
    answer(0x18, 0);
    EXPECT(fake_twi_action == HAL_TWI_GO_WRITE && fake_twi_arg == 0x3B);
    answer(0x28, 0);
    EXPECT(fake_twi_action == HAL_TWI_GO_START);
    answer(0x10, 0);
    EXPECT(fake_twi_action == HAL_TWI_GO_WRITE && fake_twi_arg == 0xD1);
    answer(0x40, 0);
    EXPECT(fake_twi_action == HAL_TWI_GO_READ && fake_twi_arg == 1);
    answer(0x50, 0xAB);
    EXPECT(fake_twi_action == HAL_TWI_GO_READ && fake_twi_arg == 0);
    answer(0x58, 0xCD);
    EXPECT(fake_twi_action == HAL_TWI_GO_STOP);
    v = sample_values();
    EXPECT(v && out[10] == 6 && !memcmp(v, "\x02\x00\xAB\xCD\x00\x00", 6));

    /* a NACKed address: the slot's status carries the code, the count goes up */
    EXPECT(until(HAL_TWI_GO_START));
    answer(0x08, 0);
    answer(0x20, 0);
    EXPECT(fake_twi_action == HAL_TWI_GO_STOP);
    v = sample_values();
    EXPECT(v && v[0] == 2 && v[1] == AIO_ERR_I2C_NACK_ADDRESS);

    /* no answer at all: the next sampling instant cuts the read off as a timeout */
    EXPECT(until(HAL_TWI_GO_START));
    fake_twi_action = 0xFFu;
    v = sample_values();
    for (int guard = 0; guard < 200 && !v; guard++) {
        fake_advance(1);
        v = sample_values();
    }
    EXPECT(v && v[0] == 2 && v[1] == AIO_ERR_I2C_TIMEOUT);
    CHECK(B(7, 2), B(7, 2, 0, 3));
    CHECK(B(4, 5, 0), B(4, 5, 0, 0, 2, AIO_ERR_I2C_TIMEOUT));
    CHECK(B(4, 2, 0x50, 0, 1), B(4, 2, 0x50, 0, 1, fake_i2c_mem[0])); /* the bus is free again */
}

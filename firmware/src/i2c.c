/*
 * i2c.c - I2C class (CT 0x04).
 *
 * READ:  START, SLA+W, REG, repeated START, SLA+R, LEN bytes (ACK all but the
 *        last), STOP.
 * WRITE: START, SLA+W, REG, data, STOP.
 * Every step is bounded by the HAL (2 ms); a timeout resets the TWI unit.
 */
#include "i2c.h"

#include "hal.h"
#include "i2cblock.h"

static uint8_t enabled;

void i2c_init(void) { enabled = 0; }

uint8_t i2c_enabled(void) { return enabled; }

/* Maps a failed step to an error code and cleans up the bus. */
static uint8_t fail(uint8_t status, uint8_t nack_code)
{
    if (status == HAL_TWI_TIMEOUT) {
        hal_twi_reset();
        return AIO_ERR_I2C_TIMEOUT;
    }
    hal_twi_stop();
    return nack_code;
}

/* START + SLA+W + REG: 0 or an error code. */
static uint8_t begin(uint8_t addr, uint8_t reg)
{
    uint8_t st = hal_twi_start();
    if (st != HAL_TWI_OK)
        return fail(st, AIO_ERR_I2C_TIMEOUT);
    st = hal_twi_write((uint8_t)(addr << 1));
    if (st != HAL_TWI_OK)
        return fail(st, AIO_ERR_I2C_NACK_ADDRESS);
    st = hal_twi_write(reg);
    if (st != HAL_TWI_OK)
        return fail(st, AIO_ERR_I2C_NACK_DATA);
    return 0;
}

uint8_t i2c_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t addr = rq->data[0], reg = rq->data[1], len = rq->data[2];
    uint8_t i, st, err;

#if AIO_WITH_I2C_STREAM
    if (rq->dt == AIO_DT_I2C_BLOCK || rq->dt == AIO_DT_I2C_BLOCK_STATUS)
        return i2cblock_handle(rq, rp);
#else
    if (rq->dt == AIO_DT_I2C_BLOCK || rq->dt == AIO_DT_I2C_BLOCK_STATUS)
        return AIO_ERR_NOT_IN_IMAGE; /* this build profile leaves the I2C stream out */
#endif
    if (rq->dt != AIO_DT_I2C_CONFIG && rq->dt != AIO_DT_I2C_READ && rq->dt != AIO_DT_I2C_WRITE)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (i2cblock_active())
        return AIO_ERR_I2C_STREAMING; /* the stream's interrupt-driven reads own the bus */
    if (rq->dt == AIO_DT_I2C_CONFIG) {
        if (rq->data[0] > AIO_I2C_KHZ_400)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        hal_twi_init(rq->data[0]);
        enabled = 1;
        return aio_echo(rq, rp);
    }
    if (!enabled)
        return AIO_ERR_I2C_NOT_CONFIGURED;
    if (addr > 0x7Fu || len > AIO_I2C_MAX_LENGTH)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    rp->data[0] = addr;
    rp->data[1] = reg;
    rp->data[2] = len;

    if (rq->dt == AIO_DT_I2C_READ) {
        if (len == 0)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        err = begin(addr, reg);
        if (err)
            return err;
        st = hal_twi_start();
        if (st != HAL_TWI_OK)
            return fail(st, AIO_ERR_I2C_TIMEOUT);
        st = hal_twi_write((uint8_t)(addr << 1 | 1u));
        if (st != HAL_TWI_OK)
            return fail(st, AIO_ERR_I2C_NACK_ADDRESS);
        for (i = 0; i < len; i++) {
            st = hal_twi_read(i + 1u < len, &rp->data[3 + i]);
            if (st != HAL_TWI_OK)
                return fail(st, AIO_ERR_I2C_TIMEOUT);
        }
        hal_twi_stop();
        rp->len = (uint8_t)(3u + len);
        return 0;
    }

    /* WRITE: the data bytes are the request's own (never past rq->len) */
    if (rq->len != (uint8_t)(3u + len))
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    err = begin(addr, reg);
    if (err)
        return err;
    for (i = 0; i < len; i++) {
        st = hal_twi_write(rq->data[3 + i]);
        if (st != HAL_TWI_OK)
            return fail(st, AIO_ERR_I2C_NACK_DATA);
    }
    hal_twi_stop();
    rp->len = 3;
    return 0;
}

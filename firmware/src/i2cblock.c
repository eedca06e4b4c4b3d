/*
 * i2cblock.c - I2C register blocks read by the board every stream period.
 *
 * Per slot: START, SLA+W, REG, repeated START, SLA+R, LEN bytes (ACK all but the last);
 * the next slot follows with a repeated START, the last with STOP.  Each step is one
 * TWI interrupt, so a 14-byte read at 400 kHz (~400 us) overlaps the ADC chain and the
 * main loop instead of blocking them.  RAM: 3 bytes a slot plus the state; the data go
 * straight into the sample frame.
 */
#include "i2cblock.h"

#if AIO_WITH_I2C_STREAM

#include "hal.h"
#include "i2c.h"
#include "stream.h"

typedef struct {
    uint8_t addr, reg, len;
    uint16_t errors;
    uint8_t last_error;
} block_t;

static block_t blocks[AIO_I2C_BLOCK_SLOTS];
static volatile uint8_t step;  /* STEP_* of the running read, or STEP_IDLE */
static uint8_t slot;           /* the slot being read */
static uint8_t got;            /* its bytes read so far */
static uint8_t *out;           /* its status byte in the frame (data follow) */

enum { STEP_IDLE, STEP_START, STEP_SLA_W, STEP_REG, STEP_RESTART, STEP_SLA_R, STEP_DATA };

void i2cblock_init(void)
{
    uint8_t s;
    step = STEP_IDLE;
    for (s = 0; s < AIO_I2C_BLOCK_SLOTS; s++)
        blocks[s].len = 0;
}

uint8_t i2cblock_active(void) { return stream_running() && stream_reads_i2c(); }

uint8_t i2cblock_bytes(void)
{
    uint8_t s, n = 0;
    for (s = 0; s < AIO_I2C_BLOCK_SLOTS; s++)
        n = (uint8_t)(n + 2u + blocks[s].len);
    return n;
}

uint8_t i2cblock_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t s = rq->data[0], len = rq->data[3], n, i;
    block_t *b;

    if (s >= AIO_I2C_BLOCK_SLOTS)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    b = &blocks[s];
    if (rq->dt == AIO_DT_I2C_BLOCK_STATUS) {
        uint8_t st = hal_irq_save();
        rp->data[0] = s;
        aio_put16(rp->data + 1, b->errors);
        rp->data[3] = b->last_error;
        hal_irq_restore(st);
        rp->len = 4;
        return 0;
    }
    if (rq->data[1] > 0x7Fu)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    for (n = len, i = 0; i < AIO_I2C_BLOCK_SLOTS; i++)
        if (i != s)
            n = (uint8_t)(n + blocks[i].len);
    if (len > AIO_I2C_BLOCK_BYTES || n > AIO_I2C_BLOCK_BYTES)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (i2cblock_active())
        return AIO_ERR_I2C_STREAMING; /* the running stream's layout would change */
    b->addr = rq->data[1];
    b->reg = rq->data[2];
    b->len = len;
    b->errors = 0;
    b->last_error = 0;
    return aio_echo(rq, rp);
}

/* Starts slot `from` or the next configured one after it (a START, or a repeated
 * START while the bus is held); STOP and done when none is left. */
static void next_slot(uint8_t from)
{
    for (slot = from; slot < AIO_I2C_BLOCK_SLOTS; slot++) {
        if (blocks[slot].len)
            break;
        out += 2; /* a free slot: its header only (length 0, status 0) */
    }
    if (slot >= AIO_I2C_BLOCK_SLOTS) {
        hal_twi_go(HAL_TWI_GO_STOP, 0);
        step = STEP_IDLE;
        stream_i2c_done();
        return;
    }
    out++; /* past the length: the status byte */
    got = 0;
    step = STEP_START;
    hal_twi_go(HAL_TWI_GO_START, 0);
}

uint8_t i2cblock_begin(uint8_t *dst)
{
    uint8_t s, *p = dst, any = 0;
    for (s = 0; s < AIO_I2C_BLOCK_SLOTS; s++) {
        *p++ = blocks[s].len;
        *p = 0;
        p += 1u + blocks[s].len;
        any |= blocks[s].len;
    }
    if (!any)
        return 0;
    if (step != STEP_IDLE)
        hal_twi_go(HAL_TWI_GO_RESET, 0); /* a read whose sample was dropped */
    out = dst;
    next_slot(0);
    return 1;
}

/* The current slot failed with `code`: count it and mark its status byte. */
static void mark(uint8_t code)
{
    block_t *b = &blocks[slot];
    b->errors++;
    b->last_error = code;
    *out = code;
    out += 1u + b->len;
}

/* A step failed: release the bus (a reset if the unit is lost) and go on. */
static void fail(uint8_t code)
{
    mark(code);
    hal_twi_go(code == AIO_ERR_I2C_TIMEOUT ? HAL_TWI_GO_RESET : HAL_TWI_GO_STOP, 0);
    next_slot((uint8_t)(slot + 1u));
}

void i2cblock_twi(uint8_t status, uint8_t data)
{
    block_t *b = &blocks[slot];
    switch (step) {
    case STEP_START:
    case STEP_RESTART:
        if (status != 0x08u && status != 0x10u)
            return fail(AIO_ERR_I2C_TIMEOUT);
        hal_twi_go(HAL_TWI_GO_WRITE, (uint8_t)(b->addr << 1 | (step == STEP_RESTART)));
        step = step == STEP_START ? STEP_SLA_W : STEP_SLA_R;
        return;
    case STEP_SLA_W:
        /* simavr 1.6 reports SLA+W's acknowledge as 0x28/0x30 (data); 0x28 cannot
         * come here on the hardware */
        if (status != 0x18u && status != 0x28u)
            return fail(status == 0x20u || status == 0x30u ? AIO_ERR_I2C_NACK_ADDRESS : AIO_ERR_I2C_TIMEOUT);
        hal_twi_go(HAL_TWI_GO_WRITE, b->reg);
        step = STEP_REG;
        return;
    case STEP_REG:
        if (status != 0x28u)
            return fail(status == 0x30u ? AIO_ERR_I2C_NACK_DATA : AIO_ERR_I2C_TIMEOUT);
        hal_twi_go(HAL_TWI_GO_START, 0);
        step = STEP_RESTART;
        return;
    case STEP_SLA_R:
        if (status != 0x40u)
            return fail(status == 0x48u ? AIO_ERR_I2C_NACK_ADDRESS : AIO_ERR_I2C_TIMEOUT);
        hal_twi_go(HAL_TWI_GO_READ, b->len > 1u);
        step = STEP_DATA;
        return;
    case STEP_DATA:
        if (status != 0x50u && status != 0x58u)
            return fail(AIO_ERR_I2C_TIMEOUT);
        out[1u + got++] = data;
        if (got < b->len) {
            hal_twi_go(HAL_TWI_GO_READ, (uint8_t)(got + 1u < b->len));
            return;
        }
        out += 1u + b->len; /* status stays 0: read */
        next_slot((uint8_t)(slot + 1u));
        return;
    default:
        return; /* a stale interrupt after an abort */
    }
}

void i2cblock_abort(void)
{
    uint8_t s = hal_irq_save();
    if (step != STEP_IDLE) {
        step = STEP_IDLE;
        hal_twi_go(HAL_TWI_GO_RESET, 0);
        for (;;) {
            mark(AIO_ERR_I2C_TIMEOUT);
            for (slot++; slot < AIO_I2C_BLOCK_SLOTS && !blocks[slot].len; slot++)
                out += 2;
            if (slot >= AIO_I2C_BLOCK_SLOTS)
                break;
            out++;
        }
        hal_irq_restore(s);
        stream_i2c_done();
        return;
    }
    hal_irq_restore(s);
}

void i2cblock_cancel(void)
{
    uint8_t s = hal_irq_save();
    if (step != STEP_IDLE) {
        step = STEP_IDLE;
        hal_twi_go(HAL_TWI_GO_RESET, 0);
    }
    hal_irq_restore(s);
}

#endif /* AIO_WITH_I2C_STREAM */

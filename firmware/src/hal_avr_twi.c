/*
 * hal_avr_twi.c - hal.h's TWI (I2C master) for the ATmega328P: the i2c.c
 * bridge's start, byte and stop steps, each bounded to 2 ms.  Apart from
 * hal_avr.c (the rest of the chip) by idea; it shares no state with it.
 */
#include <avr/io.h>
#include <util/delay.h>

#include "hal.h"
#include "hal_board.h"

#define TWI_STEP_TICKS 20u /* 2 ms */

static uint8_t twi_fast;

/* Waits for TWINT, at most 2 ms. */
static uint8_t twi_wait(void)
{
    uint16_t start = hal_ticks();
    while (!(TWCR & _BV(TWINT)))
        if ((uint16_t)(hal_ticks() - start) > TWI_STEP_TICKS)
            return 0;
    return 1;
}

/* A byte and its acknowledge take 9 SCL periods; TWINT cannot legitimately
 * come earlier.  Waiting that long before polling costs nothing on the
 * hardware and keeps us from acting on a stale TWINT/TWSR in emulators
 * (simavr 1.6 leaves TWINT readable as set while the byte is on the bus). */
static uint8_t twi_byte_wait(void)
{
    if (twi_fast)
        _delay_us(23);
    else
        _delay_us(91);
    return twi_wait();
}

void hal_twi_init(uint8_t fast)
{
    HAL_TWI_PULLUPS(); /* internal pull-ups on SDA/SCL */
    TWSR = 0;
    TWBR = fast ? 12u : 72u; /* (16 MHz / f - 16) / 2 */
    twi_fast = fast;
    TWCR = _BV(TWEN);
}

void hal_twi_reset(void)
{
    TWCR = 0;
    TWCR = _BV(TWEN);
}

uint8_t hal_twi_start(void)
{
    uint8_t st;
    TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN);
    if (!twi_wait())
        return HAL_TWI_TIMEOUT;
    st = TWSR & 0xF8u;
    return (st == 0x08u || st == 0x10u) ? HAL_TWI_OK : HAL_TWI_TIMEOUT;
}

uint8_t hal_twi_write(uint8_t byte)
{
    uint8_t st;
    TWDR = byte;
    TWCR = _BV(TWINT) | _BV(TWEN);
    if (!twi_byte_wait())
        return HAL_TWI_TIMEOUT;
    st = TWSR & 0xF8u;
    if (st == 0x18u || st == 0x28u || st == 0x40u)
        return HAL_TWI_OK;
    if (st == 0x20u || st == 0x30u || st == 0x48u)
        return HAL_TWI_NACK;
    return HAL_TWI_TIMEOUT; /* arbitration lost or bus error: reset the unit */
}

uint8_t hal_twi_read(bool ack, uint8_t *byte)
{
    uint8_t st;
    TWCR = (uint8_t)(_BV(TWINT) | _BV(TWEN) | (ack ? _BV(TWEA) : 0));
    if (!twi_byte_wait())
        return HAL_TWI_TIMEOUT;
    st = TWSR & 0xF8u;
    *byte = TWDR;
    return (st == 0x50u || st == 0x58u) ? HAL_TWI_OK : HAL_TWI_TIMEOUT;
}

void hal_twi_stop(void)
{
    uint16_t start = hal_ticks();
    TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN);
    while (TWCR & _BV(TWSTO))
        if ((uint16_t)(hal_ticks() - start) > TWI_STEP_TICKS) {
            hal_twi_reset();
            return;
        }
}

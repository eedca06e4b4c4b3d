/* i2c.h - I2C class: TWI master bridge. */
#ifndef I2C_H
#define I2C_H

#include <stdint.h>

#include "aio.h"

void i2c_init(void);
uint8_t i2c_enabled(void);
uint8_t i2c_handle(const aio_request_t *rq, aio_reply_t *rp);

#endif

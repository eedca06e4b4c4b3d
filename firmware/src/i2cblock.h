/* i2cblock.h - I2C register blocks the stream reads each period (I2C BLOCK, CT 0x04).
 *
 * The read is a TWI state machine driven by the TWI interrupt: stream.c starts it at
 * the sampling instant (i2cblock_begin) and it reads every configured slot in turn
 * (repeated START between slots) straight into the sample frame, then calls
 * stream_i2c_done().  A step with an unexpected TWI status marks that slot's status
 * byte with the error code, counts it, and the machine goes on to the next slot; a
 * read still running at the next sampling instant is cut off (i2cblock_abort). */
#ifndef I2CBLOCK_H
#define I2CBLOCK_H

#include <stdint.h>

#include "aio.h"

#if AIO_WITH_I2C_STREAM
void i2cblock_init(void);
/* I2C BLOCK (DT 0x04) and I2C BLOCK STATUS (DT 0x05). */
uint8_t i2cblock_handle(const aio_request_t *rq, aio_reply_t *rp);
/* Bytes the blocks take in a sample: per slot a length, a status and the data. */
uint8_t i2cblock_bytes(void);
/* Interrupt context: write the slots' headers at dst and start reading into it;
 * 0 if there is nothing to read (stream_i2c_done is not called then). */
uint8_t i2cblock_begin(uint8_t *dst);
/* The read did not end within its period: reset the TWI, mark the unread slots as
 * timed out and count them; calls stream_i2c_done(). */
void i2cblock_abort(void);
/* The stream stopped: end a read silently (its frame is never sent). */
void i2cblock_cancel(void);
/* The stream owns the bus (a read may run): one-shot transfers are refused. */
uint8_t i2cblock_active(void);
/* TWI interrupt: the unit finished a step with this status (TWSR & 0xF8) and data. */
void i2cblock_twi(uint8_t status, uint8_t data);
#else
static inline void i2cblock_init(void) {}
static inline uint8_t i2cblock_bytes(void) { return 0; }
static inline uint8_t i2cblock_begin(uint8_t *dst) { (void)dst; return 0; }
static inline void i2cblock_abort(void) {}
static inline void i2cblock_cancel(void) {}
static inline uint8_t i2cblock_active(void) { return 0; }
#endif

#endif

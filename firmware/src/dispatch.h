/* dispatch.h - hands a parsed request to its class sub-parser and frames the reply. */
#ifndef DISPATCH_H
#define DISPATCH_H

#include <stdint.h>

#include "aio.h"

/* Executes rq and writes the reply frame (success or error) to frame
 * (AIO_FRAME_MAX bytes); returns its length. */
uint8_t dispatch(const aio_request_t *rq, uint8_t *frame);
/* Whether requests of this class never wait (no ADC conversion, I2C transfer
 * or EEPROM write): their replies may be built in the transmit buffer, which
 * holds back interrupt frames (stream samples, events) meanwhile.
 * STREAM is not quick: a STOP reply counts the samples sent before it (the
 * next sequence number), so it must be queued after stop() ran, behind every
 * sample an interrupt finished until then; built in space claimed before, it
 * would overtake a sample finished in between, which then reached the host
 * after the stream had ended (and a new stream's first samples). */
static inline __attribute__((always_inline)) uint8_t dispatch_quick(uint8_t ct)
{
    _Static_assert(AIO_CT_PWM + 1u == AIO_CT_COUNTER, "PWM..COUNTER are one range");
    return ct == AIO_CT_GPIO || (uint8_t)(ct - AIO_CT_PWM) <= AIO_CT_COUNTER - AIO_CT_PWM ||
           ct == AIO_CT_FAILSAFE;
}
/* Writes the 4-byte error reply CT DT CODE CS; returns 4. */
uint8_t dispatch_error(uint8_t ct, uint8_t dt, uint8_t code, uint8_t *frame);

#endif

/* dispatch.h - hands a parsed request to its class sub-parser and frames the reply. */
#ifndef DISPATCH_H
#define DISPATCH_H

#include <stdint.h>

#include "aio.h"

/* Executes rq and writes the reply frame (success or error) to frame
 * (AIO_FRAME_MAX bytes); returns its length. */
uint8_t dispatch(const aio_request_t *rq, uint8_t *frame);
/* Writes the 4-byte error reply CT DT CODE CS; returns 4. */
uint8_t dispatch_error(uint8_t ct, uint8_t dt, uint8_t code, uint8_t *frame);

#endif

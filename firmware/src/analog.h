/* analog.h - ANALOG class and the shared blocking conversion. */
#ifndef ANALOG_H
#define ANALOG_H

#include <stdint.h>

#include "aio.h"

/* One blocking conversion (channel 0-5 against AVCC, 8 = temperature);
 * shares the ADC with a running stream. */
uint16_t analog_convert(uint8_t channel);
uint8_t analog_handle(const aio_request_t *rq, aio_reply_t *rp);

#endif

/* analog.h - ANALOG class, the shared blocking conversion and watched channels. */
#ifndef ANALOG_H
#define ANALOG_H

#include <stdint.h>

#include "aio.h"

/* Bit n: channel n is watched (WATCH); the tick interrupt reads it. */
extern volatile uint8_t analog_watching;

void analog_init(void);
/* One blocking conversion (channel 0-5 against AVCC, 8 = temperature);
 * shares the ADC with a running stream and the watched channels. */
uint16_t analog_convert(uint8_t channel);
uint8_t analog_handle(const aio_request_t *rq, aio_reply_t *rp);
/* The 100 us tick (interrupt context): may start a watched channel's conversion. */
void analog_tick(void);
/* ADC interrupt: a conversion started by hal_adc_start() finished (the
 * watch's or a stream's). */
void analog_adc_done(uint16_t value);
/* Bit n: channel n is watched. */
uint8_t analog_watched(void);

#endif

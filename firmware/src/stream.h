/* stream.h - STREAM class: periodic samples sent from interrupts (protocol.md 7.2). */
#ifndef STREAM_H
#define STREAM_H

#include <stdint.h>

#include "aio.h"

void stream_init(void);
uint8_t stream_handle(const aio_request_t *rq, aio_reply_t *rp);
uint8_t stream_running(void);
/* A stream that converts analog channels runs (the ADC is its own). */
uint8_t stream_converts(void);
/* The stream timer's alarm (interrupts enabled): a sampling instant. */
void stream_alarm(void);
/* ADC interrupt: a conversion started by hal_adc_start() finished. */
void stream_adc_done(uint16_t value);
/* Blocking conversions in the main loop take the ADC between these two. */
void stream_adc_acquire(void);
void stream_adc_release(void);
/* The chain's ADC clock, 16 MHz >> shift: the slowest whose chain for
 * `channels` ends within 7/8 of the period (0: none). */
uint8_t stream_adc_clock(uint8_t channels, uint16_t period_us);
/* Bytes per second a stream needs vs the link: nonzero if admitted. */
/* The stream carries I2C blocks (i2cblock.c reads them while it runs). */
uint8_t stream_reads_i2c(void);
/* i2cblock.c (TWI interrupt): the sample's blocks are read or marked. */
void stream_i2c_done(void);
uint8_t stream_admit(uint8_t value_bytes, uint16_t period_us, uint32_t baud);

#endif

/* pulse.h - the edge-timing layer pulse-width users share (PULSE_IN now, the sonar's echo
 * next): a channel is one pin whose high pulses the pin-change interrupt stamps at both
 * edges (hal_stamp, as encoder.c's edges); the main loop takes a complete pulse's width.
 *
 * It stays off the encoders' edge path: hal_avr.c's pin-change vector calls
 * pulse_edges() through a trampoline only while a channel is in use (pulse_active), so an
 * image or a session without pulse inputs pays one byte test per edge. */
#ifndef PULSE_H
#define PULSE_H

#include <stdint.h>

#include "aio.h"

/* the layer is in an image with either user */
#define AIO_WITH_PULSE (AIO_WITH_PULSE_IN || AIO_WITH_SONAR)

#if AIO_WITH_PULSE

/* the pulse inputs' slots, then one channel the sonars share (one measures at a time) */
#define PULSE_CHANNELS ((AIO_WITH_PULSE_IN ? AIO_PULSE_IN_SLOTS : 0u) + (AIO_WITH_SONAR ? 1u : 0u))

typedef struct {
    uint16_t mask;             /* the pin's bit in hal_pin_levels(); 0: channel free */
    uint16_t rise_low;         /* hal_stamp of the rising edge of the pulse under way */
    uint8_t rise_sub;
    uint8_t high;              /* a rising edge was stamped, its fall not yet */
    uint16_t start_low, end_low; /* the last complete pulse's edges */
    uint8_t start_sub, end_sub;
    uint8_t done;              /* a complete pulse waits for pulse_take() */
} pulse_chan_t;

extern pulse_chan_t pulse_chans[PULSE_CHANNELS];
extern volatile uint8_t pulse_active; /* some channel is in use */

/* Interrupt context (pin-change vector): the levels of D2-D13 now. */
void pulse_edges(uint16_t levels);
/* Main loop: start (mask = pin bit) or end (0) channel c; the pins' interrupts follow. */
void pulse_watch(uint8_t c, uint16_t mask);
/* Main loop: 1 and the width of channel c's last complete pulse in microseconds (and its
 * end in hal_micros() time) if one ended since the last take, else 0. */
uint8_t pulse_take(uint8_t c, uint32_t *width_us, uint32_t *end_us);
/* Pins the channels watch through pin-change interrupts (bit n = Dn). */
uint16_t pulse_pcint_mask(void);
void pulse_init(void);

#else
static inline uint16_t pulse_pcint_mask(void) { return 0; }
static inline void pulse_init(void) {}
#endif /* AIO_WITH_PULSE */

#endif

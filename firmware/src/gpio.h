/* gpio.h - GPIO class: digital inputs/outputs with latched edges. */
#ifndef GPIO_H
#define GPIO_H

#include <stdint.h>

#include "aio.h"

void gpio_init(void);
uint8_t gpio_handle(const aio_request_t *rq, aio_reply_t *rp);
/* GPIO WRITE alone (the dispatcher's short path for the hottest request):
 * 0 or gpio_handle's error for it, without the reply, which echoes the
 * request. */
uint8_t gpio_write(const aio_request_t *rq);
void gpio_release(uint8_t pin);
/* The GPIO inputs the pin-change interrupts watch (the encoders add theirs). */
extern volatile uint16_t gpio_watch;
uint16_t gpio_watch_mask(void);
/* Pin-change interrupt: the levels of D2-D13 now (bit n = Dn). */
void gpio_pin_change(uint16_t levels);
/* Main loop: edges of watched inputs that have no edge interrupt (AIO_PINS_POLLED_EDGES);
 * nothing on a board where every pin has one. */
void gpio_poll(void);
/* Edges of GPIO inputs since the previous call (for stream samples); clears them. */
void gpio_take_stream_edges(uint16_t *rose, uint16_t *fell);

#endif

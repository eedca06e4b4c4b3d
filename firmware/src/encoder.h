/* encoder.h - ENCODER class: quadrature encoders on any two digital pins (issue 27). */
#ifndef ENCODER_H
#define ENCODER_H

#include <stdint.h>

#include "aio.h"

void encoder_init(void);
uint8_t encoder_handle(const aio_request_t *rq, aio_reply_t *rp);
/* Ends the encoder that uses `pin` (either of its pins): both pins become free. */
void encoder_release(uint8_t pin);
/* Pins the encoders watch through pin-change interrupts (bit n = Dn). */
uint16_t encoder_pcint_mask(void);
/* Interrupt context: a pin-change interrupt with the levels of D2-D13 now. */
void encoder_pin_change(uint16_t levels);
/* Interrupt context: INT0 (index 0, D2) or INT1 (index 1, D3) saw a change. */
void encoder_int(uint8_t index);
/* A slot's count (for stream samples; free slots read 0). */
int32_t encoder_peek(uint8_t slot);

#endif

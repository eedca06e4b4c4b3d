/* stepper.h - step/dir steppers with limit switches (CT 0x09, issue 26). */
#ifndef STEPPER_H
#define STEPPER_H

#include <stdint.h>

#include "aio.h"

#if AIO_WITH_STEPPER

/* Nonzero while a stepper moves or a step pulse is pending: the tick
 * interrupt (clock.c) then calls stepper_tick(). */
extern volatile uint8_t stepper_active;

void stepper_init(void);
uint8_t stepper_handle(const aio_request_t *rq, aio_reply_t *rp);
/* One board tick (100 us), from the tick interrupt with interrupts enabled:
 * checks the limit switches, raises the step pins computed last tick,
 * advances every profile, lowers the pins. */
void stepper_tick(void);
/* Main loop: sends the StepperDone events the transmit buffer had no room for. */
void stepper_poll(void);
/* The failsafe: every stepper stops at once (StepperDone FAILSAFE). */
void stepper_stop_all(void);
/* Position of slot i (0 without a stepper); safe from interrupts (stream). */
int32_t stepper_position(uint8_t i);
/* A pin with the stepper role is released: its stepper stops and loses it. */
void stepper_release(uint8_t pin);

/* Profile arithmetic (exported for the host tests): speeds are Q32 steps a
 * tick (2^32 = one step a tick), accelerations Q32 steps a tick^2. */
uint32_t stepper_speed_q(uint16_t steps_per_s);
uint32_t stepper_accel_q(uint32_t steps_per_s2);
int16_t stepper_speed_of(uint32_t q, int8_t dir);

#else /* !AIO_WITH_STEPPER: an image without the class (protocol/profiles.py).  The hooks
       * the other modules call do nothing; the dispatcher answers the class NOT_IN_IMAGE
       * and the stream refuses its flag. */
static inline void stepper_init(void) {}
static inline void stepper_poll(void) {}
static inline void stepper_stop_all(void) {}
static inline int32_t stepper_position(uint8_t i) { (void)i; return 0; }
static inline void stepper_release(uint8_t pin) { (void)pin; }
#endif /* AIO_WITH_STEPPER */

#endif

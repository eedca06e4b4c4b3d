/*
 * pins.h - the board's pin map and the one-role-per-pin table (protocol.md section 3).
 */
#ifndef PINS_H
#define PINS_H

#include <stdint.h>

#include "aio.h"

#define PINS_FIRST 2u
#define PINS_LAST 13u
#define PINS_COUNT 14u

enum {
    ROLE_FREE = 0, ROLE_GPIO_IN, ROLE_GPIO_OUT, ROLE_PWM, ROLE_COUNTER, ROLE_DUTY, ROLE_STEPPER,
    ROLE_ENCODER, ROLE_SPI, ROLE_PULSE_IN, ROLE_SONAR
};

extern uint8_t pins_role[PINS_COUNT];

/* 1 << n: the AVR has no barrel shifter, a variable shift is a loop. */
extern const AIO_FLASH uint16_t pins_bit[16];

static inline __attribute__((always_inline)) uint16_t pins_bit_of(uint8_t pin) { return pins_bit[pin & 15u]; }

static inline __attribute__((always_inline)) uint8_t pins_capable(uint8_t pin, uint16_t table3_mask)
{
    return pin < 16u && (table3_mask & pins_bit[pin]);
}

/* 0, PIN_NOT_CAPABLE or PIN_BUSY for taking `pin` into a role of the group
 * given by same_role_a/same_role_b (GPIO input/output are one role). */
uint8_t pins_claim_check(uint8_t pin, uint16_t table3_mask, uint8_t same_a, uint8_t same_b);

/* Ends whatever role the pin has; leaves it a high-impedance input. */
void pins_release(uint8_t pin);

void pins_init(void);

#endif /* PINS_H */

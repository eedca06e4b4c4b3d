/*
 * pins.h - the board's pin map and the one-role-per-pin table (protocol.md section 3).
 */
#ifndef PINS_H
#define PINS_H

#include <stdint.h>

#include "aio.h"

/* The pins a role can be on, D2..PINS_LAST (the Uno's; a board header included by aio.h,
 * e.g. board_pins_mega2560.h, may set others: its AIO_PINS_* stay below PINS_COUNT). */
#define PINS_FIRST 2u
#ifndef PINS_LAST
#define PINS_LAST 13u
#endif
#define PINS_COUNT (PINS_LAST + 1u)
/* Digital pins without an edge interrupt (none on the Uno; the Mega's D2-D9 among
 * D2-D15): a GPIO input there has its edges found by polling (gpio_poll). */
#ifndef AIO_PINS_POLLED_EDGES
#define AIO_PINS_POLLED_EDGES 0u
#endif

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

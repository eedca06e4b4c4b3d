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

/* A set of pins, bit n = Dn: 16 bits on the Uno (its images stay as they were), wider on a
 * board whose header (board_pins_<board>.h, included by aio.h) sets AIO_PINMASK_BITS, e.g.
 * the Mega's 64 for D0-D53.  Modules keep pin sets in this type so a wider board needs no
 * code of its own (issue 29). */
#ifndef AIO_PINMASK_BITS
#define AIO_PINMASK_BITS 16u
#endif
#if AIO_PINMASK_BITS > 16
typedef uint64_t aio_pinmask_t;
#else
typedef uint16_t aio_pinmask_t;
#endif

enum {
    ROLE_FREE = 0, ROLE_GPIO_IN, ROLE_GPIO_OUT, ROLE_PWM, ROLE_COUNTER, ROLE_DUTY, ROLE_STEPPER,
    ROLE_ENCODER, ROLE_SPI, ROLE_PULSE_IN, ROLE_SONAR
};

extern uint8_t pins_role[PINS_COUNT];

#if AIO_PINMASK_BITS > 16
/* A wide board has the flash for the shift routine (a 64-bit table would be 512 B). */
static inline __attribute__((always_inline)) aio_pinmask_t pins_bit_of(uint8_t pin)
{
    return (aio_pinmask_t)1 << (pin & (AIO_PINMASK_BITS - 1u));
}
#else
/* 1 << n: the AVR has no barrel shifter, a variable shift is a loop. */
extern const AIO_FLASH uint16_t pins_bit[16];

static inline __attribute__((always_inline)) aio_pinmask_t pins_bit_of(uint8_t pin) { return pins_bit[pin & 15u]; }
#endif

static inline __attribute__((always_inline)) uint8_t pins_capable(uint8_t pin, aio_pinmask_t table3_mask)
{
#if AIO_PINMASK_BITS > 16
    return pin < AIO_PINMASK_BITS && (table3_mask & pins_bit_of(pin));
#else
    return pin < 16u && (table3_mask & pins_bit[pin]); /* already in range: no "& 15" */
#endif
}

/* 0, PIN_NOT_CAPABLE or PIN_BUSY for taking `pin` into a role of the group
 * given by same_role_a/same_role_b (GPIO input/output are one role). */
uint8_t pins_claim_check(uint8_t pin, aio_pinmask_t table3_mask, uint8_t same_a, uint8_t same_b);

/* Ends whatever role the pin has; leaves it a high-impedance input. */
void pins_release(uint8_t pin);

void pins_init(void);

#endif /* PINS_H */

/* encoder.h - ENCODER class: quadrature encoders on any two digital pins.
 *
 * The interrupt path is here, inline (as counter.h's), so hal_avr.c's vectors
 * compile it in without a call: a call makes an AVR interrupt save every
 * call-clobbered register, which cost more than the decoding itself. */
#ifndef ENCODER_H
#define ENCODER_H

#include <stdint.h>

#include "aio.h"
#include "hal.h"

#if AIO_WITH_ENCODER

#ifdef __AVR__
#define AIO_ENC_TABLE_Q __flash /* read with lpm: no RAM */
#else
#define AIO_ENC_TABLE_Q
#endif

/* One slot.  The interrupt keeps only 16-bit fields (a short interrupt with
 * few registers to save); encoder_poll() folds them into the 32-bit count and
 * the microsecond time on every main-loop pass, long before they could wrap
 * (32,767 counts: 0.3 s at 100,000 edges/s; the stamp: 3 s). */
typedef struct {
    uint8_t state;           /* bit 4: last direction forward; bits 2-3: position */
    uint8_t fresh;           /* an edge stamped since the last fold */
    int16_t moved;           /* counts since the last fold */
    uint16_t edge_low;       /* hal_stamp of the last edge that changed the count */
    uint8_t edge_sub;
    uint16_t invalid;
    uint16_t mask_a, mask_b; /* the pins' bits in hal_pin_levels(); 0: slot free */
    const AIO_ENC_TABLE_Q uint8_t *table; /* the mode's transition table */
    uint16_t every, since;   /* WATCH (main loop): a report every `every` counts moved */
    /* main loop (under hal_irq_save for what a stream sample reads) */
    uint32_t count;          /* folded count, two's complement: wraps as the i32 on the wire */
    uint32_t edge_us;        /* folded edge time (0: none yet) */
    uint8_t pin_a, pin_b;
} encoder_slot_t;

extern encoder_slot_t encoder_slots[AIO_ENCODER_SLOTS];
extern volatile uint8_t encoder_pc_slots;  /* bit s: slot s has a pin-change pin */
extern volatile uint8_t encoder_int_slot[2]; /* slot on INT0 (D2) / INT1 (D3), or 0xFF */

void encoder_init(void);
uint8_t encoder_handle(const aio_request_t *rq, aio_reply_t *rp);
/* Ends the encoder that uses `pin` (either of its pins): both pins become free. */
void encoder_release(uint8_t pin);
/* Pins the encoders watch through pin-change interrupts (bit n = Dn). */
uint16_t encoder_pcint_mask(void);
/* A slot's count (for stream samples; free slots read 0). */
int32_t encoder_peek(uint8_t slot);
/* Main loop: send the reports the interrupts found due. */
void encoder_poll(void);

/* Interrupt context: slot s sees `levels` (bit n = Dn).  The table entry of
 * (last direction, last position, new position) gives the count's change + 2
 * (bits 0-2), an invalid transition (bit 3) and the new direction (bit 4). */
static inline __attribute__((always_inline)) void encoder_step(uint8_t s, uint16_t levels)
{
    encoder_slot_t *e = &encoder_slots[s]; /* s is a constant: direct addresses */
    uint8_t g = (uint8_t)(((levels & e->mask_b) ? 2u : 0u) | ((levels & e->mask_a) ? 1u : 0u));
    uint8_t pos = (uint8_t)(g ^ (g >> 1)); /* B << 1 | A is the position's Gray code */
    uint8_t t = e->table[e->state | pos], d;
    if (!(t & 0x20u))
        return; /* no change */
    e->state = (uint8_t)((t & 0x10u) | (uint8_t)(pos << 2));
    if (t & 0x08u)
        e->invalid++;
    d = t & 7u;
    if (d == 2u)
        return; /* a step that does not count in this mode */
    e->moved = (int16_t)(e->moved + (int8_t)(d - 2u));
    hal_stamp(&e->edge_low, &e->edge_sub);
    e->fresh = 1;
    (void)s; /* reports: encoder_poll() (main loop), so the interrupt stays short */
}

/* Interrupt context: a pin-change interrupt with the levels of D2-D13 now. */
static inline __attribute__((always_inline)) void encoder_pin_change(uint16_t levels)
{
    uint8_t slots = encoder_pc_slots;
    if (slots & 1u)
        encoder_step(0, levels);
    if (slots & 2u)
        encoder_step(1, levels);
    if (slots & 4u)
        encoder_step(2, levels);
    if (slots & 8u)
        encoder_step(3, levels);
}

/* Interrupt context: INT0 (index 0, D2) or INT1 (index 1, D3) saw a change. */
static inline __attribute__((always_inline)) void encoder_int(uint8_t index, uint16_t levels)
{
    /* one case per slot: constant addresses (lds/sts), no pointer arithmetic */
    switch (encoder_int_slot[index]) {
    case 0:
        encoder_step(0, levels);
        break;
    case 1:
        encoder_step(1, levels);
        break;
    case 2:
        encoder_step(2, levels);
        break;
    case 3:
        encoder_step(3, levels);
        break;
    default:
        break;
    }
}

#else /* !AIO_WITH_ENCODER: an image without the class (protocol/profiles.py).  The hooks
       * the other modules call do nothing, so they need no #if of their own; the
       * dispatcher answers the class UNKNOWN_CLASS and the stream refuses its flag. */
static inline void encoder_init(void) {}
static inline void encoder_release(uint8_t pin) { (void)pin; }
static inline uint16_t encoder_pcint_mask(void) { return 0; }
static inline int32_t encoder_peek(uint8_t slot) { (void)slot; return 0; }
static inline void encoder_poll(void) {}
static inline void encoder_pin_change(uint16_t levels) { (void)levels; }
static inline void encoder_int(uint8_t index, uint16_t levels) { (void)index; (void)levels; }
#endif /* AIO_WITH_ENCODER */

#endif

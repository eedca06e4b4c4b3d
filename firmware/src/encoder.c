/*
 * encoder.c - ENCODER class (CT 0x0A, extension): quadrature encoders.
 *
 * Each slot decodes one encoder on two digital pins.  Every change of A or B
 * reaches encoder_step() (encoder.h) from an interrupt: INT0/INT1 (any change) for a pin on D2/D3,
 * which no other vector shares, and the pin-change interrupts for the others,
 * whose vectors the GPIO watches share (hal_avr.c runs both handlers on one
 * set of levels; each looks only at its own pins).  It reads both pins,
 * so a slot whose A is on INT0 and B on a pin-change pin is decoded by
 * whichever interrupt comes.
 *
 * Positions: AB = 00 -> 0, 10 -> 1, 11 -> 2, 01 -> 3; forward is 0 -> 1 -> 2
 * -> 3 (A leads B).  The mode is the set of positions whose entry going
 * forward (and exit going back) changes the count: x4 all four, x2 {1, 3}
 * (edges of A), x1 {1} (A rising while B is low).  A jump of two positions
 * is a skipped state (both pins changed between two interrupts): counted in
 * `invalid`, and the count moves two positions in the last valid step's
 * direction (forward before the first), which is right unless the encoder
 * reversed inside the skipped step.
 *
 * Velocity is the host's: each state carries the board time of the last edge
 * that changed the count (hal_stamp, cheap enough for every edge; turned into
 * microseconds only when read).
 *
 * The decoding itself is encoder_step() in encoder.h, inlined into the
 * interrupt vectors: one table lookup per edge (the mode's transition table
 * below, in flash), 16-bit fields only.  The main loop (encoder_poll, every
 * pass: each interrupt ends one) folds them into the 32-bit count and the
 * microsecond edge time, and sends the reports: the distance moved between
 * passes is added up, and a report goes at `every` (or the edge or two
 * after it), with the count then.  Keeping reports out of the interrupt saved
 * 5 of its 18 register pushes.
 */
#include "encoder.h"

#include "gpio.h"
#include "parser.h"
#include "pins.h"
#include "pulse.h"

#if AIO_WITH_ENCODER /* the class is in this image (protocol/profiles.py) */

#define SLOTS AIO_ENCODER_SLOTS
#define NO_SLOT 0xFFu

encoder_slot_t encoder_slots[SLOTS];
volatile uint8_t encoder_pc_slots;
volatile uint8_t encoder_int_slot[2];
static uint16_t pc_mask; /* the pins on pin-change interrupts */

/* Main-loop reads of the interrupt's fields happen between hal_irq_save()
 * and this barrier (the fields are not volatile, so the interrupt's code
 * stays short). */
#define BARRIER() __asm__ volatile("" ::: "memory")

/* [mode x1, x2, x4][dir << 4 | prev << 2 | new]: 0x20 changed, 0x10 new
 * direction forward, 0x08 invalid, bits 0-2 the count's change + 2.
 * Generated from the rules above (positions counted per mode: x4 all, x2
 * {1, 3}, x1 {1}; a skip moves two positions the last direction's way). */
static const AIO_ENC_TABLE_Q uint8_t tables[3][32] = {
    /* x1 */
    {
        0x00u, 0x33u, 0x2Au, 0x22u, 0x21u, 0x00u, 0x32u, 0x29u,
        0x29u, 0x22u, 0x00u, 0x32u, 0x32u, 0x2Au, 0x22u, 0x00u,
        0x00u, 0x33u, 0x3Bu, 0x22u, 0x21u, 0x00u, 0x32u, 0x3Au,
        0x3Au, 0x22u, 0x00u, 0x32u, 0x32u, 0x3Bu, 0x22u, 0x00u
    },
    /* x2 */
    {
        0x00u, 0x33u, 0x29u, 0x22u, 0x21u, 0x00u, 0x32u, 0x29u,
        0x29u, 0x22u, 0x00u, 0x33u, 0x32u, 0x29u, 0x21u, 0x00u,
        0x00u, 0x33u, 0x3Bu, 0x22u, 0x21u, 0x00u, 0x32u, 0x3Bu,
        0x3Bu, 0x22u, 0x00u, 0x33u, 0x32u, 0x3Bu, 0x21u, 0x00u
    },
    /* x4 */
    {
        0x00u, 0x33u, 0x28u, 0x21u, 0x21u, 0x00u, 0x33u, 0x28u,
        0x28u, 0x21u, 0x00u, 0x33u, 0x33u, 0x28u, 0x21u, 0x00u,
        0x00u, 0x33u, 0x3Cu, 0x21u, 0x21u, 0x00u, 0x33u, 0x3Cu,
        0x3Cu, 0x21u, 0x00u, 0x33u, 0x33u, 0x3Cu, 0x21u, 0x00u
    },
};

static const AIO_ENC_TABLE_Q uint8_t *table_of(uint8_t mode)
{
    return tables[mode == AIO_ENCODER_X4 ? 2 : mode == AIO_ENCODER_X2 ? 1 : 0];
}

static uint8_t position(uint16_t levels, uint16_t mask_a, uint16_t mask_b)
{
    uint8_t g = (uint8_t)(((levels & mask_b) ? 2u : 0u) | ((levels & mask_a) ? 1u : 0u));
    return (uint8_t)(g ^ (g >> 1));
}

/* Interrupts off: the interrupt's 16-bit fields into the 32-bit count;
 * returns whether an edge was stamped since, its stamp in *low / *sub, and
 * the counts moved in *moved. */
static uint8_t fold_locked(uint8_t s, uint16_t *low, uint8_t *sub, int16_t *moved)
{
    encoder_slot_t *e = &encoder_slots[s];
    uint8_t fresh = e->fresh;
    *moved = e->moved;
    e->count += (uint32_t)(int32_t)e->moved;
    e->moved = 0;
    *low = e->edge_low;
    *sub = e->edge_sub;
    e->fresh = 0;
    return fresh;
}

/* slot, count, invalid, edge_us of slot s at p */
static uint8_t *put(uint8_t *p, uint8_t s, uint32_t count, uint16_t invalid, uint32_t edge_us)
{
    *p++ = s;
    p = aio_put32(p, count);
    p = aio_put16(p, invalid);
    return aio_put32(p, edge_us);
}

/* Main loop: an EncoderReport of slot s (just folded). */
static void report(uint8_t s)
{
    uint8_t frame[AIO_REPLY_LEN_EVENT_ENCODER_REPORT + 2u + AIO_CHECK_MAX];
    encoder_slot_t *e = &encoder_slots[s];
    uint16_t invalid;
    uint8_t st = hal_irq_save();
    invalid = e->invalid;
    BARRIER();
    hal_irq_restore(st);
    e->since = 0;
    frame[0] = AIO_CT_EVENT;
    frame[1] = AIO_DT_EVENT_ENCODER_REPORT;
    put(frame + 2, s, e->count, invalid, e->edge_us);
    hal_tx_send(frame, parser_seal(frame, (uint8_t)(2u + AIO_REPLY_LEN_EVENT_ENCODER_REPORT)));
    /* dropped if it does not fit: the next report's count shows it */
}

/* Main loop: fold slot s; the time conversion after interrupts are back on. */
static void fold(uint8_t s)
{
    encoder_slot_t *e = &encoder_slots[s];
    uint16_t low;
    int16_t moved;
    uint8_t sub, fresh, st = hal_irq_save();
    fresh = fold_locked(s, &low, &sub, &moved);
    BARRIER();
    hal_irq_restore(st);
    if (fresh) {
        e->edge_us = hal_stamp_us(low, sub);
        if (!e->edge_us)
            e->edge_us = 1; /* 0 means "no edge yet" */
    }
    if (e->every && moved) {
        /* the distance moved between two passes of the main loop (~100 us apart at
         * most): a report when `every` has been reached, with the count then */
        e->since = (uint16_t)(e->since + (uint16_t)(moved < 0 ? -moved : moved));
        if (e->since >= e->every)
            report(s);
    }
}

void encoder_poll(void)
{
    uint8_t s;
    for (s = 0; s < SLOTS; s++)
        if (encoder_slots[s].mask_a)
            fold(s);
}

uint16_t encoder_pcint_mask(void) { return pc_mask; }

int32_t encoder_peek(uint8_t slot)
{
    uint8_t st = hal_irq_save();
    encoder_slot_t *e = &encoder_slots[slot];
    int32_t c = e->mask_a ? (int32_t)(e->count + (uint32_t)(int32_t)e->moved) : 0;
    BARRIER();
    hal_irq_restore(st);
    return c;
}

/* The interrupts every slot in use needs, after a slot changed. */
static void route(void)
{
    uint8_t s, pcs = 0, st;
    uint8_t ints[2] = {NO_SLOT, NO_SLOT};
    uint16_t mask = 0, pins;

    for (s = 0; s < SLOTS; s++) {
        pins = (uint16_t)(encoder_slots[s].mask_a | encoder_slots[s].mask_b);
        if (!pins)
            continue;
        if (pins & pins_bit_of(2))
            ints[0] = s;
        if (pins & pins_bit_of(3))
            ints[1] = s;
        pins &= (uint16_t)~(pins_bit_of(2) | pins_bit_of(3));
        if (pins)
            pcs |= (uint8_t)(1u << s);
        mask |= pins;
    }
    st = hal_irq_save();
    encoder_pc_slots = pcs;
    pc_mask = mask;
    hal_edge_watch((uint16_t)(gpio_watch_mask() | mask | pulse_pcint_mask()));
    for (s = 0; s < 2; s++) {
        /* only on a change: a counter may own the other external interrupt */
        if ((encoder_int_slot[s] != NO_SLOT) != (ints[s] != NO_SLOT))
            hal_encoder_int(s, ints[s] != NO_SLOT);
        encoder_int_slot[s] = ints[s];
    }
    hal_irq_restore(st);
}

static void detach(uint8_t s)
{
    uint8_t a = encoder_slots[s].pin_a, b = encoder_slots[s].pin_b, st;
    if (!encoder_slots[s].mask_a)
        return;
    st = hal_irq_save();
    encoder_slots[s].mask_a = encoder_slots[s].mask_b = 0;
    encoder_slots[s].every = 0;
    BARRIER();
    hal_irq_restore(st);
    route();
    pins_role[a] = pins_role[b] = ROLE_FREE;
    hal_pin_mode(a, HAL_IN);
    hal_pin_mode(b, HAL_IN);
}

void encoder_init(void)
{
    uint8_t s;
    for (s = 0; s < SLOTS; s++) {
        encoder_slots[s].mask_a = encoder_slots[s].mask_b = 0;
        encoder_slots[s].every = 0;
    }
    encoder_pc_slots = 0;
    pc_mask = 0;
    encoder_int_slot[0] = encoder_int_slot[1] = NO_SLOT;
    hal_encoder_int(0, 0);
    hal_encoder_int(1, 0);
}

void encoder_release(uint8_t pin)
{
    uint8_t s;
    for (s = 0; s < SLOTS; s++)
        if (encoder_slots[s].mask_a && (encoder_slots[s].pin_a == pin || encoder_slots[s].pin_b == pin))
            detach(s);
}

/* The pin is free, or already this slot's. */
static uint8_t takeable(uint8_t pin, uint8_t s)
{
    uint8_t role = pins_role[pin];
    return role == ROLE_FREE ||
           (role == ROLE_ENCODER && encoder_slots[s].mask_a && (encoder_slots[s].pin_a == pin || encoder_slots[s].pin_b == pin));
}

static uint8_t configure(const uint8_t *d)
{
    uint8_t s = d[0], a = d[1], b = d[2], mode = d[3], st;

    if (s >= SLOTS)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (!pins_capable(a, AIO_PINS_ENCODER) || !pins_capable(b, AIO_PINS_ENCODER))
        return AIO_ERR_PIN_NOT_CAPABLE;
    if (a == b || (mode != AIO_ENCODER_X1 && mode != AIO_ENCODER_X2 && mode != AIO_ENCODER_X4))
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (!takeable(a, s) || !takeable(b, s))
        return AIO_ERR_PIN_BUSY;
    detach(s);
    hal_pin_mode(a, HAL_IN_PULLUP); /* open-collector encoders need it; harmless to others */
    hal_pin_mode(b, HAL_IN_PULLUP);
    pins_role[a] = pins_role[b] = ROLE_ENCODER;
    st = hal_irq_save();
    encoder_slots[s].pin_a = a;
    encoder_slots[s].pin_b = b;
    encoder_slots[s].mask_a = pins_bit_of(a);
    encoder_slots[s].mask_b = pins_bit_of(b);
    /* forward before the first step */
    encoder_slots[s].state = (uint8_t)(0x10u | position(hal_pin_levels(), encoder_slots[s].mask_a,
                                                         encoder_slots[s].mask_b) << 2);
    encoder_slots[s].table = table_of(mode);
    encoder_slots[s].count = 0;
    encoder_slots[s].moved = 0;
    encoder_slots[s].fresh = 0;
    encoder_slots[s].invalid = 0;
    encoder_slots[s].edge_us = 0;
    encoder_slots[s].every = encoder_slots[s].since = 0;
    BARRIER();
    hal_irq_restore(st);
    route();
    return 0;
}

/* count, invalid, edge_us of slot s at p; then (PRESET) the new count. */
static uint8_t *put_state(uint8_t *p, uint8_t s, const uint8_t *preset)
{
    uint8_t st, sub, fresh;
    uint16_t invalid, low;
    int16_t moved;
    uint32_t count;

    fold(s); /* the time of an edge before now */
    st = hal_irq_save();
    fresh = fold_locked(s, &low, &sub, &moved); /* and the counts up to now */
    count = encoder_slots[s].count;
    invalid = encoder_slots[s].invalid;
    if (preset) {
        encoder_slots[s].count = (uint32_t)preset[0] << 24 | (uint32_t)preset[1] << 16 |
                                 (uint32_t)preset[2] << 8 | preset[3];
        encoder_slots[s].invalid = 0;
        encoder_slots[s].since = 0;
    }
    BARRIER();
    hal_irq_restore(st);
    if (fresh) {
        encoder_slots[s].edge_us = hal_stamp_us(low, sub);
        if (!encoder_slots[s].edge_us)
            encoder_slots[s].edge_us = 1; /* 0 means "no edge yet" */
    }
    p = aio_put32(p, count);
    p = aio_put16(p, invalid);
    return aio_put32(p, encoder_slots[s].edge_us);
}

uint8_t encoder_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t s = rq->data[0], err, st;

    switch (rq->dt) {
    case AIO_DT_ENCODER_CONFIG:
        err = configure(rq->data);
        return err ? err : aio_echo(rq, rp);
    case AIO_DT_ENCODER_READ:
    case AIO_DT_ENCODER_PRESET:
    case AIO_DT_ENCODER_WATCH:
        break;
    default:
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    }
    if (s >= SLOTS)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (!encoder_slots[s].mask_a)
        return AIO_ERR_PIN_NOT_CONFIGURED;
    if (rq->dt == AIO_DT_ENCODER_WATCH) {
        st = hal_irq_save();
        encoder_slots[s].every = aio_be16(rq->data + 1);
        encoder_slots[s].since = 0;
        BARRIER();
        hal_irq_restore(st);
        return aio_echo(rq, rp);
    }
    if (rq->dt == AIO_DT_ENCODER_READ) {
        rp->data[0] = s;
        rp->len = (uint8_t)(put_state(rp->data + 1, s, 0) - rp->data);
        return 0;
    }
    aio_echo(rq, rp); /* slot, value */
    rp->len = (uint8_t)(put_state(rp->data + 5, s, rq->data + 1) - rp->data);
    return 0;
}

#endif /* AIO_WITH_ENCODER */

/*
 * encoder.c - ENCODER class (CT 0x0A, extension): quadrature encoders.
 *
 * Each slot decodes one encoder on two digital pins.  Every change of A or B
 * reaches step() from an interrupt: INT0/INT1 (any change) for a pin on D2/D3,
 * which no other vector shares, and the pin-change interrupts for the others,
 * whose vectors the GPIO watches share (hal_avr.c runs both handlers on one
 * set of levels; each looks only at its own pins).  step() reads both pins,
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
 */
#include "encoder.h"

#include "gpio.h"
#include "hal.h"
#include "parser.h"
#include "pins.h"

#define SLOTS AIO_ENCODER_SLOTS
#define NO_SLOT 0xFFu

typedef struct {
    uint32_t count;          /* two's complement: it wraps, as the i32 on the wire */
    uint16_t invalid;
    uint32_t edge_ticks;     /* hal_stamp of the last edge that changed the count */
    uint8_t edge_sub;
    uint16_t mask_a, mask_b; /* the pins' bits in hal_pin_levels(); 0: slot free */
    uint8_t pos;             /* 0-3, see above */
    int8_t dir;              /* +1/-1: the last valid step's direction */
    uint8_t steps;           /* bit p: a step into position p changes the count */
    uint8_t pin_a, pin_b;
    uint16_t every, since;   /* WATCH: a report every `every` counts moved */
} enc_t;

static volatile enc_t enc[SLOTS];
static volatile uint8_t pc_slots; /* bit s: slot s has a pin on a pin-change interrupt */
static uint16_t pc_mask;          /* those pins */
static volatile uint8_t int_slot[2]; /* the slot on INT0 (D2) / INT1 (D3), or NO_SLOT */

/* 1 << p for p = 0-3 (pins_bit, no second table in RAM) */
#define BIT4(p) ((uint8_t)pins_bit_of(p))

static uint8_t steps_of(uint8_t mode)
{
    return mode == AIO_ENCODER_X4 ? 0x0Fu : mode == AIO_ENCODER_X2 ? 0x0Au : 0x02u;
}

/* B << 1 | A is the Gray code of the position: g ^ g >> 1 decodes it
 * (AB = 00 -> 0, 10 -> 1, 11 -> 2, 01 -> 3). */
static uint8_t position(uint16_t levels, uint16_t mask_a, uint16_t mask_b)
{
    uint8_t g = (uint8_t)(((levels & mask_b) ? 2u : 0u) | ((levels & mask_a) ? 1u : 0u));
    return (uint8_t)(g ^ (g >> 1));
}

static uint32_t stamp_us(uint32_t ticks, uint8_t sub)
{
    return ticks ? hal_stamp_us(ticks, sub) : 0u; /* 0: no edge yet */
}

/* Interrupt context: an EncoderReport of slot s. */
static void report(uint8_t s) __attribute__((noinline));
static void report(uint8_t s)
{
    uint8_t frame[AIO_REPLY_LEN_EVENT_ENCODER_REPORT + 2u + AIO_CHECK_MAX], *p = frame;
    volatile enc_t *e = &enc[s];

    *p++ = AIO_CT_EVENT;
    *p++ = AIO_DT_EVENT_ENCODER_REPORT;
    *p++ = s;
    p = aio_put32(p, e->count);
    p = aio_put16(p, e->invalid);
    p = aio_put32(p, stamp_us(e->edge_ticks, e->edge_sub));
    hal_tx_send(frame, parser_seal(frame, (uint8_t)(p - frame))); /* dropped if it does not fit */
}

/* Interrupt context: slot s sees `levels`. */
static void step(uint8_t s, uint16_t levels)
{
    volatile enc_t *e = &enc[s];
    uint8_t cur = position(levels, e->mask_a, e->mask_b), prev = e->pos, steps = e->steps;
    int8_t delta;
    uint32_t ticks;
    uint8_t sub;

    switch ((uint8_t)(cur - prev) & 3u) {
    case 0:
        return;
    case 1:
        e->dir = 1;
        delta = (steps & BIT4(cur)) ? 1 : 0;
        break;
    case 3:
        e->dir = -1;
        delta = (steps & BIT4(prev)) ? -1 : 0;
        break;
    default: /* a skipped state: two positions the last direction's way */
        e->invalid++;
        if (e->dir > 0)
            delta = (int8_t)(((steps & BIT4((prev + 1u) & 3u)) ? 1 : 0) + ((steps & BIT4(cur)) ? 1 : 0));
        else
            delta = (int8_t)-(((steps & BIT4(prev)) ? 1 : 0) + ((steps & BIT4((prev + 3u) & 3u)) ? 1 : 0));
        break;
    }
    e->pos = cur;
    if (!delta)
        return;
    e->count += (uint32_t)(int32_t)delta;
    hal_stamp(&ticks, &sub);
    e->edge_ticks = ticks;
    e->edge_sub = sub;
    if (e->every) {
        e->since = (uint16_t)(e->since + (delta < 0 ? -delta : delta));
        if (e->since >= e->every) {
            e->since = 0;
            report(s);
        }
    }
}

void encoder_pin_change(uint16_t levels)
{
    uint8_t s, slots = pc_slots;
    for (s = 0; slots; s++, slots >>= 1)
        if (slots & 1u)
            step(s, levels);
}

void encoder_int(uint8_t index)
{
    uint8_t s = int_slot[index];
    if (s < SLOTS)
        step(s, hal_pin_levels());
}

uint16_t encoder_pcint_mask(void) { return pc_mask; }

int32_t encoder_peek(uint8_t slot)
{
    uint8_t st = hal_irq_save();
    int32_t c = enc[slot].mask_a ? (int32_t)enc[slot].count : 0;
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
        pins = (uint16_t)(enc[s].mask_a | enc[s].mask_b);
        if (!pins)
            continue;
        if (pins & pins_bit_of(2))
            ints[0] = s;
        if (pins & pins_bit_of(3))
            ints[1] = s;
        pins &= (uint16_t)~(pins_bit_of(2) | pins_bit_of(3));
        if (pins)
            pcs |= BIT4(s);
        mask |= pins;
    }
    st = hal_irq_save();
    pc_slots = pcs;
    pc_mask = mask;
    hal_edge_watch((uint16_t)(gpio_watch_mask() | mask));
    for (s = 0; s < 2; s++) {
        /* only on a change: a counter may own the other external interrupt */
        if ((int_slot[s] != NO_SLOT) != (ints[s] != NO_SLOT))
            hal_encoder_int(s, ints[s] != NO_SLOT);
        int_slot[s] = ints[s];
    }
    hal_irq_restore(st);
}

static void detach(uint8_t s)
{
    uint8_t a = enc[s].pin_a, b = enc[s].pin_b, st;
    if (!enc[s].mask_a)
        return;
    st = hal_irq_save();
    enc[s].mask_a = enc[s].mask_b = 0;
    enc[s].every = 0;
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
        enc[s].mask_a = enc[s].mask_b = 0;
        enc[s].every = 0;
    }
    pc_slots = 0;
    pc_mask = 0;
    int_slot[0] = int_slot[1] = NO_SLOT;
    hal_encoder_int(0, 0);
    hal_encoder_int(1, 0);
}

void encoder_release(uint8_t pin)
{
    uint8_t s;
    for (s = 0; s < SLOTS; s++)
        if (enc[s].mask_a && (enc[s].pin_a == pin || enc[s].pin_b == pin))
            detach(s);
}

/* The pin is free, or already this slot's. */
static uint8_t takeable(uint8_t pin, uint8_t s)
{
    uint8_t role = pins_role[pin];
    return role == ROLE_FREE ||
           (role == ROLE_ENCODER && enc[s].mask_a && (enc[s].pin_a == pin || enc[s].pin_b == pin));
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
    enc[s].pin_a = a;
    enc[s].pin_b = b;
    enc[s].mask_a = pins_bit_of(a);
    enc[s].mask_b = pins_bit_of(b);
    enc[s].pos = position(hal_pin_levels(), enc[s].mask_a, enc[s].mask_b);
    enc[s].dir = 1;
    enc[s].steps = steps_of(mode);
    enc[s].count = 0;
    enc[s].invalid = 0;
    enc[s].edge_ticks = 0;
    enc[s].edge_sub = 0;
    enc[s].every = enc[s].since = 0;
    hal_irq_restore(st);
    route();
    return 0;
}

/* slot, count, invalid, edge_us of slot s at p; then (PRESET) the new count. */
static uint8_t *put_state(uint8_t *p, uint8_t s, const uint8_t *preset)
{
    uint8_t st = hal_irq_save();
    uint32_t count = enc[s].count;
    uint16_t invalid = enc[s].invalid;
    uint32_t ticks = enc[s].edge_ticks;
    uint8_t sub = enc[s].edge_sub;
    if (preset) {
        enc[s].count = (uint32_t)preset[0] << 24 | (uint32_t)preset[1] << 16 |
                       (uint32_t)preset[2] << 8 | preset[3];
        enc[s].invalid = 0;
        enc[s].since = 0;
    }
    hal_irq_restore(st);
    p = aio_put32(p, count);
    p = aio_put16(p, invalid);
    return aio_put32(p, stamp_us(ticks, sub));
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
    if (!enc[s].mask_a)
        return AIO_ERR_PIN_NOT_CONFIGURED;
    if (rq->dt == AIO_DT_ENCODER_WATCH) {
        st = hal_irq_save();
        enc[s].every = aio_be16(rq->data + 1);
        enc[s].since = 0;
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

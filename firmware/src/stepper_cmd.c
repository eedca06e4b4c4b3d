/*
 * stepper_cmd.c - the STEPPER requests (CT 0x09, issue 26): slots and their pins
 * (roles, limit switches), profiles, moves, runs, stops, reads.  The motion
 * itself is stepper.c's; every change of a slot's state here is made with
 * interrupts off, so the tick sees a request whole.
 */
#include "hal.h"
#include "pins.h"
#include "stepper.h"
#include "stepper_slots.h"

#if AIO_WITH_STEPPER /* the class is in this image (protocol/profiles.py) */


static int32_t be32s(const uint8_t *p) { return (int32_t)((uint32_t)aio_be16(p) << 16 | aio_be16(p + 2)); }

static void free_pin(uint8_t pin)
{
    pins_role[pin] = ROLE_FREE;
    hal_pin_mode(pin, HAL_IN);
}

/* The slot whose step/dir pin (uses 1) or limit switch (uses 2) `pin` is. */
static uint8_t owner(uint8_t pin, uint8_t *uses)
{
    uint8_t i;
    for (i = 0; i < N; i++) {
        *uses = stepper_slot[i].step == pin || stepper_slot[i].dir_pin == pin ? 1u : stepper_slot[i].limit[0] == pin || stepper_slot[i].limit[1] == pin ? 2u : 0u;
        if (*uses)
            return i;
    }
    return NONE;
}

/* May slot i take `pin` for a use (1 step/dir, 2 limit)? It may reuse its own. */
static uint8_t claim_check(uint8_t i, uint8_t pin, uint16_t capable, uint8_t use)
{
    uint8_t uses, err = pins_claim_check(pin, capable, ROLE_STEPPER, ROLE_STEPPER);
    if (err)
        return err;
    if (pins_role[pin] == ROLE_STEPPER && (owner(pin, &uses) != i || uses != use))
        return AIO_ERR_PIN_BUSY;
    return 0;
}

static void drop_limit(stepper_t *s, uint8_t side)
{
    uint8_t pin = s->limit[side];
    s->limit[side] = NONE;
    if (pin != NONE && s->limit[!side] != pin)
        free_pin(pin);
}

/* Unconfigures slot s (interrupts off), keeping the pins in `keep` (bit n = Dn).
 * The stepper stops at once with no StepperDone: the host ended it. */
static void unconfigure(stepper_t *s, uint16_t keep)
{
    if (s->mode != IDLE || s->pending)
        stepper_halt(s, AIO_STEPPER_DONE_STOPPED);
    s->done = 0;
    drop_limit(s, 0);
    drop_limit(s, 1);
    if (s->step != NONE && !(keep & pins_bit_of(s->step)))
        free_pin(s->step);
    if (s->dir_pin != NONE && !(keep & pins_bit_of(s->dir_pin)))
        free_pin(s->dir_pin);
    s->step = s->dir_pin = NONE;
}

void stepper_release(uint8_t pin)
{
    uint8_t uses, i = owner(pin, &uses), sreg = hal_irq_save();
    if (i != NONE) {
        if (uses == 2) {
            if (stepper_slot[i].limit[0] == pin)
                stepper_slot[i].limit[0] = NONE;
            if (stepper_slot[i].limit[1] == pin)
                stepper_slot[i].limit[1] = NONE;
        } else {
            unconfigure(&stepper_slot[i], pins_bit_of(pin)); /* the caller frees pin itself */
        }
        stepper_update_active();
    }
    hal_irq_restore(sreg);
}

static uint8_t configure(uint8_t i, const uint8_t *d)
{
    stepper_t *s = &stepper_slot[i];
    uint8_t a = d[0], b = d[1], err, sreg;
    if (a == b)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    err = claim_check(i, a, AIO_PINS_DIGITAL_OUTPUT, 1);
    if (!err)
        err = claim_check(i, b, AIO_PINS_DIGITAL_OUTPUT, 1);
    if (err)
        return err;
    sreg = hal_irq_save();
    unconfigure(s, (uint16_t)(pins_bit_of(a) | pins_bit_of(b)));
    s->pos = s->target = 0;
    s->dir = -1; /* the direction pin starts low */
    s->step = a;
    s->dir_pin = b;
    pins_role[a] = pins_role[b] = ROLE_STEPPER;
    hal_pin_mode(a, HAL_OUT_LOW);
    hal_pin_mode(b, HAL_OUT_LOW);
    hal_irq_restore(sreg);
    return 0;
}

static uint8_t set_limit(uint8_t i, const uint8_t *d)
{
    stepper_t *s = &stepper_slot[i];
    uint8_t side = d[0], pin = d[1], act = d[2], err, sreg;
    if (side > 1u || act > 1u)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (pin) {
        err = claim_check(i, pin, AIO_PINS_DIGITAL_INPUT, 2);
        if (err)
            return err;
    }
    sreg = hal_irq_save();
    if (s->limit[side] != pin)
        drop_limit(s, side);
    if (pin) {
        s->limit[side] = pin;
        s->active[side] = act;
        pins_role[pin] = ROLE_STEPPER;
        hal_pin_mode(pin, act ? HAL_IN : HAL_IN_PULLUP);
    }
    hal_irq_restore(sreg);
    return 0;
}

uint8_t stepper_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t i = rq->data[0], sreg, *p, err = 0;
    const uint8_t *d = rq->data + 1;
    stepper_t *s;
    uint32_t x;
    int32_t t;
    int16_t sp;

    if (rq->dt < AIO_DT_STEPPER_CONFIG || rq->dt > AIO_DT_STEPPER_LIMIT)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (i >= N)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    s = &stepper_slot[i];
    if (rq->dt == AIO_DT_STEPPER_CONFIG) {
        err = configure(i, d);
        return err ? err : aio_echo(rq, rp);
    }
    if (s->step == NONE)
        return AIO_ERR_PIN_NOT_CONFIGURED;
    sreg = hal_irq_save();
    s->cruise = 0; /* the next tick looks at the request's effect */
    switch (rq->dt) {
    case AIO_DT_STEPPER_PROFILE:
        sp = (int16_t)aio_be16(d);
        x = (uint32_t)be32s(d + 2);
        if (sp < 1 || sp > (int16_t)AIO_STEPPER_MAX_SPEED || !x || x > AIO_STEPPER_MAX_ACCEL) {
            err = AIO_ERR_VALUE_OUT_OF_RANGE;
            break;
        }
        s->vmax = stepper_speed_q((uint16_t)sp);
        s->acc = stepper_accel_q(x);
        s->vmin = stepper_first_speed(s->acc);
        break;
    case AIO_DT_STEPPER_MOVE:
        if (d[0] > 1u) {
            err = AIO_ERR_VALUE_OUT_OF_RANGE;
            break;
        }
        t = d[0] ? (s->mode == MOVE ? s->target : s->pos) : 0;
        t = (int32_t)((uint32_t)t + (uint32_t)be32s(d + 1));
        if (s->mode == IDLE)
            s->phase = s->ramp = 0;
        s->target = t;
        s->mode = MOVE;
        rp->data[0] = i;
        rp->data[1] = d[0];
        aio_put32(rp->data + 2, (uint32_t)t);
        rp->len = 6;
        break;
    case AIO_DT_STEPPER_RUN:
        sp = (int16_t)aio_be16(d);
        if (sp > (int16_t)AIO_STEPPER_MAX_SPEED || sp < -(int16_t)AIO_STEPPER_MAX_SPEED) {
            err = AIO_ERR_VALUE_OUT_OF_RANGE;
            break;
        }
        if (s->mode == IDLE)
            s->phase = s->ramp = 0;
        if (sp)
            s->run_dir = sp < 0 ? -1 : 1;
        else
            s->run_dir = s->dir;
        s->vrun = stepper_speed_q((uint16_t)(sp < 0 ? -sp : sp));
        s->mode = RUN;
        break;
    case AIO_DT_STEPPER_STOP:
        if (d[0] > 1u) {
            err = AIO_ERR_VALUE_OUT_OF_RANGE;
            break;
        }
        if (d[0] && (s->mode != IDLE || s->pending))
            stepper_halt(s, AIO_STEPPER_DONE_STOPPED);
        else if (s->mode != IDLE)
            s->mode = STOPPING;
        rp->data[0] = i;
        rp->data[1] = d[0];
        aio_put32(rp->data + 2, (uint32_t)s->pos);
        rp->len = 6;
        break;
    case AIO_DT_STEPPER_READ:
        p = rp->data;
        *p++ = i;
        p = aio_put32(p, (uint32_t)s->pos);
        p = aio_put32(p, (uint32_t)(s->mode == MOVE ? s->target : s->pos));
        p = aio_put16(p, (uint16_t)stepper_speed_of(s->v, s->dir));
        *p++ = (uint8_t)(s->mode != IDLE || s->pending);
        x = hal_pin_levels();
        *p++ = (uint8_t)((s->limit[0] != NONE && !!(x & pins_bit_of(s->limit[0])) == s->active[0]) |
                         (s->limit[1] != NONE && !!(x & pins_bit_of(s->limit[1])) == s->active[1]) << 1);
        rp->len = (uint8_t)(p - rp->data);
        break;
    case AIO_DT_STEPPER_SET_POSITION:
        if (s->mode != IDLE || s->pending) {
            err = AIO_ERR_STEPPER_MOVING;
            break;
        }
        s->pos = s->target = be32s(d);
        break;
    default: /* AIO_DT_STEPPER_LIMIT */
        hal_irq_restore(sreg);
        err = set_limit(i, d);
        return err ? err : aio_echo(rq, rp);
    }
    stepper_update_active();
    hal_irq_restore(sreg);
    if (err)
        return err;
    return rp->len ? 0 : aio_echo(rq, rp);
}

#endif /* AIO_WITH_STEPPER */

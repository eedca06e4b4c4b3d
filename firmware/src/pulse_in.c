/*
 * pulse_in.c - PULSE_IN class (CT 0x0C, extension): pulse-width inputs.
 *
 * Slot s is channel s of the shared edge-timing layer (pulse.h), which stamps both edges
 * of every high pulse in the pin-change interrupt.  The main loop (pulse_in_poll, every
 * pass) takes each complete pulse: its width and when it ended.  A slot whose last pulse
 * ended `timeout_ms` ago is lost: its reads say so (with the last width and its age, so
 * the host never takes an old width for a fresh one) and a PulseInSignal event goes out;
 * the next pulse sends the "back" event.  A slot starts lost: its first pulse is "back".
 */
#include "pulse_in.h"

#include "hal.h"
#include "parser.h"
#include "pins.h"
#include "pulse.h"

#if AIO_WITH_PULSE_IN

#define SLOTS AIO_PULSE_IN_SLOTS
#define AGE_MAX 65535u

typedef struct {
    uint8_t pin;      /* PINS_COUNT: slot free */
    uint8_t lost;
    uint8_t aged;     /* the last pulse is AGE_MAX ms old or more (or there was none) */
    uint16_t width_us;
    uint16_t timeout_ms;
    uint32_t end_us;  /* hal_micros() time the last pulse ended */
} slot_t;

static slot_t slots[SLOTS];

/* slot, width_us, age_ms, lost of slot s at p */
static uint8_t *put_state(uint8_t *p, uint8_t s)
{
    slot_t *q = &slots[s];
    uint32_t age = q->aged ? AGE_MAX : (hal_micros() - q->end_us) / 1000u;
    *p++ = s;
    p = aio_put16(p, q->width_us);
    p = aio_put16(p, (uint16_t)(age > AGE_MAX ? AGE_MAX : age));
    *p++ = q->lost;
    return p;
}

static void signal_event(uint8_t s)
{
    uint8_t frame[AIO_REPLY_LEN_EVENT_PULSE_IN_SIGNAL + 2u + AIO_CHECK_MAX];
    frame[0] = AIO_CT_EVENT;
    frame[1] = AIO_DT_EVENT_PULSE_IN_SIGNAL;
    put_state(frame + 2, s);
    hal_tx_send(frame, parser_seal(frame, (uint8_t)(2u + AIO_REPLY_LEN_EVENT_PULSE_IN_SIGNAL)));
    /* dropped if it does not fit: a read says the state */
}

void pulse_in_poll(void)
{
    uint8_t s;
    uint32_t width, end, since;
    for (s = 0; s < SLOTS; s++) {
        slot_t *q = &slots[s];
        if (q->pin == PINS_COUNT)
            continue;
        if (pulse_take(s, &width, &end)) {
            uint8_t was_lost = q->lost, irq = hal_irq_save(); /* the stream reads both */
            q->width_us = (uint16_t)(width > 0xFFFFu ? 0xFFFFu : width);
            q->lost = 0;
            hal_irq_restore(irq);
            q->end_us = end;
            q->aged = 0;
            if (was_lost)
                signal_event(s);
            continue;
        }
        if (q->aged)
            since = 0xFFFFFFFFu;
        else {
            since = hal_micros() - q->end_us;
            if (since >= (uint32_t)AGE_MAX * 1000u)
                q->aged = 1; /* before the clock's difference wraps (71 min) */
        }
        if (!q->lost && since >= (uint32_t)q->timeout_ms * 1000u) {
            q->lost = 1;
            signal_event(s);
        }
    }
}

uint8_t pulse_in_stream_slots(void)
{
    uint8_t s = SLOTS;
    while (s && slots[s - 1u].pin == PINS_COUNT)
        s--;
    return s;
}

uint8_t *pulse_in_put_stream(uint8_t *p, uint8_t n)
{
    uint8_t s;
    for (s = 0; s < n; s++) {
        uint8_t none = slots[s].pin == PINS_COUNT; /* a free slot: width 0, lost */
        p = aio_put16(p, none ? 0u : slots[s].width_us);
        *p++ = (uint8_t)(slots[s].lost | none);
    }
    return p;
}

static void detach(uint8_t s)
{
    uint8_t pin = slots[s].pin;
    if (pin == PINS_COUNT)
        return;
    slots[s].pin = PINS_COUNT;
    pulse_watch(s, 0);
    pins_role[pin] = ROLE_FREE;
    hal_pin_mode(pin, HAL_IN);
}

void pulse_in_init(void)
{
    uint8_t s;
    pulse_init();
    for (s = 0; s < SLOTS; s++)
        slots[s].pin = PINS_COUNT;
}

void pulse_in_release(uint8_t pin)
{
    uint8_t s;
    for (s = 0; s < SLOTS; s++)
        if (slots[s].pin == pin)
            detach(s);
}

static uint8_t configure(const uint8_t *d)
{
    uint8_t s = d[0], pin = d[1];
    uint16_t timeout = aio_be16(d + 2);

    if (s >= SLOTS)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (!pins_capable(pin, AIO_PINS_PULSE_IN))
        return AIO_ERR_PIN_NOT_CAPABLE;
    if (!timeout)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (pins_role[pin] != ROLE_FREE && slots[s].pin != pin)
        return AIO_ERR_PIN_BUSY;
    detach(s);
    hal_pin_mode(pin, HAL_IN); /* a receiver drives the line both ways */
    pins_role[pin] = ROLE_PULSE_IN;
    {
        uint8_t irq = hal_irq_save(); /* the stream reads these */
        slots[s].lost = 1;
        slots[s].width_us = 0;
        slots[s].pin = pin;
        hal_irq_restore(irq);
    }
    slots[s].aged = 1;
    slots[s].timeout_ms = timeout;
    pulse_watch(s, pins_bit_of(pin));
    return 0;
}

uint8_t pulse_in_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t s = rq->data[0], err;

    switch (rq->dt) {
    case AIO_DT_PULSE_IN_CONFIG:
        err = configure(rq->data);
        return err ? err : aio_echo(rq, rp);
    case AIO_DT_PULSE_IN_READ:
        if (s >= SLOTS)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        if (slots[s].pin == PINS_COUNT)
            return AIO_ERR_PIN_NOT_CONFIGURED;
        pulse_in_poll(); /* a pulse ended since the last pass counts */
        rp->len = (uint8_t)(put_state(rp->data, s) - rp->data);
        return 0;
    default:
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    }
}

#endif /* AIO_WITH_PULSE_IN */

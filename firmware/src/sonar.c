/*
 * sonar.c - SONAR class (CT 0x0B, extension): HC-SR04 style ultrasonic rangers.
 *
 * One sonar measures at a time, so no sonar hears another's ping: the main loop
 * (sonar_poll) raises the next configured slot's trigger, lowers it >= 10 us later (the
 * part pings on the falling edge), then waits for the echo pulse on the echo pin, timed
 * by the shared edge-timing layer (pulse.h: both edges stamped in the pin-change
 * interrupt, so the width is exact however late the main loop looks), or for
 * AIO_SONAR_TIMEOUT_US without one: "no echo", its own value, never a distance.  The next
 * firing comes after that and at least `period_ms` after this one (the round robin's
 * step).  The sonar uses one channel of the timing layer, the last.
 *
 * distance_mm = echo_us * speed / 2, with the speed of sound in 0.1 m/s:
 * echo_us * speed_dm_s / 20000, rounded.
 */
#include "sonar.h"

#include "hal.h"
#include "pins.h"
#include "pulse.h"

#if AIO_WITH_SONAR

#define SLOTS AIO_SONAR_SLOTS
#define CHAN (PULSE_CHANNELS - 1u)
#define AGE_MAX 65535u
#define TRIGGER_US 12u /* >= 10 us high, with the clock's half-microsecond steps */
#define NONE 0xFFu

enum { IDLE, TRIGGER, LISTEN };

typedef struct {
    uint8_t trig;      /* PINS_COUNT: slot free */
    uint8_t echo;
    uint8_t aged;      /* the reading is AGE_MAX ms old or more (or there was none) */
    uint16_t dist;     /* mm, AIO_SONAR_NO_ECHO or AIO_SONAR_NO_READING */
    uint16_t echo_us;
    uint16_t readings;
    uint32_t at_us;    /* hal_micros() time of the reading */
} slot_t;

static slot_t slots[SLOTS];
static uint8_t phase, cur, fired;
static uint32_t phase_us, last_fire_us;
static uint16_t period_ms, speed_dm_s;

static void record(uint8_t s, uint16_t dist, uint16_t echo_us, uint32_t at)
{
    slot_t *q = &slots[s];
    uint8_t st = hal_irq_save(); /* the stream's sampling interrupt reads them */
    q->dist = dist;
    q->echo_us = echo_us;
    q->at_us = at;
    q->aged = 0;
    q->readings++;
    hal_irq_restore(st);
}

static void end_listen(void)
{
    pulse_watch(CHAN, 0);
    phase = IDLE;
}

static uint8_t next_slot(void)
{
    uint8_t i, s;
    for (i = 1; i <= SLOTS; i++) {
        s = (uint8_t)((cur + i) % SLOTS);
        if (slots[s].trig != PINS_COUNT)
            return s;
    }
    return NONE;
}

void sonar_poll(void)
{
    uint32_t now = hal_micros(), width, end;
    uint8_t s;

    for (s = 0; s < SLOTS; s++)
        if (!slots[s].aged && now - slots[s].at_us >= (uint32_t)AGE_MAX * 1000u)
            slots[s].aged = 1; /* before the clock's difference wraps (71 min) */
    if (phase == TRIGGER) {
        if (now - phase_us < TRIGGER_US)
            return;
        hal_pin_write(slots[cur].trig, 0); /* the ping starts now */
        phase_us = hal_micros();
        phase = LISTEN;
        return;
    }
    if (phase == LISTEN) {
        /* a pulse of the timeout or longer is the part's own "nothing heard" */
        if (pulse_take(CHAN, &width, &end) && width < AIO_SONAR_TIMEOUT_US)
            record(cur, (uint16_t)((width * speed_dm_s + 10000u) / 20000u), (uint16_t)width, end);
        else if (now - phase_us >= AIO_SONAR_TIMEOUT_US)
            record(cur, AIO_SONAR_NO_ECHO, 0, now);
        else
            return;
        end_listen(); /* and the next may fire at once */
    }
    if (fired && now - last_fire_us < (uint32_t)period_ms * 1000u)
        return;
    s = next_slot();
    if (s == NONE)
        return;
    cur = s;
    pulse_watch(CHAN, pins_bit_of(slots[s].echo)); /* an echo high now is the last one's */
    hal_pin_write(slots[s].trig, 1);
    phase_us = last_fire_us = hal_micros();
    fired = 1;
    phase = TRIGGER;
}

static void detach(uint8_t s)
{
    slot_t *q = &slots[s];
    if (q->trig == PINS_COUNT)
        return;
    if (phase != IDLE && cur == s)
        end_listen();
    pins_role[q->trig] = pins_role[q->echo] = ROLE_FREE;
    hal_pin_mode(q->trig, HAL_IN);
    hal_pin_mode(q->echo, HAL_IN);
    q->trig = PINS_COUNT;
}

void sonar_init(void)
{
    uint8_t s;
#if !AIO_WITH_PULSE_IN
    pulse_init();
#endif
    for (s = 0; s < SLOTS; s++)
        slots[s].trig = PINS_COUNT;
    phase = IDLE;
    fired = 0;
    cur = SLOTS - 1u; /* slot 0 fires first */
    period_ms = 60;
    speed_dm_s = AIO_SONAR_DEFAULT_SPEED_DM_S;
}

void sonar_release(uint8_t pin)
{
    uint8_t s;
    for (s = 0; s < SLOTS; s++)
        if (slots[s].trig == pin || slots[s].echo == pin)
            detach(s);
}

/* the pin is free or this slot's already */
static uint8_t usable(uint8_t pin, const slot_t *q)
{
    return pins_role[pin] == ROLE_FREE || (q->trig != PINS_COUNT && (q->trig == pin || q->echo == pin));
}

static uint8_t configure(const uint8_t *d)
{
    uint8_t s = d[0], trig = d[1], echo = d[2];
    slot_t *q;

    if (s >= SLOTS || trig == echo)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (!pins_capable(trig, AIO_PINS_SONAR) || !pins_capable(echo, AIO_PINS_SONAR))
        return AIO_ERR_PIN_NOT_CAPABLE;
    q = &slots[s];
    if (!usable(trig, q) || !usable(echo, q))
        return AIO_ERR_PIN_BUSY;
    detach(s);
    hal_pin_mode(trig, HAL_OUT_LOW);
    hal_pin_mode(echo, HAL_IN);
    pins_role[trig] = pins_role[echo] = ROLE_SONAR;
    q->echo = echo;
    q->dist = AIO_SONAR_NO_READING;
    q->echo_us = 0;
    q->readings = 0;
    q->aged = 1;
    q->trig = trig;
    return 0;
}

uint8_t sonar_stream_count(void)
{
    uint8_t s = SLOTS;
    while (s && slots[s - 1u].trig == PINS_COUNT)
        s--;
    return s;
}

uint8_t *sonar_stream_put(uint8_t *p, uint8_t n)
{
    uint8_t s;
    uint32_t now = hal_micros(), age;
    for (s = 0; s < n; s++) {
        const slot_t *q = &slots[s];
        uint8_t free = q->trig == PINS_COUNT;
        p = aio_put16(p, free ? AIO_SONAR_NO_READING : q->dist);
        age = (now - q->at_us) >> 10;
        *p++ = (uint8_t)(free || q->aged || age > 255u ? 255u : age);
    }
    return p;
}

uint8_t sonar_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t s = rq->data[0], err, *p;
    uint32_t age;
    uint16_t period, speed;

    switch (rq->dt) {
    case AIO_DT_SONAR_CONFIG:
        err = configure(rq->data);
        return err ? err : aio_echo(rq, rp);
    case AIO_DT_SONAR_READ:
        if (s >= SLOTS)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        if (slots[s].trig == PINS_COUNT)
            return AIO_ERR_PIN_NOT_CONFIGURED;
        sonar_poll(); /* an echo that ended since the last pass counts */
        age = slots[s].aged ? AGE_MAX : (hal_micros() - slots[s].at_us) / 1000u;
        p = rp->data;
        *p++ = s;
        p = aio_put16(p, slots[s].dist);
        p = aio_put16(p, slots[s].echo_us);
        p = aio_put16(p, (uint16_t)(age > AGE_MAX ? AGE_MAX : age));
        p = aio_put16(p, slots[s].readings);
        rp->len = (uint8_t)(p - rp->data);
        return 0;
    case AIO_DT_SONAR_TIMING:
        period = aio_be16(rq->data);
        speed = aio_be16(rq->data + 2);
        if (!period || speed < 3000u || speed > 4000u)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        period_ms = period;
        speed_dm_s = speed;
        return aio_echo(rq, rp);
    default:
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    }
}

#endif /* AIO_WITH_SONAR */

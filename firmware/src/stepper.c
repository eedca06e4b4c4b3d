/*
 * stepper.c - STEPPER class (CT 0x09) and the STEPPER_DONE event (issue 26).
 *
 * Timing: the steppers share the board tick (Timer2 compare A, 100 us,
 * clock.c), because every other compare channel already has a job
 * (docs/motors.md, "Timers and pins").  Each tick the interrupt calls
 * stepper_tick() with interrupts enabled, which
 *   1. reads the limit switches and stops any stepper heading into a closed
 *      one (its pending step is dropped: no step after the switch is seen),
 *   2. raises the step pins computed in the previous tick,
 *   3. advances every profile by one tick and notes the next steps,
 *   4. lowers the step pins (the pulse lasts the profile work, >= 5 us:
 *      A4988 wants 1 us, DRV8825 1.9 us, TMC2209 0.1 us).
 * So a stepper takes at most one step a tick (10,000 steps/s), and a
 * direction change happens a tick before its first step (setup >> 200 ns).
 *
 * The profile is a digital differential analyser in 32-bit integers: the
 * speed v (Q32 steps a tick) gains or loses the acceleration each tick, a
 * phase accumulator adds v and a carry out of it is a step.  `ramp` counts the
 * steps taken while speeding up (and gives one back per step while slowing
 * down), which is the distance needed to stop: a move decelerates once the
 * steps left are no more than that, so the trapezoid needs no square root or
 * division in the interrupt.  It ends with the step that reaches the target
 * (the last tick of deceleration runs at no less than the speed of the first
 * step, `vmin`, so it never stalls a step short), which is therefore exact.
 */
#include "stepper.h"

#include "hal.h"
#include "parser.h"
#include "pins.h"
#include "stepper_slots.h"

#if AIO_WITH_STEPPER /* the class is in this image (protocol/profiles.py) */

stepper_t stepper_slot[N];
volatile uint8_t stepper_active;
static volatile uint8_t in_tick, owed;

uint32_t stepper_speed_q(uint16_t s)
{
    /* s * 2^32 / 10,000 = s * 429,496.7296 */
    if (s >= AIO_STEPPER_MAX_SPEED)
        return 0xFFFFFFFFu;
    return (uint32_t)s * 429496u + (uint32_t)s * 7296u / 10000u;
}

uint32_t stepper_accel_q(uint32_t a)
{
    /* a * 2^32 / 10^8 = a * 42.94967296 = a * 43 - a * 3298.2 / 65536 */
    return a * 43u - (a * 3298u >> 16);
}

int16_t stepper_speed_of(uint32_t q, int8_t dir)
{
    int16_t s = (int16_t)(((q >> 16) * 10000u + 32768u) >> 16);
    return dir < 0 ? (int16_t)-s : s;
}

/* Speed at the first step from rest, sqrt(2 a) steps a tick: the floor of
 * the last decelerating ticks of a move. */
uint32_t stepper_first_speed(uint32_t acc)
{
    uint32_t x = 2u * acc, r = 0, bit = 1ul << 30;
    while (bit > x)
        bit >>= 2;
    while (bit) {
        if (x >= r + bit) {
            x -= r + bit;
            r = (r >> 1) + bit;
        } else {
            r >>= 1;
        }
        bit >>= 2;
    }
    return r << 16;
}

void stepper_update_active(void)
{
    uint8_t i, a = 0;
    for (i = 0; i < N; i++)
        a |= (uint8_t)(stepper_slot[i].mode | stepper_slot[i].pending);
    stepper_active = a;
}

/* Set with any StepperDone to send: the main loop's poll costs one load else. */
static volatile uint8_t any_done;

static void done(stepper_t *s, uint8_t reason)
{
    any_done = 1;
    s->done = (uint8_t)(reason + 1u);
    s->done_pos = s->pos;
    s->done_us = hal_micros();
}

/* Comes to rest now (interrupts off or in the tick): the event is queued. */
void stepper_halt(stepper_t *s, uint8_t reason)
{
    if (s->pending) {
        s->pending = 0;
        s->pos -= s->dir; /* the step computed last tick is never pulsed */
    }
    s->mode = IDLE;
    s->cruise = 0;
    s->v = s->phase = s->ramp = 0;
    s->target = s->pos;
    done(s, reason);
}

void stepper_init(void)
{
    uint8_t i;
    for (i = 0; i < N; i++) {
        stepper_t *s = &stepper_slot[i];
        uint8_t *b = (uint8_t *)s, n = sizeof *s;
        while (n--)
            *b++ = 0;
        s->step = s->dir_pin = s->limit[0] = s->limit[1] = NONE;
        s->dir = 1;
        s->vmax = stepper_speed_q(1000u);
        s->acc = stepper_accel_q(1000u);
        s->vmin = stepper_first_speed(s->acc);
    }
    stepper_active = 0;
}

int32_t stepper_position(uint8_t i)
{
    uint8_t sreg = hal_irq_save();
    int32_t p = stepper_slot[i].pos;
    hal_irq_restore(sreg);
    return p;
}

/* The common tick, kept short (its own function: few registers to save):
 * at top speed the phase runs and the speed holds. */
static __attribute__((noinline)) uint8_t cruise(stepper_t *s)
{
    uint32_t old = s->phase, now = old + s->v;
    uint8_t sreg;
    s->phase = now;
    if (now >= old)
        return 0;
    sreg = hal_irq_save(); /* the stream reads it from an interrupt */
    s->pos += s->dir;
    hal_irq_restore(sreg);
    if (s->cruise == 1 && s->pos == s->brake_at)
        s->cruise = 0; /* the steps left are the distance to stop */
    return 1;
}

/* One tick of one stepper's profile (mode not IDLE, not cruising); returns
 * whether it steps, with the position already counted. */
static __attribute__((noinline)) uint8_t advance(stepper_t *s)
{
    uint32_t v, top, old;
    int8_t want, change = 0;
    uint8_t slow, sreg;
    int32_t d;

    v = s->v;
    top = s->mode == RUN ? s->vrun : s->vmax;
    want = s->dir;
    if (s->mode == MOVE) {
        d = s->target - s->pos;
        if (!d && !v) {
            stepper_halt(s, AIO_STEPPER_DONE_TARGET);
            return 0;
        }
        want = d < 0 ? -1 : 1;
        slow = want != s->dir || (uint32_t)(d < 0 ? -d : d) <= s->ramp;
    } else if (s->mode == RUN) {
        want = s->run_dir;
        slow = want != s->dir || !top;
    } else {
        slow = 1; /* STOPPING */
    }
    if (!v) {
        if (s->mode == STOPPING || (s->mode == RUN && !top)) {
            stepper_halt(s, AIO_STEPPER_DONE_STOPPED);
            return 0;
        }
        if (want != s->dir) {
            s->dir = want; /* a tick before the first step that way */
            hal_pin_write(s->dir_pin, want > 0);
            s->ramp = 0;
            return 0;
        }
        slow = 0;
    }
    /* Speeding up adds the acceleration before the tick's distance, slowing
     * down after it, so the ramp down mirrors the ramp up step for step. */
    old = s->phase;
    if (slow) {
        s->phase = old + v;
        v = v > s->acc ? v - s->acc : 0;
        change = -1;
        if (s->mode == MOVE && want == s->dir && v < s->vmin)
            v = s->vmin < top ? s->vmin : top; /* creep the last steps in */
    } else {
        if (v < top) {
            v = top - v > s->acc ? v + s->acc : top;
            change = 1;
        } else if (v > top) {
            v = v - top > s->acc ? v - s->acc : top; /* a lower top speed */
            change = -1;
        }
        s->phase = old + v;
    }
    s->v = v;
    slow = s->phase < old; /* carry: a step this tick */
    if (slow) {
        if (change > 0)
            s->ramp++;
        else if (change < 0 && s->ramp)
            s->ramp--;
        sreg = hal_irq_save();
        s->pos += s->dir;
        hal_irq_restore(sreg);
        if (s->mode == MOVE && s->pos == s->target) {
            s->mode = IDLE; /* this last step goes out next tick, then the event */
            s->v = s->phase = s->ramp = 0;
            return 1;
        }
    }
    if (!change && v == top && v) {
        /* at top speed: cruise until the steps left are the distance to stop */
        d = s->target - s->pos;
        if (s->mode == RUN) {
            s->cruise = 2;
        } else if (s->mode == MOVE && (s->dir > 0 ? d : -d) > (int32_t)s->ramp) {
            s->cruise = 1;
            s->brake_at = s->target - (s->dir > 0 ? (int32_t)s->ramp : -(int32_t)s->ramp);
        }
    }
    return slow;
}

/* One tick of every stepper: limits, pulses, profiles. */
static __attribute__((noinline)) void one_tick(void)
{
    uint16_t levels, mask = 0;
    uint8_t i, side, active = 0;
    stepper_t *s;

    levels = hal_pin_levels();
    for (i = 0, s = stepper_slot; i < N; i++, s++) {
        if (s->mode == IDLE && !s->pending)
            continue;
        side = s->dir > 0;
        if (s->limit[side] != NONE && (uint8_t)!!(levels & pins_bit_of(s->limit[side])) == s->active[side] &&
            (s->pending || s->v)) {
            stepper_halt(s, (uint8_t)(AIO_STEPPER_DONE_LIMIT_MIN + side));
            continue;
        }
        if (s->pending) {
            mask |= pins_bit_of(s->step);
            if (s->mode == IDLE)
                done(s, AIO_STEPPER_DONE_TARGET); /* the move's last step */
        }
    }
    hal_step_pins(mask, 1);
    for (i = 0, s = stepper_slot; i < N; i++, s++) {
        s->pending = 0;
        if (s->mode != IDLE)
            s->pending = s->cruise ? cruise(s) : advance(s);
        active |= (uint8_t)(s->mode | s->pending);
    }
    hal_step_pins(mask, 0);
    stepper_active = active;
}

/* At most this many ticks are made up: past it the CPU is overloaded (the
 * steppers' ticks plus the interrupts take more than the time there is), and
 * ticks are dropped instead, so the main loop still runs: the profiles slow
 * down, they never skip a step. */
#define OWED_MAX 4u

/* Called from the tick interrupt's assembly (clock.c) only, with interrupts
 * enabled.  Four cruising steppers take ~39 us of a tick (simulated, 16
 * MHz: ~14 us fixed, ~6.5 us each); the interrupts of a busy
 * link (RX, TX, stream) can stretch that past the next tick, whose call then
 * finds this one at work: it leaves the tick owed, and this one runs it
 * before it returns, so no tick of any profile is lost (a step comes late by
 * that stretch, never missing) and speeds and positions stay exact. */
void stepper_tick(void) __attribute__((used, externally_visible, noinline));
void stepper_tick(void)
{
    uint8_t sreg;
    if (in_tick) {
        if (owed < OWED_MAX)
            owed++;
        return;
    }
    in_tick = 1;
    for (;;) {
        one_tick();
        sreg = hal_irq_save();
        if (!owed) {
            in_tick = 0;
            hal_irq_restore(sreg);
            return;
        }
        owed--;
        hal_irq_restore(sreg);
    }
}

void stepper_stop_all(void)
{
    uint8_t i, sreg = hal_irq_save();
    for (i = 0; i < N; i++)
        if (stepper_slot[i].mode != IDLE || stepper_slot[i].pending)
            stepper_halt(&stepper_slot[i], AIO_STEPPER_DONE_FAILSAFE);
    stepper_update_active();
    hal_irq_restore(sreg);
}

void stepper_poll(void)
{
    uint8_t i, sreg, reason, frame[2u + 10u + AIO_CHECK_MAX], *p;
    if (!any_done)
        return;
    any_done = 0; /* (a done() from here on sets it again) */
    for (i = 0; i < N; i++) {
        stepper_t *s = &stepper_slot[i];
        if (!s->done)
            continue;
        p = frame;
        *p++ = AIO_CT_EVENT;
        *p++ = AIO_DT_EVENT_STEPPER_DONE;
        *p++ = i;
        sreg = hal_irq_save();
        reason = s->done;
        s->done = 0;
        *p++ = (uint8_t)(reason - 1u);
        p = aio_put32(p, (uint32_t)s->done_pos);
        p = aio_put32(p, s->done_us);
        hal_irq_restore(sreg);
        if (!hal_tx_send(frame, parser_seal(frame, (uint8_t)(p - frame)))) {
            sreg = hal_irq_save();
            if (!s->done)
                s->done = reason; /* no room: the next loop step tries again */
            any_done = 1;
            hal_irq_restore(sreg);
            return;
        }
    }
}

#endif /* AIO_WITH_STEPPER */

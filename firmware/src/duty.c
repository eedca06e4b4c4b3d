/*
 * duty.c - duty-cycle PWM (CT 0x05, DUTY_CONFIG / DUTY_SET), an extension.
 *
 * A pin's duty comes from its timer's output compare unit; the pins of one
 * timer share its frequency.  Timer allocation (docs/motors.md, "Timers and
 * pins"):
 *   Timer0: D6 (OC0A), D5 (OC0B), fast PWM TOP 0xFF; otherwise the fine
 *           alarms of software PWM and stream sampling (hal_avr.c), which
 *           cannot run while duty PWM holds it (PIN_BUSY both ways).
 *   Timer1: D9 (OC1A), D10 (OC1B), fast PWM TOP ICR1, clk/1; otherwise servo
 *           PWM (20 ms period): a timer is servo or duty, never both.
 *   Timer2: D3 (OC2B) at the board tick's 10 kHz (TOP OCR2A = 199, 0.5 us
 *           counts: clock.c); D11 (OC2A) cannot, OCR2A is the tick's period.
 * Duty 0 and full are the pin held low or high (output compare off), so
 * they have no spike; anything between is rounded to the timer's counts
 * and is at least one count high and one count low.
 */
#include "duty.h"

#include "hal.h"
#include "pins.h"
#include "pwm.h"
#include "stream.h"

typedef struct {
    uint16_t hz;  /* nominal frequency, as on the wire */
    uint8_t cs;   /* clock select bits */
    uint16_t top; /* counts in a period - 1 */
} duty_freq_t;

/* The Python mirror is arduinoio_async/protocol/timers.py. */
static const AIO_FLASH duty_freq_t freq0[] = {
    {62500u, 1u, 255u}, {7812u, 2u, 255u}, {976u, 3u, 255u}, {244u, 4u, 255u}, {61u, 5u, 255u},
};
static const AIO_FLASH duty_freq_t freq1[] = {
    {31250u, 1u, 511u}, {20000u, 1u, 799u},   {3906u, 1u, 4095u},
    {976u, 1u, 16383u}, {490u, 1u, 32652u},  {244u, 1u, 65535u},
};
static const AIO_FLASH duty_freq_t freq2[] = {{10000u, 2u, 199u}};

static const AIO_FLASH duty_freq_t *timer_freq[DUTY_TIMERS]; /* in use, 0 = no duty pin */

void duty_init(void)
{
    uint8_t i;
    for (i = 0; i < DUTY_TIMERS; i++)
        timer_freq[i] = 0;
}

static uint8_t timer_of(uint8_t pin)
{
    switch (pin) {
    case 5:
    case 6: return DUTY_TIMER0;
    case 9:
    case 10: return DUTY_TIMER1;
    default: return DUTY_TIMER2; /* D3 */
    }
}

/* The other pin with a compare unit on the same timer (D11 for D3: never a duty pin). */
static uint8_t sibling(uint8_t pin)
{
    switch (pin) {
    case 5: return 6;
    case 6: return 5;
    case 9: return 10;
    case 10: return 9;
    default: return 11;
    }
}

uint8_t duty_timer_busy(uint8_t timer) { return timer_freq[timer] != 0; }

static const AIO_FLASH duty_freq_t *find(uint8_t timer, uint16_t hz)
{
    const AIO_FLASH duty_freq_t *t = timer == DUTY_TIMER0 ? freq0 : timer == DUTY_TIMER1 ? freq1 : freq2;
    uint8_t n = timer == DUTY_TIMER0 ? sizeof freq0 / sizeof *freq0
                : timer == DUTY_TIMER1 ? sizeof freq1 / sizeof *freq1
                                       : sizeof freq2 / sizeof *freq2;
    for (; n; n--, t++)
        if (t->hz == hz)
            return t;
    return 0;
}

/* Another user holds the pin's timer: PIN_BUSY. */
static uint8_t timer_taken(uint8_t pin, const AIO_FLASH duty_freq_t *f)
{
    uint8_t timer = timer_of(pin), other = sibling(pin), p;
    if (timer_freq[timer] && timer_freq[timer] != f && pins_role[other] == ROLE_DUTY)
        return 1; /* the other pin runs duty PWM at another frequency */
    if (timer == DUTY_TIMER1 && pins_role[other] == ROLE_PWM)
        return 1; /* servo PWM on Timer1 */
    if (timer == DUTY_TIMER0) {
        if (stream_running())
            return 1;
        for (p = 2; p <= 7; p++)
            if (pins_role[p] == ROLE_PWM)
                return 1; /* software PWM's edge alarms run on Timer0 */
    }
    return 0;
}

static uint16_t high_counts(uint16_t duty, uint16_t top)
{
    /* counts high out of top + 1, rounded; 0 = low, top + 1 = high */
    return (uint16_t)(((uint32_t)duty * ((uint32_t)top + 1u) + AIO_DUTY_FULL / 2u) / AIO_DUTY_FULL);
}

void duty_set(uint8_t pin, uint16_t duty)
{
    const AIO_FLASH duty_freq_t *f = timer_freq[timer_of(pin)];
    uint16_t h;
    if (!f)
        return;
    h = high_counts(duty, f->top);
    if (h == 0)
        hal_duty_output(pin, HAL_DUTY_LOW, 0);
    else if ((uint32_t)h > f->top)
        hal_duty_output(pin, HAL_DUTY_HIGH, 0);
    else
        hal_duty_output(pin, HAL_DUTY_PWM, (uint16_t)(h - 1u)); /* high from BOTTOM to OCR */
}

void duty_release(uint8_t pin)
{
    uint8_t timer = timer_of(pin);
    hal_duty_output(pin, HAL_DUTY_LOW, 0);
    if (pins_role[sibling(pin)] != ROLE_DUTY) {
        timer_freq[timer] = 0;
        hal_duty_timer(timer, 0, 0); /* back to its other job */
    }
}

uint8_t duty_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin = rq->data[0], timer;
    uint16_t hz, duty;
    const AIO_FLASH duty_freq_t *f;
    uint8_t err;

    if (rq->dt != AIO_DT_PWM_DUTY_CONFIG && rq->dt != AIO_DT_PWM_DUTY_SET)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (!pins_capable(pin, AIO_PINS_DUTY_PWM))
        return AIO_ERR_PIN_NOT_CAPABLE;
    timer = timer_of(pin);
    if (rq->dt == AIO_DT_PWM_DUTY_SET) {
        if (pins_role[pin] != ROLE_DUTY)
            return AIO_ERR_PIN_NOT_CONFIGURED;
        duty_set(pin, aio_be16(rq->data + 1));
        return aio_echo(rq, rp);
    }
    hz = aio_be16(rq->data + 1);
    duty = aio_be16(rq->data + 3);
    err = pins_claim_check(pin, AIO_PINS_DUTY_PWM, ROLE_DUTY, ROLE_DUTY);
    if (err)
        return err;
    f = find(timer, hz);
    if (!f)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (timer_taken(pin, f))
        return AIO_ERR_PIN_BUSY;
    if (pins_role[pin] != ROLE_DUTY) {
        pins_role[pin] = ROLE_DUTY;
        hal_pin_mode(pin, HAL_OUT_LOW);
    }
    if (timer_freq[timer] != f) {
        /* the first duty pin of the timer, or its only one changes frequency */
        timer_freq[timer] = f;
        hal_duty_timer(timer, f->cs, f->top);
    }
    duty_set(pin, duty);
    return aio_echo(rq, rp);
}

/*
 * failsafe.c - FAILSAFE class (CT 0x08) and the FAILSAFE_TRIPPED event.
 */
#include "failsafe.h"

#include "hal.h"
#include "parser.h"
#include "pins.h"
#include "duty.h"
#include "pwm.h"
#include "stepper.h"

typedef struct {
    uint8_t kind;
    uint16_t value;
} safe_state_t;

volatile uint8_t failsafe_is_armed; /* read by the tick interrupt (clock.c) */
static volatile uint8_t tripped, event_pending;
static uint16_t timeout_ms;
static volatile uint16_t last_feed;
static safe_state_t safe[PINS_COUNT];

/* 40 02 and the framing's check bytes, sealed when the failsafe trips */
static uint8_t tripped_event[2u + AIO_CHECK_MAX];
static uint8_t tripped_len;

void failsafe_init(void)
{
    uint8_t i;
    failsafe_is_armed = tripped = event_pending = 0;
    for (i = 0; i < PINS_COUNT; i++)
        safe[i].kind = AIO_SAFE_NONE;
}

void failsafe_feed(void)
{
    /* Only the failsafe check reads last_feed: nothing to do while it is not
     * armed (ARM sets last_feed itself). */
    if (failsafe_is_armed) {
        uint16_t now = hal_millis();
        uint8_t s = hal_irq_save();
        last_feed = now;
        hal_irq_restore(s);
    }
}

uint8_t failsafe_tripped(void) { return tripped; }

uint8_t failsafe_armed(void) { return failsafe_is_armed; }

uint8_t failsafe_status(void)
{
    return (uint8_t)((failsafe_is_armed ? AIO_STATUS_FAILSAFE_ARMED : 0) |
                     (tripped ? AIO_STATUS_FAILSAFE_TRIPPED : 0));
}

void failsafe_tick(void)
{
    uint8_t pin;
    if (!failsafe_is_armed || (uint16_t)(hal_millis() - last_feed) < timeout_ms)
        return;
    for (pin = 0; pin < PINS_COUNT; pin++) {
        if (safe[pin].kind == AIO_SAFE_LEVEL && pins_role[pin] == ROLE_GPIO_OUT)
            hal_pin_write(pin, (uint8_t)safe[pin].value);
        else if (safe[pin].kind == AIO_SAFE_PULSE && pins_role[pin] == ROLE_PWM)
            pwm_set_pulse(pin, safe[pin].value);
        else if (safe[pin].kind == AIO_SAFE_DUTY && pins_role[pin] == ROLE_DUTY)
            duty_set(pin, safe[pin].value);
    }
    stepper_stop_all();
    failsafe_is_armed = 0;
    tripped = 1;
    tripped_event[0] = AIO_CT_EVENT;
    tripped_event[1] = AIO_DT_EVENT_FAILSAFE_TRIPPED;
    tripped_len = parser_seal(tripped_event, 2u);
    event_pending = !hal_tx_send(tripped_event, tripped_len);
}

void failsafe_poll(void)
{
    if (event_pending && hal_tx_send(tripped_event, tripped_len))
        event_pending = 0;
}

uint8_t failsafe_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin, kind, s, err;
    uint16_t v;

    switch (rq->dt) {
    case AIO_DT_FAILSAFE_ARM:
        v = aio_be16(rq->data);
        if (v < AIO_FAILSAFE_MIN_TIMEOUT_MS || v > AIO_FAILSAFE_MAX_TIMEOUT_MS)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        s = hal_irq_save();
        timeout_ms = v;
        last_feed = hal_millis();
        tripped = 0;
        event_pending = 0;
        failsafe_is_armed = 1;
        hal_irq_restore(s);
        break;
    case AIO_DT_FAILSAFE_SAFE_STATE:
        pin = rq->data[0];
        kind = rq->data[1];
        v = aio_be16(rq->data + 2);
        if (!pins_capable(pin, AIO_PINS_DIGITAL_OUTPUT))
            return AIO_ERR_PIN_NOT_CAPABLE;
        if (kind > AIO_SAFE_DUTY)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        if (kind == AIO_SAFE_LEVEL && v > 1u)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        if (kind == AIO_SAFE_PULSE) {
            if (!pins_capable(pin, AIO_PINS_SOFT_PWM | AIO_PINS_SERVO_PWM))
                return AIO_ERR_PIN_NOT_CAPABLE;
            err = pwm_check_pulse(pin, v);
            if (err)
                return err;
        }
        if (kind == AIO_SAFE_DUTY && !pins_capable(pin, AIO_PINS_DUTY_PWM))
            return AIO_ERR_PIN_NOT_CAPABLE;
        s = hal_irq_save();
        safe[pin].kind = kind;
        safe[pin].value = v;
        hal_irq_restore(s);
        break;
    case AIO_DT_FAILSAFE_DISARM:
        s = hal_irq_save();
        failsafe_is_armed = 0;
        tripped = 0;
        event_pending = 0;
        hal_irq_restore(s);
        break;
    default:
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    }
    return aio_echo(rq, rp);
}

/*
 * gpio.c - GPIO class (CT 0x02).
 *
 * Inputs are watched by pin-change interrupts: gpio_pin_change() latches
 * rising and falling edges per pin until a READ of that pin (and, separately,
 * until the next stream sample).
 *
 * Watched inputs (GPIO_WATCH, protocol.md 7.4) also report each change the
 * interrupt sees as a GPIO_CHANGE event, sent from the interrupt itself: one
 * event per pin and interrupt, stamped with the board clock.  A pulse shorter
 * than the interrupt's latency shows no change and is not reported; an event
 * that does not fit the transmit buffer is dropped, its sequence number used
 * up, so the host sees the loss as a gap.
 */
#include "gpio.h"

#include "encoder.h"
#include "hal.h"
#include "parser.h"
#include "pins.h"
#include "pulse.h"

volatile uint16_t gpio_watch; /* GPIO inputs (the pin-change vector calls gpio_pin_change only for them) */
static volatile uint16_t last_levels;
static volatile uint16_t rose, fell;  /* for READ */
static volatile uint16_t s_rose, s_fell; /* for stream samples */
static volatile uint16_t notify;      /* watched inputs: GPIO_CHANGE events */
static uint16_t change_seq;           /* sequence number of the next event */

void gpio_init(void)
{
    gpio_watch = 0;
    rose = fell = s_rose = s_fell = notify = 0;
    change_seq = 0;
    last_levels = 0;
    hal_edge_watch(0);
}

/* One GPIO_CHANGE event per changed watched pin (interrupt context). */
static void report(uint16_t changed, uint16_t levels) __attribute__((noinline));
static void report(uint16_t changed, uint16_t levels)
{
    uint8_t frame[AIO_REPLY_LEN_EVENT_GPIO_CHANGE + 2u + AIO_CHECK_MAX], *p, pin;
    uint32_t now = hal_micros();

    for (pin = PINS_FIRST; pin < PINS_COUNT; pin++) {
        if (!(changed >> pin & 1u))
            continue;
        p = frame;
        *p++ = AIO_CT_EVENT;
        *p++ = AIO_DT_EVENT_GPIO_CHANGE;
        *p++ = pin;
        *p++ = (levels >> pin & 1u) ? (uint8_t)(AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE)
                                    : (uint8_t)AIO_GPIO_STATE_FELL;
        p = aio_put16(p, change_seq);
        change_seq++;
        p = aio_put32(p, now);
        hal_tx_send(frame, parser_seal(frame, (uint8_t)(p - frame))); /* dropped if it does not fit */
    }
}

void gpio_pin_change(uint16_t levels)
{
    uint16_t changed = (uint16_t)((levels ^ last_levels) & gpio_watch);
    last_levels = levels;
    rose |= (uint16_t)(changed & levels);
    fell |= (uint16_t)(changed & ~levels);
    s_rose |= (uint16_t)(changed & levels);
    s_fell |= (uint16_t)(changed & ~levels);
    if (changed & notify)
        report((uint16_t)(changed & notify), levels);
}

void gpio_poll(void)
{
    uint8_t s;
    if (!AIO_PINS_POLLED_EDGES || !(AIO_PINS_POLLED_EDGES & gpio_watch))
        return; /* (the first test folds: gpio_watch is volatile) */
    s = hal_irq_save();
    gpio_pin_change(hal_pin_levels());
    hal_irq_restore(s);
}

void gpio_take_stream_edges(uint16_t *r, uint16_t *f)
{
    uint8_t s = hal_irq_save();
    *r = s_rose;
    *f = s_fell;
    s_rose = s_fell = 0;
    hal_irq_restore(s);
}

static void set_watch(uint8_t pin, uint8_t on)
{
    uint16_t bit = pins_bit_of(pin);
    uint8_t s = hal_irq_save();
    if (on)
        gpio_watch |= bit;
    else
        gpio_watch &= (uint16_t)~bit;
    notify &= (uint16_t)~bit; /* a new role or configuration ends a subscription */
    last_levels = (uint16_t)((last_levels & ~bit) | (hal_pin_levels() & bit));
    rose &= (uint16_t)~bit;
    fell &= (uint16_t)~bit;
    s_rose &= (uint16_t)~bit;
    s_fell &= (uint16_t)~bit;
    hal_edge_watch((uint16_t)(gpio_watch | encoder_pcint_mask() | pulse_pcint_mask()));
    hal_irq_restore(s);
}

void gpio_release(uint8_t pin) { set_watch(pin, 0); }

uint16_t gpio_watch_mask(void) { return gpio_watch; }

static uint8_t gpio_handle_other(const aio_request_t *rq, aio_reply_t *rp) __attribute__((noinline));

/* GPIO WRITE, the hot request, for gpio_handle and for the dispatcher's
 * short path (gpio_write). */
__attribute__((always_inline)) static inline uint8_t write_pin(uint8_t pin, uint8_t level)
{
    /* A pin holds ROLE_GPIO_OUT only if it is capable (pins_claim_check), so
     * one test admits every good request; a refused one gets the checks in
     * their order for its precise error. */
    if (!(pin < PINS_COUNT && pins_role[pin] == ROLE_GPIO_OUT && level <= 1)) {
        if (!pins_capable(pin, AIO_PINS_DIGITAL_INPUT | AIO_PINS_DIGITAL_OUTPUT))
            return AIO_ERR_PIN_NOT_CAPABLE;
        if (level > 1)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        return AIO_ERR_PIN_NOT_CONFIGURED;
    }
    hal_pin_write(pin, level);
    return 0;
}

__attribute__((optimize("O2"))) uint8_t gpio_write(const aio_request_t *rq)
{
    return write_pin(rq->data[0], rq->data[1]);
}

/* WRITE stays in a small function that saves few registers; the other
 * requests go to gpio_handle_other. */
__attribute__((optimize("O2"))) uint8_t gpio_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin = rq->data[0];
    uint8_t arg = rq->data[1];
    uint8_t err;

    if (rq->dt != AIO_DT_GPIO_WRITE)
        return gpio_handle_other(rq, rp);
    err = write_pin(pin, arg);
    if (err)
        return err;
    rp->data[0] = pin; /* the echo, without aio_echo's loop */
    rp->data[1] = arg;
    rp->len = 2;
    return 0;
}

static uint8_t gpio_handle_other(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin = rq->data[0];
    uint8_t arg = rq->data[1];
    uint8_t err, role, state, s;
    uint16_t bit;

    if (rq->dt != AIO_DT_GPIO_CONFIG && rq->dt != AIO_DT_GPIO_READ &&
        rq->dt != AIO_DT_GPIO_PIN_RELEASE && rq->dt != AIO_DT_GPIO_WATCH)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (!pins_capable(pin, AIO_PINS_DIGITAL_INPUT | AIO_PINS_DIGITAL_OUTPUT))
        return AIO_ERR_PIN_NOT_CAPABLE;
    bit = pins_bit_of(pin);
    role = pins_role[pin];

    switch (rq->dt) {
    case AIO_DT_GPIO_CONFIG:
        if (arg & ~(AIO_GPIO_OUTPUT | AIO_GPIO_INITIAL_HIGH | AIO_GPIO_PULL_UP))
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        if ((arg & AIO_GPIO_OUTPUT) ? (arg & AIO_GPIO_PULL_UP) : (arg & AIO_GPIO_INITIAL_HIGH))
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        err = pins_claim_check(pin, (arg & AIO_GPIO_OUTPUT) ? AIO_PINS_DIGITAL_OUTPUT
                                                            : AIO_PINS_DIGITAL_INPUT,
                               ROLE_GPIO_IN, ROLE_GPIO_OUT);
        if (err)
            return err;
        if (arg & AIO_GPIO_OUTPUT) {
            set_watch(pin, 0);
            hal_pin_mode(pin, (arg & AIO_GPIO_INITIAL_HIGH) ? HAL_OUT_HIGH : HAL_OUT_LOW);
            pins_role[pin] = ROLE_GPIO_OUT;
        } else {
            hal_pin_mode(pin, (arg & AIO_GPIO_PULL_UP) ? HAL_IN_PULLUP : HAL_IN);
            pins_role[pin] = ROLE_GPIO_IN;
            set_watch(pin, 1); /* clears the latched edges */
        }
        return aio_echo(rq, rp);
    case AIO_DT_GPIO_READ:
        if (role != ROLE_GPIO_IN && role != ROLE_GPIO_OUT)
            return AIO_ERR_PIN_NOT_CONFIGURED;
        gpio_poll(); /* an unlatched edge of a polled pin counts for this read */
        s = hal_irq_save();
        state = (hal_pin_levels() & bit) ? AIO_GPIO_STATE_HIGH : 0;
        if (rose & bit)
            state |= AIO_GPIO_STATE_ROSE;
        if (fell & bit)
            state |= AIO_GPIO_STATE_FELL;
        rose &= (uint16_t)~bit;
        fell &= (uint16_t)~bit;
        hal_irq_restore(s);
        rp->data[0] = pin;
        rp->data[1] = state;
        rp->len = 2;
        return 0;
    case AIO_DT_GPIO_WATCH:
        if (arg > 1)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        if (role != ROLE_GPIO_IN)
            return AIO_ERR_PIN_NOT_CONFIGURED;
        s = hal_irq_save();
        if (arg)
            notify |= bit;
        else
            notify &= (uint16_t)~bit;
        hal_irq_restore(s);
        return aio_echo(rq, rp);
    default: /* AIO_DT_GPIO_PIN_RELEASE */
        pins_release(pin);
        return aio_echo(rq, rp);
    }
}

/*
 * counter.c - COUNTER class (CT 0x06).
 *
 * A watched counter (WATCH, protocol.md 7.4) sends a COUNTER_REPORT from its
 * interrupt every `every` counts; one that does not fit the transmit buffer is
 * dropped (the next report's count shows it).
 */
#include "counter.h"

#include "hal.h"
#include "parser.h"
#include "pins.h"

#define COUNTER_FIRST_PIN 2u

volatile uint32_t counter_counts[2];
volatile uint16_t counter_every[2];
static uint16_t since[2]; /* counts since the last report */

void counter_init(void)
{
    counter_counts[0] = counter_counts[1] = 0;
    counter_every[0] = counter_every[1] = 0;
}

void counter_report(uint8_t index)
{
    uint8_t frame[AIO_REPLY_LEN_EVENT_COUNTER_REPORT + 2u + AIO_CHECK_MAX], *p = frame;

    if (++since[index] < counter_every[index])
        return;
    since[index] = 0;
    *p++ = AIO_CT_EVENT;
    *p++ = AIO_DT_EVENT_COUNTER_REPORT;
    *p++ = (uint8_t)(index + COUNTER_FIRST_PIN);
    p = aio_put32(p, counter_counts[index]);
    p = aio_put32(p, hal_micros());
    hal_tx_send(frame, parser_seal(frame, (uint8_t)(p - frame))); /* dropped if it does not fit */
}

static void set_every(uint8_t idx, uint16_t every)
{
    uint8_t s = hal_irq_save();
    counter_every[idx] = every;
    since[idx] = 0;
    hal_irq_restore(s);
}

uint32_t counter_peek(uint8_t index) { return counter_counts[index]; }

void counter_release(uint8_t pin)
{
    hal_counter_disable((uint8_t)(pin - COUNTER_FIRST_PIN));
    set_every((uint8_t)(pin - COUNTER_FIRST_PIN), 0);
}

uint8_t counter_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin = rq->data[0];
    uint8_t idx = (uint8_t)(pin - COUNTER_FIRST_PIN);
    uint8_t err, s;
    uint32_t count;

    if (rq->dt != AIO_DT_COUNTER_CONFIG && rq->dt != AIO_DT_COUNTER_READ &&
        rq->dt != AIO_DT_COUNTER_RESET && rq->dt != AIO_DT_COUNTER_WATCH)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (!pins_capable(pin, AIO_PINS_COUNTER))
        return AIO_ERR_PIN_NOT_CAPABLE;
    if (rq->dt == AIO_DT_COUNTER_CONFIG) {
        if (rq->data[1] > AIO_EDGE_RISING)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        err = pins_claim_check(pin, AIO_PINS_COUNTER, ROLE_COUNTER, ROLE_COUNTER);
        if (err)
            return err;
        hal_counter_disable(idx);
        set_every(idx, 0); /* a new configuration ends a watch */
        hal_pin_mode(pin, HAL_IN);
        pins_role[pin] = ROLE_COUNTER;
        hal_counter_enable(idx, rq->data[1]);
        s = hal_irq_save(); /* after enabling: a stale edge flag has been counted */
        counter_counts[idx] = 0;
        hal_irq_restore(s);
        return aio_echo(rq, rp);
    }
    if (pins_role[pin] != ROLE_COUNTER)
        return AIO_ERR_PIN_NOT_CONFIGURED;
    if (rq->dt == AIO_DT_COUNTER_WATCH) {
        set_every(idx, aio_be16(rq->data + 1));
        return aio_echo(rq, rp);
    }
    s = hal_irq_save();
    count = counter_counts[idx];
    if (rq->dt == AIO_DT_COUNTER_RESET)
        counter_counts[idx] = 0;
    hal_irq_restore(s);
    rp->data[0] = pin;
    aio_put32(rp->data + 1, count);
    rp->len = 5;
    return 0;
}

/*
 * counter.c - COUNTER class (CT 0x06).
 */
#include "counter.h"

#include "hal.h"
#include "pins.h"

#define COUNTER_FIRST_PIN 2u

volatile uint32_t counter_counts[2];

void counter_init(void) { counter_counts[0] = counter_counts[1] = 0; }

uint32_t counter_peek(uint8_t index) { return counter_counts[index]; }

void counter_release(uint8_t pin) { hal_counter_disable((uint8_t)(pin - COUNTER_FIRST_PIN)); }

uint8_t counter_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t pin = rq->data[0];
    uint8_t idx = (uint8_t)(pin - COUNTER_FIRST_PIN);
    uint8_t err, s;
    uint32_t count;

    if (rq->dt != AIO_DT_COUNTER_CONFIG && rq->dt != AIO_DT_COUNTER_READ &&
        rq->dt != AIO_DT_COUNTER_RESET)
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

/*
 * analog.c - ANALOG class (CT 0x03).
 */
#include "analog.h"

#include "hal.h"
#include "i2c.h"
#include "stream.h"

uint16_t analog_convert(uint8_t channel)
{
    uint16_t v;
    stream_adc_acquire();
    v = hal_adc_convert(channel);
    stream_adc_release();
    return v;
}

uint8_t analog_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t ch, *p;

    if (rq->dt != AIO_DT_ANALOG_READ && rq->dt != AIO_DT_ANALOG_READ_ALL)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (rq->dt == AIO_DT_ANALOG_READ) {
        ch = rq->data[0];
        if (!(ch < 16u && (AIO_PINS_ANALOG_INPUT >> ch & 1u)))
            return AIO_ERR_PIN_NOT_CAPABLE;
        if (i2c_enabled() && (AIO_PINS_I2C >> ch & 1u))
            return AIO_ERR_PIN_BUSY;
        rp->data[0] = ch;
        aio_put16(rp->data + 1, analog_convert(ch));
        rp->len = 3;
        return 0;
    }
    /* READ_ALL: with the I2C bridge on, A4/A5 read the bus line levels. */
    p = rp->data;
    for (ch = 0; ch < AIO_ANALOG_CHANNELS; ch++)
        p = aio_put16(p, analog_convert(ch));
    rp->len = (uint8_t)(p - rp->data);
    return 0;
}

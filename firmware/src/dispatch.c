/*
 * dispatch.c - class dispatch, the failsafe gate, reply framing.
 */
#include "dispatch.h"

#include "analog.h"
#include "counter.h"
#include "encoder.h"
#include "spi.h"
#include "pulse_in.h"
#include "sonar.h"
#include "failsafe.h"
#include "gpio.h"
#include "i2c.h"
#include "misc.h"
#include "parser.h"
#include "pwm.h"
#include "stepper.h"
#include "stream.h"

uint8_t dispatch_error(uint8_t ct, uint8_t dt, uint8_t code, uint8_t *frame)
{
    frame[0] = ct;
    frame[1] = dt;
    frame[2] = code;
    return parser_seal(frame, 3u);
}

/* Requests that change an output: refused while the failsafe is tripped. */
static uint8_t changes_output(const aio_request_t *rq)
{
    if (rq->ct == AIO_CT_GPIO)
        return rq->dt != AIO_DT_GPIO_READ && rq->dt != AIO_DT_GPIO_WATCH;
    if (rq->ct == AIO_CT_STEPPER)
        return rq->dt == AIO_DT_STEPPER_MOVE || rq->dt == AIO_DT_STEPPER_RUN;
    return rq->ct == AIO_CT_PWM;
}

/* Every handler answers a descriptor it does not implement with UNKNOWN_DESCRIPTOR
 * before it reads a field or changes any state, even though the parser already filters
 * unknown (CT, DT) pairs: a handler is never safe only because of its caller. */
static aio_handler_t handler(uint8_t ct)
{
    switch (ct) {
    case AIO_CT_MISC: return misc_handle;
    case AIO_CT_GPIO: return gpio_handle;
    case AIO_CT_ANALOG: return analog_handle;
    case AIO_CT_I2C: return i2c_handle;
    case AIO_CT_PWM: return pwm_handle;
    case AIO_CT_COUNTER: return counter_handle;
    case AIO_CT_STREAM: return stream_handle;
    case AIO_CT_FAILSAFE: return failsafe_handle;
#if AIO_WITH_STEPPER
    case AIO_CT_STEPPER: return stepper_handle;
#endif
#if AIO_WITH_ENCODER
    case AIO_CT_ENCODER: return encoder_handle;
#endif
#if AIO_WITH_SPI
    case AIO_CT_SPI: return spi_handle;
#endif
#if AIO_WITH_PULSE_IN
    case AIO_CT_PULSE_IN: return pulse_in_handle;
#endif
#if AIO_WITH_SONAR
    case AIO_CT_SONAR: return sonar_handle;
#endif
    default: return 0;
    }
}

/* The short path for GPIO WRITE, the request a host pipelines most: no
 * handler table, no generic framing.  Its reply echoes the request's pin and
 * level, so the checksum is CT ^ DT ^ pin ^ level as for any reply. */
_Static_assert(AIO_REPLY_LEN_GPIO_WRITE == 2u, "GPIO WRITE replies pin and level");
static inline __attribute__((always_inline)) uint8_t gpio_write_reply(const aio_request_t *rq, uint8_t *frame)
{
    uint8_t err = gpio_write(rq), pin = rq->data[0], level = rq->data[1];
    if (err)
        return dispatch_error((uint8_t)(AIO_CT_GPIO | AIO_ERROR_FLAG), AIO_DT_GPIO_WRITE, err, frame);
    frame[0] = AIO_CT_GPIO;
    frame[1] = AIO_DT_GPIO_WRITE;
    frame[2] = pin;
    frame[3] = level;
    if (parser_crc)
        return parser_seal(frame, 4u);
    frame[4] = (uint8_t)(AIO_CT_GPIO ^ AIO_DT_GPIO_WRITE ^ pin ^ level);
    return 5u;
}

__attribute__((optimize("O2"))) uint8_t dispatch(const aio_request_t *rq, uint8_t *frame)
{
    /* The handler writes its reply data straight into the frame (no copy, no
     * reply on the stack): frame[1] holds rp->len until the DT goes there. */
    aio_reply_t *rp = (aio_reply_t *)(void *)(frame + 1);
    aio_handler_t h;
    uint8_t err, len, i, cs, *p;

    failsafe_feed();
    if (rq->ct == AIO_CT_GPIO && rq->dt == AIO_DT_GPIO_WRITE && !failsafe_tripped())
        return gpio_write_reply(rq, frame);
    h = handler(rq->ct);
    rp->len = 0;
    if (!h)
        err = AIO_ERR_NOT_IN_IMAGE; /* the parser knows the class; this image's profile leaves it out */
    else if (failsafe_tripped() && changes_output(rq))
        err = AIO_ERR_FAILSAFE_TRIPPED;
    else
        err = h(rq, rp);
    if (err)
        return dispatch_error((uint8_t)(rq->ct | AIO_ERROR_FLAG), rq->dt, err, frame);
    /* 8-bit pointer steps: the frame is at most AIO_FRAME_MAX bytes */
    len = i = rp->len;
    frame[0] = rq->ct;
    frame[1] = rq->dt;
    if (parser_crc)
        return parser_seal(frame, (uint8_t)(len + 2u));
    cs = (uint8_t)(rq->ct ^ rq->dt);
    for (p = frame + 2; i; i--)
        cs ^= *p++;
    *p = cs;
    return (uint8_t)(len + 3u);
}

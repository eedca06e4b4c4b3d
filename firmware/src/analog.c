/*
 * analog.c - ANALOG class (CT 0x03) and the ANALOG_CHANGE event.
 *
 * Watched channels (WATCH, protocol.md 7.4, an extension) are sampled from
 * the 100 us timer tick without blocking anything: every WATCH_TICKS ticks,
 * if the ADC is free, the tick starts an interrupt-driven conversion of the
 * next watched channel (in turn), and the ADC interrupt compares the value
 * with the one last reported: a move of more than the channel's deadband
 * sends an ANALOG_CHANGE (channel, value, sequence, board time) and makes the
 * value the new reference.  An event that does not fit the transmit buffer
 * is dropped; its sequence number (one count for all channels) is used up,
 * so the host sees the gap, and the reference stays, so the next sample
 * reports the move again.
 *
 * The ADC has one user at a time: a stream that converts analog channels
 * and a watch exclude each other (PIN_BUSY for the later one); a blocking
 * conversion of the main loop (READ, READ_ALL, WATCH's baseline) waits for
 * a watch conversion in flight (at most one, 104 us) and keeps the tick from
 * starting another until it is done.
 */
#include "analog.h"

#include "hal.h"
#include "parser.h"
#include "i2c.h"
#include "stream.h"

/* Ticks between two watch conversions: each watched channel is sampled
 * every 0.5 ms x the number of watched channels; the ADC is busy ~20 %. */
#define WATCH_TICKS 5u

volatile uint8_t analog_watching; /* bit n: channel n is watched (read by the tick, clock.c) */
static uint16_t deadband[AIO_ANALOG_CHANNELS];
static uint16_t reported[AIO_ANALOG_CHANNELS];
static uint16_t change_seq; /* sequence number of the next event */
static uint8_t countdown;   /* ticks to the next conversion */
static uint8_t sampled;     /* the channel converting or converted last */
static volatile uint8_t converting; /* a watch conversion is in flight */
static volatile uint8_t main_owns;  /* the main loop converts */

void analog_init(void)
{
    analog_watching = 0;
    change_seq = 0;
    converting = main_owns = 0;
    countdown = 1;
}

void analog_tick(void)
{
    uint8_t ch = sampled;
    if (!analog_watching || converting || main_owns || --countdown)
        return;
    countdown = WATCH_TICKS;
    do
        ch = (uint8_t)(ch + 1u < AIO_ANALOG_CHANNELS ? ch + 1u : 0u);
    while (!(analog_watching >> ch & 1u));
    sampled = ch;
    converting = 1;
    hal_adc_start(ch, HAL_ADC_SHIFT_ACCURATE);
}

static void watch_done(uint16_t value)
{
    uint8_t frame[AIO_REPLY_LEN_EVENT_ANALOG_CHANGE + 2u + AIO_CHECK_MAX], *p = frame, len;
    uint8_t ch = sampled;
    uint16_t last = reported[ch];

    /* (A4/A5 read the bus lines while the I2C bridge is on: they stay silent) */
    if (analog_watching >> ch & 1u && !(i2c_enabled() && (AIO_PINS_I2C >> ch & 1u)) &&
        (value > last ? value - last : last - value) > deadband[ch]) {
        *p++ = AIO_CT_EVENT;
        *p++ = AIO_DT_EVENT_ANALOG_CHANGE;
        *p++ = ch;
        p = aio_put16(p, value);
        p = aio_put16(p, change_seq);
        change_seq++;
        p = aio_put32(p, hal_micros());
        len = parser_seal(frame, (uint8_t)(p - frame));
        if (hal_tx_send(frame, len)) /* dropped if it does not fit */
            reported[ch] = value;
    }
    converting = 0;
}

void analog_adc_done(uint16_t value)
{
    if (converting)
        watch_done(value);
    else
        stream_adc_done(value);
}

uint16_t analog_convert(uint8_t channel)
{
    uint16_t v, start;
    stream_adc_acquire();
    main_owns = 1;
    start = hal_ticks();
    while (converting && (uint16_t)(hal_ticks() - start) <= 3u)
        hal_wait();
    converting = 0; /* (a conversion that never ended: its sample is lost) */
    v = hal_adc_convert(channel);
    main_owns = 0;
    stream_adc_release();
    return v;
}

uint8_t analog_watched(void) { return analog_watching; }

/* WATCH: channel, deadband (0 stops); the reply adds the baseline value. */
static uint8_t watch(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t ch = rq->data[0], bit = (uint8_t)(1u << ch), s;
    uint16_t band = aio_be16(rq->data + 1), v;

    /* A board with more analog inputs than watch slots (the Mega: 16 and 6) watches the
     * first AIO_ANALOG_CHANNELS; folds away where every input has a slot (the Uno). */
    if ((AIO_PINS_ANALOG_INPUT >> AIO_ANALOG_CHANNELS) && ch >= AIO_ANALOG_CHANNELS)
        return AIO_ERR_PIN_NOT_CAPABLE;

    if (band > AIO_ANALOG_MAX)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (band && stream_converts())
        return AIO_ERR_PIN_BUSY;
    v = analog_convert(ch);
    s = hal_irq_save(); /* the ADC interrupt reads them */
    deadband[ch] = band;
    reported[ch] = v;
    if (band)
        analog_watching |= bit;
    else
        analog_watching &= (uint8_t)~bit;
    countdown = 1;
    hal_irq_restore(s);
    aio_echo(rq, rp);
    aio_put16(rp->data + 3, v);
    rp->len = 5;
    return 0;
}

uint8_t analog_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t ch, *p;

    if (rq->dt != AIO_DT_ANALOG_READ && rq->dt != AIO_DT_ANALOG_READ_ALL &&
        rq->dt != AIO_DT_ANALOG_WATCH)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (rq->dt != AIO_DT_ANALOG_READ_ALL) {
        ch = rq->data[0];
        if (!(ch < 16u && (AIO_PINS_ANALOG_INPUT >> ch & 1u)))
            return AIO_ERR_PIN_NOT_CAPABLE;
        if (i2c_enabled() && (AIO_PINS_I2C >> ch & 1u))
            return AIO_ERR_PIN_BUSY;
        if (rq->dt == AIO_DT_ANALOG_WATCH)
            return watch(rq, rp);
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

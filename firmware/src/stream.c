/*
 * stream.c - STREAM class (CT 0x07) and the STREAM_SAMPLE event.
 *
 * A Timer0 alarm (hal_stream_timer_start) marks the sampling instants, exact
 * to 0.5 us, so a sample's timestamp is the start time plus whole periods
 * (read from the clock it could be torn by a tick interrupt the alarm
 * preempted); there the alarm latches the timestamp, levels, edges and
 * counters into the frame, then an ADC conversion chain (one interrupt per
 * channel) fills in the analog values, and the last step queues the frame if
 * it fits the transmit buffer (else the sample is dropped; its sequence
 * number is used up either way).
 *
 * The chain's ADC clock is chosen at START: the slowest (most accurate) one
 * whose chain for all channels ends within 7/8 of the period.  At
 * 125 kHz (prescaler 128) a conversion takes 104 us with full 10-bit
 * accuracy; each halving of the prescaler halves the time and costs
 * accuracy (the datasheet gives full accuracy only at 50-200 kHz).  Periods of 1 ms and more with up to 6 channels keep 125 kHz.
 * Blocking conversions of the main loop wait for a running chain; a sampling
 * instant that finds the main loop converting starts its chain when the main
 * loop releases the ADC.
 */
#include "stream.h"

#include "analog.h"
#include "counter.h"
#include "duty.h"
#include "encoder.h"
#include "gpio.h"
#include "hal.h"
#include "parser.h"
#include "i2c.h"
#include "stepper.h"
#include "i2cblock.h"
#include "sonar.h"
#include "pulse_in.h"

#ifndef BAUD
#define BAUD 115200UL
#endif

#define HDR 11u /* 40 01 MASK FLAGS SEQ(2) T(4) LEN */

/* The stream flags this image can carry: an optional class's flag only where the
 * build profile holds the class (protocol/profiles.py); START refuses the others. */
#define STREAM_FLAGS                                                                     \
    (AIO_STREAM_LEVELS | AIO_STREAM_EDGES | AIO_STREAM_COUNTERS |                        \
     (AIO_WITH_STEPPER ? AIO_STREAM_STEPPERS : 0u) | (AIO_WITH_ENCODER ? AIO_STREAM_ENCODERS : 0u) | \
     (AIO_WITH_SONAR ? AIO_STREAM_SONAR : 0u) | (AIO_WITH_PULSE_IN ? AIO_STREAM_PULSE_IN : 0u) | \
     (AIO_WITH_I2C_STREAM ? AIO_STREAM_I2C : 0u))

static volatile uint8_t running;
static uint8_t mask, flags;
#if AIO_WITH_SONAR
static uint8_t sonars;               /* the sonar slots the samples carry (frozen at START) */
#else
#define sonars 0u
#endif
#if AIO_WITH_PULSE_IN
static uint8_t pulse_ins;            /* the pulse input slots the samples carry (frozen at START) */
#else
#define pulse_ins 0u
#endif
static uint8_t adc_shift;            /* ADC clock of the chain: 16 MHz >> adc_shift */
static uint16_t seq;                 /* sequence number of the next sample */
static uint32_t instant;             /* its sampling instant, board microseconds */
static uint16_t stream_period;          /* the stream's period */
static volatile uint8_t busy;        /* a sample is being assembled */
static volatile uint8_t pending;     /* its ADC chain waits for the main loop */
static volatile uint8_t main_owns;   /* the main loop converts */
static uint8_t channels[AIO_ANALOG_CHANNELS]; /* the mask's channels, in order */
static uint8_t channel_count;
static uint8_t channel;              /* index in channels[] of the next conversion */
static uint8_t pos;                  /* next analog value position in frame */
static volatile uint8_t waiting;     /* WAIT_* parts of the sample still being filled */
/* a sample frame: header, values, check bytes */
static uint8_t frame[HDR + AIO_STREAM_MAX_VALUES + AIO_CHECK_MAX];

enum { WAIT_CHAIN = 1, WAIT_I2C = 2 };
static uint8_t frame_len;

void stream_init(void)
{
    running = busy = pending = main_owns = 0;
    seq = 0;
}

uint8_t stream_running(void) { return running; }

uint8_t stream_converts(void) { return running && mask; }

/* `sn`: the sonar slots, if f holds SONAR; `pn`: the pulse input slots, if PULSE_IN */
static uint8_t value_bytes(uint8_t m, uint8_t f, uint8_t sn, uint8_t pn)
{
    uint8_t n = 0;
    for (; m; m >>= 1)
        n = (uint8_t)(n + (m & 1u) * 2u);
    if (f & AIO_STREAM_LEVELS)
        n += 2;
    if (f & AIO_STREAM_EDGES)
        n += 4;
    if (f & AIO_STREAM_COUNTERS)
        n += 8;
#if AIO_WITH_STEPPER
    if (f & AIO_STREAM_STEPPERS)
        n += 4u * AIO_STEPPER_COUNT;
#endif
#if AIO_WITH_ENCODER
    if (f & AIO_STREAM_ENCODERS)
        n += 4u * AIO_ENCODER_SLOTS;
#endif
#if AIO_WITH_SONAR
    if (f & AIO_STREAM_SONAR)
        n += 1u + 3u * sn;
#else
    (void)sn;
#endif
#if AIO_WITH_PULSE_IN
    if (f & AIO_STREAM_PULSE_IN)
        n += 1u + 3u * pn;
#else
    (void)pn;
#endif
#if AIO_WITH_I2C_STREAM
    if (f & AIO_STREAM_I2C)
        n += i2cblock_bytes();
#endif
    return n;
}

uint8_t stream_admit(uint8_t len, uint16_t period_us, uint32_t baud)
{
    /* (12 + LEN) * 10 * 1e6 / baud <= 3/4 * PERIOD */
    uint64_t need = (uint64_t)(AIO_STREAM_FRAME_OVERHEAD + len) * 10000000ull * AIO_STREAM_LINK_SHARE_DEN;
    uint64_t have = (uint64_t)AIO_STREAM_LINK_SHARE_NUM * period_us * baud;
    return need <= have;
}

static void finish(void)
{
    /* frame_len counts one check byte: the framing's are appended here */
    hal_tx_send(frame, parser_seal(frame, (uint8_t)(frame_len - 1u))); /* dropped if it does not fit */
    busy = 0;
}

/* A part of the sample (the ADC chain, the I2C reads) is complete: the last one
 * sends the frame.  The ADC interrupt runs with interrupts enabled, so the TWI
 * interrupt may end its part meanwhile: the test-and-clear is atomic. */
static void part_done(uint8_t part)
{
    uint8_t s = hal_irq_save(), left;
    left = waiting = (uint8_t)(waiting & ~part);
    hal_irq_restore(s);
    if (!left)
        finish();
}

uint8_t stream_reads_i2c(void) { return (flags & AIO_STREAM_I2C) != 0; }

void stream_i2c_done(void)
{
    if (busy)
        part_done(WAIT_I2C);
}

static void next_channel(void)
{
    if (channel >= channel_count)
        part_done(WAIT_CHAIN);
    else
        hal_adc_start(channels[channel], adc_shift);
}

void stream_adc_done(uint16_t value)
{
    if (!busy || pending)
        return; /* cancelled by STOP */
    frame[pos++] = (uint8_t)(value >> 8);
    frame[pos++] = (uint8_t)value;
    channel++;
    next_channel();
}

static void sample(void)
{
    uint8_t *p = frame;
    uint8_t len = value_bytes(mask, flags, sonars, pulse_ins);
    uint16_t r, f;

    *p++ = AIO_CT_EVENT;
    *p++ = AIO_DT_EVENT_STREAM_SAMPLE;
    *p++ = mask;
    *p++ = flags;
    p = aio_put16(p, seq);
    seq++;
    p = aio_put32(p, instant);
    *p++ = len;
    pos = (uint8_t)(p - frame);
    p += (uint8_t)(len - value_bytes(0, flags, sonars, pulse_ins)); /* analog values come from the chain */
    if (flags & AIO_STREAM_LEVELS)
        p = aio_put16(p, hal_pin_levels() & AIO_PINS_DIGITAL_INPUT);
    if (flags & AIO_STREAM_EDGES) {
        gpio_take_stream_edges(&r, &f);
        p = aio_put16(p, r);
        p = aio_put16(p, f);
    }
    if (flags & AIO_STREAM_COUNTERS) {
        p = aio_put32(p, counter_peek(0));
        p = aio_put32(p, counter_peek(1));
    }
#if AIO_WITH_STEPPER
    if (flags & AIO_STREAM_STEPPERS)
        for (r = 0; r < AIO_STEPPER_COUNT; r++)
            p = aio_put32(p, (uint32_t)stepper_position((uint8_t)r));
#endif
#if AIO_WITH_ENCODER
    if (flags & AIO_STREAM_ENCODERS)
        for (r = 0; r < AIO_ENCODER_SLOTS; r++)
            p = aio_put32(p, (uint32_t)encoder_peek((uint8_t)r));
#endif
#if AIO_WITH_SONAR
    if (flags & AIO_STREAM_SONAR) {
        *p++ = sonars;
        p = sonar_stream_put(p, sonars);
    }
#endif
#if AIO_WITH_PULSE_IN
    if (flags & AIO_STREAM_PULSE_IN) {
        *p++ = pulse_ins;
        p = pulse_in_put_stream(p, pulse_ins);
    }
#endif
    frame_len = (uint8_t)(HDR + len + 1u);
    busy = 1;
    waiting = WAIT_CHAIN | WAIT_I2C;
    /* the blocks' bytes are the payload's last; the read overlaps the ADC chain (it
     * may end before i2cblock_begin returns: a first step refused at once) */
    if (!(flags & AIO_STREAM_I2C) || !i2cblock_begin(p))
        waiting = WAIT_CHAIN;
    channel = 0;
    if (main_owns)
        pending = 1;
    else
        next_channel();
}

void stream_alarm(void)
{
    if (!running)
        return;
    instant += stream_period;
    if (busy && waiting == WAIT_I2C)
        i2cblock_abort(); /* the read outlasted its period: the sample goes, marked */
    if (busy)
        seq++; /* the previous sample is still converting: drop this one */
    else
        sample();
}

void stream_adc_acquire(void)
{
    uint16_t start = hal_ticks();
    uint8_t s;
    for (;;) {
        s = hal_irq_save();
        if (!busy || pending || (uint16_t)(hal_ticks() - start) > 50u) {
            if (busy && !pending)
                busy = 0; /* a chain that never finished: drop its sample */
            main_owns = 1;
            hal_irq_restore(s);
            return;
        }
        hal_irq_restore(s);
        hal_wait();
    }
}

void stream_adc_release(void)
{
    uint8_t s = hal_irq_save();
    main_owns = 0;
    if (pending) {
        pending = 0;
        if (busy)
            next_channel();
    }
    hal_irq_restore(s);
}

/* Cycles a chain costs besides the conversions: per channel (the ADC
 * interrupt and the next start) and per sample (latching, checksum, queueing),
 * measured in simavr with margin. */
#define CHAIN_CYCLES_PER_CHANNEL 160u
#define CHAIN_CYCLES_PER_SAMPLE 960u

uint8_t stream_adc_clock(uint8_t channels, uint16_t period_us)
{
    uint8_t shift;
    /* a conversion is 13 ADC clocks = 13 << shift CPU cycles; the chain must
     * end within 7/8 of the period (16 cycles a microsecond) */
    for (shift = HAL_ADC_SHIFT_ACCURATE; shift >= HAL_ADC_SHIFT_FASTEST; shift--)
        if ((uint32_t)channels * ((13u << shift) + CHAIN_CYCLES_PER_CHANNEL) + CHAIN_CYCLES_PER_SAMPLE <=
            (uint32_t)period_us * 14u)
            return shift;
    return 0;
}

static void stop(void)
{
    uint8_t s = hal_irq_save();
    hal_stream_timer_stop();
    running = 0;
    i2cblock_cancel();
    if (busy) {
        busy = 0; /* cancel the sample being assembled: it was never sent */
        pending = 0;
        seq--;
    }
    hal_irq_restore(s);
}

uint8_t stream_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t m, f, s, shift, sn = sonar_stream_count(), pn;
    uint16_t period, r;

    if (rq->dt != AIO_DT_STREAM_START && rq->dt != AIO_DT_STREAM_STOP)
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    if (rq->dt == AIO_DT_STREAM_STOP) {
        stop();
        aio_put16(rp->data, seq);
        rp->len = 2;
        return 0;
    }
    m = rq->data[0];
    f = rq->data[1];
    period = aio_be16(rq->data + 2);
#if AIO_WITH_PULSE_IN
    pn = pulse_in_stream_slots();
#else
    pn = 0;
#endif
    if (m & ~((1u << AIO_ANALOG_CHANNELS) - 1u) ||
        f & ~STREAM_FLAGS ||
        (m == 0 && f == 0) || value_bytes(m, f, sn, pn) > AIO_STREAM_MAX_VALUES ||
        period < AIO_STREAM_MIN_PERIOD_US || period > AIO_STREAM_MAX_PERIOD_US ||
        period % AIO_STREAM_PERIOD_STEP_US)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (i2c_enabled() && (m & AIO_PINS_I2C))
        return AIO_ERR_PIN_BUSY;
    if ((f & AIO_STREAM_I2C) && !i2c_enabled())
        return AIO_ERR_I2C_NOT_CONFIGURED;
    if (duty_timer_busy(DUTY_TIMER0))
        return AIO_ERR_PIN_BUSY; /* duty PWM on D5/D6 holds the alarm timer */
    if (m && analog_watched())
        return AIO_ERR_PIN_BUSY; /* the ADC samples watched channels */
    if (!stream_admit(value_bytes(m, f, sn, pn), period, BAUD))
        return AIO_ERR_LINK_CAPACITY;
    shift = stream_adc_clock((uint8_t)(value_bytes(m, 0, 0, 0) / 2u), period);
    if (!shift)
        return AIO_ERR_VALUE_OUT_OF_RANGE; /* not reached: 6 channels take 78 us at 1 MHz */
    stop();
    gpio_take_stream_edges(&r, &r); /* start the edges afresh */
    s = hal_irq_save();
    mask = m;
    flags = f;
#if AIO_WITH_SONAR
    sonars = sn;
#endif
#if AIO_WITH_PULSE_IN
    pulse_ins = pn;
#endif
    adc_shift = shift;
    channel_count = 0;
    for (r = 0; r < AIO_ANALOG_CHANNELS; r++)
        if (m >> r & 1u)
            channels[channel_count++] = (uint8_t)r;
    seq = 0;
    running = 1;
    stream_period = period;
    instant = hal_micros(); /* the alarm is a period from now: each instant adds one */
    hal_stream_timer_start((uint32_t)period * HAL_FINE_PER_US);
    hal_irq_restore(s);
    return aio_echo(rq, rp);
}

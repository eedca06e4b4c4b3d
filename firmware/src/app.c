/*
 * app.c - the main loop: RX FIFO -> parser -> class sub-parsers -> TX buffer.
 *
 * A reply is queued only when the whole frame fits the transmit buffer; until
 * then the loop waits and takes no further byte from the receive FIFO.
 *
 * While the host keeps requests in flight the FIFO holds whole frames: up to
 * BATCH_MAX quick ones (dispatch_quick: requests that never wait) are
 * answered in one step, their replies built in the transmit buffer itself
 * (no copy) and queued at once, so each waits at most for a few quick
 * requests that were already waiting behind it.
 *
 * Low-latency mode (SET_LOW_LATENCY): the loop counts the reply bytes of a
 * burst; when the FIFO has run dry it asks the UART for filler so that burst
 * and filler make AIO_LOW_LATENCY_PAD (97) bytes, which the Uno's 16U2 bridge
 * sends at once instead of on its 4.096 ms tick.
 */
#include "app.h"

#include "analog.h"

#include "counter.h"
#include "encoder.h"
#include "spi.h"
#include "pulse_in.h"
#include "sonar.h"
#include "duty.h"
#include "dispatch.h"
#include "failsafe.h"
#include "gpio.h"
#include "hal.h"
#include "i2c.h"
#include "i2cblock.h"
#include "misc.h"
#include "parser.h"
#include "pins.h"
#include "pwm.h"
#include "stepper.h"
#include "stream.h"

/* A batch answers at most BATCH_MAX requests and claims at most CLAIM_MAX
 * bytes of the transmit buffer for their replies: half of it, so frames
 * that interrupts queue meanwhile (events, stream samples) keep the other
 * half.  Larger batches share the step's fixed cost among more requests:
 * 8 requests in 76 bytes cost 8 cycles more per pipelined GPIO WRITE
 * (benchmarks/firmware_cycles.py). */
#define BATCH_MAX 16u
#define CLAIM_MAX 96u

static parser_t parser;
static uint8_t pending[2u * AIO_FRAME_MAX]; /* replies not yet queued: whole frames */
static uint8_t pending_len;
static uint8_t burst_len; /* reply bytes since the FIFO last ran dry (< 97 + a batch) */

_Static_assert(CLAIM_MAX >= sizeof pending && CLAIM_MAX <= AIO_TX_BUFFER_SIZE / 2u, "a batch's replies");
_Static_assert(AIO_LOW_LATENCY_PAD + CLAIM_MAX <= 255u, "burst_len is 8-bit");

/* Counts queued reply bytes for the filler (stops counting at the pad). */
static inline void count_burst(uint8_t len)
{
    if (burst_len < AIO_LOW_LATENCY_PAD)
        burst_len = (uint8_t)(burst_len + len);
}

_Static_assert(sizeof pending <= AIO_TX_BUFFER_SIZE, "a batch fits the empty transmit buffer");

void app_init(void)
{
    parser_init(&parser);
    pending_len = 0;
    burst_len = 0;
    pins_init();
    gpio_init();
    i2c_init();
    i2cblock_init();
    pwm_init();
    duty_init();
    stepper_init();
    counter_init();
    encoder_init();
    spi_init();
    pulse_in_init();
    sonar_init();
    stream_init();
    analog_init();
    failsafe_init();
    misc_init();
}

void app_tick(void)
{
    failsafe_tick();
    analog_tick();
}

/* A parser event: build the reply and queue it at once (the transmitter
 * usually takes its first byte right away); if the buffer is full it stays
 * pending and the next steps retry. */
static void handle(uint8_t event)
{
    uint8_t len;

    if (event == PARSER_REQUEST)
        pending_len = dispatch(&parser.rq, pending);
    else
        pending_len = dispatch_error(parser.err_ct, parser.err_dt, parser.err_code, pending);
    len = pending_len;
    if (hal_tx_send(pending, pending_len))
        pending_len = 0;
    count_burst(len); /* after the send: off the reply's path */
}

/* Answers the request parser_take found (n bytes) and, if it is quick, up
 * to BATCH_MAX - 1 quick ones behind it.  Replies of quick requests are built
 * straight in the transmit buffer when it has room there; the others go
 * through `pending`, so interrupt frames are never held up by a slow
 * request.  The hottest path of the firmware: parser_take and dispatch are
 * inlined into it (flatten), which saves their calls and register saves
 * once per pipelined request. */
static void answer_batch(uint8_t n) __attribute__((flatten, noinline, optimize("O2")));
/* A RESET (MISC) is never quick, so it is always a batch of its own and the
 * loop need not look for misc_reset_pending after each request. */
_Static_assert(AIO_CT_MISC != AIO_CT_GPIO && AIO_CT_MISC < AIO_CT_PWM, "MISC is not quick (dispatch_quick)");
static void answer_batch(uint8_t n)
{
    hal_rx_view_t rx;
    uint8_t quick = dispatch_quick(parser.rq.ct), batch = quick ? BATCH_MAX : 1u;
    uint8_t room = 0, len = 0;
    uint8_t *out = quick ? hal_tx_claim(AIO_FRAME_MAX, CLAIM_MAX, &room) : 0;
    if (!out) {
        out = pending;
        room = sizeof pending;
    }
    do {
        hal_rx_consume(n);
        len = (uint8_t)(len + dispatch(&parser.rq, out + len));
        if (!--batch || (uint8_t)(room - len) < AIO_FRAME_MAX)
            break;
        rx = hal_rx_view();
        n = parser_take(&parser, rx.ring, rx.tail, rx.count);
    } while (n && dispatch_quick(parser.rq.ct));
    if (out != pending)
        hal_tx_publish(len);
    else if (!hal_tx_send(pending, len))
        pending_len = len;
    count_burst(len); /* after the send: off the reply's path */
}

uint8_t app_step(void)
{
    int16_t c;
    uint8_t event, n;
    hal_rx_view_t rx;

    failsafe_poll();
    stepper_poll();
    encoder_poll();
    pulse_in_poll();
    sonar_poll();
    gpio_poll();
    if (pending_len) {
        if (!hal_tx_send(pending, pending_len))
            return 0;
        pending_len = 0;
        return 1;
    }
    if (misc_reset_pending) {
        if (hal_tx_idle())
            hal_system_reset();
        return 0;
    }
    if (hal_rx_take_overflow()) {
        pending_len = dispatch_error(AIO_ERROR_FLAG, 0, AIO_ERR_RX_OVERFLOW, pending);
        count_burst(pending_len);
        parser_discard(&parser, hal_ticks());
        return 1;
    }
    rx = hal_rx_view();
    if (rx.count) {
        /* (a request trickling in at the line rate goes byte by byte, and
         * its last byte should not pay for a call that cannot succeed) */
        n = rx.count >= 3u && parser_idle(&parser) ? parser_take(&parser, rx.ring, rx.tail, rx.count) : 0;
        if (n) {
            answer_batch(n);
            return 1;
        }
        /* Part of a frame, or something the parser must see byte by byte:
         * feed the bytes straight from the FIFO until a frame ends or the
         * FIFO is empty (at most a FIFO's worth, so the watchdog and the
         * checks above still come round).  The quiet period counts from
         * now. */
        n = AIO_RX_FIFO_SIZE;
        event = PARSER_NONE;
        while (n-- && (c = hal_rx_get()) >= 0) {
            event = parser_feed(&parser, (uint8_t)c, 0);
            if (event != PARSER_NONE)
                break;
        }
        if (event != PARSER_REQUEST) /* mid-frame or discarding: the quiet period matters */
            parser.last_tick = hal_ticks();
        if (event != PARSER_NONE)
            handle(event);
        return 1;
    }
    event = parser_poll(&parser, hal_ticks());
    if (event == PARSER_NONE) {
        if (burst_len) {
            /* the FIFO ran dry: the burst is over */
            /* no filler while a stream runs: it would take wire time the stream's
             * admission counted on (samples were dropped), and a stream's own
             * frames reach the 97 bytes that flush the bridge */
            if (misc_low_latency && !stream_running())
                hal_tx_pad(burst_len < AIO_LOW_LATENCY_PAD ? (uint8_t)(AIO_LOW_LATENCY_PAD - burst_len) : 0u);
            burst_len = 0;
        }
        return 0;
    }
    handle(event);
    return 1;
}

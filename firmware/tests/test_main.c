/*
 * test_main.c - host tests: parser + dispatcher + class modules with the fake HAL.
 * Built with AddressSanitizer and UBSan by `make -C firmware test`.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "aio_protocol.h"
#include "app.h"
#include "counter.h"
#include "dispatch.h"
#include "fake_hal.h"
#include "hal.h"
#include "i2c.h"
#include "parser.h"
#include "stream.h"
#include "transaction.h"
#include "vectors.h"

static int failures, checks;

#define B(...) ((const uint8_t[]){__VA_ARGS__}), sizeof((const uint8_t[]){__VA_ARGS__})
#define CHECK(...) check(__FILE__, __LINE__, __VA_ARGS__)
#define EXPECT(cond)                                                         \
    do {                                                                     \
        checks++;                                                            \
        if (!(cond)) {                                                       \
            failures++;                                                      \
            printf("%s:%d: FAIL: %s\n", __FILE__, __LINE__, #cond);          \
        }                                                                    \
    } while (0)

static uint8_t out[FAKE_TX_MAX];
static uint32_t outn;

static void board(void)
{
    fake_reset();
    app_init();
}

static void run(void)
{
    int guard = 0;
    while (app_step())
        if (++guard > 1000000) {
            printf("app_step never goes idle\n");
            exit(1);
        }
}

static void take(void)
{
    memcpy(out, fake_tx, fake_tx_len);
    outn = fake_tx_len;
    fake_tx_len = 0;
}

static uint8_t xor_of(const uint8_t *p, size_t n)
{
    uint8_t x = 0;
    while (n--)
        x ^= *p++;
    return x;
}

static void send_frame(const uint8_t *req, size_t rn)
{
    uint8_t buf[300];
    memcpy(buf, req, rn);
    buf[rn] = xor_of(req, rn);
    fake_rx_push(buf, (uint32_t)rn + 1u);
}

static void dump(const char *what, const uint8_t *p, size_t n)
{
    size_t i;
    printf("  %s:", what);
    for (i = 0; i < n; i++)
        printf(" %02x", p[i]);
    printf("\n");
}

/* Sends req (without CS), expects exactly exp (without CS) + CS back. */
static void check(const char *file, int line, const uint8_t *req, size_t rn, const uint8_t *exp,
                  size_t en)
{
    uint8_t want[64];
    send_frame(req, rn);
    run();
    take();
    memcpy(want, exp, en);
    want[en] = xor_of(exp, en);
    checks++;
    if (outn != en + 1 || memcmp(out, want, en + 1)) {
        failures++;
        printf("%s:%d: FAIL\n", file, line);
        dump("request", req, rn);
        dump("expected", want, en + 1);
        dump("got", out, outn);
    }
}

/* ------------------------------------------------------------ MISC */
static void test_misc(void)
{
    board();
    fake_eeprom[0] = 0x01;
    fake_eeprom[1] = 0x02;
    /* Table I -> Table II, byte for byte */
    fake_rx_push(B(0x01, 0x02, 0x03));
    run();
    take();
    EXPECT(outn == 5 && !memcmp(out, "\x01\x02\x01\x02\x00", 5));

    fake_adc[8] = 0x0137;
    CHECK(B(1, 3), B(1, 3, 0x01, 0x37));
    CHECK(B(1, 4), B(1, 4, 1, AIO_FIRMWARE_MAJOR, AIO_FIRMWARE_MINOR, 0x00, 0x05, 0xFF, 0xFF, 0x00,
                     0x01, 0xC2, 0x00, 128));
    CHECK(B(1, 6), B(1, 6, 0, 0, 0));
    CHECK(B(1, 7, 0xBE, 0xEF), B(1, 7, 0xBE, 0xEF));
    CHECK(B(1, 6), B(1, 6, 0, 0xBE, 0xEF));
    CHECK(B(1, 5, 0x12, 0x34), B(1, 5, 0x12, 0x34));
    CHECK(B(1, 2), B(1, 2, 0x12, 0x34));
    fake_eeprom_broken = true;
    CHECK(B(1, 5, 0x55, 0x66), B(0x81, 5, AIO_ERR_EEPROM_FAILED));
    CHECK(B(1, 2), B(1, 2, 0x12, 0x34));
    /* erased EEPROM */
    board();
    CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    /* RESET: reply first, then the watchdog reset; nothing parsed after it */
    send_frame(B(1, 1));
    send_frame(B(1, 2));
    run();
    take();
    EXPECT(outn == 3 && out[0] == 1 && out[1] == 1 && out[2] == 0);
    EXPECT(fake_reset_done);
}

/* SET_LOW_LATENCY: a burst of replies is padded to 97 bytes once the FIFO is dry */
static void test_low_latency(void)
{
    board();
    /* off (after boot): no filler */
    CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    EXPECT(fake_tx_pads == 0);
    /* on: the reply, then 97 - 3 bytes of filler (its reply is padded too) */
    CHECK(B(1, AIO_DT_MISC_SET_LOW_LATENCY, 1), B(1, AIO_DT_MISC_SET_LOW_LATENCY, 1));
    EXPECT(fake_tx_pads == 1 && fake_tx_pad == AIO_LOW_LATENCY_PAD - 4u);
    CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    EXPECT(fake_tx_pads == 2 && fake_tx_pad == AIO_LOW_LATENCY_PAD - 5u);
    /* a burst of three pipelined requests: one pad after the last reply */
    send_frame(B(1, 2));
    send_frame(B(1, 2));
    send_frame(B(1, 6));
    run();
    take();
    EXPECT(outn == 5u + 5u + 6u);
    EXPECT(fake_tx_pads == 3 && fake_tx_pad == AIO_LOW_LATENCY_PAD - 16u);
    /* an error reply is padded too */
    CHECK(B(1, 0x7F), B(0x81, 0x7F, AIO_ERR_UNKNOWN_DESCRIPTOR));
    EXPECT(fake_tx_pads == 4 && fake_tx_pad == AIO_LOW_LATENCY_PAD - 4u);
    fake_advance(2u * AIO_INTER_BYTE_GAP_MS * 10u); /* the parser discards until the line is quiet */
    run();
    /* a burst longer than the pad needs no filler, but the count restarts */
    {
        int i;
        for (i = 0; i < 25; i++)
            send_frame(B(1, 2));
        run();
        take();
        EXPECT(outn == 125u);
        EXPECT(fake_tx_pads == 5 && fake_tx_pad == 0);
    }
    /* nothing sent, nothing padded: idle steps do not pad again */
    run();
    EXPECT(fake_tx_pads == 5);
    /* a value other than 0/1 is refused; the mode stays on */
    CHECK(B(1, AIO_DT_MISC_SET_LOW_LATENCY, 2),
          B(0x81, AIO_DT_MISC_SET_LOW_LATENCY, AIO_ERR_VALUE_OUT_OF_RANGE));
    EXPECT(fake_tx_pads == 6 && fake_tx_pad == AIO_LOW_LATENCY_PAD - 4u);
    /* off again: no more filler */
    CHECK(B(1, AIO_DT_MISC_SET_LOW_LATENCY, 0), B(1, AIO_DT_MISC_SET_LOW_LATENCY, 0));
    CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    EXPECT(fake_tx_pads == 6);
    /* no filler while a stream runs (its frames reach the pad by themselves and the
     * filler's wire time is the stream's), again once it stops */
    CHECK(B(1, AIO_DT_MISC_SET_LOW_LATENCY, 1), B(1, AIO_DT_MISC_SET_LOW_LATENCY, 1));
    EXPECT(fake_tx_pads == 7);
    CHECK(B(7, 1, 0x0F, 0, 0x09, 0x60), B(7, 1, 0x0F, 0, 0x09, 0x60)); /* 4 ch 2400 us */
    CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    EXPECT(fake_tx_pads == 7);
    send_frame(B(7, 2));
    run();
    take();
    EXPECT(outn == 5u && out[0] == 7u && out[1] == 2u);
    EXPECT(fake_tx_pads == 8 && fake_tx_pad == AIO_LOW_LATENCY_PAD - 5u);
    /* a reboot turns it off */
    board();
    CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    EXPECT(fake_tx_pads == 0);
}

/* GPIO_WATCH and the GPIO_CHANGE events sent from the pin-change interrupt */
static void expect_change(int line, uint8_t pin, uint8_t state, uint16_t seq, uint32_t us)
{
    uint8_t want[11] = {AIO_CT_EVENT, AIO_DT_EVENT_GPIO_CHANGE, pin, state,
                        (uint8_t)(seq >> 8), (uint8_t)seq, (uint8_t)(us >> 24),
                        (uint8_t)(us >> 16), (uint8_t)(us >> 8), (uint8_t)us, 0};
    want[10] = xor_of(want, 10);
    take();
    checks++;
    if (outn != 11 || memcmp(out, want, 11)) {
        failures++;
        printf("%s:%d: FAIL\n", __FILE__, line);
        dump("expected", want, 11);
        dump("got", out, outn);
    }
}

static void test_gpio_changes(void)
{
    board();
    CHECK(B(2, 5, 7, 1), B(0x82, 5, AIO_ERR_PIN_NOT_CONFIGURED)); /* not an input */
    CHECK(B(2, 1, 13, 0x01), B(2, 1, 13, 0x01));
    CHECK(B(2, 5, 13, 1), B(0x82, 5, AIO_ERR_PIN_NOT_CONFIGURED)); /* an output */
    CHECK(B(2, 5, 1, 1), B(0x82, 5, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00));
    CHECK(B(2, 5, 7, 2), B(0x82, 5, AIO_ERR_VALUE_OUT_OF_RANGE));
    fake_drive(7, 1); /* not watched yet: no event */
    take();
    EXPECT(outn == 0);
    CHECK(B(2, 5, 7, 1), B(2, 5, 7, 1));
    fake_fine_now = 2u * 1234u;
    fake_drive(7, 0);
    expect_change(__LINE__, 7, AIO_GPIO_STATE_FELL, 0, 1234);
    fake_drive(7, 0); /* no change, no event */
    take();
    EXPECT(outn == 0);
    fake_fine_now = 2u * 5000u;
    fake_drive(7, 1);
    expect_change(__LINE__, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE, 1, 5000);
    /* the READ latch is independent of the events */
    CHECK(B(2, 2, 7), B(2, 2, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE | AIO_GPIO_STATE_FELL));
    /* a full transmit buffer drops the event; its sequence number is used up */
    fake_tx_capacity = 5;
    fake_drive(7, 0);
    take();
    EXPECT(outn == 0);
    fake_tx_capacity = 192;
    fake_drive(7, 1);
    expect_change(__LINE__, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE, 3, 5000);
    /* unsubscribe */
    CHECK(B(2, 5, 7, 0), B(2, 5, 7, 0));
    fake_drive(7, 0);
    take();
    EXPECT(outn == 0);
    /* reconfiguring or releasing ends the subscription */
    CHECK(B(2, 5, 7, 1), B(2, 5, 7, 1));
    CHECK(B(2, 1, 7, 0x04), B(2, 1, 7, 0x04));
    fake_drive(7, 1);
    take();
    EXPECT(outn == 0);
    CHECK(B(2, 5, 7, 1), B(2, 5, 7, 1));
    CHECK(B(2, 4, 7), B(2, 4, 7));
    fake_drive(7, 0);
    take();
    EXPECT(outn == 0);
}

/* COUNTER WATCH: a COUNTER_REPORT from the counter's interrupt every N counts */
static void test_counter_reports(void)
{
    uint8_t i;
    board();
    CHECK(B(6, 4, 2, 0, 3), B(0x86, 4, AIO_ERR_PIN_NOT_CONFIGURED)); /* not a counter */
    CHECK(B(6, 4, 4, 0, 3), B(0x86, 4, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(6, 1, 2, AIO_EDGE_RISING), B(6, 1, 2, AIO_EDGE_RISING));
    CHECK(B(6, 4, 2, 0, 3), B(6, 4, 2, 0, 3));
    fake_fine_now = 2u * 777u;
    for (i = 0; i < 7; i++) {
        fake_drive(2, 1);
        fake_drive(2, 0);
        take();
        if (i == 2 || i == 5) {
            uint8_t want[12] = {AIO_CT_EVENT, AIO_DT_EVENT_COUNTER_REPORT, 2, 0, 0, 0,
                                (uint8_t)(i + 1), 0, 0, 0x03, 0x09, 0};
            want[11] = xor_of(want, 11);
            EXPECT(outn == 12 && !memcmp(out, want, 12));
        } else {
            EXPECT(outn == 0);
        }
    }
    CHECK(B(6, 4, 2, 0, 0), B(6, 4, 2, 0, 0)); /* stop */
    for (i = 0; i < 4; i++) {
        fake_drive(2, 1);
        fake_drive(2, 0);
    }
    take();
    EXPECT(outn == 0);
    CHECK(B(6, 2, 2), B(6, 2, 2, 0, 0, 0, 11));
    /* a new configuration ends the watch */
    CHECK(B(6, 4, 2, 0, 1), B(6, 4, 2, 0, 1));
    CHECK(B(6, 1, 2, AIO_EDGE_RISING), B(6, 1, 2, AIO_EDGE_RISING));
    fake_drive(2, 1);
    take();
    EXPECT(outn == 0);
}

/* ------------------------------------------------------------ TRANSACTION */
static void test_transaction(void)
{
    board();
    CHECK(B(2, 1, 13, 0x01), B(2, 1, 13, 0x01));
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00));
    fake_drive(7, 1);
    /* write D13, read it back, read D7: back to back, every result in order */
    CHECK(B(1, 9, 0x5A, 10, 2, 3, 13, 0, 2, 2, 13, 2, 2, 7),
          B(1, 9, 0x5A, 12, 2, 3, 13, 0, 2, 2, 13, 0, 2, 2, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE));
    EXPECT(fake_pin_level[13] == 0);
    /* a refused item leaves its error reply; the next item still runs */
    CHECK(B(1, 9, 0x5A, 8, 2, 3, 7, 1, 2, 3, 13, 1),
          B(1, 9, 0x5A, 7, 0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED, 2, 3, 13, 1));
    EXPECT(fake_pin_level[13] == 1);
    /* the whole list is checked first: a refused list changes nothing */
    CHECK(B(1, 9, 0x5A, 0), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE));                  /* empty */
    CHECK(B(1, 9, 0x5A, 6, 2, 3, 13, 0, 2, 9), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* unknown */
    CHECK(B(1, 9, 0x5A, 6, 2, 3, 13, 0, 2, 2), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* cut */
    CHECK(B(1, 9, 0x5A, 6, 2, 3, 13, 0, 1, 1), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* reset */
    CHECK(B(1, 9, 0x5A, 8, 2, 3, 13, 0, 1, 9, 0, 0), B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE)); /* nested */
    CHECK(B(1, 9, 0x5A, 10, 2, 3, 13, 0, 3, 3, 3, 3, 3, 3), /* 4 + 3 x 14 result bytes > 32 */
          B(0x81, 9, AIO_ERR_VALUE_OUT_OF_RANGE));
    EXPECT(fake_pin_level[13] == 1);
    /* variable-length items: an I2C write of two bytes (bus off: a per-item error) */
    CHECK(B(1, 9, 0x5A, 7, 4, 3, 0x50, 0, 2, 0xAA, 0xBB),
          B(1, 9, 0x5A, 3, 0x84, 3, AIO_ERR_I2C_NOT_CONFIGURED));
    /* A declared items length over 32 (issue 28: found by a libFuzzer target; SEQ 0): 40 item
     * bytes, an I2C write of 32 bytes and a GPIO read, so walking the list reaches past
     * the 35 data bytes a request holds.  The whole frame is consumed and refused; nothing
     * is read beyond the request (ASan) and the next frame is answered. */
    {
        static const uint8_t frame[] = {
            1, 9, 0x00, 0x28, 4, 3, 0x50, 0, 0x20, 0xED, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
            0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 2, 13, 0xB7};
        EXPECT(xor_of(frame, sizeof frame) == 0);
        fake_rx_push(frame, sizeof frame);
        run();
        take();
        EXPECT(outn == 4 && out[0] == 0x81 && out[1] == 9 && out[2] == AIO_ERR_VALUE_OUT_OF_RANGE);
        CHECK(B(2, 2, 13), B(2, 2, 13, 1));
    }
    /* the handler does not rely on the parser: a length byte over what the request holds
     * is refused before a byte past rq->len is read */
    {
        aio_request_t rq = {AIO_CT_MISC, AIO_DT_MISC_TRANSACTION, AIO_REQUEST_DATA_MAX, {0}};
        aio_reply_t rp;
        memset(rq.data + 2, 2, AIO_REQUEST_DATA_MAX - 2u); /* GPIO READ D2, back to back */
        rq.data[1] = 40;
        EXPECT(transaction_handle(&rq, &rp) == AIO_ERR_VALUE_OUT_OF_RANGE);
        rq.data[1] = AIO_REQUEST_DATA_MAX - 1u; /* one more than it holds */
        EXPECT(transaction_handle(&rq, &rp) == AIO_ERR_VALUE_OUT_OF_RANGE);
    }
    /* nor does I2C WRITE: a length byte of 32 with 2 data bytes sent writes nothing */
    {
        aio_request_t rq = {AIO_CT_I2C, AIO_DT_I2C_WRITE, 5, {0x50, 0x10, 32, 0xAA, 0xBB}};
        aio_reply_t rp;
        CHECK(B(4, 1, 0), B(4, 1, 0));
        fake_i2c_mem[0x10] = 0x11;
        EXPECT(i2c_handle(&rq, &rp) == AIO_ERR_VALUE_OUT_OF_RANGE);
        EXPECT(fake_i2c_mem[0x10] == 0x11);
        rq.data[2] = 2;
        EXPECT(i2c_handle(&rq, &rp) == 0 && fake_i2c_mem[0x10] == 0xAA);
    }
    /* six servo widths at once */
    board();
    {
        uint8_t pin;
        for (pin = 2; pin <= 7; pin++)
            CHECK(B(5, 1, pin, 0, 0), B(5, 1, pin, 0, 0));
    }
    CHECK(B(1, 9, 0x5A, 30, 5, 2, 2, 0x05, 0xDC, 5, 2, 3, 0x05, 0xDD, 5, 2, 4, 0x05, 0xDE, 5, 2, 5,
            0x05, 0xDF, 5, 2, 6, 0x05, 0xE0, 5, 2, 7, 0x05, 0xE1),
          B(1, 9, 0x5A, 30, 5, 2, 2, 0x05, 0xDC, 5, 2, 3, 0x05, 0xDD, 5, 2, 4, 0x05, 0xDE, 5, 2, 5,
            0x05, 0xDF, 5, 2, 6, 0x05, 0xE0, 5, 2, 7, 0x05, 0xE1));
}

/* ------------------------------------------------------------ GPIO */
static void test_gpio(void)
{
    board();
    CHECK(B(2, 1, 13, 0x03), B(2, 1, 13, 0x03)); /* output, high */
    EXPECT(fake_pin_mode[13] == 3 && fake_pin_level[13] == 1);
    CHECK(B(2, 2, 13), B(2, 2, 13, 1));
    CHECK(B(2, 3, 13, 0), B(2, 3, 13, 0));
    EXPECT(fake_pin_level[13] == 0);
    CHECK(B(2, 2, 13), B(2, 2, 13, 0));
    CHECK(B(2, 3, 13, 2), B(0x82, 3, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(2, 1, 7, 0x04), B(2, 1, 7, 0x04)); /* input with pull-up */
    EXPECT(fake_pin_mode[7] == 1);
    CHECK(B(2, 3, 7, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED));
    fake_drive(7, 0); /* the pull-up had it high */
    fake_drive(7, 1);
    fake_drive(7, 0);
    CHECK(B(2, 2, 7), B(2, 2, 7, AIO_GPIO_STATE_ROSE | AIO_GPIO_STATE_FELL));
    CHECK(B(2, 2, 7), B(2, 2, 7, 0)); /* cleared by the read */
    fake_drive(7, 1);
    CHECK(B(2, 2, 7), B(2, 2, 7, AIO_GPIO_STATE_HIGH | AIO_GPIO_STATE_ROSE));
    fake_drive(7, 0);
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00)); /* reconfiguring clears the edges */
    CHECK(B(2, 2, 7), B(2, 2, 7, 0));
    /* flags */
    CHECK(B(2, 1, 5, 0x05), B(0x82, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* output + pull-up */
    CHECK(B(2, 1, 5, 0x02), B(0x82, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* input + level */
    CHECK(B(2, 1, 5, 0x08), B(0x82, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    /* pins */
    CHECK(B(2, 1, 1, 1), B(0x82, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 1, 14, 1), B(0x82, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 2, 0xFF), B(0x82, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 2, 8), B(0x82, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(2, 4, 0), B(0x82, 4, AIO_ERR_PIN_NOT_CAPABLE));
    /* WRITE's refusals in their order: capability, value, role (its handler
     * admits good requests with one test and checks the others one by one) */
    CHECK(B(2, 3, 1, 2), B(0x82, 3, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 3, 14, 0), B(0x82, 3, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 3, 0xFF, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(2, 3, 8, 2), B(0x82, 3, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(2, 3, 8, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(2, 3, 7, 0xFF), B(0x82, 3, AIO_ERR_VALUE_OUT_OF_RANGE)); /* an input */
    CHECK(B(2, 3, 13, 1), B(2, 3, 13, 1));
    EXPECT(fake_pin_level[13] == 1);
    /* one role per pin */
    CHECK(B(5, 1, 3, 0x05, 0xDC), B(5, 1, 3, 0x05, 0xDC));
    CHECK(B(2, 1, 3, 1), B(0x82, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 2, 3), B(0x82, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(2, 3, 3, 1), B(0x82, 3, AIO_ERR_PIN_NOT_CONFIGURED)); /* a PWM pin */
    CHECK(B(2, 4, 3), B(2, 4, 3));
    CHECK(B(2, 1, 3, 1), B(2, 1, 3, 1));
    CHECK(B(2, 4, 3), B(2, 4, 3));
    EXPECT(fake_pin_mode[3] == 0);
    CHECK(B(2, 4, 3), B(2, 4, 3)); /* releasing a free pin */

    /* READ_PIN_ROLES: masks for input, output, PWM, counter; bit n = Dn */
    board();
    CHECK(B(1, 8), B(1, 8, 0, 0, 0, 0, 0, 0, 0, 0));
    CHECK(B(2, 1, 7, 0x00), B(2, 1, 7, 0x00));
    CHECK(B(2, 1, 13, 0x01), B(2, 1, 13, 0x01));
    CHECK(B(5, 1, 3, 0x05, 0xDC), B(5, 1, 3, 0x05, 0xDC));
    CHECK(B(5, 1, 9, 0x05, 0xDC), B(5, 1, 9, 0x05, 0xDC));
    CHECK(B(1, 8), B(1, 8, 0x00, 0x80, 0x20, 0x00, 0x02, 0x08, 0x00, 0x00));
    CHECK(B(2, 4, 9), B(2, 4, 9));
    CHECK(B(1, 8), B(1, 8, 0x00, 0x80, 0x20, 0x00, 0x00, 0x08, 0x00, 0x00));
}

/* ------------------------------------------------------------ ANALOG */
static void test_analog(void)
{
    board();
    fake_adc[0] = 0x3FF;
    fake_adc[5] = 0x123;
    CHECK(B(3, 2, 0), B(3, 2, 0, 0x03, 0xFF));
    CHECK(B(3, 2, 5), B(3, 2, 5, 0x01, 0x23));
    CHECK(B(3, 2, 6), B(0x83, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(3, 3), B(3, 3, 3, 0xFF, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0x23));
    CHECK(B(4, 1, 0), B(4, 1, 0));
    CHECK(B(3, 2, 4), B(0x83, 2, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 2, 5), B(0x83, 2, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 2, 3), B(3, 2, 3, 0, 0));
    CHECK(B(3, 3), B(3, 3, 3, 0xFF, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0x23));
}

/* ------------------------------------------------------------ ANALOG WATCH */
/* The tick starts a watched channel's conversion every 5 ticks; completes it. */
static void analog_sample(void)
{
    fake_advance(5);
    fake_adc_complete();
    take();
}

static void expect_analog_change(uint8_t ch, uint16_t value, uint16_t seq)
{
    uint8_t want[11] = {AIO_CT_EVENT, AIO_DT_EVENT_ANALOG_CHANGE, ch, (uint8_t)(value >> 8),
                        (uint8_t)value, (uint8_t)(seq >> 8), (uint8_t)seq};
    uint32_t t = hal_micros();
    memcpy(want + 7, (uint8_t[]){(uint8_t)(t >> 24), (uint8_t)(t >> 16), (uint8_t)(t >> 8), (uint8_t)t}, 4);
    EXPECT(outn == 12);
    EXPECT(!memcmp(out, want, 11) && out[11] == xor_of(out, 11));
}

static void test_analog_watch(void)
{
    board();
    fake_adc[1] = 100;
    fake_adc[3] = 500;
    CHECK(B(3, 4, 6, 0, 10), B(0x83, 4, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(3, 4, 1, 0x04, 0x00), B(0x83, 4, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 1024 */
    CHECK(B(3, 4, 1, 0, 10), B(3, 4, 1, 0, 10, 0, 100)); /* the baseline comes back */
    EXPECT(fake_adc_pending < 0);
    fake_adc[1] = 110; /* inside the deadband (a move of exactly 10) */
    analog_sample();
    EXPECT(outn == 0);
    fake_adc[1] = 111;
    analog_sample();
    expect_analog_change(1, 111, 0);
    analog_sample(); /* no move: nothing */
    EXPECT(outn == 0);
    fake_adc[1] = 100; /* measured from the value reported last, 111 */
    analog_sample();
    expect_analog_change(1, 100, 1);
    /* two channels take turns; the sequence counts both */
    CHECK(B(3, 4, 3, 0x03, 0xFF), B(3, 4, 3, 0x03, 0xFF, 0x01, 0xF4));
    fake_adc[1] = 0;
    fake_adc[3] = 0;
    analog_sample(); /* channel 3: 500 -> 0 stays inside 1023 */
    EXPECT(outn == 0);
    analog_sample(); /* channel 1: 100 -> 0 */
    expect_analog_change(1, 0, 2);
    /* a blocking read waits for the watch conversion in flight, which still reports */
    fake_adc[1] = 300;
    fake_advance(5);
    EXPECT(fake_adc_pending == 3);
    fake_adc[3] = 0;
    CHECK(B(3, 2, 1), B(3, 2, 1, 0x01, 0x2C));
    fake_adc_complete();
    take();
    EXPECT(outn == 0);
    analog_sample();
    expect_analog_change(1, 300, 3);
    /* the ADC has one user: a stream of analog channels and a watch exclude each other */
    CHECK(B(7, 1, 1, 0, 0x27, 0x10), B(0x87, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(7, 1, 0, AIO_STREAM_LEVELS, 0x27, 0x10), B(7, 1, 0, AIO_STREAM_LEVELS, 0x27, 0x10));
    take();
    CHECK(B(3, 4, 3, 0, 0), B(3, 4, 3, 0, 0, 0, 0)); /* stop */
    CHECK(B(3, 4, 1, 0, 0), B(3, 4, 1, 0, 0, 0x01, 0x2C));
    fake_adc[1] = 0;
    analog_sample();
    EXPECT(outn == 0 && fake_adc_pending < 0); /* nothing watched: no conversion */
    CHECK(B(7, 1, 1, 0, 0x27, 0x10), B(7, 1, 1, 0, 0x27, 0x10));
    CHECK(B(3, 4, 0, 0, 10), B(0x83, 4, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 4, 0, 0, 0), B(3, 4, 0, 0, 0, 0, 0)); /* stopping is always accepted */
    CHECK(B(7, 2), B(7, 2, 0, 0));
    /* A4/A5 belong to the I2C bridge while it is on */
    CHECK(B(4, 1, 0), B(4, 1, 0));
    CHECK(B(3, 4, 4, 0, 10), B(0x83, 4, AIO_ERR_PIN_BUSY));
    CHECK(B(3, 4, 0, 0, 10), B(3, 4, 0, 0, 10, 0, 0));
    /* A4 watched before the bridge went on stays silent while it is on */
    board();
    CHECK(B(3, 4, 4, 0, 10), B(3, 4, 4, 0, 10, 0, 0));
    CHECK(B(4, 1, 0), B(4, 1, 0));
    fake_adc[4] = 900;
    analog_sample();
    EXPECT(outn == 0);
}

/* ------------------------------------------------------------ I2C */
static void test_i2c(void)
{
    board();
    CHECK(B(4, 2, 0x50, 0, 1), B(0x84, 2, AIO_ERR_I2C_NOT_CONFIGURED));
    CHECK(B(4, 3, 0x50, 0, 0), B(0x84, 3, AIO_ERR_I2C_NOT_CONFIGURED));
    CHECK(B(4, 1, 2), B(0x84, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(4, 1, 1), B(4, 1, 1));
    CHECK(B(4, 3, 0x50, 0x10, 4, 0xDE, 0xAD, 0xBE, 0xEF), B(4, 3, 0x50, 0x10, 4));
    EXPECT(!memcmp(fake_i2c_mem + 0x10, "\xDE\xAD\xBE\xEF", 4));
    CHECK(B(4, 2, 0x50, 0x11, 3), B(4, 2, 0x50, 0x11, 3, 0xAD, 0xBE, 0xEF));
    CHECK(B(4, 3, 0x50, 0x20, 0), B(4, 3, 0x50, 0x20, 0));
    CHECK(B(4, 2, 0x51, 0, 1), B(0x84, 2, AIO_ERR_I2C_NACK_ADDRESS));
    CHECK(B(4, 3, 0x51, 0, 1, 9), B(0x84, 3, AIO_ERR_I2C_NACK_ADDRESS));
    CHECK(B(4, 3, 0x50, 0xF0, 1, 9), B(0x84, 3, AIO_ERR_I2C_NACK_DATA));
    CHECK(B(4, 2, 0x80, 0, 1), B(0x84, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(4, 2, 0x50, 0, 0), B(0x84, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(4, 2, 0x50, 0, 33), B(0x84, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    fake_i2c_stuck = true;
    CHECK(B(4, 2, 0x50, 0, 1), B(0x84, 2, AIO_ERR_I2C_TIMEOUT));
    EXPECT(fake_i2c_resets == 1);
    fake_i2c_stuck = false;
    /* 32 bytes each way */
    {
        uint8_t req[3 + 3 + 32], rep[5 + 32];
        int i;
        req[0] = 4; req[1] = 3; req[2] = 0x50; req[3] = 0x40; req[4] = 32;
        for (i = 0; i < 32; i++)
            req[5 + i] = (uint8_t)(i * 7);
        CHECK(req, 37, B(4, 3, 0x50, 0x40, 32));
        rep[0] = 4; rep[1] = 2; rep[2] = 0x50; rep[3] = 0x40; rep[4] = 32;
        memcpy(rep + 5, req + 5, 32);
        CHECK(B(4, 2, 0x50, 0x40, 32), rep, 37);
    }
    /* a length beyond 32 keeps the frame boundaries: 40 data bytes are skipped */
    {
        uint8_t req[5 + 40];
        memset(req, 0x5A, sizeof req);
        req[0] = 4; req[1] = 3; req[2] = 0x50; req[3] = 0; req[4] = 40;
        CHECK(req, sizeof req, B(0x84, 3, AIO_ERR_VALUE_OUT_OF_RANGE));
        CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    }
}

/* ------------------------------------------------------------ PWM */
static void test_pwm(void)
{
    int t;
    board();
    CHECK(B(5, 1, 9, 0x05, 0xDC), B(5, 1, 9, 0x05, 0xDC));
    EXPECT(fake_servo_us[0] == 1500);
    CHECK(B(5, 2, 9, 0x05, 0xDD), B(5, 2, 9, 0x05, 0xDD)); /* 1 us resolution */
    EXPECT(fake_servo_us[0] == 1501);
    CHECK(B(5, 2, 9, 0, 0), B(5, 2, 9, 0, 0));
    EXPECT(fake_servo_us[0] == 0);
    CHECK(B(5, 2, 10, 0x05, 0xDC), B(0x85, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(5, 1, 10, 0, 0), B(5, 1, 10, 0, 0));
    CHECK(B(5, 1, 8, 0x05, 0xDC), B(0x85, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(5, 1, 9, 0x01, 0xF3), B(0x85, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 499 */
    CHECK(B(5, 1, 9, 0x09, 0xC5), B(0x85, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 2501 */
    CHECK(B(5, 1, 4, 0x01, 0xF3), B(0x85, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* soft: 499 */
    CHECK(B(2, 1, 4, 1), B(2, 1, 4, 1));
    CHECK(B(5, 1, 4, 0x05, 0xDC), B(0x85, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 4, 4), B(2, 4, 4));
    CHECK(B(5, 1, 4, 0x05, 0xDC), B(5, 1, 4, 0x05, 0xDC)); /* 1500 us */
    /* software PWM: high for 15 ticks every 200 */
    fake_advance(400 - (fake_ticks % 200) - 1);
    {
        int high = 0, starts = 0;
        uint8_t prev = 0;
        for (t = 0; t < 400; t++) {
            fake_advance(1);
            uint8_t now = fake_softpwm_port >> 4 & 1u;
            high += now;
            starts += now && !prev;
            prev = now;
        }
        EXPECT(high == 30 && starts == 2);
        if (high != 30 || starts != 2)
            printf("  soft PWM: high %d starts %d\n", high, starts);
    }
    /* exact to the alarm count: 1500 us = 3000 counts of 0.5 us */
    EXPECT(fake_softpwm_width[4] == 1500u * 2u);
    /* 1 us steps; a new width takes effect at the next frame */
    CHECK(B(5, 2, 4, 0x05, 0xDD), B(5, 2, 4, 0x05, 0xDD)); /* 1501 */
    fake_advance(400);
    EXPECT(fake_softpwm_width[4] == 1501u * 2u);
    CHECK(B(5, 2, 4, 0x07, 0xD0), B(5, 2, 4, 0x07, 0xD0));
    fake_advance(200);
    {
        int high = 0;
        for (t = 0; t < 200; t++) {
            fake_advance(1);
            high += fake_softpwm_port >> 4 & 1u;
        }
        EXPECT(high == 20);
    }
    EXPECT(fake_softpwm_width[4] == 2000u * 2u);
    /* six pins: distinct, equal and 1 us apart widths each exact; frames 20 ms apart */
    {
        static const uint16_t widths[8] = {0, 0, 1000, 1001, 2000, 1500, 1500, 1999};
        uint8_t pin;
        uint32_t rises, before[8];
        for (pin = 2; pin < 8; pin++) {
            if (pin != 4) {
                uint8_t cfg[] = {5, 1, pin, (uint8_t)(widths[pin] >> 8), (uint8_t)widths[pin]};
                check(__FILE__, __LINE__, cfg, sizeof cfg, cfg, sizeof cfg);
            }
        }
        CHECK(B(5, 2, 4, 0x07, 0xD0), B(5, 2, 4, 0x07, 0xD0));
        fake_advance(400);
        memcpy(before, fake_softpwm_rises, sizeof before);
        fake_advance(1000); /* 100 ms: 5 frames */
        for (pin = 2; pin < 8; pin++) {
            EXPECT(fake_softpwm_width[pin] == widths[pin] * 2u);
            EXPECT(fake_softpwm_rises[pin] - before[pin] == 5);
        }
        /* releasing a pin mid-pulse takes it low at once, for good */
        fake_advance(200 - (uint32_t)(fake_fine_now / 200u) % 200u + 5u); /* 0.5 ms into a frame */
        EXPECT(fake_softpwm_port >> 7 & 1u);
        CHECK(B(2, 4, 7), B(2, 4, 7));
        EXPECT(!(fake_softpwm_port >> 7 & 1u));
        rises = fake_softpwm_rises[7];
        fake_advance(400);
        EXPECT(fake_softpwm_rises[7] == rises && fake_softpwm_rises[2] > rises);
        /* width 0 stops that pin's pulses; the last pin stopped stops the alarm */
        for (pin = 2; pin < 7; pin++) {
            uint8_t set0[] = {5, 2, pin, 0, 0};
            check(__FILE__, __LINE__, set0, sizeof set0, set0, sizeof set0);
        }
        fake_advance(400);
        rises = fake_softpwm_rises[2];
        fake_advance(400);
        EXPECT(fake_softpwm_rises[2] == rises && (fake_softpwm_port & 0xFCu) == 0);
        /* and a new width starts it again */
        CHECK(B(5, 2, 3, 0x04, 0x4C), B(5, 2, 3, 0x04, 0x4C)); /* 1100 */
        fake_advance(400);
        EXPECT(fake_softpwm_width[3] == 1100u * 2u && fake_softpwm_rises[3] > rises);
    }
    CHECK(B(2, 4, 4), B(2, 4, 4));
    fake_advance(400);
    EXPECT(!(fake_softpwm_port >> 4 & 1u));
}

/* ------------------------------------------------------------ COUNTER */
static void test_counter(void)
{
    int i;
    board();
    CHECK(B(6, 2, 2), B(0x86, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(6, 1, 4, 0), B(0x86, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(6, 1, 2, 2), B(0x86, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(6, 1, 2, 1), B(6, 1, 2, 1));
    EXPECT(fake_counter_enabled[0] && fake_counter_rising[0]);
    for (i = 0; i < 1000; i++)
        counter_event(0);
    CHECK(B(6, 2, 2), B(6, 2, 2, 0, 0, 0x03, 0xE8));
    CHECK(B(6, 3, 2), B(6, 3, 2, 0, 0, 0x03, 0xE8));
    CHECK(B(6, 2, 2), B(6, 2, 2, 0, 0, 0, 0));
    counter_counts[1] = 0xFFFFFFFFu;
    CHECK(B(6, 1, 3, 0), B(6, 1, 3, 0)); /* config starts at 0 */
    counter_counts[1] = 0xFFFFFFFFu;
    counter_event(1); /* wraps */
    CHECK(B(6, 2, 3), B(6, 2, 3, 0, 0, 0, 0));
    CHECK(B(2, 1, 2, 1), B(0x82, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 4, 2), B(2, 4, 2));
    EXPECT(!fake_counter_enabled[0]);
    CHECK(B(6, 2, 2), B(0x86, 2, AIO_ERR_PIN_NOT_CONFIGURED));
}

/* ------------------------------------------------------------ STREAM */
static void test_stream(void)
{
    int i;
    board();
    CHECK(B(7, 1, 0, 0, 0x03, 0xE8), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* empty */
    CHECK(B(7, 1, 0x40, 0, 0x03, 0xE8), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(7, 1, 1, 8, 0x03, 0xE8), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(7, 1, 1, 0, 0x03, 0xE7), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 999 */
    CHECK(B(7, 1, 1, 0, 0x00, 0xF9), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 249 */
    CHECK(B(7, 1, 1, 0, 0x01, 0x13), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 275 */
    CHECK(B(7, 1, 1, 0, 0x00, 0xFA), B(0x87, 1, AIO_ERR_LINK_CAPACITY));     /* 250 at 115200 */
    /* 250 us: 4 channels fit 2 Mbaud, not 1 Mbaud; 6 channels every 500 us fit 1 Mbaud */
    EXPECT(stream_admit(8, 250, 2000000) && !stream_admit(8, 250, 1000000));
    EXPECT(stream_admit(12, 500, 1000000) && !stream_admit(12, 300, 1000000));
    /* the chain's ADC clock: 125 kHz (104 us a conversion) wherever it fits */
    EXPECT(stream_adc_clock(6, 1000) == 7 && stream_adc_clock(1, 250) == 7);
    EXPECT(stream_adc_clock(4, 250) == 5 && stream_adc_clock(6, 500) == 6);
    EXPECT(stream_adc_clock(6, 250) == 4 && stream_adc_clock(6, 100) == 0);
    CHECK(B(7, 1, 1, 0, 0xEA, 0x61), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 60001 */
    CHECK(B(7, 1, 1, 0, 0x04, 0x4D), B(0x87, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 1101 */
    CHECK(B(7, 1, 1, 0, 0x06, 0x40), B(0x87, 1, AIO_ERR_LINK_CAPACITY));     /* 1600 */
    CHECK(B(7, 1, 0x0F, 0, 0x08, 0xFC), B(0x87, 1, AIO_ERR_LINK_CAPACITY));  /* 4 ch 2300 */
    CHECK(B(7, 1, 0x0F, 0, 0x09, 0x60), B(7, 1, 0x0F, 0, 0x09, 0x60));      /* 4 ch 2400 */
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_STREAMING, 0, 0));
    /* 1 channel + levels + edges + counters, 3300 us (limit at 115200) */
    CHECK(B(7, 1, 0x01, 0x07, 0x0C, 0xE4), B(7, 1, 0x01, 0x07, 0x0C, 0xE4));
    CHECK(B(7, 1, 0x01, 0x07, 0x0C, 0x80), B(0x87, 1, AIO_ERR_LINK_CAPACITY)); /* 3200 */
    CHECK(B(2, 1, 8, 0), B(2, 1, 8, 0));
    CHECK(B(6, 1, 3, 1), B(6, 1, 3, 1));
    fake_adc[0] = 0x2AB;
    fake_drive(8, 1);
    counter_event(1);
    counter_event(1);
    fake_advance(33);
    EXPECT(fake_adc_pending == 0);
    fake_adc_complete();
    take();
    {
        uint8_t exp[] = {0x40, 0x01, 0x01, 0x07, 0, 0, 0, 0, 0, 0, 16,
                         0x02, 0xAB,             /* A0 */
                         0x01, 0x00,             /* levels: D8 */
                         0x01, 0x00, 0x00, 0x00, /* rose D8, fell none */
                         0, 0, 0, 0, 0, 0, 0, 2, /* counters */
                         0};
        uint32_t ts = fake_ticks * 100u;
        exp[6] = (uint8_t)(ts >> 24); exp[7] = (uint8_t)(ts >> 16);
        exp[8] = (uint8_t)(ts >> 8); exp[9] = (uint8_t)ts;
        exp[sizeof exp - 1] = xor_of(exp, sizeof exp - 1);
        EXPECT(outn == sizeof exp && !memcmp(out, exp, sizeof exp));
        if (outn != sizeof exp || memcmp(out, exp, sizeof exp)) {
            dump("expected", exp, sizeof exp);
            dump("got", out, outn);
        }
    }
    /* second sample: sequence 1, no new edges */
    fake_advance(33);
    fake_adc_complete();
    take();
    EXPECT(outn == 28 && out[4] == 0 && out[5] == 1 && out[15] == 0 && out[16] == 0);
    /* a full transmit buffer drops the sample, but uses its number */
    fake_tx_capacity = 10;
    fake_advance(33);
    fake_adc_complete();
    EXPECT(fake_tx_len == 0);
    fake_tx_capacity = 192;
    fake_advance(33);
    fake_adc_complete();
    take();
    EXPECT(outn == 28 && out[5] == 3);
    /* ANALOG READ during a stream, while a chain is running */
    fake_advance(33);
    EXPECT(fake_adc_pending == 0);
    fake_adc[1] = 0x111;
    send_frame(B(3, 2, 1));
    run();
    take();
    EXPECT(outn == 28 + 6 && out[0] == 0x40 && out[28] == 3 && out[31] == 0x01 && out[32] == 0x11);
    /* STOP: next sequence number; nothing after the reply */
    fake_advance(33); /* a sample is being converted */
    CHECK(B(7, 2), B(7, 2, 0, 5));
    fake_adc_complete();
    fake_advance(1000);
    fake_adc_complete();
    EXPECT(fake_tx_len == 0);
    CHECK(B(1, 6), B(1, 6, 0, 0, 0));
    /* replace: counters only (no ADC), restart at 0 */
    CHECK(B(7, 1, 0, 4, 0x27, 0x10), B(7, 1, 0, 4, 0x27, 0x10));
    for (i = 0; i < 3; i++)
        fake_advance(100);
    take();
    EXPECT(outn == 3 * 20 && out[5] == 0 && out[20 + 5] == 1 && out[40 + 5] == 2);
    CHECK(B(7, 2), B(7, 2, 0, 3));
    CHECK(B(4, 1, 0), B(4, 1, 0));
    CHECK(B(7, 1, 0x10, 0, 0x27, 0x10), B(0x87, 1, AIO_ERR_PIN_BUSY));
}

/* ------------------------------------------------------------ FAILSAFE */
static void test_failsafe(void)
{
    board();
    CHECK(B(8, 1, 0, 19), B(0x88, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 1, 0x27, 0x11), B(0x88, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 2, 1, 1, 0, 0), B(0x88, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(8, 2, 13, 4, 0, 0), B(0x88, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 2, 13, 1, 0, 2), B(0x88, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(8, 2, 13, 2, 0x05, 0xDC), B(0x88, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(8, 2, 9, 2, 0x01, 0xF3), B(0x88, 2, AIO_ERR_VALUE_OUT_OF_RANGE)); /* 499 us */
    CHECK(B(2, 1, 13, 3), B(2, 1, 13, 3));
    CHECK(B(5, 1, 9, 0x07, 0xD0), B(5, 1, 9, 0x07, 0xD0));
    CHECK(B(8, 2, 13, 1, 0, 0), B(8, 2, 13, 1, 0, 0));
    CHECK(B(8, 2, 9, 2, 0x05, 0xDC), B(8, 2, 9, 2, 0x05, 0xDC));
    CHECK(B(8, 1, 0, 50), B(8, 1, 0, 50));
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0));
    fake_advance(400); /* 40 ms: fed in time */
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0));
    EXPECT(fake_pin_level[13] == 1 && fake_servo_us[0] == 2000);
    fake_advance(520);
    EXPECT(fake_pin_level[13] == 0 && fake_servo_us[0] == 1500);
    take();
    EXPECT(outn == 3 && out[0] == 0x40 && out[1] == 0x02 && out[2] == 0x42);
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_TRIPPED, 0, 0));
    CHECK(B(2, 3, 13, 1), B(0x82, 3, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(2, 1, 13, 3), B(0x82, 1, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(2, 4, 13), B(0x82, 4, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(5, 2, 9, 0x07, 0xD0), B(0x85, 2, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(5, 1, 10, 0x07, 0xD0), B(0x85, 1, AIO_ERR_FAILSAFE_TRIPPED));
    CHECK(B(2, 2, 13), B(2, 2, 13, 0)); /* reads keep working */
    fake_advance(2000);
    take();
    EXPECT(outn == 0); /* fires once */
    CHECK(B(8, 3), B(8, 3));
    CHECK(B(1, 6), B(1, 6, 0, 0, 0));
    CHECK(B(2, 3, 13, 1), B(2, 3, 13, 1));
    /* ARM also clears the tripped state */
    CHECK(B(8, 1, 0, 20), B(8, 1, 0, 20));
    fake_advance(300);
    take();
    EXPECT(outn == 3 && fake_pin_level[13] == 0);
    CHECK(B(8, 1, 0, 20), B(8, 1, 0, 20));
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0));
    /* the tripped event waits for room in a full transmit buffer */
    fake_tx_capacity = 0;
    fake_advance(300);
    EXPECT(fake_tx_len == 0);
    fake_tx_capacity = 192;
    run();
    take();
    EXPECT(outn == 3 && out[0] == 0x40);
}

/* Every handler refuses a descriptor it does not implement, the same way, with nothing
 * changed: called past the parser (which filters them) with a valid pin in data[0]. */
static void test_unknown_descriptors(void)
{
    static const uint8_t classes[] = {AIO_CT_MISC, AIO_CT_GPIO,    AIO_CT_ANALOG, AIO_CT_I2C,
                                      AIO_CT_PWM,  AIO_CT_COUNTER, AIO_CT_STREAM, AIO_CT_FAILSAFE};
    aio_request_t rq;
    uint8_t frame[64], fixed, n, i;
    int8_t lp;
    int dt, wrong = 0;

    board();
    CHECK(B(6, 1, 2, 1), B(6, 1, 2, 1));                   /* a counter on D2 */
    CHECK(B(5, 1, 9, 0x05, 0xDC), B(5, 1, 9, 0x05, 0xDC)); /* a servo on D9 */
    CHECK(B(8, 1, 0, 50), B(8, 1, 0, 50));                 /* the failsafe armed */
    counter_counts[0] = 5;
    for (i = 0; i < sizeof classes; i++)
        for (dt = 0; dt < 256; dt++) {
            if (parser_lookup(classes[i], (uint8_t)dt, &fixed, &lp))
                continue;
            memset(&rq, 0, sizeof rq);
            rq.ct = classes[i];
            rq.dt = (uint8_t)dt;
            rq.data[0] = 2;
            n = dispatch(&rq, frame);
            if (n != 4 || frame[0] != (classes[i] | AIO_ERROR_FLAG) || frame[1] != dt ||
                frame[2] != AIO_ERR_UNKNOWN_DESCRIPTOR) {
                if (!wrong++)
                    printf("  class 0x%02x descriptor 0x%02x not refused as unknown\n",
                           classes[i], dt);
            }
        }
    EXPECT(wrong == 0);
    EXPECT(counter_counts[0] == 5 && fake_servo_us[0] == 1500);
    CHECK(B(1, 6), B(1, 6, AIO_STATUS_FAILSAFE_ARMED, 0, 0)); /* still armed */
}

/* ------------------------------------------------------------ framing */
static void test_framing(void)
{
    board();
    fake_eeprom[0] = 0x12;
    fake_eeprom[1] = 0x34;
    /* bad checksum: one error, then the rest of the burst is discarded */
    fake_rx_push(B(1, 2, 0x04, 1, 2, 3));
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\x81\x02\x01\x82", 4));
    fake_advance(50);
    send_frame(B(1, 2)); /* still within 10 ms of the garbage: discarded */
    run();
    take();
    EXPECT(outn == 0);
    fake_advance(101);
    run();
    CHECK(B(1, 2), B(1, 2, 0x12, 0x34));
    /* unknown class, unknown descriptor */
    fake_rx_push(B(0x09));
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\x89\x00\x02\x8B", 4));
    fake_advance(101);
    run();
    fake_rx_push(B(0xC1));
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\xC1\x00\x02\xC3", 4));
    fake_advance(101);
    run();
    fake_rx_push(B(0x03, 0x01));
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\x83\x01\x03\x81", 4));
    fake_advance(101);
    run();
    /* incomplete frame: after more than 10 ms of silence */
    fake_rx_push(B(0x02, 0x01, 13));
    run();
    fake_advance(100);
    run();
    take();
    EXPECT(outn == 0);
    fake_advance(1);
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\x82\x01\x04\x87", 4));
    CHECK(B(1, 2), B(1, 2, 0x12, 0x34)); /* ready at once */
    fake_rx_push(B(0x01));
    run();
    fake_advance(101);
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\x81\x00\x04\x85", 4));
    /* bytes arriving 9.9 ms apart still make a frame */
    fake_rx_push(B(0x01));
    run();
    fake_advance(99);
    run();
    fake_rx_push(B(0x02));
    run();
    fake_advance(99);
    run();
    fake_rx_push(B(0x03));
    run();
    take();
    EXPECT(outn == 5 && out[2] == 0x12);
    /* receive overflow */
    fake_rx_overflow();
    fake_rx_push(B(1, 2, 3));
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\x80\x00\x05\x85", 4));
    fake_advance(101);
    run();
    CHECK(B(1, 2), B(1, 2, 0x12, 0x34));
    /* 129 bytes in one go overflow the 128-byte FIFO */
    {
        uint8_t burst[129];
        int i;
        for (i = 0; i < 43; i++)
            memcpy(burst + 3 * i, "\x01\x02\x03", 3);
        fake_rx_push(burst, 129);
        run();
        take();
        EXPECT(outn == 4 && out[2] == AIO_ERR_RX_OVERFLOW);
        fake_advance(101);
        run();
    }
}


/* ------------------------------------------------------------ CRC-16 framing */
/* The oracle: CRC-16/CCITT-FALSE bit by bit (the firmware computes it byte-wise). */
static uint16_t crc_of(const uint8_t *p, size_t n)
{
    uint16_t crc = 0xFFFFu;
    int bit;
    while (n--) {
        crc ^= (uint16_t)(*p++ << 8);
        for (bit = 0; bit < 8; bit++)
            crc = (uint16_t)(crc & 0x8000u ? ((unsigned)crc << 1) ^ 0x1021u : (unsigned)crc << 1);
    }
    return crc;
}

static size_t crc_seal(uint8_t *buf, const uint8_t *body, size_t n)
{
    uint16_t crc = crc_of(body, n);
    memcpy(buf, body, n);
    buf[n] = (uint8_t)(crc >> 8);
    buf[n + 1] = (uint8_t)crc;
    return n + 2;
}

#define CRC_CHECK(...) crc_check(__FILE__, __LINE__, __VA_ARGS__)
/* Sends req + its CRC, expects exactly exp + its CRC back. */
static void crc_check(const char *file, int line, const uint8_t *req, size_t rn, const uint8_t *exp,
                      size_t en)
{
    uint8_t buf[64], want[64];
    size_t wn;
    fake_rx_push(buf, (uint32_t)crc_seal(buf, req, rn));
    run();
    take();
    wn = crc_seal(want, exp, en);
    checks++;
    if (outn != wn || memcmp(out, want, wn)) {
        failures++;
        printf("%s:%d: FAIL (CRC framing)\n", file, line);
        dump("request", req, rn);
        dump("expected", want, wn);
        dump("got", out, outn);
    }
}

static void test_crc_framing(void)
{
    uint8_t burst[256], want[128];
    size_t n, wn;
    int offset, i;
    board();
    fake_eeprom[0] = 0x01;
    fake_eeprom[1] = 0x02;
    EXPECT(crc_of((const uint8_t *)"123456789", 9) == 0x29B1u); /* the catalogue's check */
    /* the switch: sent XOR-framed, answered CRC-framed */
    send_frame(B(1, 0x0B, 1));
    run();
    take();
    wn = crc_seal(want, B(1, 0x0B, 1));
    EXPECT(outn == wn && !memcmp(out, want, wn));
    CRC_CHECK(B(1, 2), B(1, 2, 1, 2));
    CRC_CHECK(B(2, 1, 13, 1), B(2, 1, 13, 1));
    CRC_CHECK(B(2, 3, 13, 0), B(2, 3, 13, 0)); /* GPIO WRITE's own reply path */
    EXPECT(fake_pin_level[13] == 0);
    CRC_CHECK(B(2, 3, 13, 1), B(2, 3, 13, 1));
    EXPECT(fake_pin_level[13] == 1);
    CRC_CHECK(B(3, 2, 7), B(0x83, 2, AIO_ERR_PIN_NOT_CAPABLE));
    CRC_CHECK(B(1, 0x0B, 2), B(0x81, 0x0B, AIO_ERR_VALUE_OUT_OF_RANGE));
    /* pipelined at every position of the receive ring (parsed in place, or byte by
     * byte across its end): each ID answered in order */
    for (offset = 0; offset < 256; offset += 3) {
        n = 0;
        for (i = 0; i < 6; i++)
            n += crc_seal(burst + n, B(1, 2));
        n += crc_seal(burst + n, B(2, 3, 13, (uint8_t)(offset & 1)));
        fake_rx_push(burst, (uint32_t)n);
        run();
        take();
        wn = 0;
        for (i = 0; i < 6; i++)
            wn += crc_seal(want + wn, B(1, 2, 1, 2));
        wn += crc_seal(want + wn, B(2, 3, 13, (uint8_t)(offset & 1)));
        EXPECT(outn == wn && !memcmp(out, want, wn));
        fake_rx_push(burst, (uint32_t)(offset % 5)); /* shift the ring: garbage IDs... */
        run();
        take();
        fake_advance(PARSER_GAP_TICKS + 1u); /* ...then quiet: back in step */
        run();
        take();
    }
    /* a wrong CRC, high or low byte: BAD_CHECKSUM once, then quiet, then in step */
    for (i = 0; i < 2; i++) {
        n = crc_seal(burst, B(1, 2));
        burst[2 + i] ^= 0x10;
        fake_rx_push(burst, (uint32_t)n);
        run();
        take();
        wn = crc_seal(want, B(0x81, 2, AIO_ERR_BAD_CHECKSUM));
        EXPECT(outn == wn && !memcmp(out, want, wn));
        fake_advance(PARSER_GAP_TICKS + 1u);
        run();
        take();
        CRC_CHECK(B(1, 2), B(1, 2, 1, 2));
    }
    /* a paper-framed request in CRC framing: its XOR byte 03 is not the CRC's
     * high byte (0E), so BAD_CHECKSUM at once (what tells a host after a
     * reconnect that the board is in CRC framing) */
    send_frame(B(1, 2));
    run();
    take();
    wn = crc_seal(want, B(0x81, 2, AIO_ERR_BAD_CHECKSUM));
    EXPECT(outn == wn && !memcmp(out, want, wn));
    fake_advance(PARSER_GAP_TICKS + 1u);
    run();
    take();
    /* one CRC byte short, then quiet: INCOMPLETE_FRAME */
    fake_rx_push(B(1, 2, 0x0E));
    run();
    fake_advance(PARSER_GAP_TICKS + 1u);
    run();
    take();
    wn = crc_seal(want, B(0x81, 2, AIO_ERR_INCOMPLETE_FRAME));
    EXPECT(outn == wn && !memcmp(out, want, wn));
    /* events are sealed in the framing in force: the failsafe's */
    CRC_CHECK(B(8, 1, 0, 20), B(8, 1, 0, 20));
    fake_advance(300);
    take();
    wn = crc_seal(want, B(0x40, 0x02));
    EXPECT(outn == wn && !memcmp(out, want, wn));
    CRC_CHECK(B(8, 3), B(8, 3));
    /* a transaction's items carry no check bytes; its reply has the framing's */
    CRC_CHECK(B(1, 9, 0x30, 3, 2, 2, 13), B(1, 9, 0x30, 4, 2, 2, 13, 1));
    /* back to the paper's framing: the reply is XOR-framed already */
    n = crc_seal(burst, B(1, 0x0B, 0));
    fake_rx_push(burst, (uint32_t)n);
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\x01\x0B\x00\x0A", 4));
    CHECK(B(1, 2), B(1, 2, 1, 2));
    /* every boot starts in XOR framing */
    send_frame(B(1, 0x0B, 1));
    run();
    take();
    board();
    fake_eeprom[0] = 0x01;
    fake_eeprom[1] = 0x02;
    CHECK(B(1, 2), B(1, 2, 1, 2));
}

static void test_pipelining(void)
{
    uint8_t burst[128];
    uint32_t n = 0;
    int i;
    board();
    fake_eeprom[0] = 0;
    fake_eeprom[1] = 7;
    fake_adc[2] = 0x200;
    /* 5 + 4 + 3 + 4 + 5 + 3 ... interleaved, answered in order */
    memcpy(burst + n, "\x02\x01\x0D\x01\x0F", 5); n += 5;    /* GPIO CONFIG 13 out */
    memcpy(burst + n, "\x03\x02\x02\x03", 4); n += 4;        /* ANALOG READ 2 */
    memcpy(burst + n, "\x01\x02\x03", 3); n += 3;            /* ID */
    memcpy(burst + n, "\x02\x02\x0D\x0D", 4); n += 4;        /* GPIO READ 13 */
    memcpy(burst + n, "\x02\x03\x05\x01\x05", 5); n += 5;    /* GPIO WRITE 5: not configured */
    memcpy(burst + n, "\x01\x02\x03", 3); n += 3;            /* ID */
    fake_rx_push(burst, n);
    run();
    take();
    {
        const uint8_t exp[] = {0x02, 0x01, 0x0D, 0x01, 0x0F,
                               0x03, 0x02, 0x02, 0x02, 0x00, 0x01,
                               0x01, 0x02, 0x00, 0x07, 0x04,
                               0x02, 0x02, 0x0D, 0x00, 0x0D,
                               0x82, 0x03, 0x07, 0x86,
                               0x01, 0x02, 0x00, 0x07, 0x04};
        EXPECT(outn == sizeof exp && !memcmp(out, exp, sizeof exp));
    }
    /* replies wait for room in the transmit buffer; none is dropped (a
     * batch of replies, at most 2 * AIO_FRAME_MAX bytes, must fit the emptied
     * buffer: 76 bytes here, 192 on the board) */
    fake_tx_capacity = 2u * AIO_FRAME_MAX;
    n = 0;
    for (i = 0; i < 40; i++) {
        memcpy(burst + n, "\x01\x02\x03", 3);
        n += 3;
    }
    fake_rx_push(burst, n);
    {
        uint32_t total = 0;
        int rounds = 0;
        while (rounds++ < 100) {
            run();
            take();
            for (i = 0; (uint32_t)i < outn; i += 5)
                EXPECT(!memcmp(out + i, "\x01\x02\x00\x07\x04", 5));
            total += outn;
            if (!outn)
                break;
        }
        EXPECT(total == 40 * 5);
    }
    fake_tx_capacity = 192;
}

/* Frames parsed in place: at every position of the 256-byte receive ring,
 * also across its end (those go byte by byte), whole bursts answered in
 * order, a bad checksum in a burst answered as such. */
static void test_ring_positions(void)
{
    int offset, i;
    board();
    CHECK(B(2, 1, 13, 1), B(2, 1, 13, 1));
    for (offset = 0; offset < 300; offset++) {
        uint8_t burst[20];
        memcpy(burst, "\x02\x03\x0D\x01\x0D", 5);      /* GPIO WRITE 13 high */
        memcpy(burst + 5, "\x01\x02\x03", 3);             /* READ ID */
        memcpy(burst + 8, "\x02\x03\x0D\x00\xFF", 5);  /* bad checksum */
        memcpy(burst + 13, "\x02\x03\x0D\x00\x0C", 5); /* GPIO WRITE 13 low */
        fake_rx_push(burst, 18);
        run();
        take();
        {
            static const uint8_t exp[] = {0x02, 0x03, 0x0D, 0x01, 0x0D, 0x01, 0x02, 0xFF, 0xFF,
                                          0x03, 0x82, 0x03, 0x01, 0x80};
            EXPECT(outn == sizeof exp && !memcmp(out, exp, sizeof exp));
            if (outn != sizeof exp || memcmp(out, exp, sizeof exp)) {
                printf("  at offset %d\n", offset);
                dump("got", out, outn);
                return;
            }
        }
        /* after the error the rest is discarded until 10 ms of quiet */
        fake_advance(PARSER_GAP_TICKS + 1);
        run();
        /* one byte more each round moves the frames across the ring */
        fake_rx_push(B(0x01, 0x02, 0x03));
        for (i = 0; i < offset % 3; i++)
            fake_rx_push(B(0x01, 0x02, 0x03));
        run();
        take();
    }
}

/* 1,000,000 random bytes: no crash, no out-of-bounds access (ASan/UBSan),
 * and after 10 ms of quiet the board answers an ID request. */
static void test_random(void)
{
    uint32_t i, seed = 12345;
    uint8_t chunk[64];
    board();
    fake_eeprom[0] = 0xAB;
    fake_eeprom[1] = 0xCD;
    for (i = 0; i < 1000000u;) {
        uint32_t n, k;
        seed = seed * 1103515245u + 12345u;
        n = 1 + (seed >> 16) % 64u;
        for (k = 0; k < n; k++) {
            seed = seed * 1103515245u + 12345u;
            chunk[k] = (uint8_t)(seed >> 16);
        }
        fake_rx_push(chunk, n);
        i += n;
        run();
        seed = seed * 1103515245u + 12345u;
        if ((seed >> 16) % 16u == 0)
            fake_advance((seed >> 20) % 150u); /* sometimes a pause, sometimes > 10 ms */
        fake_adc_complete();
        fake_tx_len = 0; /* the host reads everything */
        if (fake_reset_done) { /* a random RESET: the board restarts */
            uint8_t id[2] = {fake_eeprom[0], fake_eeprom[1]};
            board();
            fake_eeprom[0] = id[0];
            fake_eeprom[1] = id[1];
        }
    }
    /* stop a random stream/failsafe noise from interleaving, then check */
    fake_advance(101);
    run();
    fake_tx_len = 0;
    send_frame(B(8, 3));
    send_frame(B(7, 2));
    run();
    fake_tx_len = 0;
    fake_eeprom[0] = 0xAB;
    fake_eeprom[1] = 0xCD;
    CHECK(B(1, 2), B(1, 2, 0xAB, 0xCD));
}

/* ------------------------------------------------------------ shared vectors */
/* The .vec files of tests/vectors: the same request -> reply vectors the virtual Uno and FakeBoard run. */
static void test_vectors(void)
{
    size_t f, i, j;
    for (f = 0; f < sizeof aio_vector_files / sizeof aio_vector_files[0]; f++) {
        const aio_vector_file_t *vf = &aio_vector_files[f];
        board();
        fake_eeprom[0] = (uint8_t)(vf->board_id >> 8);
        fake_eeprom[1] = (uint8_t)vf->board_id;
        for (i = 0; i < vf->count; i++) {
            const aio_vector_step_t *st = &vf->steps[i];
            int ok;
            if (st->drive_pin >= 0) {
                fake_drive((uint8_t)st->drive_pin, st->drive_level);
                continue;
            }
            fake_rx_push(st->request, st->request_len);
            run();
            take();
            ok = outn == st->reply_len;
            for (j = 0; ok && j < outn; j++)
                ok = st->reply[j] < 0 || out[j] == st->reply[j];
            checks++;
            if (!ok) {
                failures++;
                printf("tests/vectors/%s.vec:%u: FAIL\n", vf->name, st->line);
                dump("request", st->request, st->request_len);
                dump("got", out, outn);
            }
        }
    }
}

/* Every (CT, DT) the table knows parses; every other DT is unknown. */
static void test_table(void)
{
    int ct, dt, known = 0;
    uint8_t fixed;
    int8_t lp;
    for (ct = 0; ct < 256; ct++)
        for (dt = 0; dt < 256; dt++)
            if (parser_lookup((uint8_t)ct, (uint8_t)dt, &fixed, &lp)) {
                known++;
                EXPECT(parser_known_class((uint8_t)ct));
                EXPECT(fixed + (lp >= 0 ? AIO_MAX_BLOB : 0) <= 46);
            }
#define AIO_X(CLASS, NAME, ct_, dt_, dl, lpos) +1
    EXPECT(known == 0 AIO_REQUEST_TABLE(AIO_X));
#undef AIO_X
}

int main(void)
{
    test_table();
    test_misc();
    test_low_latency();
    test_gpio();
    test_gpio_changes();
    test_transaction();
    test_counter_reports();
    test_analog_watch();
    test_analog();
    test_i2c();
    test_pwm();
    test_counter();
    test_stream();
    test_failsafe();
    test_unknown_descriptors();
    test_framing();
    test_crc_framing();
    test_pipelining();
    test_ring_positions();
    test_random();
    test_vectors();
    printf("%d checks, %d failures\n", checks, failures);
    return failures != 0;
}

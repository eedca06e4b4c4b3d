/*
 * test_encoder.c - host tests of the ENCODER class (encoder.c) with the fake HAL:
 * quadrature decoding in x1/x2/x4, invalid transitions, preset, reports, the
 * stream's ENCODERS values and the pin roles.  The oracle is the position the
 * test itself drove (quarter steps), never the firmware's own state.
 * Run by tests/test_main.c (see host_check.h).
 */
#include "host_check.h"

/* A fresh board whose pins 2-13 the circuit holds low (an encoder's pull-ups
 * would otherwise lift the free ones: the test's positions start at 0). */
static void encoder_board(void)
{
    uint8_t pin;
    board();
    for (pin = 2; pin < 14; pin++)
        fake_drive(pin, 0);
}

/* ---- the encoder the test turns: its true position in quarter steps ---- */
typedef struct {
    uint8_t a, b;
    long pos;
} turned_t;

/* AB levels at a position: 00, 10, 11, 01 (A leads B going forward) */
static void levels_at(long pos, uint8_t *a, uint8_t *b)
{
    static const uint8_t A[4] = {0, 1, 1, 0}, Bv[4] = {0, 0, 1, 1};
    uint8_t p = (uint8_t)(((pos % 4) + 4) % 4);
    *a = A[p];
    *b = Bv[p];
}

/* One quarter step each way: exactly one pin changes, with its interrupt. */
static void turn(turned_t *q, long steps)
{
    uint8_t a0, b0, a1, b1;
    while (steps) {
        long d = steps > 0 ? 1 : -1;
        levels_at(q->pos, &a0, &b0);
        q->pos += d;
        steps -= d;
        levels_at(q->pos, &a1, &b1);
        if (a1 != a0)
            fake_drive(q->a, a1);
        else
            fake_drive(q->b, b1);
        fake_fine_now += 2u * 37u; /* 37 us an edge */
    }
}

/* Two quarter steps with one interrupt: the first pin changes unseen. */
static void skip(turned_t *q, long d)
{
    uint8_t a1, b1, a2, b2;
    levels_at(q->pos + d, &a1, &b1);
    levels_at(q->pos + 2 * d, &a2, &b2);
    q->pos += 2 * d;
    /* both pins change; only the second change raises the interrupt */
    if (a2 != a1) { /* the B change came first */
        fake_pin_level[q->b] = b2;
        fake_drive(q->a, a2);
    } else {
        fake_pin_level[q->a] = a2;
        fake_drive(q->b, b2);
    }
}

static int32_t be32(const uint8_t *p)
{
    return (int32_t)((uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3]);
}

/* READ of slot s: count, invalid, edge_us. */
static int32_t read_slot(uint8_t s, uint16_t *invalid, uint32_t *edge_us)
{
    send_frame(B(AIO_CT_ENCODER, AIO_DT_ENCODER_READ, s));
    run();
    take();
    checks++;
    if (outn != 2u + AIO_REPLY_LEN_ENCODER_READ + 1u || out[0] != AIO_CT_ENCODER || out[2] != s) {
        failures++;
        printf("%s:%d: FAIL: read of slot %u (%u bytes)\n", __FILE__, __LINE__, s, outn);
        return 0;
    }
    if (invalid)
        *invalid = (uint16_t)(out[7] << 8 | out[8]);
    if (edge_us)
        *edge_us = (uint32_t)be32(out + 9);
    return be32(out + 3);
}

static long floor_div(long x, long d) { return x >= 0 ? x / d : -((-x + d - 1) / d); }

static void encoder_config_errors(void)
{
    encoder_board();
    CHECK(B(0x0A, 1, 4, 4, 5, 4), B(0x8A, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* slot 4 of 0-3 */
    CHECK(B(0x0A, 1, 0, 1, 5, 4), B(0x8A, 1, AIO_ERR_PIN_NOT_CAPABLE));    /* D1: the UART */
    CHECK(B(0x0A, 1, 0, 4, 14, 4), B(0x8A, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(0x0A, 1, 0, 4, 4, 4), B(0x8A, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* A = B */
    CHECK(B(0x0A, 1, 0, 4, 5, 3), B(0x8A, 1, AIO_ERR_VALUE_OUT_OF_RANGE)); /* no x3 */
    CHECK(B(0x0A, 2, 0), B(0x8A, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(0x0A, 4, 1, 0, 5), B(0x8A, 4, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(0x0A, 3, 2, 0, 0, 0, 0), B(0x8A, 3, AIO_ERR_PIN_NOT_CONFIGURED));
    /* another user's pin: a counter on D2, a GPIO output on D7 */
    CHECK(B(6, 1, 2, AIO_EDGE_RISING), B(6, 1, 2, AIO_EDGE_RISING));
    CHECK(B(0x0A, 1, 0, 2, 4, 4), B(0x8A, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 1, 7, 1), B(2, 1, 7, 1));
    CHECK(B(0x0A, 1, 0, 6, 7, 4), B(0x8A, 1, AIO_ERR_PIN_BUSY));
    /* another slot's pin */
    CHECK(B(0x0A, 1, 0, 4, 5, 4), B(0x0A, 1, 0, 4, 5, 4));
    CHECK(B(0x0A, 1, 1, 5, 6, 4), B(0x8A, 1, AIO_ERR_PIN_BUSY));
    /* its own pins again (a reconfiguration), one swapped for a free one */
    CHECK(B(0x0A, 1, 0, 5, 6, 2), B(0x0A, 1, 0, 5, 6, 2));
    EXPECT(fake_pin_mode[4] == HAL_IN && fake_pin_mode[5] == HAL_IN_PULLUP);
    CHECK(B(0x0A, 1, 1, 4, 8, 4), B(0x0A, 1, 1, 4, 8, 4)); /* D4 is free again */
    /* a GPIO pin release of either pin ends the encoder: both pins free */
    CHECK(B(2, 4, 8), B(2, 4, 8));
    CHECK(B(0x0A, 2, 1), B(0x8A, 2, AIO_ERR_PIN_NOT_CONFIGURED));
    CHECK(B(2, 1, 4, 1), B(2, 1, 4, 1));
    /* the counter's D2 stays counting on INT0 beside an encoder on D3 + D9 */
    CHECK(B(0x0A, 1, 2, 3, 9, 4), B(0x0A, 1, 2, 3, 9, 4));
    EXPECT(fake_counter_enabled[0] && !fake_encoder_int[0] && fake_encoder_int[1]);
    fake_drive(2, 1);
    CHECK(B(6, 2, 2), B(6, 2, 2, 0, 0, 0, 1));
    CHECK(B(0x0A, 9), B(0x8A, 9, AIO_ERR_UNKNOWN_DESCRIPTOR)); /* last: input is discarded after it */
}

/* Exact x4 counts over random turns on INT0/INT1 (D2/D3) and pin-change pins. */
static void encoder_counts(void)
{
    turned_t qs[3] = {{2, 3, 0}, {4, 12, 0}, {13, 7, 0}};
    uint16_t invalid;
    uint32_t edge;
    int i, k;

    encoder_board();
    CHECK(B(0x0A, 1, 0, 2, 3, 4), B(0x0A, 1, 0, 2, 3, 4));
    CHECK(B(0x0A, 1, 1, 4, 12, 4), B(0x0A, 1, 1, 4, 12, 4));
    CHECK(B(0x0A, 1, 3, 13, 7, 4), B(0x0A, 1, 3, 13, 7, 4));
    EXPECT(fake_encoder_int[0] && fake_encoder_int[1]);
    EXPECT((fake_edge_watch & 0x3FFCu) == ((1u << 4) | (1u << 12) | (1u << 13) | (1u << 7)));
    srand(7);
    for (i = 0; i < 300; i++)
        for (k = 0; k < 3; k++)
            turn(&qs[k], (long)(rand() % 41) - 20);
    for (k = 0; k < 3; k++) {
        uint8_t s = (uint8_t)(k == 2 ? 3 : k);
        EXPECT(read_slot(s, &invalid, &edge) == qs[k].pos);
        EXPECT(invalid == 0);
    }
    /* edge_us is the last counting edge's time, not the read's */
    turn(&qs[0], 1);
    edge = 0;
    fake_fine_now += 2u * 5000u;
    read_slot(0, &invalid, &edge);
    EXPECT(edge == (uint32_t)(fake_fine_now / 2u - 5000u - 37u));
    /* a GPIO watch shares the pin-change vector: it still sees its own pin only */
    CHECK(B(2, 1, 6, 0), B(2, 1, 6, 0));
    CHECK(B(2, AIO_DT_GPIO_WATCH, 6, 1), B(2, AIO_DT_GPIO_WATCH, 6, 1));
    turn(&qs[1], 3);
    take();
    EXPECT(outn == 0); /* no GPIO_CHANGE for the encoder's pins */
    fake_drive(6, 1);
    take();
    EXPECT(outn > 2 && out[0] == AIO_CT_EVENT && out[1] == AIO_DT_EVENT_GPIO_CHANGE && out[2] == 6);
    EXPECT(read_slot(1, 0, 0) == qs[1].pos);
}

/* x1 and x2 count whole cycles and edges of A: floor((pos + 3) / 4), floor((pos + 1) / 2). */
static void encoder_modes(void)
{
    turned_t q1 = {5, 6, 0}, q2 = {8, 9, 0};
    int i;
    encoder_board();
    CHECK(B(0x0A, 1, 0, 5, 6, 1), B(0x0A, 1, 0, 5, 6, 1));
    CHECK(B(0x0A, 1, 1, 8, 9, 2), B(0x0A, 1, 1, 8, 9, 2));
    srand(11);
    for (i = 0; i < 400; i++) {
        long d = (long)(rand() % 23) - 11;
        turn(&q1, d);
        turn(&q2, d);
        if (i % 50 == 0) {
            EXPECT(read_slot(0, 0, 0) == floor_div(q1.pos + 3, 4));
            EXPECT(read_slot(1, 0, 0) == floor_div(q2.pos + 1, 2));
        }
    }
    EXPECT(read_slot(0, 0, 0) == floor_div(q1.pos + 3, 4));
    EXPECT(read_slot(1, 0, 0) == floor_div(q2.pos + 1, 2));
}

/* A skipped state is counted and moves the count two steps the last way. */
static void encoder_invalid(void)
{
    turned_t q = {4, 5, 0}, q1 = {6, 7, 0};
    uint16_t invalid;
    encoder_board();
    CHECK(B(0x0A, 1, 0, 4, 5, 4), B(0x0A, 1, 0, 4, 5, 4));
    CHECK(B(0x0A, 1, 1, 6, 7, 1), B(0x0A, 1, 1, 6, 7, 1));
    turn(&q, 5);
    skip(&q, 1);
    turn(&q, 2);
    EXPECT(read_slot(0, &invalid, 0) == q.pos && q.pos == 9);
    EXPECT(invalid == 1);
    turn(&q, -3);
    skip(&q, -1);
    skip(&q, -1);
    EXPECT(read_slot(0, &invalid, 0) == q.pos && q.pos == 2);
    EXPECT(invalid == 3);
    /* x1: a skip across the counting edge counts it */
    turn(&q1, -1); /* position -1: backwards, so the skip goes back */
    turn(&q1, 1);  /* forward again */
    skip(&q1, 1);  /* 0 -> 2 crosses the A rising edge at 1 */
    EXPECT(read_slot(1, &invalid, 0) == floor_div(q1.pos + 3, 4) && q1.pos == 2);
    EXPECT(invalid == 1);
}

static void encoder_preset_and_watch(void)
{
    turned_t q = {10, 11, 0};
    uint32_t i;
    int reports = 0;
    encoder_board();
    CHECK(B(0x0A, 1, 2, 10, 11, 4), B(0x0A, 1, 2, 10, 11, 4));
    fake_fine_now = 2u * 1000u;
    turn(&q, -6);
    /* PRESET replies with the state before it: count -6, no invalid, last edge */
    CHECK(B(0x0A, 3, 2, 0x00, 0x01, 0x00, 0x02), /* 65538: the same phase as -6 */
          B(0x0A, 3, 2, 0x00, 0x01, 0x00, 0x02, 0xFF, 0xFF, 0xFF, 0xFA, 0, 0, 0, 0, 0x04, 0xA1));
    q.pos = 65538;
    turn(&q, 3);
    EXPECT(read_slot(2, 0, 0) == 65541);
    /* WATCH: a report every 5 counts either way */
    CHECK(B(0x0A, 4, 2, 0, 5), B(0x0A, 4, 2, 0, 5));
    for (i = 0; i < 23; i++) {
        turn(&q, i < 12 ? 1 : -1);
        run(); /* the main loop sends what the interrupt found due */
        take();
        if (outn) {
            EXPECT(outn == 2u + AIO_REPLY_LEN_EVENT_ENCODER_REPORT + 1u);
            EXPECT(out[0] == AIO_CT_EVENT && out[1] == AIO_DT_EVENT_ENCODER_REPORT && out[2] == 2);
            EXPECT(be32(out + 3) == q.pos);
            EXPECT(out[outn - 1] == xor_of(out, outn - 1));
            reports++;
        }
    }
    EXPECT(reports == 4);
    CHECK(B(0x0A, 4, 2, 0, 0), B(0x0A, 4, 2, 0, 0));
    turn(&q, 20);
    run();
    take();
    EXPECT(outn == 0);
}

static void encoder_stream(void)
{
    turned_t q = {2, 3, 0}, q3 = {8, 9, 0};
    uint32_t guard;
    encoder_board();
    CHECK(B(0x0A, 1, 0, 2, 3, 4), B(0x0A, 1, 0, 2, 3, 4));
    CHECK(B(0x0A, 1, 3, 8, 9, 4), B(0x0A, 1, 3, 8, 9, 4));
    turn(&q, 1234);
    turn(&q3, -77);
    CHECK(B(7, 1, 0x00, AIO_STREAM_ENCODERS, 0x27, 0x10), B(7, 1, 0x00, AIO_STREAM_ENCODERS, 0x27, 0x10));
    for (guard = 0; guard < 1000 && fake_tx_len == 0; guard++) {
        fake_advance(1);
        run();
    }
    take();
    EXPECT(outn == 11u + 16u + 1u);
    EXPECT(out[0] == AIO_CT_EVENT && out[1] == AIO_DT_EVENT_STREAM_SAMPLE && out[10] == 16);
    EXPECT(be32(out + 11) == 1234 && be32(out + 15) == 0 && be32(out + 19) == 0 && be32(out + 23) == -77);
    CHECK(B(7, 2), B(7, 2, 0, 1));
}

void test_encoder(void)
{
    encoder_config_errors();
    encoder_counts();
    encoder_modes();
    encoder_invalid();
    encoder_preset_and_watch();
    encoder_stream();
}

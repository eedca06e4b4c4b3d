/*
 * test_parser.c - host tests of Parser: the command table, XOR and CRC-16 framing, random bytes (parser.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "parser.h"

/* Every (CT, DT) the table knows parses; every other DT is unknown. */
void test_table(void)
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

/* ------------------------------------------------------------ framing */
void test_framing(void)
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
    fake_rx_push(B(0x3F));
    run();
    take();
    EXPECT(outn == 4 && !memcmp(out, "\xBF\x00\x02\xBD", 4));
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

void test_crc_framing(void)
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

/* 1,000,000 random bytes: no crash, no out-of-bounds access (ASan/UBSan),
 * and after 10 ms of quiet the board answers an ID request. */
void test_random(void)
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

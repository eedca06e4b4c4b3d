/*
 * test_uart.c - host tests of UART rings: pipelined bursts and frames at every ring position (uart.c, app.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "parser.h"

void test_pipelining(void)
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
void test_ring_positions(void)
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

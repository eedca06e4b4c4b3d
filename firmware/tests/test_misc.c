/*
 * test_misc.c - host tests of MISC: identity, EEPROM ID, reset, status, low-latency filler (misc.c).
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"

/* ------------------------------------------------------------ MISC */
void test_misc(void)
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
    CHECK(B(1, 4), B(1, 4, 1, AIO_FIRMWARE_MAJOR, AIO_FIRMWARE_MINOR, 0x00, (0x07 | AIO_FEATURE_SPI >> 16 | AIO_FEATURE_I2C_STREAM >> 16 | AIO_FEATURE_PULSE_IN >> 16 | AIO_FEATURE_BOARD_DESCRIPTION >> 16 | AIO_FEATURE_SONAR >> 16), 0xFF, 0xFF, 0x00,
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

/* READ_BOARD_DESCRIPTION: the Uno's table in two pages, each with the 4-byte head */
void test_board_description(void)
{
    static const uint8_t table[] = AIO_BOARD_TABLE_UNO_R3;
    uint8_t want[2 + 1 + 4 + 1 + AIO_BOARD_PAGE_LEN_UNO_R3];
    uint8_t page, at = 4, n;

    board();
    EXPECT(sizeof table == 4u + AIO_BOARD_FUNCTIONS * 3u);
    for (page = 0; page < 2; page++) {
        n = (uint8_t)(sizeof table - at < AIO_BOARD_PAGE_LEN_UNO_R3 ? sizeof table - at : AIO_BOARD_PAGE_LEN_UNO_R3);
        want[0] = 1;
        want[1] = AIO_DT_MISC_READ_BOARD_DESCRIPTION;
        want[2] = page;
        memcpy(&want[3], table, 4);
        want[7] = n;
        memcpy(&want[8], &table[at], n);
        send_frame(B(1, AIO_DT_MISC_READ_BOARD_DESCRIPTION, page));
        run();
        take();
        EXPECT(outn == 8u + n + 1u && !memcmp(out, want, 8u + n));
        at = (uint8_t)(at + n);
    }
    EXPECT(at == sizeof table);
    /* the head: the Uno, 14 digital pins, 6 analog, every function; D2-D13 digital */
    EXPECT(table[0] == AIO_BOARD_UNO_R3 && table[1] == 14 && table[2] == 6 && table[3] == AIO_BOARD_FUNCTIONS);
    EXPECT((table[4 + 3 * AIO_FUNCTION_DIGITAL_OUTPUT] | table[5 + 3 * AIO_FUNCTION_DIGITAL_OUTPUT] << 8) == AIO_PINS_DIGITAL_OUTPUT);
    EXPECT((table[4 + 3 * AIO_FUNCTION_SERVO_PWM] | table[5 + 3 * AIO_FUNCTION_SERVO_PWM] << 8) == AIO_PINS_SERVO_PWM);
    /* past the last page, and the highest page number (no wrap of the offset) */
    CHECK(B(1, AIO_DT_MISC_READ_BOARD_DESCRIPTION, 2), B(0x81, AIO_DT_MISC_READ_BOARD_DESCRIPTION, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(1, AIO_DT_MISC_READ_BOARD_DESCRIPTION, 255), B(0x81, AIO_DT_MISC_READ_BOARD_DESCRIPTION, AIO_ERR_VALUE_OUT_OF_RANGE));
}

/* SET_LOW_LATENCY: a burst of replies is padded to 97 bytes once the FIFO is dry */
void test_low_latency(void)
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

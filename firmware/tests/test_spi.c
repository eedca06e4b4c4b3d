/*
 * test_spi.c - host tests of SPI: the master bridge (spi.c).
 * The fake HAL loops MISO back to MOSI, so a transfer's reply is what it sent.
 * Part of `make -C firmware test` (see host_check.h).
 */
#include "host_check.h"
#include "pins.h"
#include "spi.h"

void test_spi(void)
{
    board();
    /* a transfer before CONFIG */
    CHECK(B(0x0D, 2, 1, 0xAA), B(0x8D, 2, AIO_ERR_SPI_NOT_CONFIGURED));
    /* refused settings: chip select on an SPI pin or D0/D1, mode 4, clock 7, order 2 */
    CHECK(B(0x0D, 1, 11, 0, 0, 0), B(0x8D, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(0x0D, 1, 1, 0, 0, 0), B(0x8D, 1, AIO_ERR_PIN_NOT_CAPABLE));
    CHECK(B(0x0D, 1, 10, 4, 0, 0), B(0x8D, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(0x0D, 1, 10, 0, 7, 0), B(0x8D, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    CHECK(B(0x0D, 1, 10, 0, 0, 2), B(0x8D, 1, AIO_ERR_VALUE_OUT_OF_RANGE));
    EXPECT(!fake_spi_on);
    /* D13 busy as an output: refused, nothing taken */
    CHECK(B(2, 1, 13, 1), B(2, 1, 13, 1));
    CHECK(B(0x0D, 1, 10, 0, 0, 0), B(0x8D, 1, AIO_ERR_PIN_BUSY));
    EXPECT(pins_role[10] == ROLE_FREE && pins_role[11] == ROLE_FREE && !fake_spi_on);
    CHECK(B(2, 4, 13), B(2, 4, 13));
    /* mode 3, 125 kHz, LSB first on D10 */
    CHECK(B(0x0D, 1, 10, 3, 6, 1), B(0x0D, 1, 10, 3, 6, 1));
    EXPECT(fake_spi_on && fake_spi_mode == 3 && fake_spi_clock == 6 && fake_spi_lsb_first == 1);
    EXPECT(pins_role[10] == ROLE_SPI && pins_role[11] == ROLE_SPI && pins_role[12] == ROLE_SPI &&
           pins_role[13] == ROLE_SPI);
    EXPECT(fake_pin_level[10] == 1); /* the chip select idles high */
    /* the pins refuse other roles while SPI holds them */
    CHECK(B(2, 1, 12, 0), B(0x82, 1, AIO_ERR_PIN_BUSY));
    CHECK(B(2, 1, 10, 1), B(0x82, 1, AIO_ERR_PIN_BUSY));
    /* full duplex: as many bytes back as sent */
    CHECK(B(0x0D, 2, 3, 0x01, 0x80, 0x00), B(0x0D, 2, 3, 0x01, 0x80, 0x00));
    EXPECT(fake_spi_count == 3 && fake_spi_out[1] == 0x80);
    EXPECT(fake_pin_level[10] == 1);
    /* empty, over-long and mislabelled transfers */
    CHECK(B(0x0D, 2, 0), B(0x8D, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
    {
        uint8_t req[3 + 40];
        memset(req, 0x5A, sizeof req);
        req[0] = 0x0D; req[1] = 2; req[2] = 40;
        CHECK(req, sizeof req, B(0x8D, 2, AIO_ERR_VALUE_OUT_OF_RANGE));
        CHECK(B(1, 2), B(1, 2, 0xFF, 0xFF));
    }
    /* 32 bytes */
    {
        uint8_t req[3 + 32];
        int i;
        req[0] = 0x0D; req[1] = 2; req[2] = 32;
        for (i = 0; i < 32; i++)
            req[3 + i] = (uint8_t)(i * 5);
        CHECK(req, 35, req, 35);
    }
    /* a mode fault: answered, master mode restored */
    fake_spi_fault = 1;
    CHECK(B(0x0D, 2, 1, 0x11), B(0x8D, 2, AIO_ERR_SPI_MODE_FAULT));
    EXPECT(fake_pin_level[10] == 1);
    fake_spi_fault = 0;
    CHECK(B(0x0D, 2, 1, 0x11), B(0x0D, 2, 1, 0x11));
    /* a new chip select releases the old one */
    CHECK(B(0x0D, 1, 4, 0, 0, 0), B(0x0D, 1, 4, 0, 0, 0));
    EXPECT(pins_role[10] == ROLE_FREE && pins_role[4] == ROLE_SPI);
    /* releasing any of its pins ends the bridge and frees all four */
    CHECK(B(2, 4, 12), B(2, 4, 12));
    EXPECT(!fake_spi_on && pins_role[4] == ROLE_FREE && pins_role[11] == ROLE_FREE &&
           pins_role[12] == ROLE_FREE && pins_role[13] == ROLE_FREE);
    CHECK(B(0x0D, 2, 1, 0xAA), B(0x8D, 2, AIO_ERR_SPI_NOT_CONFIGURED));
}

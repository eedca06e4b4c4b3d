/*
 * spi.c - SPI class (CT 0x0D, extension): the SPI master bridge.
 *
 * CONFIG takes D11 (MOSI), D12 (MISO), D13 (SCK) and a chip select on any
 * other digital pin (one role per pin: all four must be free or already the
 * bridge's), in mode 0-3 (CPOL << 1 | CPHA), at 16 MHz / 2**(clock + 1) and
 * MSB or LSB first.  TRANSFER pulls the chip select low, exchanges its bytes
 * one by one (each reply byte is the one clocked in while its partner went
 * out), and lets the chip select go high: one device transaction per request.
 * A byte takes 8 SPI clocks (1 us at 8 MHz, 64 us at 125 kHz), so a 32-byte
 * transfer holds the main loop at most ~2 ms; the stream's sampling runs from
 * its timer interrupt meanwhile.
 *
 * D11 is also Timer2's OC2A pin; the board tick uses Timer2's compare register
 * with the OC2A output disconnected (COM2A = 0, docs/motors.md), so the SPI
 * unit's MOSI drives the pin and the tick is unaffected.
 *
 * D10 is the AVR's SS: if it is an input and goes low, the SPI unit drops to
 * slave mode (a "mode fault").  A transfer that finds the unit out of master
 * mode restores it and answers SPI_MODE_FAULT; the host library keeps D10
 * the chip select or an output while the bridge is on.
 */
#include "spi.h"

#include "hal.h"
#include "pins.h"

#if AIO_WITH_SPI /* the class is in this image (protocol/profiles.py) */

#define NO_PIN 0xFFu
#define PIN_MOSI 11u
#define PIN_MISO 12u
#define PIN_SCK 13u

static uint8_t cs = NO_PIN; /* NO_PIN: the bridge is off */
static uint8_t settings;    /* mode | clock << 2 | order << 5: for a mode fault's restore */

/* The chip select becomes an input without a low glitch: hal_pin_mode(HAL_IN)
 * clears PORT before DDR, which would drive it low for a moment and select the
 * device (the harness's MCP3008 saw that extra CS fall).  Through the pull-up
 * state first, the pin goes from driven high to input high, then loses the pull-up. */
static void cs_off(uint8_t pin)
{
    hal_pin_mode(pin, HAL_IN_PULLUP);
    hal_pin_mode(pin, HAL_IN);
}

void spi_init(void)
{
    cs = NO_PIN;
    hal_spi_off();
}

void spi_release(uint8_t pin)
{
    uint8_t old = cs;
    (void)pin;
    if (old == NO_PIN)
        return;
    cs = NO_PIN;
    hal_spi_off();
    pins_role[PIN_MOSI] = pins_role[PIN_MISO] = pins_role[PIN_SCK] = pins_role[old] = ROLE_FREE;
    hal_pin_mode(PIN_MOSI, HAL_IN);
    hal_pin_mode(PIN_MISO, HAL_IN);
    hal_pin_mode(PIN_SCK, HAL_IN);
    cs_off(old);
}

/* The pin is free or already the bridge's. */
static uint8_t takeable(uint8_t pin) { return pins_role[pin] == ROLE_FREE || pins_role[pin] == ROLE_SPI; }

static void start(void)
{
    hal_spi_on((uint8_t)(settings & 3u), (uint8_t)(settings >> 2 & 7u), (uint8_t)(settings >> 5 & 1u));
}

static uint8_t configure(const uint8_t *d)
{
    uint8_t pin = d[0], mode = d[1], clock = d[2], order = d[3];

    if (!pins_capable(pin, AIO_PINS_SPI_CS))
        return AIO_ERR_PIN_NOT_CAPABLE;
    if (mode > 3u || clock > AIO_SPI_CLOCK_KHZ_125 || order > AIO_SPI_ORDER_LSB_FIRST)
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    if (!takeable(PIN_MOSI) || !takeable(PIN_MISO) || !takeable(PIN_SCK) || !takeable(pin))
        return AIO_ERR_PIN_BUSY;
    if (cs != NO_PIN && cs != pin) {
        pins_role[cs] = ROLE_FREE; /* a new chip select: the old one is released */
        cs_off(cs);
    }
    pins_role[PIN_MOSI] = pins_role[PIN_MISO] = pins_role[PIN_SCK] = pins_role[pin] = ROLE_SPI;
    hal_pin_mode(pin, HAL_OUT_HIGH); /* the chip select idles high */
    hal_pin_mode(PIN_MOSI, HAL_OUT_LOW);
    hal_pin_mode(PIN_SCK, (uint8_t)((mode & 2u) ? HAL_OUT_HIGH : HAL_OUT_LOW)); /* CPOL: idle level */
    hal_pin_mode(PIN_MISO, HAL_IN);
    cs = pin;
    settings = (uint8_t)(mode | clock << 2 | order << 5);
    start();
    return 0;
}

static uint8_t transfer(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t len = rq->data[0], i, err = 0;

    if (cs == NO_PIN)
        return AIO_ERR_SPI_NOT_CONFIGURED;
    if (len == 0 || len > AIO_MAX_BLOB || rq->len != (uint8_t)(1u + len))
        return AIO_ERR_VALUE_OUT_OF_RANGE;
    hal_pin_write(cs, 0);
    for (i = 0; i < len; i++) {
        if (hal_spi_exchange(rq->data[1 + i], &rp->data[1 + i]) != HAL_SPI_OK) {
            err = AIO_ERR_SPI_MODE_FAULT;
            break;
        }
    }
    hal_pin_write(cs, 1);
    if (err) {
        start(); /* back to master mode for the next transfer */
        return err;
    }
    rp->data[0] = len;
    rp->len = (uint8_t)(1u + len);
    return 0;
}

uint8_t spi_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t err;

    switch (rq->dt) {
    case AIO_DT_SPI_CONFIG:
        err = configure(rq->data);
        return err ? err : aio_echo(rq, rp);
    case AIO_DT_SPI_TRANSFER:
        return transfer(rq, rp);
    default:
        return AIO_ERR_UNKNOWN_DESCRIPTOR;
    }
}

#endif /* AIO_WITH_SPI */

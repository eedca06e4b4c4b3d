/*
 * misc.c - MISC class (CT 0x01).
 */
#include "misc.h"

#include "analog.h"
#include "board.h"
#include "failsafe.h"
#include "hal.h"
#include "parser.h"
#include "pins.h"
#include "stream.h"
#include "transaction.h"

#ifndef BAUD
#define BAUD 115200UL
#endif

#define FEATURES                                                                         \
    (AIO_FEATURE_GPIO | AIO_FEATURE_ANALOG | AIO_FEATURE_I2C | AIO_FEATURE_SERVO_PWM |   \
     AIO_FEATURE_SOFT_PWM | AIO_FEATURE_COUNTER | (HAL_HAS_TEMPERATURE ? AIO_FEATURE_TEMPERATURE : 0u) |               \
     AIO_FEATURE_EEPROM_ID | AIO_FEATURE_STREAM | AIO_FEATURE_FAILSAFE | AIO_FEATURE_GPIO_CHANGES | \
     AIO_FEATURE_TRANSACTIONS | AIO_FEATURE_COUNTER_REPORTS | AIO_FEATURE_ANALOG_CHANGES | \
     AIO_FEATURE_LOW_LATENCY | AIO_FEATURE_DUTY_PWM | AIO_FEATURE_CRC16 | AIO_FEATURE_BOARD_DESCRIPTION | \
     (AIO_WITH_STEPPER ? AIO_FEATURE_STEPPER : 0u) | (AIO_WITH_ENCODER ? AIO_FEATURE_ENCODER : 0u) | \
     (AIO_WITH_SPI ? AIO_FEATURE_SPI : 0u) | (AIO_WITH_I2C_STREAM ? AIO_FEATURE_I2C_STREAM : 0u) | \
     (AIO_WITH_PULSE_IN ? AIO_FEATURE_PULSE_IN : 0u) | (AIO_WITH_SONAR ? AIO_FEATURE_SONAR : 0u))

uint8_t misc_reset_pending;
uint8_t misc_low_latency;
static uint16_t session;

/* Bit n set when digital pin n has `role` (READ_PIN_ROLES reply). */
static uint16_t role_mask(uint8_t role)
{
    uint16_t mask = 0;
    uint8_t pin;

    for (pin = 0; pin < PINS_COUNT; pin++)
        if (pins_role[pin] == role)
            mask |= (uint16_t)(1u << pin);
    return mask;
}

void misc_init(void)
{
    misc_reset_pending = 0;
    misc_low_latency = 0;
    session = 0;
}

uint8_t misc_handle(const aio_request_t *rq, aio_reply_t *rp)
{
    uint8_t *p = rp->data;
    uint16_t id;

    switch (rq->dt) {
    case AIO_DT_MISC_RESET:
        misc_reset_pending = 1;
        break;
    case AIO_DT_MISC_READ_ID:
        p = aio_put16(p, hal_eeprom_read_u16(AIO_EEPROM_ID_ADDRESS));
        break;
    case AIO_DT_MISC_READ_TEMPERATURE:
        if (!HAL_HAS_TEMPERATURE)
            return AIO_ERR_NOT_IN_IMAGE;
        p = aio_put16(p, analog_convert(HAL_ADC_TEMPERATURE));
        break;
    case AIO_DT_MISC_READ_CAPABILITIES:
        *p++ = AIO_PROTOCOL_VERSION;
        *p++ = AIO_FIRMWARE_MAJOR;
        *p++ = AIO_FIRMWARE_MINOR;
        p = aio_put32(p, FEATURES);
        p = aio_put32(p, (uint32_t)BAUD);
        *p++ = AIO_RX_FIFO_SIZE;
        break;
    case AIO_DT_MISC_WRITE_ID:
        id = aio_be16(rq->data);
        hal_eeprom_write_u16(AIO_EEPROM_ID_ADDRESS, id);
        if (hal_eeprom_read_u16(AIO_EEPROM_ID_ADDRESS) != id)
            return AIO_ERR_EEPROM_FAILED;
        p = aio_put16(p, id);
        break;
    case AIO_DT_MISC_READ_STATUS:
        *p++ = (uint8_t)(failsafe_status() | (stream_running() ? AIO_STATUS_STREAMING : 0));
        p = aio_put16(p, session);
        break;
    case AIO_DT_MISC_SET_SESSION:
        session = aio_be16(rq->data);
        p = aio_put16(p, session);
        break;
    case AIO_DT_MISC_TRANSACTION:
        return transaction_handle(rq, rp);
    case AIO_DT_MISC_SET_LOW_LATENCY:
        if (rq->data[0] > 1u)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        misc_low_latency = rq->data[0];
        *p++ = misc_low_latency;
        break;
    case AIO_DT_MISC_SET_FRAMING:
        /* the reply is sealed in the new framing (dispatch seals after this), which
         * is how the host knows the switch happened; every later request is
         * parsed in it */
        if (rq->data[0] > 1u)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
        parser_crc = rq->data[0];
        *p++ = parser_crc;
        break;
    case AIO_DT_MISC_READ_BOARD_DESCRIPTION:
        return board_describe(rq->data[0], rp);
    case AIO_DT_MISC_READ_PIN_ROLES:
        p = aio_put16(p, role_mask(ROLE_GPIO_IN));
        p = aio_put16(p, role_mask(ROLE_GPIO_OUT));
        p = aio_put16(p, (uint16_t)(role_mask(ROLE_PWM) | role_mask(ROLE_DUTY))); /* duty PWM is PWM */
        p = aio_put16(p, role_mask(ROLE_COUNTER));
        p = aio_put16(p, role_mask(ROLE_PULSE_IN)); /* 0 in an image without them */
        break;
    default:
        return AIO_ERR_UNKNOWN_DESCRIPTOR; /* not reached: the parser checked the tags */
    }
    rp->len = (uint8_t)(p - rp->data);
    return 0;
}

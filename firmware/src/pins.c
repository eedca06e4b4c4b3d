/*
 * pins.c - one role per pin.
 */
#include "pins.h"

#include "aio.h"
#include "counter.h"
#include "duty.h"
#include "encoder.h"
#include "pulse_in.h"
#include "sonar.h"
#include "gpio.h"
#include "hal.h"
#include "pwm.h"
#include "stepper.h"
#include "spi.h"

uint8_t pins_role[PINS_COUNT];

#if AIO_PINMASK_BITS <= 16
const AIO_FLASH uint16_t pins_bit[16] = {
    1u << 0, 1u << 1, 1u << 2,  1u << 3,  1u << 4,  1u << 5,  1u << 6,  1u << 7,
    1u << 8, 1u << 9, 1u << 10, 1u << 11, 1u << 12, 1u << 13, 1u << 14, 1u << 15,
};
#endif

void pins_init(void)
{
    uint8_t pin;
    for (pin = 0; pin < PINS_COUNT; pin++)
        pins_role[pin] = ROLE_FREE;
}

uint8_t pins_claim_check(uint8_t pin, aio_pinmask_t table3_mask, uint8_t same_a, uint8_t same_b)
{
    uint8_t role;
    if (!pins_capable(pin, table3_mask))
        return AIO_ERR_PIN_NOT_CAPABLE;
    role = pins_role[pin];
    if (role != ROLE_FREE && role != same_a && role != same_b)
        return AIO_ERR_PIN_BUSY;
    return 0;
}

void pins_release(uint8_t pin)
{
    if (pin < PINS_FIRST || pin > PINS_LAST)
        return;
    switch (pins_role[pin]) {
    case ROLE_PWM:
        pwm_release(pin);
        break;
    case ROLE_COUNTER:
        counter_release(pin);
        break;
    case ROLE_DUTY:
        duty_release(pin);
        break;
    case ROLE_STEPPER:
        stepper_release(pin);
        break;
    case ROLE_ENCODER:
        encoder_release(pin); /* and its other pin */
        break;
    case ROLE_SPI:
        spi_release(pin); /* and the bridge's other three pins */
        break;
    case ROLE_PULSE_IN:
        pulse_in_release(pin);
        break;
    case ROLE_SONAR:
        sonar_release(pin); /* and its other pin */
        break;
    case ROLE_GPIO_IN:
    case ROLE_GPIO_OUT:
        gpio_release(pin);
        break;
    default:
        break;
    }
    pins_role[pin] = ROLE_FREE;
    hal_pin_mode(pin, HAL_IN);
}

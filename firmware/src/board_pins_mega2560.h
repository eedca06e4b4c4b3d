/*
 * board_pins_mega2560.h - the Mega 2560 image's pin checks (AIO_PINS_*, bit n = Dn, or
 * An for ANALOG_INPUT), replacing the Uno's Table III from aio_protocol.h (aio.h
 * includes this for -DAIO_BUILD_MEGA2560).
 *
 * First stage (notes/w4-mega.md): what hal_board_mega2560.h reaches with 16-bit masks.
 * D2-D15 digital in/out; A0-A15 analog READ (WATCH and the stream: A0-A5); servo PWM
 * on Timer1's D11/D12; counters on INT4/INT5 (D2, D3); encoders on those and the
 * pin-change pins D10-D15; pulse inputs on D10-D15.  Not yet: soft PWM (port A,
 * D22-D29), duty PWM, SPI (D50-D53), and the pins above D15.  I2C (D20/D21) is not an
 * analog input here, so no analog channel is shared with it.
 */
#ifndef BOARD_PINS_MEGA2560_H
#define BOARD_PINS_MEGA2560_H

#define PINS_LAST 15u /* pins.h: the role table reaches D15 */
/* pins.h: pin sets are 64-bit (D0-D53); the modules still narrow them to D0-D15. */
#define AIO_PINMASK_BITS 64u
/* D2-D9 have no pin-change interrupt (D2/D3's INT4/INT5 serve counters and encoders):
 * GPIO inputs there are polled by the main loop (gpio_poll: ~10 kHz, the tick wakes it). */
#define AIO_PINS_POLLED_EDGES 0x03FCu

#undef AIO_PINS_DIGITAL_INPUT
#undef AIO_PINS_DIGITAL_OUTPUT
#undef AIO_PINS_ANALOG_INPUT
#undef AIO_PINS_SOFT_PWM
#undef AIO_PINS_SERVO_PWM
#undef AIO_PINS_I2C
#undef AIO_PINS_COUNTER
#undef AIO_PINS_DUTY_PWM
#undef AIO_PINS_ENCODER
#undef AIO_PINS_SPI
#undef AIO_PINS_SPI_CS
#undef AIO_PINS_PULSE_IN
#undef AIO_PINS_SONAR
#define AIO_PINS_DIGITAL_INPUT 0xFFFCu
#define AIO_PINS_DIGITAL_OUTPUT 0xFFFCu
#define AIO_PINS_ANALOG_INPUT 0xFFFFu
#define AIO_PINS_SOFT_PWM 0x0000u
#define AIO_PINS_SERVO_PWM 0x1800u
#define AIO_PINS_I2C 0x0000u
#define AIO_PINS_COUNTER 0x000Cu
#define AIO_PINS_DUTY_PWM 0x0000u
#define AIO_PINS_ENCODER 0xFC0Cu
#define AIO_PINS_SPI 0x0000u
#define AIO_PINS_SPI_CS 0x0000u
#define AIO_PINS_PULSE_IN 0xFC00u
#define AIO_PINS_SONAR 0xFC00u

#endif /* BOARD_PINS_MEGA2560_H */

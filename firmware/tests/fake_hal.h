/* fake_hal.h - the host-test implementation of hal.h: state the tests inspect and drive. */
#ifndef FAKE_HAL_H
#define FAKE_HAL_H

#include <stdbool.h>
#include <stdint.h>

#define FAKE_TX_MAX 65536

extern uint32_t fake_ticks;          /* 100 us ticks since start */
extern uint8_t fake_tx[FAKE_TX_MAX]; /* everything the board sent, not yet taken */
extern uint32_t fake_tx_len;
extern uint8_t fake_tx_pad;          /* filler count of the last hal_tx_pad */
extern uint32_t fake_tx_pads;        /* hal_tx_pad calls */
extern uint32_t fake_tx_capacity;    /* bytes the "UART buffer" holds before the test drains */
extern uint8_t fake_eeprom[1024];
extern bool fake_eeprom_broken;      /* writes do not stick */
extern bool fake_reset_done;
extern uint8_t fake_pin_mode[14];
extern uint8_t fake_pin_level[14];   /* output levels, or driven input levels */
extern uint16_t fake_adc[9];
extern int fake_adc_pending;         /* channel of an interrupt conversion, or -1 */
extern uint8_t fake_duty_cs[3];      /* duty PWM clock select per timer, 0 = given back */
extern uint16_t fake_duty_top[3];
extern uint8_t fake_duty_how[14];    /* HAL_DUTY_LOW/HIGH/PWM per pin */
extern uint16_t fake_duty_ocr[14];
extern uint16_t fake_servo_us[2];    /* D9, D10; 0xFFFF = detached */
extern uint8_t fake_counter_enabled[2];
extern uint8_t fake_counter_rising[2];
extern uint8_t fake_encoder_int[2];   /* INT0/INT1 on any change for an encoder */
extern uint8_t fake_spi_on, fake_spi_mode, fake_spi_clock, fake_spi_lsb_first, fake_spi_fault;
extern uint8_t fake_spi_out[64];     /* the bytes sent on MOSI (MISO loops back) */
extern uint8_t fake_spi_count;
extern uint8_t fake_i2c_mem[256];    /* 24C02-like device at 0x50 */
extern bool fake_i2c_stuck;          /* every step times out */
extern uint8_t fake_i2c_resets;
extern uint8_t fake_twi_action, fake_twi_arg;
extern unsigned fake_twi_steps;
extern uint8_t fake_softpwm_port;    /* PORTD bits driven by software PWM */
extern uint16_t fake_edge_watch;
extern uint64_t fake_fine_now;          /* Timer0 counts (0.5 us) since start */
extern uint32_t fake_softpwm_width[8];  /* counts of each D2-D7 pin's last pulse */
extern uint32_t fake_softpwm_rises[8];  /* its pulses started */
extern uint32_t fake_adc_shift;
extern uint32_t fake_step_rises[14];    /* step pulses per pin (hal_step_pins) */         /* clock shift of the last chain conversion */

void fake_reset(void);
void fake_rx_push(const uint8_t *bytes, uint32_t n);
void fake_rx_overflow(void);
uint32_t fake_rx_pending(void);
void fake_advance(uint32_t ticks);   /* 100 us ticks pass: the alarms due, then the tick */
void fake_drive(uint8_t pin, uint8_t level); /* an input changes: pin-change interrupt */
void fake_adc_complete(void);

#endif

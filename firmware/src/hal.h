/*
 * hal.h - the thin hardware layer.
 *
 * Everything that touches a register is behind these functions: hal_avr.c and
 * uart.c implement them for the ATmega328P, tests/fake_hal.c implements them
 * for host tests.  The parser, the dispatcher and the class modules only call
 * these, so they compile and run on the host.
 */
#ifndef HAL_H
#define HAL_H

#include <stdbool.h>
#include <stdint.h>

/* ---- interrupts (critical sections) ---- */
uint8_t hal_irq_save(void);          /* disable interrupts, return previous state */
void hal_irq_restore(uint8_t state); /* restore the state hal_irq_save returned */

/* ---- time (timebase timer, 100 us ticks) ---- */
#define HAL_TICK_US 100u
uint16_t hal_ticks(void);   /* free-running 100 us tick count, wraps */
uint16_t hal_millis(void);  /* free-running millisecond count, wraps */
uint32_t hal_micros(void);  /* microsecond timestamp, wraps */

/* ---- UART ---- */
int16_t hal_rx_get(void);            /* next received byte, or -1 */
bool hal_rx_take_overflow(void);     /* true once after the RX FIFO overflowed (FIFO flushed) */
/* The receive FIFO in place: its ring of HAL_RX_RING bytes (8-bit indices
 * wrap with it; at most AIO_RX_FIFO_SIZE bytes wait), the index of the
 * oldest byte and how many wait; hal_rx_consume() drops the oldest n. */
#define HAL_RX_RING 256u
typedef struct {
    const uint8_t *ring;
    uint8_t tail;
    uint8_t count;
} hal_rx_view_t;
hal_rx_view_t hal_rx_view(void);
void hal_rx_consume(uint8_t n);
uint8_t hal_tx_free(void);           /* bytes free in the transmit buffer */
bool hal_tx_send(const uint8_t *frame, uint8_t len); /* whole frame or nothing; ISR-safe */
/* Main loop only: replies built in place.  hal_tx_claim() reserves the free,
 * contiguous room at the end of the transmit buffer, at most `want` bytes
 * (returns its size in *room; NULL when less than `need` is there);
 * hal_tx_publish() queues the first len bytes of it (whole frames) and gives
 * the rest back.  Interrupts may queue frames meanwhile: they go after. */
uint8_t *hal_tx_claim(uint8_t need, uint8_t want, uint8_t *room);
void hal_tx_publish(uint8_t len);
bool hal_tx_idle(void);              /* transmit buffer and UART shift register empty */

/* ---- system ---- */
void hal_wait(void);                 /* wait for something to happen (sleep) */
void hal_system_reset(void);         /* reset through the watchdog; does not return on AVR */
uint16_t hal_eeprom_read_u16(uint16_t address);  /* big-endian */
void hal_eeprom_write_u16(uint16_t address, uint16_t value);

/* ---- digital pins (Arduino numbers 2-13) ---- */
enum { HAL_IN = 0, HAL_IN_PULLUP = 1, HAL_OUT_LOW = 2, HAL_OUT_HIGH = 3 };
void hal_pin_mode(uint8_t pin, uint8_t mode);
void hal_pin_write(uint8_t pin, uint8_t level);
uint16_t hal_pin_levels(void);       /* bit n = level of Dn */
void hal_edge_watch(uint16_t mask);  /* pin-change interrupts on these pins (bit n = Dn) */

/* ---- ADC ---- */
#define HAL_ADC_TEMPERATURE 8u
uint16_t hal_adc_convert(uint8_t channel); /* blocking; channel 8 uses the 1.1 V reference */
/* AVCC, interrupt: calls analog_adc_done().  The ADC clock is 16 MHz >>
 * clock_shift (7: 125 kHz, 104 us a conversion, full accuracy; each step
 * down halves the time and costs accuracy: 4 = 1 MHz, 13 us). */
#define HAL_ADC_SHIFT_ACCURATE 7u
#define HAL_ADC_SHIFT_FASTEST 4u
void hal_adc_start(uint8_t channel, uint8_t clock_shift);

/* ---- TWI master ---- */
enum { HAL_TWI_OK = 0, HAL_TWI_NACK = 1, HAL_TWI_TIMEOUT = 2 };
void hal_twi_init(uint8_t fast);      /* 0 = 100 kHz, 1 = 400 kHz */
uint8_t hal_twi_start(void);          /* START or repeated START */
uint8_t hal_twi_write(uint8_t byte);  /* SLA+R/W or data; OK on ACK */
uint8_t hal_twi_read(bool ack, uint8_t *byte);
void hal_twi_stop(void);
void hal_twi_reset(void);             /* after a timeout: disable and re-enable the unit */

/* ---- Timer1 servo PWM on D9 (OC1A) / D10 (OC1B) ---- */
void hal_servo_attach(uint8_t pin, uint16_t pulse_us);
void hal_servo_set(uint8_t pin, uint16_t pulse_us);
void hal_servo_detach(uint8_t pin);

/* ---- fine alarms: Timer0, 0.5 us a count, running while an alarm does ---- */
#define HAL_FINE_PER_US 2u
/* Software PWM on D2-D7 (port D bits): `delay` counts from now (at least 16)
 * the alarm applies the pending edge (PORTD |= pwm_soft_set, &= pwm_soft_keep)
 * and calls pwm_soft_edge() for the counts to the next one (0: stop), each
 * counted from the previous edge's compare match, so latencies do not add up.
 * Interrupts disabled; the edge is the alarm's first action. */
void hal_softpwm_start(uint16_t delay);
void hal_softpwm_low(uint8_t portd_mask);
/* Stream sampling: stream_alarm() every `period` counts (with interrupts
 * enabled), the first one a period from now. */
void hal_stream_timer_start(uint32_t period);
void hal_stream_timer_stop(void);

/* ---- external interrupts INT0 (D2) / INT1 (D3) ---- */
void hal_counter_enable(uint8_t index, uint8_t rising);
void hal_counter_disable(uint8_t index);

#endif /* HAL_H */

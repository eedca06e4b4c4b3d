/*
 * fake_hal.c - hal.h for host tests: memory instead of registers, a clock
 * the test advances, a 24C02-like I2C device at 0x50.
 */
#include "fake_hal.h"

#include <string.h>

#include "analog.h"
#include "app.h"
#include "counter.h"
#include "encoder.h"
#include "pulse.h"
#include "gpio.h"
#include "hal.h"
#include "pwm.h"
#include "stepper.h"
#include "stream.h"

uint32_t fake_ticks;
uint8_t fake_tx[FAKE_TX_MAX];
uint32_t fake_tx_len;
uint8_t fake_tx_pad;
uint32_t fake_tx_pads;
uint32_t fake_tx_capacity;
uint8_t fake_eeprom[1024];
bool fake_eeprom_broken;
bool fake_reset_done;
uint8_t fake_pin_mode[14];
uint8_t fake_pin_level[14];
static uint8_t fake_driven[14]; /* set by fake_drive: a pull-up no longer decides the level */
uint16_t fake_adc[9];
int fake_adc_pending;
uint8_t fake_duty_cs[3];
uint16_t fake_duty_top[3];
uint8_t fake_duty_how[14];
uint16_t fake_duty_ocr[14];
uint16_t fake_servo_us[2];
uint8_t fake_counter_enabled[2];
uint8_t fake_counter_rising[2];
uint8_t fake_encoder_int[2];
uint8_t fake_i2c_mem[256];
bool fake_i2c_stuck;
uint8_t fake_i2c_resets;
uint8_t fake_softpwm_port;
uint16_t fake_edge_watch;
uint64_t fake_fine_now;
uint32_t fake_softpwm_width[8];
uint32_t fake_softpwm_rises[8];
uint32_t fake_adc_shift;
uint32_t fake_step_rises[14];

/* The two Timer0 alarms: due time in fine counts, 0 = off. */
static uint64_t pwm_due, stream_due, stream_period;
static uint64_t rise_at[8];

#define RX_MAX HAL_RX_RING /* the board's FIFO: a ring the parser reads in place */
static uint8_t rx[RX_MAX];
static uint32_t rx_head, rx_tail;
static bool rx_over;
static uint8_t irq_on = 1;

/* I2C device model */
static enum { I2C_IDLE, I2C_ADDRESSED_W, I2C_REG_SET, I2C_ADDRESSED_R } i2c_state;
static bool i2c_after_start;
static uint8_t i2c_ptr;

void fake_reset(void)
{
    fake_ticks = 0;
    memset(fake_step_rises, 0, sizeof fake_step_rises);
    fake_tx_len = 0;
    fake_tx_pad = 0;
    fake_tx_pads = 0;
    fake_tx_capacity = 192;
    memset(fake_eeprom, 0xFF, sizeof fake_eeprom);
    fake_eeprom_broken = false;
    fake_reset_done = false;
    memset(fake_pin_mode, 0, sizeof fake_pin_mode);
    memset(fake_pin_level, 0, sizeof fake_pin_level);
    memset(fake_driven, 0, sizeof fake_driven);
    memset(fake_adc, 0, sizeof fake_adc);
    fake_adc_pending = -1;
    fake_servo_us[0] = fake_servo_us[1] = 0xFFFF;
    memset(fake_duty_cs, 0, sizeof fake_duty_cs);
    memset(fake_duty_top, 0, sizeof fake_duty_top);
    memset(fake_duty_how, 0, sizeof fake_duty_how);
    memset(fake_duty_ocr, 0, sizeof fake_duty_ocr);
    memset(fake_counter_enabled, 0, 2);
    memset(fake_encoder_int, 0, 2);
    memset(fake_i2c_mem, 0xFF, sizeof fake_i2c_mem);
    fake_i2c_stuck = false;
    fake_i2c_resets = 0;
    fake_spi_on = fake_spi_fault = 0;
    fake_spi_count = 0;
    fake_softpwm_port = 0;
    fake_edge_watch = 0;
    fake_fine_now = 0;
    pwm_due = stream_due = 0;
    memset(fake_softpwm_width, 0, sizeof fake_softpwm_width);
    memset(fake_softpwm_rises, 0, sizeof fake_softpwm_rises);
    fake_adc_shift = 0;
    rx_head = rx_tail = 0;
    rx_over = false;
    i2c_state = I2C_IDLE;
    irq_on = 1;
}

void fake_rx_push(const uint8_t *bytes, uint32_t n)
{
    uint32_t i;
    for (i = 0; i < n; i++) {
        if (rx_head - rx_tail >= 128u) { /* the board's FIFO size */
            rx_over = true;
            continue;
        }
        rx[rx_head++ % RX_MAX] = bytes[i];
    }
}

void fake_rx_overflow(void) { rx_over = true; }
uint32_t fake_rx_pending(void) { return rx_head - rx_tail; }

/* The software PWM alarm: apply the pending edge (recording each pin's
 * rises and the width of its last pulse), ask for the next one. */
static void pwm_alarm(void)
{
    uint8_t before = fake_softpwm_port, pin;
    uint16_t delay;
    fake_softpwm_port = (uint8_t)((fake_softpwm_port | pwm_soft_set) & pwm_soft_keep);
    for (pin = 2; pin < 8; pin++) {
        uint8_t was = before >> pin & 1u, now = fake_softpwm_port >> pin & 1u;
        if (now && !was) {
            rise_at[pin] = fake_fine_now;
            fake_softpwm_rises[pin]++;
        } else if (was && !now) {
            fake_softpwm_width[pin] = (uint32_t)(fake_fine_now - rise_at[pin]);
        }
    }
    delay = pwm_soft_edge();
    pwm_due = delay ? pwm_due + delay : 0;
    if (delay >= 256u)
        pwm_soft_plan();
}

void fake_advance(uint32_t ticks)
{
    while (ticks--) {
        uint64_t end = fake_fine_now + 100u * HAL_FINE_PER_US;
        for (;;) {
            uint64_t due = 0;
            if (pwm_due && pwm_due <= end)
                due = pwm_due;
            if (stream_due && stream_due <= end && (!due || stream_due < due))
                due = stream_due;
            if (!due)
                break;
            fake_fine_now = due;
            if (due == pwm_due) {
                pwm_alarm();
            } else {
                stream_due += stream_period;
                stream_alarm();
            }
        }
        fake_fine_now = end;
        fake_ticks++;
        if (stepper_active)
            stepper_tick(); /* first, as the tick interrupt does (clock.c) */
        app_tick();
    }
}

void hal_softpwm_start(uint16_t delay) { pwm_due = fake_fine_now + delay; }

void hal_stream_timer_start(uint32_t period)
{
    stream_period = period;
    stream_due = fake_fine_now + period;
}

void hal_stream_timer_stop(void) { stream_due = 0; }

uint16_t hal_pin_levels(void)
{
    uint16_t v = 0;
    uint8_t pin;
    for (pin = 2; pin < 14; pin++) {
        uint8_t level = fake_pin_level[pin];
        if (pin < 8 && (fake_softpwm_port >> pin & 1u))
            level = 1;
        if (level)
            v |= (uint16_t)(1u << pin);
    }
    return v;
}

void fake_drive(uint8_t pin, uint8_t level)
{
    uint8_t changed = fake_pin_level[pin] != level;
    fake_pin_level[pin] = level;
    fake_driven[pin] = 1;
    if (fake_edge_watch >> pin & 1u) { /* hal_avr.c's pin-change interrupt */
        encoder_pin_change(hal_pin_levels());
#if AIO_WITH_PULSE
        if (pulse_active)
            pulse_edges(hal_pin_levels());
#endif
        gpio_pin_change(hal_pin_levels());
    }
    if (changed && (pin == 2 || pin == 3) && fake_encoder_int[pin - 2])
        encoder_int((uint8_t)(pin - 2), hal_pin_levels());
    /* INT0/INT1 on D2/D3: the configured edge only, as the external interrupts do */
    if (changed && (pin == 2 || pin == 3) && fake_counter_enabled[pin - 2] &&
        level == fake_counter_rising[pin - 2])
        counter_event((uint8_t)(pin - 2));
}

void fake_adc_complete(void)
{
    int ch = fake_adc_pending;
    if (ch < 0)
        return;
    fake_adc_pending = -1;
    analog_adc_done(fake_adc[ch]);
}

uint8_t hal_irq_save(void)
{
    uint8_t s = irq_on;
    irq_on = 0;
    return s;
}

void hal_irq_restore(uint8_t state) { irq_on = state; }

uint16_t hal_ticks(void) { return (uint16_t)fake_ticks; }
uint16_t hal_millis(void) { return (uint16_t)(fake_ticks / 10u); }
uint32_t hal_micros(void) { return (uint32_t)(fake_fine_now / HAL_FINE_PER_US); }

int16_t hal_rx_get(void)
{
    if (rx_head == rx_tail)
        return -1;
    return rx[rx_tail++ % RX_MAX];
}

bool hal_rx_take_overflow(void)
{
    if (!rx_over)
        return false;
    rx_over = false;
    rx_tail = rx_head;
    return true;
}

hal_rx_view_t hal_rx_view(void)
{
    hal_rx_view_t v = {rx, (uint8_t)rx_tail, (uint8_t)(rx_head - rx_tail)};
    return v;
}

void hal_rx_consume(uint8_t n) { rx_tail += n; }

uint8_t hal_tx_free(void)
{
    return (uint8_t)(fake_tx_len >= fake_tx_capacity ? 0 : fake_tx_capacity - fake_tx_len);
}

bool hal_tx_send(const uint8_t *frame, uint8_t len)
{
    if (fake_tx_len + len > fake_tx_capacity || fake_tx_len + len > FAKE_TX_MAX)
        return false;
    memcpy(fake_tx + fake_tx_len, frame, len);
    fake_tx_len += len;
    return true;
}

/* The claimed room is reserved at the end of fake_tx; frames "interrupts"
 * send meanwhile go after it and move down on publish, as on the board. */
static uint32_t claim_at, claim_size;

uint8_t *hal_tx_claim(uint8_t need, uint8_t want, uint8_t *room)
{
    uint32_t free_bytes = fake_tx_len >= fake_tx_capacity ? 0 : fake_tx_capacity - fake_tx_len;
    if (free_bytes > want)
        free_bytes = want;
    if (free_bytes < need || fake_tx_len + free_bytes > FAKE_TX_MAX)
        return 0;
    claim_at = fake_tx_len;
    claim_size = free_bytes;
    fake_tx_len += free_bytes;
    *room = (uint8_t)free_bytes;
    return fake_tx + claim_at;
}

void hal_tx_publish(uint8_t len)
{
    uint32_t after = fake_tx_len - (claim_at + claim_size);
    memmove(fake_tx + claim_at + len, fake_tx + claim_at + claim_size, after);
    fake_tx_len = claim_at + len + after;
}

bool hal_tx_idle(void) { return true; }

void hal_tx_pad(uint8_t n)
{
    fake_tx_pad = n;
    fake_tx_pads++;
}

void hal_wait(void)
{
    fake_advance(1);
    fake_adc_complete();
}

void hal_system_reset(void) { fake_reset_done = true; }

uint16_t hal_eeprom_read_u16(uint16_t a) { return (uint16_t)(fake_eeprom[a] << 8 | fake_eeprom[a + 1]); }

void hal_eeprom_write_u16(uint16_t a, uint16_t v)
{
    if (fake_eeprom_broken)
        return;
    fake_eeprom[a] = (uint8_t)(v >> 8);
    fake_eeprom[a + 1] = (uint8_t)v;
}

void hal_pin_mode(uint8_t pin, uint8_t mode)
{
    fake_pin_mode[pin] = mode;
    if (mode == HAL_OUT_LOW || mode == HAL_OUT_HIGH)
        fake_pin_level[pin] = mode == HAL_OUT_HIGH;
    else if (mode == HAL_IN_PULLUP && !fake_driven[pin])
        fake_pin_level[pin] = 1; /* nothing attached: the pull-up wins */
}

void hal_pin_write(uint8_t pin, uint8_t level) { fake_pin_level[pin] = level; }

void hal_step_pins(uint16_t mask, uint8_t level)
{
    uint8_t pin;
    for (pin = 2; pin < 14; pin++)
        if (mask >> pin & 1u) {
            if (level && !fake_pin_level[pin])
                fake_step_rises[pin]++;
            fake_pin_level[pin] = level;
        }
}

void hal_edge_watch(uint16_t mask) { fake_edge_watch = mask; }

uint16_t hal_adc_convert(uint8_t channel) { return fake_adc[channel]; }

void hal_adc_start(uint8_t channel, uint8_t clock_shift)
{
    fake_adc_pending = channel;
    fake_adc_shift = clock_shift;
}

/* SPI: MISO wired to MOSI (a loopback), so a transfer's reply is what it sent. */
uint8_t fake_spi_on, fake_spi_mode, fake_spi_clock, fake_spi_lsb_first, fake_spi_fault;
uint8_t fake_spi_out[64];
uint8_t fake_spi_count;

void hal_spi_on(uint8_t mode, uint8_t clock, uint8_t lsb_first)
{
    fake_spi_on = 1;
    fake_spi_mode = mode;
    fake_spi_clock = clock;
    fake_spi_lsb_first = lsb_first;
}

void hal_spi_off(void) { fake_spi_on = 0; }

uint8_t hal_spi_exchange(uint8_t out, uint8_t *in)
{
    if (!fake_spi_on || fake_spi_fault)
        return HAL_SPI_MODE_FAULT;
    fake_spi_out[fake_spi_count++ & 63u] = out;
    *in = out;
    return HAL_SPI_OK;
}

void hal_twi_init(uint8_t fast) { (void)fast; i2c_state = I2C_IDLE; }

uint8_t hal_twi_start(void)
{
    if (fake_i2c_stuck)
        return HAL_TWI_TIMEOUT;
    i2c_after_start = true;
    return HAL_TWI_OK;
}

uint8_t hal_twi_write(uint8_t byte)
{
    if (fake_i2c_stuck)
        return HAL_TWI_TIMEOUT;
    if (i2c_after_start) {
        i2c_after_start = false;
        if ((byte >> 1) != 0x50u) {
            i2c_state = I2C_IDLE;
            return HAL_TWI_NACK;
        }
        i2c_state = (byte & 1u) ? I2C_ADDRESSED_R : I2C_ADDRESSED_W;
        return HAL_TWI_OK;
    }
    if (i2c_state == I2C_ADDRESSED_W) {
        i2c_ptr = byte;
        i2c_state = I2C_REG_SET;
        return HAL_TWI_OK;
    }
    if (i2c_state == I2C_REG_SET) {
        if (i2c_ptr == 0xF0u) /* a write-protected area refuses data */
            return HAL_TWI_NACK;
        fake_i2c_mem[i2c_ptr++] = byte;
        return HAL_TWI_OK;
    }
    return HAL_TWI_NACK;
}

uint8_t hal_twi_read(bool ack, uint8_t *byte)
{
    (void)ack;
    if (fake_i2c_stuck)
        return HAL_TWI_TIMEOUT;
    *byte = fake_i2c_mem[i2c_ptr++];
    return HAL_TWI_OK;
}

void hal_twi_stop(void) { i2c_state = I2C_IDLE; }
void hal_twi_reset(void) { fake_i2c_resets++; i2c_state = I2C_IDLE; }
/* Interrupt-driven steps (i2cblock.c): recorded; a test answers with i2cblock_twi(). */
uint8_t fake_twi_action = 0xFFu, fake_twi_arg;
unsigned fake_twi_steps;
void hal_twi_go(uint8_t action, uint8_t arg)
{
    fake_twi_action = action;
    fake_twi_arg = arg;
    fake_twi_steps++;
}

void hal_duty_timer(uint8_t timer, uint8_t cs, uint16_t top)
{
    fake_duty_cs[timer] = cs;
    fake_duty_top[timer] = top;
}

void hal_duty_output(uint8_t pin, uint8_t how, uint16_t ocr)
{
    fake_duty_how[pin] = how;
    fake_duty_ocr[pin] = ocr;
    if (how != HAL_DUTY_PWM)
        fake_pin_level[pin] = how == HAL_DUTY_HIGH;
}

void hal_servo_attach(uint8_t pin, uint16_t us) { fake_servo_us[pin - 9] = us; }
void hal_servo_set(uint8_t pin, uint16_t us) { fake_servo_us[pin - 9] = us; }
void hal_servo_detach(uint8_t pin) { fake_servo_us[pin - 9] = 0xFFFF; }

void hal_softpwm_low(uint8_t mask) { fake_softpwm_port &= (uint8_t)~mask; }

void hal_counter_enable(uint8_t index, uint8_t rising)
{
    fake_counter_enabled[index] = 1;
    fake_counter_rising[index] = rising;
}

void hal_counter_disable(uint8_t index) { fake_counter_enabled[index] = 0; }

void hal_encoder_int(uint8_t index, uint8_t on) { fake_encoder_int[index] = on; }

void hal_stamp(uint16_t *ticks, uint8_t *sub)
{
    uint64_t us = fake_fine_now / HAL_FINE_PER_US; /* as hal_micros() */
    *ticks = (uint16_t)(us / 100u);
    *sub = (uint8_t)(us % 100u * 2u);
}

uint32_t hal_stamp_us(uint16_t ticks, uint8_t sub)
{
    uint32_t now = (uint32_t)(fake_fine_now / HAL_FINE_PER_US / 100u);
    now -= (uint32_t)(int32_t)(int16_t)(uint16_t)((uint16_t)now - ticks);
    return now * 100u + sub / 2u;
}

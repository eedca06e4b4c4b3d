/*
 * main.c - arduinoio firmware for the ATmega328P (Arduino Uno, 16 MHz).
 *
 * Initialises the peripherals and runs the main loop: bytes from the RX FIFO
 * go into the parser, complete requests to their class sub-parser, replies
 * into the TX buffer.  With nothing to do the CPU sleeps (idle mode) until
 * the next interrupt.  The watchdog (0.5 s) resets a stalled loop.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>

#include "app.h"
#include "clock.h"
#include "hal.h"
#include "uart.h"

/* A watchdog reset leaves the watchdog enabled with its shortest timeout:
 * clear it before anything else so the board does not reset in a loop. */
void early_init(void) __attribute__((naked, used, section(".init3")));
void early_init(void)
{
    MCUSR = 0;
    wdt_disable();
}

int main(void)
{
    app_init();
    uart_init();
    clock_init();
    set_sleep_mode(SLEEP_MODE_IDLE);
    wdt_enable(WDTO_500MS);
    sei();
    for (;;) {
        wdt_reset();
        if (app_step())
            continue;
        cli();
        if (!uart_rx_available()) {
            sleep_enable();
            sei();
            sleep_cpu();
            sleep_disable();
        }
        sei();
    }
}

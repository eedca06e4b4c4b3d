/* app.h - the main loop's work, independent of the hardware. */
#ifndef APP_H
#define APP_H

#include <stdint.h>

void app_init(void);
/* One step: returns nonzero if it did something, 0 if it has to wait for an
 * interrupt (a received byte, room in the transmit buffer, a tick). */
uint8_t app_step(void);
/* The timebase interrupt's work, every 100 us (the AVR build reaches
 * failsafe_tick() from clock.c directly). */
void app_tick(void);

#endif

/* sonar.h - SONAR class: HC-SR04 style rangers fired in turn, echoes timed on the board. */
#ifndef SONAR_H
#define SONAR_H

#include <stdint.h>

#include "aio.h"

#if AIO_WITH_SONAR
void sonar_init(void);
uint8_t sonar_handle(const aio_request_t *rq, aio_reply_t *rp);
/* Ends the sonar holding `pin` (its trigger or its echo): both pins become free. */
void sonar_release(uint8_t pin);
/* Main loop: the trigger pulse's end, the echo's end or timeout, the next firing. */
void sonar_poll(void);
/* The stream's sonar slots: the highest configured slot + 1 (0: none). */
uint8_t sonar_stream_count(void);
/* Interrupt context (the stream's sampling instant): per slot 0..n-1 the distance in mm
 * (u16) and the reading's age in 1.024 ms steps (u8, 255: that old or more). */
uint8_t *sonar_stream_put(uint8_t *p, uint8_t n);
#else /* !AIO_WITH_SONAR: the hooks other modules call do nothing */
static inline void sonar_init(void) {}
static inline void sonar_release(uint8_t pin) { (void)pin; }
static inline void sonar_poll(void) {}
static inline uint8_t sonar_stream_count(void) { return 0; }
#endif

#endif

/* counter.h - COUNTER class: 32-bit event counters on D2 (INT0) and D3 (INT1). */
#ifndef COUNTER_H
#define COUNTER_H

#include <stdint.h>

#include "aio.h"

extern volatile uint32_t counter_counts[2];
extern volatile uint16_t counter_every[2]; /* WATCH: a report every this many counts */

void counter_init(void);
uint8_t counter_handle(const aio_request_t *rq, aio_reply_t *rp);
void counter_release(uint8_t pin);
/* External interrupt of counter `index` (0 = D2, 1 = D3). */
/* Interrupt context: a watched counter may have reached its next report. */
void counter_report(uint8_t index);
static inline void counter_event(uint8_t index)
{
    counter_counts[index]++;
    if (counter_every[index])
        counter_report(index);
}
/* Both counts, read atomically (for stream samples; called with interrupts off). */
uint32_t counter_peek(uint8_t index);

#endif

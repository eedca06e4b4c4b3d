/*
 * pulse.c - the shared edge-timing layer (pulse.h): high pulses on pin-change pins.
 *
 * The interrupt stamps a channel's rising edge; at the falling edge it keeps both stamps
 * as the last complete pulse and marks it done, so the main loop always takes the latest
 * whole pulse (never one pulse's start with another's end), however late it looks.  The widths are
 * turned into microseconds outside the interrupt (hal_stamp_us, within 3 s), the
 * difference of the two edge times: 0.5 us steps on the Uno.
 */
#include "pulse.h"

#include "encoder.h"
#include "gpio.h"
#include "hal.h"

#if AIO_WITH_PULSE

#define BARRIER() __asm__ volatile("" ::: "memory")

pulse_chan_t pulse_chans[PULSE_CHANNELS];
volatile uint8_t pulse_active;
static uint16_t last_levels, pc_mask;

void pulse_edges(uint16_t levels)
{
    uint16_t changed = (uint16_t)((levels ^ last_levels) & pc_mask);
    uint8_t c;
    last_levels = levels;
    if (!changed)
        return;
    for (c = 0; c < PULSE_CHANNELS; c++) {
        pulse_chan_t *p = &pulse_chans[c];
        if (!(changed & p->mask))
            continue;
        if (levels & p->mask) {
            hal_stamp(&p->rise_low, &p->rise_sub);
            p->high = 1;
        } else if (p->high) {
            hal_stamp(&p->end_low, &p->end_sub);
            p->start_low = p->rise_low;
            p->start_sub = p->rise_sub;
            p->high = 0;
            p->done = 1;
        }
    }
}

void pulse_watch(uint8_t c, uint16_t mask)
{
    uint8_t i, st = hal_irq_save();
    uint16_t all = 0;
    pulse_chans[c].mask = mask;
    pulse_chans[c].high = pulse_chans[c].done = 0;
    for (i = 0; i < PULSE_CHANNELS; i++)
        all |= pulse_chans[i].mask;
    pc_mask = all;
    last_levels = hal_pin_levels(); /* a pin high now starts no pulse: its rise is unseen */
    pulse_active = all ? 1u : 0u;
    hal_edge_watch((uint16_t)(gpio_watch_mask() | encoder_pcint_mask() | all));
    BARRIER();
    hal_irq_restore(st);
}

uint8_t pulse_take(uint8_t c, uint32_t *width_us, uint32_t *end_us)
{
    pulse_chan_t *p = &pulse_chans[c];
    uint16_t rl, fl;
    uint8_t rs, fs, st = hal_irq_save();
    if (!p->done) {
        hal_irq_restore(st);
        return 0;
    }
    rl = p->start_low;
    rs = p->start_sub;
    fl = p->end_low;
    fs = p->end_sub;
    p->done = 0;
    BARRIER();
    hal_irq_restore(st);
    *end_us = hal_stamp_us(fl, fs);
    *width_us = *end_us - hal_stamp_us(rl, rs);
    return 1;
}

uint16_t pulse_pcint_mask(void) { return pc_mask; }

void pulse_init(void)
{
    uint8_t c;
    for (c = 0; c < PULSE_CHANNELS; c++)
        pulse_chans[c].mask = 0;
    pc_mask = 0;
    pulse_active = 0;
}

#endif /* AIO_WITH_PULSE */

/*
 * stepper_slots.h - the stepper slots shared by stepper.c (profiles, the tick,
 * events) and stepper_cmd.c (the requests); not for other modules.
 */
#ifndef STEPPER_SLOTS_H
#define STEPPER_SLOTS_H

#include <stdint.h>

#include "aio.h"

#define N AIO_STEPPER_COUNT
#define NONE 0xFFu

enum { IDLE = 0, MOVE, RUN, STOPPING };

typedef struct {
    uint8_t step, dir_pin;  /* NONE: slot unused */
    uint8_t limit[2];       /* negative, positive side; NONE: no switch */
    uint8_t active[2];      /* level of a closed switch */
    uint8_t mode;
    int8_t dir;             /* +1 / -1: the direction pin's meaning now */
    int8_t run_dir;         /* RUN: the wanted direction */
    uint8_t pending;        /* a step computed, pulsed next tick */
    uint8_t cruise;         /* at top speed: 1 a move until brake_at, 2 a run */
    int32_t brake_at;       /* a cruising move decelerates from here */
    int32_t pos, target;
    uint32_t v, vmax, vrun, vmin, acc, phase, ramp;
    uint8_t done;           /* StepperDone to send: reason + 1 */
    int32_t done_pos;
    uint32_t done_us;
} stepper_t;

extern stepper_t stepper_slot[N];

/* Comes to rest now (interrupts off or in the tick): StepperDone `reason` queued. */
void stepper_halt(stepper_t *s, uint8_t reason);
/* stepper_active from the slots' states. */
void stepper_update_active(void);
/* Speed at the first step from rest (the floor of a move's last ticks), Q32. */
uint32_t stepper_first_speed(uint32_t acc);

#endif

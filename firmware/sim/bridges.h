/* bridges.h - the FTDI and CH340 USB bridge models (see bridges.c); the Uno's
 * 16U2 model is in wire.c.  wire.c hands every board->host byte to the active
 * model and runs its events.  The model chosen is opt->usb_bridge (harness.h). */
#ifndef VIRTUAL_UNO_BRIDGES_H
#define VIRTUAL_UNO_BRIDGES_H

#include <stdint.h>

#include "json.h"

/* Any USB bridge (16U2 included): host bytes and board bytes move in 1 ms USB
 * frames, and a frame's last byte ends its burst. */
int usb_bridge_on(void);
const char *bridge_name(enum usb_bridge b);            /* "none", "16u2", "ftdi", "ch340" */
int bridge_parse(const char *name, enum usb_bridge *b); /* --usb-bridge; -1: unknown */
int bridge_set_latency_ms(long ms); /* the FTDI model's latency timer; -1: not 1..255 */

/* for wire.c */
int bridge_model_take(uint8_t b, uint64_t now); /* 1: the model took the byte */
void bridge_model_schedule(void);
int bridge_model_run(uint64_t now);
int bridge_model_empty(void);
void bridge_model_clear(void);  /* the cable is pulled */

void bridge_status(struct sbuf *r); /* its part of "status": , "bridge": {...} */

#endif

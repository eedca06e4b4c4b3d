/* bridges.h - the FTDI and CH340 USB bridge models (see bridges.c); the Uno's
 * 16U2 model is in wire.c.  wire.c hands every board->host byte to the active
 * model and runs its events. */
#ifndef VIRTUAL_UNO_BRIDGES_H
#define VIRTUAL_UNO_BRIDGES_H

#include <stdint.h>

enum bridge_model { BRIDGE_NONE, BRIDGE_FTDI, BRIDGE_CH340 };

extern enum bridge_model opt_bridge_model; /* --usb-bridge ftdi|ch340 (16u2: opt_16u2) */
extern unsigned ftdi_latency_ms;           /* the FTDI model's latency timer, 1..255 */

/* Any USB bridge (16U2 included): host bytes and board bytes move in 1 ms USB
 * frames, and a frame's last byte ends its burst. */
int usb_bridge_on(void);
const char *bridge_model_name(void); /* "none", "16u2", "ftdi", "ch340" */
int bridge_parse(const char *name);   /* --usb-bridge; -1: unknown */

/* for wire.c */
int bridge_model_take(uint8_t b, uint64_t now); /* 1: the model took the byte */
void bridge_model_schedule(void);
int bridge_model_run(uint64_t now);
int bridge_model_empty(void);
void bridge_model_clear(void);  /* the cable is pulled */

/* the control channel's "set_latency_timer" (control.c's table) */
struct jobj;
struct sbuf;
void cmd_set_latency_timer(struct jobj *o, struct sbuf *r);
void bridge_status_json(struct sbuf *r); /* appends , "bridge": {...} to the status */

#endif

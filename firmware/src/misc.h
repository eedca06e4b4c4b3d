/* misc.h - MISC class: reset, board ID, temperature, capabilities, status, session. */
#ifndef MISC_H
#define MISC_H

#include <stdint.h>

#include "aio.h"

extern uint8_t misc_reset_pending; /* RESET answered: reset once the reply has left */
extern uint8_t misc_low_latency;   /* SET_LOW_LATENCY: pad each burst of replies with filler */

void misc_init(void);
uint8_t misc_handle(const aio_request_t *rq, aio_reply_t *rp);

#endif

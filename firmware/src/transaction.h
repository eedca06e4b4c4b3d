/* transaction.h - MISC TRANSACTION: several requests in one frame (protocol.md 7.5). */
#ifndef TRANSACTION_H
#define TRANSACTION_H

#include <stdint.h>

#include "aio.h"

uint8_t transaction_handle(const aio_request_t *rq, aio_reply_t *rp);

#endif

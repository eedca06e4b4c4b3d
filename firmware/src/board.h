/*
 * board.h - the board's self-description (READ_BOARD_DESCRIPTION, issue 29).
 *
 * Each board has one file, board_<model>.c, beside the HAL that puts its description
 * table in flash (AIO_BOARD_TABLE_<MODEL> of aio_protocol.h) and defines
 * board_describe with it (three lines: see board_uno.c).  The table is rendered
 * from the Python model data (arduinoio_async/protocol/boards.py), the same data the
 * library checks pins against and AIO_PINS_* (the Uno's own pin checks) come from.
 * Layout: model, digital pins, analog pins, function count, then per function (wire
 * order, AIO_FUNCTION_*) a bitmap of ceil(pins / 8) bytes, pin n in bit n % 8 of
 * byte n / 8 (Arduino numbering: An is digital pins + n).  The Makefile picks the file
 * with BOARD= (uno by default).
 */
#ifndef BOARD_H
#define BOARD_H

#include <stdint.h>

#include "aio.h"

/* Page `page` of the board's description into rp: 0, or VALUE_OUT_OF_RANGE past the
 * last page (board_<model>.c: board_page on its own table). */
uint8_t board_describe(uint8_t page, aio_reply_t *rp);

/* Page `page` of `table` (`size` bytes, `page_len` map bytes a page: the model's
 * AIO_BOARD_PAGE_LEN_<MODEL>) into rp. */
uint8_t board_page(const AIO_FLASH uint8_t *table, uint8_t size, uint8_t page_len,
                   uint8_t page, aio_reply_t *rp);

#endif /* BOARD_H */

/*
 * board_uno.c - the Arduino Uno R3's description (board.h): the paper's Table III,
 * rendered from the same Python data as AIO_PINS_*, which the Uno's pin checks keep
 * using as immediate operands (cheaper than reading this table back).
 */
#include "board.h"

static const AIO_FLASH uint8_t board_table[] = AIO_BOARD_TABLE_UNO_R3;

uint8_t board_describe(uint8_t page, aio_reply_t *rp)
{
    return board_page(board_table, sizeof board_table, AIO_BOARD_PAGE_LEN_UNO_R3, page, rp);
}

/*
 * board_mega2560.c - the Arduino Mega 2560's description (board.h), rendered from
 * MEGA2560 in arduinoio_async/protocol/boards.py.
 */
#include "board.h"

static const AIO_FLASH uint8_t board_table[] = AIO_BOARD_TABLE_MEGA2560;

uint8_t board_describe(uint8_t page, aio_reply_t *rp)
{
    return board_page(board_table, sizeof board_table, AIO_BOARD_PAGE_LEN_MEGA2560, page, rp);
}

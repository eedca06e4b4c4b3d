/*
 * board.c - READ_BOARD_DESCRIPTION: pages of a board's flash table (board.h).
 *
 * Every page repeats the table's 4-byte head, then up to page_len bytes of maps (whole
 * maps: 27 bytes, 9 maps of 3, on the Uno: 2 pages; 27 bytes, 3 maps of 9, on the Mega:
 * 4 pages).  Pages are found by adding, not multiplying: the AVR has no divider and the
 * standard image has few bytes to spare.
 */
#include "board.h"

uint8_t board_page(const AIO_FLASH uint8_t *table, uint8_t size, uint8_t page_len,
                   uint8_t page, aio_reply_t *rp)
{
    uint8_t *p = rp->data;
    uint8_t at = 4u, n;

    *p++ = page;
    while (page--) {
        at = (uint8_t)(at + page_len);
        if (at >= size)
            return AIO_ERR_VALUE_OUT_OF_RANGE;
    }
    for (n = 0; n < 4u; n++)
        *p++ = table[n];
    n = (uint8_t)(size - at);
    if (n > page_len)
        n = page_len;
    *p++ = n;
    while (n--)
        *p++ = table[at++];
    rp->len = (uint8_t)(p - rp->data);
    return 0;
}

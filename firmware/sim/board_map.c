/*
 * board_map.c - the per-board pin tables of board_map.h.
 */
#include "board_map.h"

#include "avr_timer.h"

static const struct oc_pin uno_oc[] = {
	{6, '0', AVR_TIMER_COMPA, 0x44, 6}, {5, '0', AVR_TIMER_COMPB, 0x44, 4},
	{9, '1', AVR_TIMER_COMPA, 0x80, 6}, {10, '1', AVR_TIMER_COMPB, 0x80, 4},
	{11, '2', AVR_TIMER_COMPA, 0xB0, 6}, {3, '2', AVR_TIMER_COMPB, 0xB0, 4},
};

static const struct board_map uno = {
	.nports = 3,
	.port_names = {'B', 'C', 'D'},
	.addr_pin = {0x23, 0x26, 0x29},
	.uart_port = 2,
	.pin_port = {2, 2, 2, 2, 2, 2, 2, 2, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1},
	.pin_bit = {0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 0, 1, 2, 3, 4, 5},
	.last_jumpered = 13,
	.adc_channels = 8,
	.first_analog_pin = 14,
	.oc = uno_oc,
	.n_oc = (int)(sizeof uno_oc / sizeof uno_oc[0]),
};

/* Timers 0-2 have the same registers on the ATmega2560; their pins differ. */
static const struct oc_pin mega_oc[] = {
	{13, '0', AVR_TIMER_COMPA, 0x44, 6}, {4, '0', AVR_TIMER_COMPB, 0x44, 4},
	{11, '1', AVR_TIMER_COMPA, 0x80, 6}, {12, '1', AVR_TIMER_COMPB, 0x80, 4},
	{10, '2', AVR_TIMER_COMPA, 0xB0, 6}, {9, '2', AVR_TIMER_COMPB, 0xB0, 4},
};

enum { MB, ME, MG, MH, MJ, MF };
static const struct board_map mega2560 = {
	.nports = 6,
	.port_names = {'B', 'E', 'G', 'H', 'J', 'F'},
	.addr_pin = {0x23, 0x2C, 0x32, 0x100, 0x103, 0x2F},
	.uart_port = ME,
	.pin_port = {ME, ME, ME, ME, MG, ME, MH, MH, MH, MH, MB, MB, MB, MB, MJ, MJ, MF, MF, MF, MF},
	.pin_bit = {0, 1, 4, 5, 5, 3, 3, 4, 5, 6, 4, 5, 6, 7, 1, 0, 0, 1, 2, 3},
	.last_jumpered = 15,
	.adc_channels = 16,
	.first_analog_pin = 16,
	.oc = mega_oc,
	.n_oc = (int)(sizeof mega_oc / sizeof mega_oc[0]),
};

const struct board_map *board = &uno;

void board_map_select(int mega)
{
	board = mega ? &mega2560 : &uno;
}

/*
 * board_map.h - which AVR port bit each harness pin number is, per board.
 *
 * The circuit (circuit.c) works on harness pin numbers 0..NPINS-1; this table says
 * which port and bit each one is on the board the harness runs (--board), which
 * timer compare outputs reach which pins, and how far the loopback jumpers go.
 *   Uno:  0-7 = PD0-7 (D0-D7), 8-13 = PB0-5 (D8-D13), 14-19 = PC0-5 (A0-A5).
 *   Mega 2560 (first stage, D0-D15 of its header): the Arduino core's map, D0 PE0,
 *         D1 PE1, D2 PE4, D3 PE5, D4 PG5, D5 PE3, D6-D9 PH3-6, D10-D13 PB4-7, D14 PJ1,
 *         D15 PJ0; 16-19 = PF0-3 (A0-A3).  Jumpers D2-D3 ... D14-D15; ADC0-15.
 */
#ifndef BOARD_MAP_H
#define BOARD_MAP_H

#include <stdint.h>

#include "harness.h"

#define NPORTS_MAX 6

struct oc_pin {
	int pin;
	char timer;
	int comp;       /* AVR_TIMER_COMPA / COMPB */
	uint8_t tccr;   /* TCCRnA's data address */
	int shift;      /* of COMnx1:0 in TCCRnA */
};

struct board_map {
	int nports;
	char port_names[NPORTS_MAX];
	uint16_t addr_pin[NPORTS_MAX];  /* PINx data address; DDRx is +1, PORTx +2 */
	int uart_port;                  /* the port index of D0/D1 */
	int pin_port[NPINS];            /* index into port_names */
	int pin_bit[NPINS];
	int last_jumpered;              /* loopback pairs D2-D3 ... up to this pin */
	int adc_channels;               /* ADC inputs set_analog reaches (A0..) */
	int first_analog_pin;           /* the harness pin of A0 (the `pin` command's mv) */
	const struct oc_pin *oc;
	int n_oc;
};

extern const struct board_map *board;
void board_map_select(int mega2560);

#endif /* BOARD_MAP_H */

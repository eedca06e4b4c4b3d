/* spi_device.h - an MCP3008 on the Uno's SPI pins (see spi_device.c). */
#ifndef VIRTUAL_UNO_SPI_DEVICE_H
#define VIRTUAL_UNO_SPI_DEVICE_H

#include "json.h"

void spi_device_attach(void); /* SPI and pin hooks, once at start (after circuit_attach) */

/* control commands (control.c's table) */
void cmd_spi_device(struct jobj *o, struct sbuf *r);
void cmd_spi_device_status(struct jobj *o, struct sbuf *r);

#endif

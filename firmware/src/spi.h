/* spi.h - SPI class: the hardware SPI master on D11 (MOSI), D12 (MISO), D13 (SCK)
 * with a chip select on any other digital pin. */
#ifndef SPI_H
#define SPI_H

#include <stdint.h>

#include "aio.h"

#if AIO_WITH_SPI

void spi_init(void);
uint8_t spi_handle(const aio_request_t *rq, aio_reply_t *rp);
/* Ends the bridge (any of its four pins was released): all four become free. */
void spi_release(uint8_t pin);

#else /* !AIO_WITH_SPI: an image without the class (protocol/profiles.py) */
static inline void spi_init(void) {}
static inline void spi_release(uint8_t pin) { (void)pin; }
#endif /* AIO_WITH_SPI */

#endif

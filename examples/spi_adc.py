"""An MCP3008 ADC on the SPI bridge: eight more analog inputs, 10 bits each.

    python examples/spi_adc.py [--port P] [--vref 5.0]

Wiring (docs/sensors.md, "SPI bridge"): CLK to D13, DOUT to D12, DIN to D11, CS/SHDN to
D10 (with a 10 kOhm pull-up to 5 V), VDD and VREF to 5 V, AGND and DGND to GND.  Each
read is one 3-byte SPI transfer the board makes under the chip select; the driver turns
the code into volts.  Needs a firmware image with SPI (``arduinoio flash --profile
sensing``); without --port it runs on a virtual Uno whose MCP3008 model reads 0 V until a
test sets its channels.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D10
from arduinoio_async.devices import MCP3008
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--vref", type=float, default=5.0)
    args = parser.parse_args()
    async with example_board(args, fixture="open", profile="sensing") as board:
        adc = await MCP3008.open(board, cs=D10, clock_hz=1_000_000, vref=args.vref)
        for channel in range(8):
            volts = await adc.read_channel(channel)
            print(f"CH{channel}: {volts:.3f} V")
        pair = await adc.read_channel(1, differential=True)
        print(f"CH1 - CH0: {pair:.3f} V")


if __name__ == "__main__":
    anyio.run(main)

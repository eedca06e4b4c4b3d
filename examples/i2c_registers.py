"""Write and read registers of an I2C device: the 24C02-style memory at address 0x50.

    python examples/i2c_registers.py [--port P] [--address 0x50]

The board is an I2C master (A4 = SDA, A5 = SCL); a register read is a write of the
register number followed by a repeated-start read, up to 32 bytes at once.  A missing
device is an I2CError naming the NACK, never a hang.
"""

from __future__ import annotations

import anyio

from arduinoio_async import I2CError
from arduinoio_async import protocol as p
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--address", type=lambda text: int(text, 0), default=0x50)
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        bus = await board.i2c(p.I2CSpeed.KHZ_400)
        await bus.write(args.address, 0x10, b"hello")
        await anyio.sleep(0.01)  # an EEPROM's write cycle (5 ms) before it answers again
        print("read back", await bus.read(args.address, 0x10, 5))
        try:
            await bus.read(0x51, 0x00, 1)
        except I2CError as exc:
            print("no device at 0x51:", exc)


if __name__ == "__main__":
    anyio.run(main)

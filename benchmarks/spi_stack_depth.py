"""The sensing image's free stack at peak while the SPI bridge and a 1 kHz stream work.

    python -m benchmarks.spi_stack_depth

Runs 200 MCP3008 reads and 200 32-byte transfers on the virtual Uno while 4 analog
channels stream at 1 kHz, then reads RAM through the harness's ``peek``: the free bytes
are those between the end of static RAM (``_end`` of the ELF) and the deepest byte the
stack touched.  simavr starts RAM zeroed, so a pushed 0 byte is invisible: the figure is
an upper bound on the free stack, close for a stack of return addresses and registers.
"""

from __future__ import annotations

import subprocess

import anyio

from arduinoio_async import A0, A1, A2, A3, D10
from arduinoio_async._resources import firmware_image
from arduinoio_async.board import Board
from arduinoio_async.devices import MCP3008
from arduinoio_async.sim import VirtualUno

RAM_END = 0x900  # one past RAMEND (0x8FF) on the ATmega328P


def static_end(elf: str) -> int:
    """The data-space address just past .data and .bss (``_end``)."""
    symbols = subprocess.run(["avr-nm", elf], capture_output=True, text=True, check=True).stdout
    for line in symbols.splitlines():
        fields = line.split()
        if len(fields) == 3 and fields[2] == "_end":
            return int(fields[0], 16) & 0xFFFF
    raise RuntimeError(f"no _end in {elf}")


async def main() -> None:
    end = static_end(str(firmware_image(1_000_000, "elf", profile="sensing")))
    async with VirtualUno(profile="sensing", baud=1_000_000) as uno:
        await uno.spi_device(cs=10, volts=[1, 2, 3, 4, 5, 1, 2, 3])
        async with Board.open(uno.port, baudrate=uno.baud) as board:
            adc = await MCP3008.open(board, cs=D10)
            async with board.stream(analog=[A0, A1, A2, A3], period_ms=1):
                for i in range(200):
                    await adc.read_channel(i % 8)
                    await adc.bus.transfer(bytes(range(32)))
            ram = (await uno.command("peek", addr=end, length=RAM_END - end))["bytes"]
    free = next(i for i, byte in enumerate(ram) if byte)
    print(f"static RAM ends at 0x{end:03X}; free stack at peak: {free} B (budget: >= 400 B)")


if __name__ == "__main__":
    anyio.run(main)

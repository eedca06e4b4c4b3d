"""The ten commands of the paper's Table IV, as protocol requests with their set-up."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from .. import protocol as p
from ..board import Board

__all__ = ["COMMANDS", "EEPROM_ADDRESS", "PAPER_MS", "BenchCommand", "prepare"]

#: The I2C device of the virtual Uno's test circuit (a 256-byte EEPROM).
EEPROM_ADDRESS = 0x50

#: Table IV of the paper (ms), C++ client on Linux, Arduino Uno at 115200 baud.
PAPER_MS: dict[str, float] = {
    "read ID": 4.15532,
    "read temperature": 5.08272,
    "read all analog values": 6.49595,
    "write pin value": 4.64086,
    "read pin value": 4.6447,
    "read analog value": 5.00152,
    "I2C write 1 byte": 4.88282,
    "I2C write 4 bytes": 5.65578,
    "I2C read 1 byte": 6.25022,
    "I2C read 4 bytes": 6.73164,
}


@dataclass(frozen=True)
class BenchCommand:
    """One benchmarked command: a name from Table IV and the request it sends."""

    name: str
    request: p.Request[Any]
    #: A representative reply, for the wire-size part of the model.
    reply: p.Reply

    @property
    def paper_ms(self) -> float:
        return PAPER_MS[self.name]

    @property
    def request_bytes(self) -> int:
        return len(self.request.encode())

    @property
    def reply_bytes(self) -> int:
        return len(self.reply.encode())

    def call(self, board: Board) -> Callable[[], Awaitable[Any]]:
        request = self.request
        return lambda: board.request(request)


def _i2c_write(n: int) -> BenchCommand:
    data = bytes(range(n))
    return BenchCommand(
        f"I2C write {n} byte{'s' if n > 1 else ''}",
        p.I2CWrite(EEPROM_ADDRESS, 0x40, data),
        p.I2CWriteReply(EEPROM_ADDRESS, 0x40, n),
    )


def _i2c_read(n: int) -> BenchCommand:
    return BenchCommand(
        f"I2C read {n} byte{'s' if n > 1 else ''}",
        p.I2CRead(EEPROM_ADDRESS, 0x40, n),
        p.I2CReadReply(EEPROM_ADDRESS, 0x40, bytes(n)),
    )


COMMANDS: tuple[BenchCommand, ...] = (
    BenchCommand("read ID", p.ReadId(), p.ReadIdReply(1)),
    BenchCommand("read temperature", p.ReadTemperature(), p.ReadTemperatureReply(300)),
    BenchCommand("read all analog values", p.AnalogReadAll(), p.AnalogReadAllReply((0,) * 6)),
    BenchCommand("write pin value", p.GpioWrite(2, True), p.GpioWriteReply(2, True)),
    BenchCommand("read pin value", p.GpioRead(3), p.GpioReadReply(3, p.GpioState.LOW)),
    BenchCommand("read analog value", p.AnalogRead(0), p.AnalogReadReply(0, 0)),
    _i2c_write(1),
    _i2c_write(4),
    _i2c_read(1),
    _i2c_read(4),
)


async def prepare(board: Board) -> None:
    """Put the board in the state the commands need: D2 output, D3 input, I2C on."""
    await board.request(p.GpioConfig(2, p.GpioFlags.OUTPUT))
    await board.request(p.GpioConfig(3, p.GpioFlags.INPUT))
    await board.request(p.I2CConfig(p.I2CSpeed.KHZ_100))

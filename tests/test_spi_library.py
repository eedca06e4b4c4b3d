"""The SPI bus handle and the MCP3008 driver against the FakeBoard: no simulator.

The FakeBoard's SPI model answers with its device (here a FakeMcp3008 whose voltages the
test sets) and records every transfer; the oracles are those voltages and that record.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from arduinoio_async import D2, D4, D10, D11, D12, D13
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.devices import MCP3008
from arduinoio_async.errors import (
    PinCapabilityError,
    PinRoleError,
    StaleHandleError,
    UsageError,
    ValueRangeError,
)
from arduinoio_async.testing import FakeBoard, FakeMcp3008

VOLTS = [0.1, 0.7, 1.3, 1.9, 2.6, 3.1, 3.9, 4.8]


async def test_mcp3008_driver_reads_the_fake_device() -> None:
    async with FakeBoard() as fake:
        fake.spi_device = FakeMcp3008(VOLTS)
        async with Board.connect(fake.host_stream) as board:
            adc = await MCP3008.open(board, cs=D10, clock_hz=2_000_000)
            for channel, volts in enumerate(VOLTS):
                assert abs(await adc.read_channel(channel) - volts) <= 5 / 1024
            assert fake.spi_config == p.SpiConfig(10, 0, p.SpiClock.MHZ_2, p.SpiBitOrder.MSB_FIRST)
            assert fake.spi_frames[0][0] == b"\x01\x80\x00"
            assert [fake.role(pin) for pin in (10, 11, 12, 13)] == ["spi"] * 4


async def test_transfer_write_read_and_loopback() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        bus = await board.spi(D4, mode=2, clock_hz=125_000, bit_order="lsb")
        assert await bus.transfer(b"\x12\x34") == b"\x12\x34"  # MISO wired to MOSI
        await bus.write(bytes(range(32)))
        assert await bus.read(3, fill=0xFF) == b"\xff\xff\xff"
        assert [sent for sent, _ in fake.spi_frames] == [b"\x12\x34", bytes(range(32)), b"\xff" * 3]
        with pytest.raises(ValueRangeError, match="SPI transfer length"):
            await bus.transfer(bytes(33))
        with pytest.raises(ValueRangeError, match="SPI transfer length"):
            await bus.transfer(b"")
        assert len(fake.spi_frames) == 3  # nothing sent


async def test_settings_refused_before_sending() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        for kwargs, words in (
            ({"mode": 4}, "SPI mode"),
            ({"mode": True}, "SPI mode"),
            ({"clock_hz": 1_500_000}, "SPI clock"),
            ({"bit_order": "middle"}, "SPI bit order"),
        ):
            with pytest.raises(ValueRangeError, match=words):
                await board.spi(D10, **kwargs)
        with pytest.raises(PinCapabilityError):
            await board.spi(D12)  # type: ignore[arg-type]
        assert fake.spi_config is None


async def test_pin_roles_both_ways_and_release() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        out = await board.digital_output(D11)
        with pytest.raises(PinRoleError, match="D11 is in use as digital output"):
            await board.spi(D10)
        await out.release()
        d10 = await board.digital_input(D10)
        with pytest.raises(PinRoleError, match="D10 is in use as digital input"):
            await board.spi(D2)  # D10 (the AVR's SS) must not be an input
        await d10.release()
        bus = await board.spi(D2)
        with pytest.raises(UsageError, match="already set up"):
            await board.spi(D4)
        for pin in (D2, D11, D12, D13):
            with pytest.raises(PinRoleError, match=f"{pin.name} is in use as SPI"):
                await board.digital_output(pin)
        await board.release(D13)  # any pin ends the bus
        assert bus.released and not board.roles and fake.spi_config is None
        with pytest.raises(StaleHandleError):
            await bus.transfer(b"\x00")
        bus = await board.spi(D2)
        await bus.release()
        assert not board.roles and fake.role(11) == "free"


async def test_bus_is_replayed_after_a_reset() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        fake.spi_device = FakeMcp3008(VOLTS)
        adc = await MCP3008.open(board, cs=D10)
        fake.reboot()
        await board.restore()
        assert fake.spi_config is not None and fake.spi_config.cs == 10
        assert abs(await adc.read_channel(7) - VOLTS[7]) <= 5 / 1024


def test_mypy_refuses_an_spi_pin_as_chip_select(tmp_path: Path) -> None:
    snippet = tmp_path / "misuse.py"
    snippet.write_text(
        textwrap.dedent(
            """
            from arduinoio_async import D10, D11, D13
            from arduinoio_async.board import Board

            async def main(board: Board) -> None:
                await board.spi(D10)
                await board.spi(D11)
                await board.spi(cs=D13, mode=1)
            """
        )
    )
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(snippet)],
        capture_output=True,
        text=True,
        check=False,
    )
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert [e.split(":")[1] for e in errors] == ["7", "8"], result.stdout

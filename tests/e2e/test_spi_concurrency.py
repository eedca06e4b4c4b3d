"""SPI transfers from many tasks at once, and cancelled in flight, on the virtual Uno.

The transport orders every request; these tests prove it for the SPI class, whose replies
carry data the caller cannot check by itself: a reply delivered to the wrong task would
be a plausible reading of another channel.  Oracles: the MCP3008 model's channel
voltages and its own count of conversions and chip-select edges.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D10
from arduinoio_async.board import Board
from arduinoio_async.devices import MCP3008
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

#: Eight channels whose codes differ by far more than 1 LSB, so a swapped reply shows.
VOLTS = [0.3, 0.9, 1.5, 2.1, 2.7, 3.3, 3.9, 4.5]
LSB = 5.0 / 1024


async def test_many_tasks_each_get_their_own_channel(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """24 tasks read their channel 8 times each, all at once: every reading is that
    channel's voltage, and the device saw exactly one framed conversion per call."""
    uno = await virtual_uno_factory(profile="sensing", baud=1_000_000)
    await uno.spi_device(cs=10, volts=VOLTS)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        adc = await MCP3008.open(board, cs=D10)
        wrong: list[tuple[int, float]] = []
        calls = 0

        async def reader(channel: int) -> None:
            nonlocal calls
            for _ in range(8):
                volts = await adc.read_channel(channel)
                calls += 1
                if abs(volts - VOLTS[channel]) > LSB:
                    wrong.append((channel, volts))

        with anyio.fail_after(60):
            async with anyio.create_task_group() as tg:
                for task in range(24):
                    tg.start_soon(reader, task % 8)
        assert wrong == []
        truth = await uno.spi_device_status()
        assert calls == 24 * 8
        assert truth.conversions == truth.cs_falls == truth.cs_rises == calls
        assert not truth.cs_low


async def test_cancelled_transfers_leave_later_answers_right(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Readers cancelled in flight, round after round: the board finishes or never starts
    each transfer (chip select never left low), and every reading that does return,
    during and after the storm, is its own channel's."""
    uno = await virtual_uno_factory(profile="sensing", baud=1_000_000)
    await uno.spi_device(cs=10, volts=VOLTS)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        adc = await MCP3008.open(board, cs=D10)
        wrong: list[tuple[int, float]] = []

        async def reader(channel: int) -> None:
            while True:
                volts = await adc.read_channel(channel)
                if abs(volts - VOLTS[channel]) > LSB:
                    wrong.append((channel, volts))

        with anyio.fail_after(60):
            for round_ in range(20):
                async with anyio.create_task_group() as tg:
                    for channel in range(8):
                        tg.start_soon(reader, channel)
                    # Cancel once some transfers are in flight: wait on the device's count.
                    start = (await uno.spi_device_status()).conversions
                    while (await uno.spi_device_status()).conversions < start + 1 + round_ % 4:
                        pass
                    tg.cancel_scope.cancel()
            for channel in range(8):
                assert abs(await adc.read_channel(channel) - VOLTS[channel]) <= LSB
        assert wrong == []
        truth = await uno.spi_device_status()
        assert truth.cs_falls == truth.cs_rises == truth.conversions
        assert not truth.cs_low

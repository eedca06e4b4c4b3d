"""Low-latency mode with FakeBoard (protocol extension, docs/protocol.md 7.6): the fake
pads its replies with filler as the firmware does, and no caller ever sees a filler byte.
The virtual Uno counterpart with the 16U2 bridge model is ``tests/e2e/test_low_latency.py``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import anyio
import pytest

from arduinoio_async import A0, D2, D3
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board import board as board_module
from arduinoio_async.errors import ProtocolError
from arduinoio_async.testing import FakeBoard
from arduinoio_async.transport import tick_holding_bridge


def without_the_mode(board: Board) -> None:
    """Make ``board`` look like a firmware without the LOW_LATENCY feature bit."""
    caps = board.capabilities
    features = caps.features & ~p.Feature.LOW_LATENCY
    board.capabilities = dataclasses.replace(caps, features=features)


async def test_many_concurrent_callers_get_their_replies_and_never_filler() -> None:
    async with FakeBoard(board_id=0x0203) as fake, Board.connect(fake.host_stream) as board:
        assert board.capabilities.features & p.Feature.LOW_LATENCY
        await board.set_low_latency(True)
        assert fake.low_latency and board.low_latency
        out = await board.digital_output(D2)
        results: list[object] = []

        async def caller(n: int) -> None:
            for i in range(n):
                if i % 2:
                    results.append(await board.read_id())
                else:
                    await out.write(bool(i % 4))
                    results.append("written")

        async with anyio.create_task_group() as tg:
            for _ in range(16):
                tg.start_soon(caller, 10)
        assert results.count(0x0203) == 80 and results.count("written") == 80
        assert fake.filler_sent >= 160 * (p.LOW_LATENCY_PAD - 6)  # filler did flow
        assert board.link.stats.garbage_bytes == 0 and board.link.stats.resyncs == 0
        sent = fake.filler_sent
        await board.set_low_latency(False)
        assert not fake.low_latency and not board.low_latency
        assert await board.read_id() == 0x0203
        assert fake.filler_sent == sent


async def test_cancelled_callers_leave_the_link_aligned_in_low_latency_mode() -> None:
    async with FakeBoard(board_id=9) as fake, Board.connect(fake.host_stream) as board:
        await board.set_low_latency(True)
        with anyio.move_on_after(0):  # cancelled before or while its request is out
            await board.read_id()
        async with anyio.create_task_group() as tg:
            for _ in range(8):
                tg.start_soon(board.read_id)
            tg.cancel_scope.cancel()
        assert await board.read_id() == 9
        assert board.link.stats.garbage_bytes == 0
        assert fake.filler_sent > 0


async def test_the_mode_is_replayed_after_a_reset() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        await board.set_low_latency(True)
        await board.reset(restore=True)
        assert fake.low_latency  # the fake forgot it at reset; restore() set it again
        inp = await board.digital_input(D3)
        assert (await inp.read()).level is False
        assert board.link.stats.garbage_bytes == 0


async def test_a_board_without_the_feature_bit_refuses_with_a_precise_error() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        without_the_mode(board)
        with pytest.raises(ProtocolError, match="low-latency"):
            await board.set_low_latency(True)
        assert not fake.low_latency and not board.low_latency


class _Port:
    """What pyserial's list_ports reports for one port."""

    def __init__(self, device: str, vid: int | None, pid: int | None) -> None:
        self.device, self.vid, self.pid = device, vid, pid


def test_the_bridge_is_known_by_the_ports_usb_ids(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from serial.tools import list_ports

    ports = [
        _Port("/dev/ttyACM0", 0x2341, 0x0043),  # Uno R3: ATmega16U2
        _Port("/dev/ttyUSB0", 0x1A86, 0x7523),  # a clone's CH340
        _Port("/dev/ttyS0", None, None),
    ]
    monkeypatch.setattr(list_ports, "comports", lambda: ports)
    by_id = tmp_path / "usb-Arduino_Uno-if00"
    by_id.symlink_to("/dev/ttyACM0")  # as /dev/serial/by-id/ names it
    name = "ATmega16U2/8U2 (arduino-usbserial: Uno, Mega 2560)"  # transport.BRIDGES
    assert tick_holding_bridge("/dev/ttyACM0") == name
    assert tick_holding_bridge(str(by_id)) == name
    assert tick_holding_bridge("/dev/ttyUSB0") is None
    assert tick_holding_bridge("/dev/ttyS0") is None
    assert tick_holding_bridge("/dev/pts/3") is None  # a pseudo-terminal: no USB IDs
    assert tick_holding_bridge("socket://localhost:5000") is None


@pytest.mark.parametrize(
    ("bridge", "baud", "choice", "expected"),
    [
        ("Arduino Uno R3 (ATmega16U2 bridge)", 1_000_000, None, True),
        ("Arduino Uno R3 (ATmega16U2 bridge)", 2_000_000, None, True),
        ("Arduino Uno R3 (ATmega16U2 bridge)", 115200, None, False),  # filler > the tick
        (None, 1_000_000, None, False),  # another bridge, or none
        (None, 1_000_000, True, True),  # the caller's word counts
        ("Arduino Uno R3 (ATmega16U2 bridge)", 1_000_000, False, False),
    ],
)
async def test_the_default_turns_the_mode_on_only_behind_a_ticking_bridge_at_speed(
    monkeypatch: pytest.MonkeyPatch,
    bridge: str | None,
    baud: int,
    choice: bool | None,
    expected: bool,
) -> None:
    monkeypatch.setattr(board_module, "tick_holding_bridge", lambda port: bridge)
    async with FakeBoard(baud=baud) as fake, Board.connect(fake.host_stream) as board:
        assert await board.choose_low_latency(choice) is expected
        assert board.low_latency is expected and fake.low_latency is expected
        assert await board.read_id() == fake.board_id  # replies arrive, filler or not


async def test_the_default_leaves_a_board_without_the_mode_alone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(board_module, "tick_holding_bridge", lambda port: "an Uno R3")
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        without_the_mode(board)
        assert await board.choose_low_latency(None) is False  # no ProtocolError
        assert not fake.low_latency


async def test_a_board_left_in_the_mode_by_a_previous_program_is_set_as_chosen() -> None:
    async with FakeBoard() as fake:
        fake.low_latency = True  # the board keeps the mode while its port is closed
        async with Board.connect(fake.host_stream) as board:
            assert await board.choose_low_latency(False) is False
            assert not fake.low_latency and not board.low_latency


async def test_no_filler_while_a_stream_runs_as_on_the_firmware() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        await board.set_low_latency(True)
        async with board.stream(analog=[A0], period_ms=5):
            before = fake.filler_sent
            assert await board.read_id() == fake.board_id
            assert fake.filler_sent == before  # the stream's frames flush the bridge
        after_stop = fake.filler_sent
        assert await board.read_id() == fake.board_id
        assert fake.filler_sent > after_stop
        assert board.link.stats.garbage_bytes == 0

"""Boards on the network: ``arduinoio serve`` in one process, clients in others (loopback)."""

from __future__ import annotations

import contextlib
import itertools
import signal
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
import anyio.abc
import pytest

from arduinoio_async import A0, A1, D4, D5, D6, D7, D9
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.streaming import Sample
from arduinoio_async.errors import BoardError, BoardNotFoundError, PinRoleError, UsageError
from arduinoio_async.manager import ManagerEvent
from arduinoio_async.network import NetworkBoardManager, RemoteBoards, open_remote_board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_remote_read_id_and_the_same_api(serve_unos: ServeFactory) -> None:
    async with serve_unos([7]) as served:
        async with open_remote_board(7, connect=[served.endpoint]) as board:
            assert isinstance(board, Board)
            assert board.board_id == 7 and await board.read_id() == 7
            assert board.capabilities.protocol_version == p.PROTOCOL_VERSION
            assert board.port == "zenoh://0x0007"
            # An error reply crosses the network as a frame: the same exception as locally.
            with pytest.raises(BoardError) as refused:
                await board.request(p.GpioRead(4))
            assert refused.value.code is p.ErrorCode.PIN_NOT_CONFIGURED
            # Table III is checked before anything is sent, remotely as locally.
            await board.digital_output(D4)
            with pytest.raises(PinRoleError):
                await board.soft_pwm(D4)
        async with Board.open(f"zenoh://0x0007@{served.endpoint}") as board:
            assert await board.read_id() == 7
        result = await anyio.run_process(
            [
                sys.executable,
                "-m",
                "arduinoio_async",
                "info",
                "--remote",
                "--id",
                "0x0007",
                "--connect",
                served.endpoint,
            ],
            check=False,
        )
        assert result.returncode == 0, result.stderr.decode()
        assert "0x0007" in result.stdout.decode()


async def test_the_manager_finds_boards_on_ports_and_on_the_network(
    serve_unos: ServeFactory, virtual_uno_factory: VirtualUnoFactory
) -> None:
    local_uno = await virtual_uno_factory(board_id=8)
    async with (
        serve_unos([7]) as served,
        NetworkBoardManager(
            ports=[local_uno.port], usb=False, env=False, connect=[served.endpoint]
        ) as boards,
    ):
        local, remote = await boards.get(8), await boards.get(7)
        assert local.port == local_uno.port and remote.port == "zenoh://0x0007"
        assert await local.read_id() == 8 and await remote.read_id() == 7
        assert set(boards.present()) == {7, 8}
        with pytest.raises(BoardNotFoundError) as missing:
            await boards.get(9, timeout=0.5)
        assert missing.value.tried["zenoh"] == "no server announces it"


async def test_gpio_through_the_loopback_fixture(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7], fixture="loopback") as served,
        open_remote_board(7, connect=[served.endpoint]) as board,
    ):
        out4, in5 = await board.digital_output(D4), await board.digital_input(D5)
        out6, in7 = await board.digital_output(D6), await board.digital_input(D7)
        for a, b in itertools.product((False, True), repeat=2):
            async with anyio.create_task_group() as tg:  # pipelined over the network
                tg.start_soon(out4.write, a)
                tg.start_soon(out6.write, b)
            assert (await in5.read()).level is a
            assert (await in7.read()).level is b
            assert (await served.unos[7].pin("D4")).level == int(a)


async def test_a_1khz_stream_for_10s_without_gaps(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7], baud=1_000_000) as served,
        open_remote_board(7, connect=[served.endpoint]) as board,
    ):
        samples: list[Sample] = []
        # 10 s of the board's time: 10000 samples, however the host's clock runs.
        with anyio.fail_after(40):
            async with board.stream(analog=[A0, A1], period_ms=1, buffer=20_000) as stream:
                async for sample in stream:
                    samples.append(sample)
                    if len(samples) == 10_000:
                        break
        span_us = (samples[-1].board_time_us - samples[0].board_time_us) & 0xFFFFFFFF
        print(f"\nremote 1 kHz stream: {len(samples)} samples over {span_us / 1e6:.3f} s")
        assert abs(span_us - 9_999_000) <= 100  # 1 kHz on the board's timer
        # Every sample arrived, in order (the stop accounts for any sent but lost).
        assert stream.gaps == 0 and stream.dropped == 0
        sequences = [sample.sequence for sample in samples]
        assert all((b - a) & 0xFFFF == 1 for a, b in itertools.pairwise(sequences))


async def test_many_callers_and_cancellations_never_get_a_wrong_reply(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7]) as served,
        open_remote_board(7, connect=[served.endpoint]) as board,
    ):
        await served.unos[7].set_analog(0, 1000)
        await served.unos[7].set_analog(1, 4000)
        a0, a1 = board.analog(A0), board.analog(A1)
        completed = cancelled = 0

        async def caller(index: int) -> None:
            nonlocal completed, cancelled
            for round_ in range(10):
                # Every third call gives up at once: its reply arrives later and is dropped.
                with anyio.move_on_after(0.0005 if (index + round_) % 3 == 0 else 5) as scope:
                    value = await (a0 if index % 2 else a1).read()
                    assert abs(value - (205 if index % 2 else 819)) <= 3, (index, value)
                    assert await board.read_id() == 7
                    completed += 1
                cancelled += scope.cancelled_caught

        async with anyio.create_task_group() as tg:
            for index in range(20):
                tg.start_soon(caller, index)
        assert completed > 100 and cancelled > 0
        assert await board.read_id() == 7


async def test_unplug_and_replug_are_seen_remotely_and_roles_restored(
    serve_unos: ServeFactory,
) -> None:
    async with serve_unos([7]) as served, RemoteBoards(connect=[served.endpoint]) as remote:
        uno = served.unos[7]
        events: list[ManagerEvent] = []
        changed = anyio.Event()

        def record(event: ManagerEvent) -> None:
            nonlocal changed
            events.append(event)
            changed.set()
            changed = anyio.Event()

        board = await remote.get(7)
        led = await board.digital_output(D4, initial=True)
        motor = await board.servo(D9, pulse_us=1500)
        remote.subscribe(record)
        assert (await uno.pin("D4")).level == 1

        async def wait_for(kind: str) -> None:
            with anyio.fail_after(10):
                while not any(e.kind == kind for e in events):
                    await changed.wait()

        served.unlink_port(7)
        await uno.unplug()
        await wait_for("disconnected")
        assert not board.connected and 7 not in remote.announced()
        await uno.replug()
        served.link_port(7)
        await wait_for("connected")
        assert [e.kind for e in events] == ["disconnected", "connected"]
        assert remote.present()[7] is board  # the same Board, its handles still work
        assert (await uno.pin("D4")).level == 1  # its roles were replayed on the fresh boot
        await led.write(False)
        assert (await uno.pin("D4")).level == 0
        await motor.set_pulse(1200)
        assert (await board.request(p.ReadStatus())).session == board.session


async def test_two_clients_share_one_board(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7], fixture="loopback") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        a, b = await first.get(7), await second.get(7)
        resets: list[ManagerEvent] = []
        reset_seen = anyio.Event()

        def record(event: ManagerEvent) -> None:
            if event.kind == "reset":
                resets.append(event)
                if len(resets) == 2:
                    reset_seen.set()

        first.subscribe(record)
        second.subscribe(record)
        assert a is not b and a.session != b.session
        out_a, in_a = await a.digital_output(D4), await a.digital_input(D5)
        out_b, in_b = await b.digital_output(D6), await b.digital_input(D7)
        # Each client sees its own session tag: the other's is no reset.
        assert (await a.status()).session == a.session
        assert (await b.status()).session == b.session

        async def hammer(out: object, inp: object, rounds: int) -> None:
            for n in range(rounds):
                await out.write(bool(n & 1))  # type: ignore[attr-defined]
                assert (await inp.read()).level is bool(n & 1)  # type: ignore[attr-defined]

        async def ids(board: Board) -> None:
            for _ in range(20):
                assert await board.read_id() == 7

        async with anyio.create_task_group() as tg:
            tg.start_soon(hammer, out_a, in_a, 40)
            tg.start_soon(hammer, out_b, in_b, 40)
            for _ in range(5):
                tg.start_soon(ids, a)
                tg.start_soon(ids, b)
        assert not resets
        # The board's pin roles are the board's: B cannot take A's output pin.
        with pytest.raises(BoardError) as busy:
            await b.request(p.PwmConfig(4, 1500))
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        # A real reset still reaches both clients; each restores its own roles.
        await out_a.write(True)
        await out_b.write(True)
        await uno.reset()
        with anyio.fail_after(10):
            await reset_seen.wait()
            assert await first.wait_connected(7) is a
            assert await second.wait_connected(7) is b
        assert {e.board_id for e in resets} == {7}
        # Both restored their own outputs as last written (a fresh boot has them as inputs).
        assert (await uno.pin("D4")).level == 1 and (await uno.pin("D6")).level == 1
        await out_a.write(False)
        await out_b.write(False)
        assert not (await in_a.read()).level and not (await in_b.read()).level
        assert (await a.status()).session == a.session
        assert (await b.status()).session == b.session


CLIENT = """
import sys, anyio
from arduinoio_async import A0, D4, D9
from arduinoio_async.network import open_remote_board

async def main():
    async with open_remote_board(7, connect=[sys.argv[1]]) as board:
        led = await board.digital_output(D4, initial=True)
        motor = await board.servo(D9, pulse_us=1500)
        await board.arm_failsafe({timeout}, {{led: False, motor: 1000}})
        async with board.stream(analog=[A0], period_ms=10):
            print("armed", flush=True)
            await anyio.sleep_forever()

anyio.run(main)
"""


async def start_armed_client(tmp_path: Path, endpoint: str, timeout_ms: int) -> anyio.abc.Process:
    """A controller process that arms the failsafe of board 7 and then just lives."""
    script = tmp_path / "client.py"
    script.write_text(CLIENT.format(timeout=timeout_ms))
    client = await anyio.open_process([sys.executable, str(script), endpoint])
    assert client.stdout is not None
    with anyio.fail_after(20):
        assert (await client.stdout.receive()).strip() == b"armed"
    return client


@asynccontextmanager
async def killed_on_exit(process: anyio.abc.Process) -> AsyncIterator[anyio.abc.Process]:
    """The process, killed when the block ends (a failed assertion must not wait forever
    for a controller that just lives)."""
    async with process:
        try:
            yield process
        finally:
            if process.returncode is None:
                with contextlib.suppress(ProcessLookupError):
                    process.kill()


async def wait_board_time(uno: VirtualUno, span_us: float) -> None:
    """Let ``span_us`` of the board's time pass (a condition on the fixture's clock)."""
    start = float((await uno.status())["sim_us"])
    with anyio.fail_after(5):
        while float((await uno.status())["sim_us"]) < start + span_us:
            await uno.pin("D4")


async def test_a_killed_remote_client_trips_the_failsafe(
    serve_unos: ServeFactory, tmp_path: Path
) -> None:
    timeout_ms = 100
    async with serve_unos([7]) as served:
        uno = served.unos[7]
        client = await start_armed_client(tmp_path, served.endpoint, timeout_ms)
        async with killed_on_exit(client):
            await wait_board_time(uno, 3 * timeout_ms * 1000)  # the live client feeds it
            assert (await uno.pin("D4")).level == 1
            killed_at = float((await uno.status())["sim_us"])
            client.send_signal(signal.SIGKILL)
            with anyio.fail_after(2):
                while (await uno.pin("D4")).level != 0:
                    await uno.status()
        led = await uno.pulse_stats("D4")
        assert led.last_edge_us is not None
        reaction_ms = (led.last_edge_us - killed_at) / 1000
        print(f"\nfailsafe after SIGKILL of the remote client: {reaction_ms:.1f} ms")
        assert 0 < reaction_ms <= timeout_ms + 20
        # Nobody reads the dead client's stream any more: the server stops it.
        async with RemoteBoards(connect=[served.endpoint]) as remote:
            observer = await remote.get(7)
            with anyio.fail_after(5):
                while (await observer.status()).flags & p.StatusFlags.STREAMING:
                    await uno.status()


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGSTOP], ids=["killed", "frozen"])
async def test_other_clients_do_not_feed_a_lost_owners_failsafe(
    serve_unos: ServeFactory, tmp_path: Path, how: signal.Signals
) -> None:
    """A killed owner vanishes (its liveliness token goes); a frozen one only falls silent."""
    timeout_ms = 100
    async with serve_unos([7]) as served, RemoteBoards(connect=[served.endpoint]) as remote:
        uno = served.unos[7]
        watcher = await remote.get(7)
        client = await start_armed_client(tmp_path, served.endpoint, timeout_ms)
        async with killed_on_exit(client):
            client.send_signal(how)
            killed_at = float((await uno.status())["sim_us"])
            # Without the server's gate these reads would keep the watchdog fed forever.
            with anyio.fail_after(2):
                while (await uno.pin("D4")).level != 0:
                    assert await watcher.read_id() == 7
            if how is not signal.SIGKILL:
                client.send_signal(signal.SIGKILL)
        led = await uno.pulse_stats("D4")
        assert led.last_edge_us is not None
        print(
            f"\nfailsafe with another client busy, owner {how.name}: "
            f"{(led.last_edge_us - killed_at) / 1000:.1f} ms (the server's notice + the timeout)"
        )
        status = await watcher.status()
        assert status.flags & p.StatusFlags.FAILSAFE_TRIPPED
        assert watcher.failsafe is None  # not this client's failsafe: it does not re-arm


async def test_write_id_is_refused_over_the_network(serve_unos: ServeFactory) -> None:
    """A remote write_id gets a precise UsageError; the board keeps its ID, and reads in
    flight around the refused request get their own replies (no resync)."""
    async with (
        serve_unos([7]) as served,
        open_remote_board(7, connect=[served.endpoint]) as board,
    ):
        ids: list[int] = []

        async def read_id() -> None:
            ids.append(await board.read_id())

        async with anyio.create_task_group() as tg:
            for _ in range(5):
                tg.start_soon(read_id)
            with pytest.raises(UsageError, match=r"write_id\(0x0042\) is refused over the net"):
                await board.write_id(0x0042)
            for _ in range(5):
                tg.start_soon(read_id)
        assert ids == [7] * 10
        assert board.board_id == 7 and board.link.expected_id == 7
        assert board.link.state.value == "ready" and board.link.stats.resyncs == 0
        assert await board.read_id() == 7

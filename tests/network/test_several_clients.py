"""Several clients of one served board: joining while another streams, pins held by one
client, the failsafe owner across a server restart."""

from __future__ import annotations

import sys
from pathlib import Path

import anyio
import pytest
import zenoh
from anyio.streams.text import TextReceiveStream

from arduinoio_async import A0, D6, D7
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError
from arduinoio_async.network import RemoteBoards, open_remote_board, zenoh_config
from arduinoio_async.network._keys import decode_fault, request_key
from arduinoio_async.network._limits import MAX_ATTACHMENT, MAX_PAYLOAD
from arduinoio_async.sim import VirtualUno

from .conftest import ServeFactory
from .test_remote import killed_on_exit

pytestmark = pytest.mark.sim

#: A client joining must not need longer than this (it takes well under a second).
JOIN_TIMEOUT = 4.0


@pytest.mark.parametrize("period_ms", [1, 20])
async def test_a_client_joins_while_another_streams(
    serve_unos: ServeFactory, period_ms: int
) -> None:
    """Another client's samples reach every client's session: a joining client's wait
    for the board must not depend on a pause in them (it never comes at 20 ms)."""
    async with serve_unos([7]) as served, RemoteBoards(connect=[served.endpoint]) as first:
        streamer = await first.get(7)
        async with (
            streamer.stream(analog=[A0], period_ms=period_ms) as samples,
            anyio.create_task_group() as tg,
        ):
            received = 0

            async def consume() -> None:
                nonlocal received
                async for _ in samples:
                    received += 1

            tg.start_soon(consume)
            for _ in range(2):
                async with open_remote_board(
                    7, connect=[served.endpoint], ready_timeout=JOIN_TIMEOUT
                ) as joined:
                    assert await joined.read_id() == 7
            # A client in its own process, as `arduinoio status --remote` is.
            command = [sys.executable, "-m", "arduinoio_async", "status", "--remote"]
            command += ["--id", "0x0007", "--connect", served.endpoint]
            result = await anyio.run_process(command, check=False)
            assert result.returncode == 0, result.stderr.decode()
            tg.cancel_scope.cancel()
        # The streaming client lost nothing to the newcomers.
        assert received > 0 and samples.gaps == 0 and samples.dropped == 0


async def test_a_client_cannot_take_another_clients_pin(serve_unos: ServeFactory) -> None:
    """Within one client a second role on a pin is a PinRoleError; between clients the
    server refuses it with the board's PIN_BUSY, and the holder's output keeps working."""
    async with (
        serve_unos([7], fixture="loopback") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        a, b = await first.get(7), await second.get(7)
        led = await a.digital_output(D6, initial=True)
        with pytest.raises(BoardError) as busy:
            await b.digital_input(D6)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:  # nor release it from under A
            await b.release(D6)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:  # nor inside a transaction
            async with b.transaction() as tx:
                tx.add(p.GpioConfig(int(D6), p.GpioFlags(0)))
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        assert D6 not in b.roles  # B's refused claim was undone
        await led.write(False)  # A's output is still A's
        assert (await uno.pin("D6")).level == 0
        await led.write(True)
        assert (await uno.pin("D6")).level == 1
        # The same role is shared (a restarted controller sets its pins up again) ...
        again = await b.digital_output(D6, initial=True)
        await again.write(True)
        # ... and a pin nobody else holds is free to change.
        await b.digital_input(D7)
        inp = b.roles[D7]
        assert inp.role == "digital input"
        await b.release(D7)
        await a.digital_output(D7)


OWNER = """
import sys, anyio
from arduinoio_async import D2
from arduinoio_async.network import RemoteBoards

async def main():
    async with RemoteBoards(connect=[sys.argv[1]]) as remote:
        remote.subscribe(lambda event: print(event.kind, event.detail, flush=True))
        board = await remote.get(7)
        led = await board.digital_output(D2, initial=True)
        await board.arm_failsafe(300, {led: False})
        print("armed", flush=True)
        await anyio.sleep_forever()

anyio.run(main)
"""


async def wait_level(uno: VirtualUno, pin: str, level: int, timeout: float) -> None:
    """Until the board drives ``pin`` at ``level`` (the fixture's ground truth)."""
    with anyio.fail_after(timeout):
        while (await uno.pin(pin)).level != level:
            await uno.status()


async def test_the_failsafe_owner_recovers_after_the_server_restarts(
    serve_unos: ServeFactory, tmp_path: Path
) -> None:
    """The server dies: the owner's failsafe trips (its outputs go safe).  The server
    comes back on the tripped board: the owner reconnects, re-arms and restores D2, and
    its failsafe works again under the new server."""
    async with serve_unos([7]) as served:
        uno = served.unos[7]
        script = tmp_path / "owner.py"
        script.write_text(OWNER)
        owner = await anyio.open_process([sys.executable, str(script), served.endpoint])
        async with killed_on_exit(owner):
            assert owner.stdout is not None
            lines = TextReceiveStream(owner.stdout)
            said: list[str] = []

            async def wait_said(word: str, timeout: float) -> None:
                with anyio.fail_after(timeout):
                    async for chunk in lines:
                        said.extend(chunk.splitlines())
                        if any(line.startswith(word) for line in said):
                            return
                raise AssertionError(f"the owner ended; it said {said}")

            await wait_said("armed", 20)
            assert (await uno.pin("D2")).level == 1
            await served.kill()
            await wait_level(uno, "D2", 0, 3)  # the failsafe tripped: D2 is safe
            said.clear()
            assert await served.start() == ["0x0007"]
            await wait_said("connected", 15)
            await wait_level(uno, "D2", 1, 3)  # the owner's role is back, re-armed
            # The owner's failsafe is armed under the new server: its death trips it.
            owner.kill()
            await wait_level(uno, "D2", 0, 3)
        print(f"\nthe owner said while the server restarted: {said}")


async def test_the_monitor_shows_another_clients_pin_and_cannot_take_it(
    serve_unos: ServeFactory,
) -> None:
    """A monitor on a served board shows the pins another live client holds as set
    elsewhere (the board's roles, through the server), and taking one is refused."""
    monitor = pytest.importorskip("arduinoio_async.monitor")
    async with (
        serve_unos([7]) as served,
        RemoteBoards(connect=[served.endpoint]) as controller,
        RemoteBoards(connect=[served.endpoint]) as watcher,
    ):
        led = await (await controller.get(7)).digital_output(D6, initial=True)
        hub = monitor.MonitorHub([await watcher.get(7)], period_ms=20)
        panel = hub.panels["b0"]
        async with anyio.create_task_group() as tg:
            tg.start_soon(hub.run)
            with anyio.fail_after(5):
                while panel.pin_roles()[D6].elsewhere is None:
                    await panel.board.read_id()
            assert panel.snapshot()["pins"][6 - 2]["role"] == "elsewhere"
            result = await hub.perform(
                {"id": 1, "board": "b0", "op": "role", "pin": "D6", "role": "input"}
            )
            assert not result["ok"] and "the pin is busy" in str(result["error"]), result
            await led.write(False)  # still the controller's
            assert (await served.unos[7].pin("D6")).level == 0
            tg.cancel_scope.cancel()


async def test_a_client_gets_no_samples_of_another_clients_stream(
    serve_unos: ServeFactory,
) -> None:
    """Samples go to the client whose stream it is: the others' links do not carry them
    (a 1 ms stream would otherwise cost every client 1,000 frames a second)."""
    async with (
        serve_unos([7]) as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        streamer, other = await first.get(7), await second.get(7)
        before = other.link.stats.events
        async with streamer.stream(analog=[A0], period_ms=1) as samples:
            received = 0
            async for _ in samples:
                received += 1
                if received == 300:
                    break
        assert samples.gaps == 0
        assert await other.read_id() == 7  # anything published meanwhile has arrived
        assert other.link.stats.events - before == 0


async def test_a_holder_a_streamer_and_a_hostile_peer_at_once(serve_unos: ServeFactory) -> None:
    """The server's three defences together: one client holds a pin, another streams at
    1 ms, and a third peer floods the board's key with oversized, garbage and overlong
    attachment queries.  The hostile queries are refused, the holder's writes reach the
    pin (the fixture's ground truth), the pin stays the holder's, and the stream loses no
    sample."""
    async with (
        serve_unos([7], fixture="loopback") as served,
        RemoteBoards(connect=[served.endpoint]) as holder_side,
        RemoteBoards(connect=[served.endpoint]) as streamer_side,
    ):
        uno = served.unos[7]
        holder, streamer = await holder_side.get(7), await streamer_side.get(7)
        led = await holder.digital_output(D6, initial=False)
        hostile = await anyio.to_thread.run_sync(
            zenoh.open, zenoh_config(connect=[served.endpoint])
        )
        refused: list[tuple[str, str]] = []

        def attack() -> None:
            bad_queries = [
                ("oversized", b"\x01" * (MAX_PAYLOAD + 1), None),
                ("not a request", b"\x7f\x13\x37\x00", None),
                ("overlong attachment", p.ReadId().encode(), b"x" * (MAX_ATTACHMENT + 1)),
            ]
            for _ in range(30):
                for kind, payload, attachment in bad_queries:
                    for reply in hostile.get(
                        request_key(7), payload=payload, attachment=attachment, timeout=10.0
                    ):
                        outcome = "answered"
                        if reply.err is not None:
                            outcome = decode_fault(reply.err.payload.to_bytes()).error
                        refused.append((kind, outcome))

        try:
            async with (
                streamer.stream(analog=[A0], period_ms=1) as samples,
                anyio.create_task_group() as tg,
            ):
                received = 0

                async def consume() -> None:
                    nonlocal received
                    async for _ in samples:
                        received += 1

                tg.start_soon(consume)
                attacker = anyio.Event()

                async def run_attack() -> None:
                    await anyio.to_thread.run_sync(attack)
                    attacker.set()

                tg.start_soon(run_attack)
                level = False
                writes = 0
                while not attacker.is_set() or writes < 20:
                    level = not level
                    await led.write(level)
                    assert (await uno.pin("D6")).level == int(level)
                    writes += 1
                with pytest.raises(BoardError) as busy:  # still the holder's pin
                    await streamer.digital_input(D6)
                assert busy.value.code is p.ErrorCode.PIN_BUSY
                tg.cancel_scope.cancel()
        finally:
            await anyio.to_thread.run_sync(hostile.close)
        assert sorted(set(refused)) == [
            ("not a request", "ProtocolError"),
            ("overlong attachment", "ProtocolError"),
            ("oversized", "ProtocolError"),
        ]
        assert len(refused) == 90
        assert received > 0 and samples.gaps == 0 and samples.dropped == 0

"""End-to-end tests of the virtual Uno harness, driven through a real pseudo-terminal.

They use the harness's own test firmware (``firmware/sim/testfw``), so they check the
harness, not the project firmware.  Timings are printed (run with ``-s``) and only checked
against generous sanity bounds, because the machine is shared.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time

import anyio
import pytest

from arduinoio_async import protocol as proto
from arduinoio_async.sim import SimulatorError, SimulatorNotAvailable, VirtualUno
from arduinoio_async.sim.cli import main as cli_main
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import Link, poll_until, start_test_board, test_elf

pytestmark = pytest.mark.sim


async def _median_rtt(link: Link, n: int) -> float:
    for _ in range(5):
        await link.echo_rtt_us()
    return statistics.median([await link.echo_rtt_us() for _ in range(n)])


@pytest.mark.parametrize("baud", [115200, 1000000])
async def test_echo_round_trip(virtual_uno_factory: VirtualUnoFactory, baud: int) -> None:
    uno = await start_test_board(virtual_uno_factory, baud=baud, board_id=0x0102)
    link = await Link.open(uno)
    try:
        rtt = await _median_rtt(link, 100)
        print(f"\necho round trip at {baud} baud, no USB bridge model: median {rtt:.0f} us")
        assert rtt < 20000
        assert await link.eeprom(0) == 0x01 and await link.eeprom(1) == 0x02  # board ID in EEPROM
        cycles = await uno.firmware_cycles()
        assert cycles.last is not None and cycles.samples
    finally:
        await link.close()


async def test_16u2_model_delays_replies_in_ticks(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory, baud=1000000, usb_bridge="16u2")
    link = await Link.open(uno)
    try:
        rtts = [await link.echo_rtt_us() for _ in range(40)]
        med = statistics.median(rtts)
        print(
            f"\necho round trip at 1000000 baud with 16U2 model: median {med:.0f} us, "
            f"min {min(rtts):.0f}, max {max(rtts):.0f}"
        )
        # each reply waits for the next 4.096 ms tick (plus a 1 ms USB frame): 0..~5.1 ms
        assert 1000 < med < 20000
        assert max(rtts) > 3000
    finally:
        await link.close()


async def test_pacing_tracks_wall_clock(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory)
    a = await uno.status()
    await anyio.sleep(1.0)  # the wall-clock interval being measured, not a synchronisation
    b = await uno.status()
    dsim = b["sim_us"] - a["sim_us"]
    dwall = b["wall_us"] - a["wall_us"]
    print(f"\npacing: {dsim:.0f} us simulated in {dwall:.0f} us wall, lag {b['lag_us']:.1f} us")
    assert abs(dsim - dwall) < 5000
    assert abs(b["lag_us"]) < 5000


async def test_pacing_keeps_up_with_pipelined_project_firmware(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Back-to-back pipelined requests at 1 Mbaud: simulated time keeps up with the wall
    clock (no rebase) and reply bytes reach the pty in batched writes.

    Uses the project firmware: an unconnected D2/D3 is low, which used to keep simavr's
    INT0/INT1 low-level poll (a cycle timer firing every cycle) running for good.
    """
    uno = await virtual_uno_factory(baud=1000000, board_id=1)
    link = await Link.open(uno, timeout=2)
    try:
        await link.write(proto.GpioConfig(2, proto.GpioFlags.OUTPUT).encode())
        assert len(await link.read(5)) == 5
        req = proto.GpioWrite(2, True).encode()
        a = await uno.status()
        n, window = 3000, 12
        t0 = time.perf_counter()
        await link.write(req * window)
        sent, got = window, 0
        while got < n:
            r = await link.read(5 * max(1, min(window, n - got) // 2))
            assert r, f"timeout after {got} replies"
            k = len(r) // 5
            got += k
            if sent < n:
                m = min(k, n - sent)
                await link.write(req * m)
                sent += m
        elapsed = time.perf_counter() - t0
        b = await uno.status()
    finally:
        await link.close()
    writes = b["pty_writes"] - a["pty_writes"]
    nbytes = b["bytes_to_host"] - a["bytes_to_host"]
    print(
        f"\npipelined GPIO WRITE, window {window}: {n / elapsed:.0f} cmd/s, "
        f"lag {b['lag_us']:.0f} us, rebases {b['rebases'] - a['rebases']}, "
        f"{nbytes / max(writes, 1):.1f} bytes per pty write"
    )
    assert b["rebases"] == a["rebases"]
    assert abs(b["lag_us"]) < 5000
    assert nbytes == 5 * n
    assert writes < nbytes


async def test_loopback_fixture(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory, fixture="loopback")
    link = await Link.open(uno)
    try:
        await link.pin_mode(9, 3)  # D9 output high drives D8
        await link.pin_mode(8, 0)
        assert await link.digital_read(8) == 1
        assert (await uno.pin(8)).level == 1
        await link.pin_mode(9, 2)
        assert await link.digital_read(8) == 0
        await link.pin_mode(4, 2)  # D5 <- D4 low beats D5's pull-up
        await link.pin_mode(5, 1)
        assert await link.digital_read(5) == 0
        await link.pin_mode(12, 1)  # neither side drives: D12's pull-up holds the pair high
        await link.pin_mode(13, 0)
        assert await link.digital_read(13) == 1
        await link.pin_mode(12, 0)
        assert await link.digital_read(13) == 0
        with pytest.raises(SimulatorError):
            await uno.drive(3, 1)  # jumpered pins cannot be driven from outside
    finally:
        await link.close()


@pytest.mark.parametrize("tolerance", [0.0, 5.0])
async def test_r2r_fixture(virtual_uno_factory: VirtualUnoFactory, tolerance: float) -> None:
    uno = await start_test_board(virtual_uno_factory, fixture="r2r", r2r_tolerance=tolerance)
    link = await Link.open(uno)
    try:
        for b1 in (0, 1):
            for b0 in (0, 1):
                await link.pin_mode(4, 2 | b0)  # ladder 1: A1 <- D4 (B0), D5 (B1)
                await link.pin_mode(5, 2 | b1)
                ideal = (2 * b1 + b0) * 1023 / 4
                got = await link.adc(1)
                if tolerance == 0.0:
                    assert abs(got - ideal) <= 1, (b1, b0, got)
                else:
                    assert abs(got - ideal) <= 1023 * tolerance / 100 + 2, (b1, b0, got)
        await uno.set_analog(1, 1000)  # the ladder wins over a set voltage
        assert abs(await link.adc(1) - 3 * 1023 / 4) <= 1023 * tolerance / 100 + 2
        await uno.set_analog(0, 1000)  # ladder 0 with D2/D3 floating inputs outputs 0 V
        assert await link.adc(0) < 5
    finally:
        await link.close()


async def test_auto_reset_on_open(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory, reset_on_open=True, boot_delay_ms=300)

    async def booted() -> bool:
        status = await uno.status()
        return bool(status["state"] != "reset" and status["sim_us"] > 400_000)

    await poll_until(booted, "the first boot")
    before = await uno.status()
    link = await Link.open(uno)
    try:
        await link.write(b"lost")  # the "bootloader" swallows bytes
        assert await link.read(4, timeout=0.1) == b""
        held = await uno.status()
        assert held["state"] == "reset"

        async def released() -> bool:
            return bool((await uno.status())["state"] != "reset")

        await poll_until(released, "the end of the boot delay")
        assert await link.echo_rtt_us() > 0
        assert await link.uptime_ms() < 200  # fresh boot after the open
        after = await uno.status()
        assert after["resets"] > before["resets"] and after["opens"] == 1
    finally:
        await link.close()


async def test_no_reset_on_open_by_default(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory)

    async def ran_300_ms() -> bool:
        return bool((await uno.status())["sim_us"] >= 300_000)

    await poll_until(ran_300_ms, "300 ms of simulated time")
    link = await Link.open(uno)
    try:
        assert await link.uptime_ms() > 250
    finally:
        await link.close()


async def test_unplug_and_replug(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory, board_id=7)
    link = await Link.open(uno)
    old_port = uno.port
    try:
        await link.echo_rtt_us()
        await uno.unplug()
        with pytest.raises((anyio.BrokenResourceError, anyio.EndOfStream)):
            await link.write(b"x")
            await link.stream.receive()
        assert (await uno.status())["plugged"] is False
    finally:
        await link.close()
    new_port = await uno.replug()
    assert new_port == uno.port and new_port != old_port
    print(f"\nreplug: {old_port} -> {new_port}")
    link = await Link.open(uno)
    try:
        await link.wait_answering()  # bytes sent before the UART is enabled are lost
        await link.echo_rtt_us()
        assert await link.uptime_ms() < 300  # fresh boot
        assert await link.eeprom(1) == 7  # EEPROM survived the power cycle
    finally:
        await link.close()


async def test_faults_corrupt_at_roughly_the_rate(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory, baud=1000000, fault_drop=0.1, seed=42)
    link = await Link.open(uno, timeout=0.05)
    sent = received = 0
    try:
        payload = bytes(range(0x20, 0x20 + 50))
        for _ in range(20):
            await link.write(payload)
            sent += len(payload)
            received += len(await link.read(200))
        print(f"\ndrop 0.1: {received}/{sent} bytes arrived")
        assert 0.8 * sent < received < 0.97 * sent
        await uno.set_faults(drop=0.0, flip=0.2)
        flipped = 0
        for _ in range(10):
            await link.write(payload)
            got = await link.read(len(payload))
            assert len(got) == len(payload)
            flipped += sum(a != b for a, b in zip(got, payload, strict=True))
        print(f"flip 0.2: {flipped}/500 bytes corrupted")
        assert 50 < flipped < 150
        status = await uno.status()
        assert status["faults"]["dropped"] > 0 and status["faults"]["flipped"] == flipped
    finally:
        await link.close()


async def test_control_commands(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await start_test_board(virtual_uno_factory, baud=1000000, board_id=0xBEEF)
    link = await Link.open(uno)
    try:
        assert await uno.eeprom(0, 2) == b"\xbe\xef"
        await uno.set_analog(3, 2500)
        assert abs(await link.adc(3) - 511) <= 1
        await uno.set_temperature(85.0)
        assert abs(await link.adc(8) - round((314 + 60) * 1023 / 1100)) <= 1
        await uno.drive("D7", 1)
        assert await link.digital_read(7) == 1 and (await uno.pin("D7")).level == 1
        await uno.drive("D7", None)
        assert await link.digital_read(7) == 0
        await link.pin_mode(7, 1)
        assert await link.digital_read(7) == 1  # released pin with pull-up
        await uno.pulses(3, count=25, high_us=200, low_us=300)
        await uno.wait_pulses(timeout=5)
        count = int.from_bytes(await link.request(bytes([0x87, 3]), 2), "little")
        assert count == 25
        stats = await uno.pulse_stats(3)
        assert stats.count == 25
        assert all(abs(h - 200) < 1 for h in stats.high_us)
        assert all(abs(p - 500) < 1 for p in stats.period_us)
        await uno.clear_pulse_stats(3)
        assert (await uno.pulse_stats(3)).count == 0
        assert await link.request(bytes([0x86, 0]), 1) == b"\x86"  # servo pulses on D9/D10

        async def servo_pulses() -> bool:
            return len((await uno.pulse_stats("D9")).high_us) >= 3

        await poll_until(servo_pulses, "servo pulses on D9")
        servo = await uno.pulse_stats("D9")
        assert servo.high_us and abs(statistics.median(servo.high_us) - 1500) < 2
        assert abs(statistics.median(servo.period_us) - 20000) < 5
        reply = await link.request(bytes([0x85, 0x5A]), 1)  # I2C EEPROM write at 0x10
        assert (await uno.eeprom_i2c(0x10, 1)) == b"\x5a", reply
        cycles = await uno.firmware_cycles()
        assert cycles.last is not None
        print(f"\nfirmware cycles (last {len(cycles.samples)}): {cycles.samples[-5:]}")
        await link.request(bytes([0x88, 0]), 0)  # watchdog reset inside the firmware
        await link.wait_answering()
        assert (await link.request(bytes([0x8B, 0]), 1))[0] & 0x08  # WDRF
        assert await uno.eeprom(0, 2) == b"\xbe\xef"
        await uno.reset()
        await link.wait_answering()  # bytes sent before the rebooted firmware's UART is on are lost
        assert await link.uptime_ms() < 100
        with pytest.raises(SimulatorError):
            await uno.command("no_such_command")
        with pytest.raises(SimulatorError):
            await uno.pulses(9, 1, 1, 1)
        status = await uno.status()
        assert status["id"] == 0xBEEF and status["fixture"] == "open"
    finally:
        await link.close()


async def test_launcher_cleans_up() -> None:
    elf = test_elf(115200)
    from arduinoio_async.sim import start_virtual_unos

    async with start_virtual_unos([1, 2], elf=elf) as boards:
        pids = [b.pid for b in boards]
        paths = [b.control_path for b in boards]
        assert len({b.port for b in boards}) == 2
    for pid, path in zip(pids, paths, strict=True):
        assert pid is not None
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
        assert not await anyio.Path(path).exists()

    with anyio.move_on_after(0.5):  # cancelled while starting: nothing may leak
        async with VirtualUno(elf=elf) as uno:
            pid = uno.pid
            await anyio.sleep(10)
    assert pid is not None
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


async def test_missing_simulator_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ARDUINOIO_SIM_BIN", "/nonexistent/virtual-uno")
    with pytest.raises(SimulatorNotAvailable, match="make firmware sim"):
        await VirtualUno().start()


def test_cli_missing_simulator_exits_2(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("ARDUINOIO_SIM_BIN", "/nonexistent/virtual-uno")
    assert cli_main(["--id", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "apt-get install simavr" in err


def test_cli_runs_until_interrupted() -> None:
    elf = test_elf(115200)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from arduinoio_async.sim.cli import main; sys.exit(main(sys.argv[1:]))",
            "--id",
            "0x0001",
            "--id",
            "0x0002",
            "--elf",
            elf,
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        import json

        lines = [json.loads(proc.stdout.readline()) for _ in range(2)]
        assert [line["id"] for line in lines] == [1, 2]
        assert all(line["port"].startswith("/dev/pts/") for line in lines)
        proc.send_signal(2)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()

"""Every program in examples/ runs here against a virtual Uno, so no example can rot.

Each runs as a user runs it (``python examples/NAME.py --port P``) in a subprocess under a
deadline; where an example waits for the world (a button, an encoder, a replugged cable)
the test plays the world through the virtual Uno's circuit once the example says it is
ready, and checks what the example printed.
"""

from __future__ import annotations

import csv
import importlib.util
import os
import re
import subprocess
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
import anyio.abc
import pytest
from anyio.streams.text import TextReceiveStream

from arduinoio_async.sim import PulseStats, VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DEADLINE = 60.0
#: How late the harness may stamp a pin edge (firmware/sim/README.md, "Pulse capture"):
#: at the end of the instruction running when the timer moved the pin.
EDGE_STAMP_US = 4 / 16


class ExampleRun:
    """A running example: its output so far, line by line."""

    def __init__(self, process: anyio.abc.Process) -> None:
        self.process = process
        self.lines: list[str] = []
        self._pending = ""
        assert process.stdout is not None
        self._text = TextReceiveStream(process.stdout)

    async def wait_for(self, text: str) -> str:
        """The first line (seen or still to come) that contains ``text``."""
        seen = 0
        while True:
            for line in self.lines[seen:]:
                if text in line:
                    return line
            seen = len(self.lines)
            if not await self._read_more():
                raise AssertionError(f"the example ended without printing {text!r}:\n{self}")

    async def finish(self) -> str:
        while await self._read_more():
            pass
        assert await self.process.wait() == 0, f"the example failed:\n{self}"
        return str(self)

    async def _read_more(self) -> bool:
        try:
            chunk = await self._text.receive()
        except anyio.EndOfStream:
            return False
        *complete, self._pending = (self._pending + chunk).split("\n")
        self.lines += complete
        return True

    def __str__(self) -> str:
        return "\n".join([*self.lines, self._pending])


@asynccontextmanager
async def run_example(
    name: str, *args: str, env: dict[str, str] | None = None
) -> AsyncIterator[ExampleRun]:
    command = [sys.executable, str(EXAMPLES / f"{name}.py"), *args]
    with anyio.fail_after(DEADLINE):
        async with await anyio.open_process(
            command,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            env={**os.environ, **(env or {})},
        ) as process:
            try:
                yield ExampleRun(process)
            finally:
                if process.returncode is None:
                    process.kill()


async def captured_pulses(uno: VirtualUno, pin: int, count: int) -> PulseStats:
    """The fixture's capture of ``pin`` once it holds ``count`` fresh pulses (polled: the
    harness has no pulse notification; each poll is one control round trip)."""
    await uno.clear_pulse_stats(pin)
    with anyio.fail_after(5):
        while len((stats := await uno.pulse_stats(pin)).high_us) < count:  # noqa: ASYNC110
            await anyio.sleep(0.02)
    return stats


async def run_to_end(name: str, uno: VirtualUno, *args: str) -> str:
    async with run_example(name, "--port", uno.port, "--baud", str(uno.baud), *args) as run:
        return await run.finish()


async def test_blink(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(fixture="loopback")
    out = await run_to_end("blink", uno, "--times", "2")
    assert "D13 on  -> D12 reads True" in out and "D13 off -> D12 reads False" in out
    assert "blinked 2 times" in out


async def test_button_edges(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory()
    async with run_example("button_edges", "--port", uno.port, "--presses", "3") as run:
        await run.wait_for("ready")
        for n in range(1, 4):
            await uno.drive(3, 0)  # pressed: to ground
            assert "held" in await run.wait_for(f"press {n}")
            await uno.drive(3, 1)  # released: seen before the next press, or the two
            if n < 3:  # drives could land in one interrupt (the example stops at 3)
                await run.wait_for(f"release {n}")
        assert "3 presses counted" in await run.finish()


async def test_analog_volts(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory()
    await uno.set_analog(0, 1250.0)
    await uno.set_analog(5, 2500.0)
    out = await run_to_end("analog_volts", uno, "--samples", "1")
    assert "A0 1.25 V" in out and "A5 2.50 V" in out


async def test_servo_sweep(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory()
    out = await run_to_end("servo_sweep", uno, "--step", "45")
    assert "servo centred at 1500 us" in out
    stats = await captured_pulses(uno, 9, 2)
    assert all(abs(high - 1500) <= 1 for high in stats.high_us), stats


async def test_dc_motor(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory()
    out = await run_to_end("dc_motor", uno, "--cruise", "-0.25")
    assert "braked" in out and "motor at -0.25: D9 25.0 % at 20000 Hz" in out, out
    stats = await captured_pulses(uno, 9, 4)  # 50 us periods, 12.5 us high, 1/16 us counts
    # Each edge is stamped at the instruction boundary after it, up to EDGE_STAMP_US late
    # (firmware/sim/README.md, "Pulse capture"): 12.375 against 12.5 was seen in a run.
    assert all(abs(high - 12.5) <= EDGE_STAMP_US for high in stats.high_us), stats
    assert all(abs(period - 50) <= EDGE_STAMP_US for period in stats.period_us), stats
    assert (await uno.pin("D7")).level == 0 and (await uno.pin("D8")).level == 1  # reverse


async def test_six_soft_servos(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory()
    out = await run_to_end("six_soft_servos", uno)
    widths = {int(line[1]): int(line.split()[1]) for line in out.splitlines() if line[:1] == "D"}
    assert sorted(widths) == [2, 3, 4, 5, 6, 7]
    for pin, width in widths.items():
        stats = await captured_pulses(uno, pin, 2)
        assert all(abs(high - width) <= 100 for high in stats.high_us), (pin, stats)


async def test_wheel_encoder(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The oracle: the harness's quadrature generators (their positions in quarter steps)."""
    uno = await virtual_uno_factory()
    for pin in ("D2", "D3", "D4", "D5"):
        await uno.drive(pin, 0)  # where the generators start (AB = 00)
    async with run_example("wheel_encoder", "--port", uno.port, "--seconds", "1.5") as run:
        await run.wait_for("ready")
        await uno.quadrature("D2", "D3", edges=4_000, rate=8_000, reverse=0.001)
        await uno.quadrature("D4", "D5", edges=2_000, rate=4_000, direction=-1)
        truth = {g.a: g.position for g in await uno.wait_quadrature()}
        out = await run.finish()
        assert truth[4] == -2_000
        assert f"total counts: left {truth[2]}, right -2000" in out, out
        assert "invalid" not in out


async def test_spi_adc(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The oracle: the voltages set on the harness's MCP3008 model, within 1 LSB."""
    uno = await virtual_uno_factory(profile="sensing", baud=1_000_000)
    volts = [0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 4.9]
    await uno.spi_device(cs=10, volts=volts)
    out = await run_to_end("spi_adc", uno)
    for channel, v in enumerate(volts):
        line = next(x for x in out.splitlines() if x.startswith(f"CH{channel}:"))
        assert abs(float(line.split()[1]) - v) <= 5 / 1024 + 0.0005, line
    line = next(x for x in out.splitlines() if x.startswith("CH1 - CH0"))
    assert abs(float(line.split()[3]) - 0.25) <= 5 / 1024 + 0.0005, line
    assert (await uno.spi_device_status()).conversions == 9


async def test_i2c_registers(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory()
    out = await run_to_end("i2c_registers", uno)
    assert "read back b'hello'" in out and "no I2C device answered at that address" in out
    assert await uno.eeprom_i2c(0x10, 5) == b"hello"


async def test_stream_to_csv(virtual_uno_factory: VirtualUnoFactory, tmp_path: Path) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    for channel, mv in enumerate((1000.0, 2000.0, 3000.0, 4000.0)):
        await uno.set_analog(channel, mv)
    table = tmp_path / "stream.csv"
    out = await run_to_end("stream_to_csv", uno, "--seconds", "1", "--csv", str(table))
    assert "gaps 0, dropped 0" in out
    with table.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) > 500  # 1 kHz for 1 s, less start-up
    sequences = [int(row["sequence"]) for row in rows]
    assert sequences == list(range(sequences[0], sequences[0] + len(rows)))
    assert abs(int(rows[-1]["A2"]) - 614) <= 3  # 3 V of 5 V in 10 bits


async def test_failsafe_demo(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(fixture="loopback")
    out = await run_to_end("failsafe_demo", uno)
    assert "failsafe fired" in out and "the failsafe has tripped" in out
    assert "re-armed: D13 reads True, D9 at 1800 us" in out


async def test_two_board_robot_survives_a_replug(
    virtual_uno_factory: VirtualUnoFactory, tmp_path: Path
) -> None:
    """The robot's ports are symlinks (as udev names would be); a replug gives the
    actuator board a new pty, and the link is moved as udev would move it."""
    unos = [await virtual_uno_factory(board_id=1), await virtual_uno_factory(board_id=2)]
    links = [tmp_path / "actuators", tmp_path / "sensors"]
    for link, uno in zip(links, unos, strict=True):
        link.symlink_to(uno.port)
    env = {"ARDUINOIO_PORTS": str(tmp_path / "*")}
    async with run_example("two_board_robot", "--seconds", "8", env=env) as run:
        await run.wait_for("ready")
        await unos[0].unplug()
        await run.wait_for("board 0x0001: disconnected")
        links[0].unlink()
        links[0].symlink_to(await unos[0].replug())
        await run.wait_for("board 0x0001: connected")
        out = await run.finish()
    summary = next(line for line in out.splitlines() if "control cycles" in line).split()
    cycles, waits = int(summary[0]), int(summary[3])
    assert cycles > 10 and waits >= 1, out


def test_fastapi_app(virtual_uno_factory_sync: list[VirtualUno]) -> None:
    fastapi = pytest.importorskip("fastapi.testclient")
    uno = virtual_uno_factory_sync[0]
    # Loaded from its file (examples/ is not a package; nothing edits sys.path).
    spec = importlib.util.spec_from_file_location("fastapi_app", EXAMPLES / "fastapi_app.py")
    assert spec is not None and spec.loader is not None
    fastapi_app = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fastapi_app)
    with fastapi.TestClient(fastapi_app.app) as client:
        assert client.get("/boards").json() == {"0x0005": uno.port}
        assert client.put("/boards/5/gpio/D4", params={"level": True}).json() == {"level": True}
        assert client.get("/boards/5/gpio/D5").json()["level"] is True  # D4-D5 jumper
        assert client.get("/boards/6/gpio/D5").status_code == 404
        assert client.get("/boards/5/gpio/D1").status_code == 422  # not a GPIO pin
        assert client.get("/boards/5/gpio/X9").status_code == 422
        assert 0.0 <= client.get("/boards/5/analog/A0").json()["volts"] <= 5.0


async def test_notebook_blocking(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(fixture="loopback")
    async with run_example("notebook_blocking", "--port", uno.port) as run:
        out = await run.finish()
    assert "D3 (jumpered to D2) reads PinState(level=True" in out
    assert "five samples of A0" in out and out.rstrip().endswith("closed")


async def test_design_card_starts_its_own_virtual_uno() -> None:
    async with run_example("design_card") as run:
        out = await run.finish()
    assert "D2 high; D3 (jumpered to D2 on the test circuit) reads" in out


async def test_stepper_homing(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The fixture logs the step pulses, closes the switch on D4 at the 800th step and
    opens it again 50 steps into the move away from it."""
    uno = await virtual_uno_factory()
    await uno.command("step_log", pin="D2", enable=True)
    await uno.command("limit_at", pin="D2", after=800, drive="D4", level=0)
    await uno.command("limit_at", pin="D2", after=850, drive="D4", level=1)
    out = await run_to_end("stepper_homing", uno, "--to", "2000", "500")
    assert "homed after 800 steps: position 0" in out and "at 2000" in out and "at 500" in out
    steps = await uno.command("steps", pin="D2", **{"from": 1 << 30})
    assert steps["count"] == 800 + 2000 + 1500, steps


async def test_imu_stream(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The oracle: the harness's MPU-6050 model (its served reads and its z axis, 1 g)."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing", fixture="open")
    first = (await uno.command("imu"))["logged"]
    out = await run_to_end("imu_stream", uno, "--seconds", "0.5")
    assert "samples: ok 500, failed reads 0 (board counted 0), gaps 0" in out, out
    assert (await uno.command("imu"))["logged"] - first >= 501  # one-shot + 500 periods
    assert out.count("+9.81 m/s^2") >= 2  # z is 1 g in every printed reading


async def test_rc_receiver(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The oracle: the harness's RC sources (the widths they drive)."""
    uno = await virtual_uno_factory(profile="sensing")
    async with run_example("rc_receiver", "--port", uno.port, "--seconds", "1.5") as run:
        await run.wait_for("ready")
        await uno.rcpulse("D4", width_us=1750)
        await uno.rcpulse("D7", width_us=1250)
        out = await run.finish()
    # the board's widths are good to the pin-change path's accuracy (docs/sensors.md:
    # 12 us, 0.024 of steering's half range and 0.012 of the throttle's range)
    shown = re.findall(r"steering ([+-]\d\.\d\d)   throttle (\d\.\d\d)", out)
    assert shown, out
    steer, throttle = (float(v) for v in shown[-1])
    assert abs(steer - 0.50) <= 0.03 and abs(throttle - 0.25) <= 0.02, out
    truth = {s.pin: s for s in await uno.rcpulse_status()}
    # the source's edges land on instruction boundaries: within a 5-cycle instruction
    assert abs(truth[4].last_width_us - 1750) <= 5 / 16
    last = re.search(r"last steering pulse: (\d+) us", out)
    assert last is not None, out
    assert abs(int(last[1]) - 1750) <= 12, out  # the documented accuracy


async def test_sonar(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The oracle: the harness's sonar models (the distances they are set to, the echo
    widths they drove, no overlap between the two sonars)."""
    uno = await virtual_uno_factory(profile="sensing")
    await uno.sonar("D7", "D8", distance_mm=0)
    await uno.sonar("D4", "D5", distance_mm=0)
    async with run_example("sonar", "--port", uno.port, "--seconds", "1.5") as run:
        await run.wait_for("ready")
        await uno.sonar("D7", distance_mm=1500)
        await uno.sonar("D4", distance_mm=250)
        out = await run.finish()
    last = re.fullmatch(r"front +(\d+) mm   rear +(\d+) mm", out.strip().splitlines()[-1])
    assert last is not None, out
    front, rear = int(last[1]), int(last[2])
    # 20 C: the board uses 343.2 m/s, the model 343.0: 0.06 % apart
    assert abs(front - 1500) <= 15 and abs(rear - 250) <= 3, out
    status = await uno.sonar_status()
    assert status.overlaps == 0
    assert status.on(7).echoes >= 2 and status.on(4).echoes >= 2


async def test_paper_robot(virtual_uno_factory: VirtualUnoFactory) -> None:
    """Both boards of the paper's robot, each a virtual Uno; the oracles are the harness's
    models: the quadrature generators' positions, the sonar's distance, the MPU-6050's
    1 g on z, the servo widths the actuator board's timer drove (steering from the
    wheels, ESC from the sonar), and those widths at 1,500 us once the host stops."""
    actuators = await virtual_uno_factory(board_id=1)
    sensors = await virtual_uno_factory(board_id=2, profile="sensing", fixture="open")
    for pin in ("D2", "D3", "D4", "D5"):
        await sensors.drive(pin, 0)  # where the generators start (AB = 00)
    await sensors.sonar("D7", "D8", distance_mm=1000)
    ports = ("--port", actuators.port, "--port", sensors.port)
    async with run_example("paper_robot", *ports, "--seconds", "3") as run:
        await run.wait_for("ready")
        await sensors.quadrature("D2", "D3", edges=600, rate=3_000)
        await sensors.quadrature("D4", "D5", edges=400, rate=2_000)
        truth = {g.a: g.position for g in await sensors.wait_quadrature()}
        assert truth == {2: 600, 4: 400}
        # steering 1500 + (600 - 400); ESC 1500 + 300 * (1000 - 300) / 1000
        for servo, width in ((9, 1700), (10, 1710)):
            with anyio.fail_after(5):  # until the loop has seen the generators' last edges
                while True:
                    highs = (await captured_pulses(actuators, servo, 3)).high_us
                    if all(abs(h - width) <= 1 for h in highs):
                        break
        out = await run.finish()
    last = next(line for line in out.splitlines() if line.startswith("last: "))
    assert "encoders left 600 right 400" in last, out
    distance = int(last.split("sonar ")[1].split()[0])
    assert abs(distance - 1000) <= 10, out
    assert "accel z +9.81 m/s^2" in last and "steering 1700 us  ESC 1710 us" in last, out
    assert "failsafe tripped" in out, out
    for servo in (9, 10):
        stats = await captured_pulses(actuators, servo, 3)
        assert all(abs(h - 1500) <= 1 for h in stats.high_us), (servo, stats)
    assert (await sensors.sonar_status()).on(7).echoes >= 10

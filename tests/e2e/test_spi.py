"""The SPI bridge on the virtual Uno, against the harness's MCP3008 (firmware/sim/spi_device.c).

Every oracle is the device model's: the voltages the test set on its channels, the bytes
it saw under each chip select, its chip-select edges and the SPI unit's settings at each
byte; never the library's own answer.
"""

from __future__ import annotations

import io
import itertools

import anyio
import anyio.to_thread
import pytest
from rich.console import Console

from arduinoio_async import A0, A1, A2, A3, D4, D9, D10, D11, D12, D13, blocking
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.cli import main as cli_main
from arduinoio_async.devices import MCP3008
from arduinoio_async.errors import (
    FirmwareFeatureError,
    PinCapabilityError,
    PinRoleError,
    ValueRangeError,
)
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

VOLTS = [0.0, 0.6, 1.25, 2.0, 2.5, 3.3, 4.2, 4.995]
LSB = 5.0 / 1024


def rev(data: bytes) -> bytes:
    """Each byte's bits in reverse order."""
    return bytes(int(f"{b:08b}"[::-1], 2) for b in data)


async def sensing(factory: VirtualUnoFactory, cs: int = 10) -> VirtualUno:
    uno = await factory(profile="sensing", baud=1_000_000)
    await uno.spi_device(cs=cs, volts=VOLTS)
    return uno


async def test_mcp3008_reads_every_channel(virtual_uno_factory: VirtualUnoFactory) -> None:
    """Single-ended reads equal the model's voltages within 1 LSB on all 8 channels, and
    differential pairs read IN+ - IN- (0 when negative)."""
    uno = await sensing(virtual_uno_factory)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        adc = await MCP3008.open(board, cs=D10)
        for channel, volts in enumerate(VOLTS):
            assert abs(await adc.read_channel(channel) - volts) <= LSB, channel
        await uno.spi_device(volts={5: 1.0})
        assert abs(await adc.read_channel(5) - 1.0) <= LSB
        # CH3 - CH2 = 0.75 V; CH2 - CH3 is negative: 0
        assert abs(await adc.read_channel(3, differential=True) - 0.75) <= LSB
        assert await adc.read_code(2, differential=True) == 0
        truth = await uno.spi_device_status()
        assert truth.conversions == 11
        assert (truth.cpol, truth.cpha, truth.lsb_first, truth.clock_hz) == (0, 0, 0, 1_000_000)


async def test_transfer_echoes_the_model_and_cs_frames_it(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """A multi-byte transfer returns exactly what the device sent (its own record), and the
    chip select falls once before and rises once after each transfer."""
    uno = await sensing(virtual_uno_factory, cs=4)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        bus = await board.spi(cs=D4, mode=3, clock_hz=4_000_000)
        start = await uno.spi_device_status()
        assert (start.cs_falls, start.cs_rises, start.cs_low) == (0, 0, False)
        sent = [bytes((0x01, 0xA0, 0x00, 0x00, 0xFF)), bytes(range(1, 33)), b"\x01\x90\x00"]
        got = [await bus.transfer(data) for data in sent]
        truth = await uno.spi_device_status()
        assert truth.cs_falls == truth.cs_rises == len(sent)
        assert not truth.cs_low and truth.bytes_outside_cs == 0
        assert [f.mosi for f in truth.frames] == sent
        assert [f.miso for f in truth.frames] == got
        assert truth.mode == 3 and truth.clock_hz == 4_000_000
        # the MCP3008 answer inside the 5-byte frame: CH2 (single) after the start bit
        code = (got[0][1] & 3) << 8 | got[0][2]
        assert abs(code * 5.0 / 1024 - VOLTS[2]) <= LSB


async def test_lsb_first_and_every_clock(virtual_uno_factory: VirtualUnoFactory) -> None:
    """Every clock the divider gives and every mode reach the SPI unit (the model reads
    SPCR/SPSR at each byte); LSB-first bytes reach the device bit-reversed."""
    uno = await sensing(virtual_uno_factory)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        for mode, clock in zip((0, 1, 2, 3, 0, 1, 2), p.SpiClock, strict=True):
            bus = await board.spi(cs=D10, mode=mode, clock_hz=clock.hz)
            await bus.transfer(b"\x00")
            truth = await uno.spi_device_status()
            assert (truth.mode, truth.clock_hz, truth.lsb_first) == (mode, clock.hz, 0)
            await bus.release()
        bus = await board.spi(cs=D10, clock_hz=125_000, bit_order="lsb")
        # the conversion of CH6 with each byte's bits reversed on the wire
        request = MCP3008.request_bytes(6)
        reply = rev(await bus.transfer(rev(request)))
        truth = await uno.spi_device_status()
        assert truth.lsb_first == 1 and truth.frames[-1].mosi == rev(request)
        code = (reply[1] & 3) << 8 | reply[2]
        assert abs(code * 5.0 / 1024 - VOLTS[6]) <= LSB


async def test_settings_and_pins_refused(virtual_uno_factory: VirtualUnoFactory) -> None:
    """Bad settings are refused before anything is sent; the SPI pins refuse other roles
    while SPI holds them (naming SPI), and SPI is refused while one of them is taken."""
    uno = await sensing(virtual_uno_factory)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with pytest.raises(ValueRangeError, match="SPI clock"):
            await board.spi(cs=D10, clock_hz=3_000_000)
        with pytest.raises(ValueRangeError, match="SPI mode"):
            await board.spi(cs=D10, mode=4)
        with pytest.raises(PinCapabilityError):
            await board.spi(cs=D11)  # type: ignore[arg-type]
        out = await board.digital_output(D13)
        with pytest.raises(PinRoleError, match="D13 is in use as digital output"):
            await board.spi(cs=D10)
        await out.release()
        servo = await board.servo(D10)
        with pytest.raises(PinRoleError, match="D10 is in use as servo PWM"):
            await board.spi(cs=D10)
        await servo.release()
        bus = await board.spi(cs=D10)
        for pin in (D10, D11, D12, D13):
            with pytest.raises(PinRoleError, match=f"{pin.name} is in use as SPI"):
                await board.digital_input(pin)
        with pytest.raises(PinRoleError, match="D10 is in use as SPI"):
            await board.servo(D10)
        await board.release(D12)  # any of the four ends the bus
        assert bus.released and not board.roles
        assert await board.digital_output(D11)
        with pytest.raises(Exception, match="released"):
            await bus.transfer(b"\x00")


async def test_image_without_spi_is_refused_before_sending(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="standard", baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with pytest.raises(FirmwareFeatureError, match="sensing"):
            await board.spi(cs=D10)


async def test_bridge_works_while_a_1khz_stream_runs(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """MCP3008 reads stay exact while the board streams 4 analog channels at 1 kHz, and the
    stream loses no sample (the board tick on Timer2 is untouched by MOSI on D11/OC2A)."""
    uno = await sensing(virtual_uno_factory)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        adc = await MCP3008.open(board, cs=D10, clock_hz=125_000)
        async with board.stream(analog=[A0, A1, A2, A3], period_ms=1) as stream:
            samples = 0
            reads = 0
            times: list[int] = []
            async with anyio.create_task_group() as tg:

                async def consume() -> None:
                    nonlocal samples
                    async for sample in stream:
                        times.append(sample.board_time_us)
                        samples += 1
                        if samples >= 500:
                            return

                tg.start_soon(consume)
                while samples < 500:
                    channel = reads % 8
                    assert abs(await adc.read_channel(channel) - VOLTS[channel]) <= LSB
                    reads += 1
            assert stream.gaps == 0 and stream.dropped == 0
        # the board's clock (Timer2's tick) keeps time while MOSI toggles D11 (OC2A): the
        # samples' board times step by the period (the harness runs the AVR exactly)
        steps = [(b - a) & 0xFFFFFFFF for a, b in itertools.pairwise(times)]
        assert all(abs(step - 1000) <= 50 for step in steps), sorted(steps)[:: len(steps) // 8]
        assert reads >= 20
        truth = await uno.spi_device_status()
        assert truth.conversions == reads and truth.cs_falls == reads


async def test_d9_servo_and_spi_together(virtual_uno_factory: VirtualUnoFactory) -> None:
    """A servo on D9 (Timer1) and SPI with D10 as chip select coexist."""
    uno = await sensing(virtual_uno_factory)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await board.servo(D9)
        adc = await MCP3008.open(board, cs=D10)
        assert abs(await adc.read_channel(4) - VOLTS[4]) <= LSB


async def test_cli_and_blocking_api(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    """``arduinoio spi --cs D10 transfer 01 80 00`` prints what the model answered (its own
    record) and frees the pins; the blocking twin reads a channel; bad hex is one line."""
    uno = await sensing(virtual_uno_factory)
    buffer = io.StringIO()
    target = ["--port", uno.port, "--baud", str(uno.baud)]
    argv = ["spi", "--cs", "D10", *target, "transfer", "01", "B0", "00"]
    code = await anyio.to_thread.run_sync(
        lambda: cli_main(argv, console=Console(file=buffer, width=200))
    )
    out = buffer.getvalue()
    assert code == 0, out
    truth = await uno.spi_device_status()
    assert truth.cs_falls == truth.cs_rises == 1
    assert f"received {truth.frames[-1].miso.hex(' ')}" in out

    bad = io.StringIO()
    argv = ["spi", *target, "transfer", "zz"]
    code = await anyio.to_thread.run_sync(lambda: cli_main(argv, console=Console(file=bad)))
    error = bad.getvalue() + capsys.readouterr().err
    assert code != 0 and "not hex bytes" in error and "Traceback" not in error

    def script() -> bytes:
        with blocking.open_board(uno.port, baudrate=uno.baud) as board:
            bus = board.spi(D10)  # the CLI released the pins
            reply = bus.transfer(MCP3008.request_bytes(5))
            bus.release()
            return reply

    reply = await anyio.to_thread.run_sync(script)
    assert abs(((reply[1] & 3) << 8 | reply[2]) * 5.0 / 1024 - VOLTS[5]) <= LSB

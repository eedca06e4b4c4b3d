"""The Arduino Mega 2560 image on the virtual Mega (issue 29, first stage).

The firmware is built from the same sources for the ATmega2560 (`make -C firmware mega`,
BOARD wiring in firmware/src/hal_board_mega2560.h) and runs on simavr's ATmega2560 core
(`virtual-uno --board mega2560`).  Oracles: the ID the harness wrote into the EEPROM, the
library's MEGA2560 model data for the description, the board's own refusals.  The Mega
fixture reaches D0-D15 so far (firmware/sim/board_map.c: jumpers D2-D3 ... D14-D15);
D16-D53 and R2R on A0-A15 are not built yet (notes/w4-mega.md).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import anyio
import pytest
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async import D2, D3, D11, D12
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.mega import Mega2560Board
from arduinoio_async.errors import BoardError, PinCapabilityError
from arduinoio_async.manager import BoardManager
from arduinoio_async.protocol.boards import MEGA2560, WIRE_FUNCTIONS
from arduinoio_async.protocol.pins import AnalogPin, DigitalPin
from arduinoio_async.sim import SimulatorNotAvailable, VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.transport._serial import open_serial_stream

from ..vectors.test_vectors import BAUD, VECTORS, RawLink, run_vectors, wait_answering
from ..vectors.vectors import VectorFile
from .pulses import fresh_pulses
from .test_paper_verification import check_jumpers

pytestmark = pytest.mark.sim

REPO = Path(__file__).resolve().parents[2]
BUILD = REPO / "firmware" / "build"


def mega_elf(baud: int) -> Path:
    path = BUILD / f"arduinoio-mega2560-{baud}.elf"
    if not path.is_file():
        pytest.skip(f"{path.name} not built (make -C firmware mega)")
    return path


async def test_the_mega_image_boots_and_describes_the_mega(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    mega = await virtual_uno_factory(
        board="mega2560", elf=mega_elf(115200), baud=115200, board_id=0x2560
    )
    async with Board.open(mega.port, baudrate=mega.baud) as board:
        assert await board.read_id() == 0x2560  # the harness's EEPROM, through USART0
        assert board.model.model_id == p.BoardModelId.MEGA2560
        assert (board.model.digital_pins, board.model.analog_pins) == (54, 16)
        assert board.model.functions == {f: MEGA2560.pin_numbers(f) for f in WIRE_FUNCTIONS}
        # the ATmega2560 has no temperature sensor: neither offered nor answered
        assert not board.capabilities.features & p.Feature.TEMPERATURE
        with pytest.raises(BoardError) as refused:
            await board.request(p.ReadTemperature())
        assert refused.value.code == p.ErrorCode.NOT_IN_IMAGE


# The first stage's pins: D2-D15 (hal_board_mega2560.h), jumpered in pairs.
MEGA_EVEN = [DigitalPin(n) for n in range(2, 16, 2)]
MEGA_ODD = [DigitalPin(n) for n in range(3, 16, 2)]


async def test_every_output_drives_the_port_bit_the_arduino_core_names(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Ground truth from the harness: D4 is PG5, D6 PH3, D14 PJ1 ... (board_map.c)."""
    mega = await virtual_uno_factory(
        board="mega2560", elf=mega_elf(1_000_000), baud=1_000_000, fast=True
    )
    async with Board.open(mega.port, baudrate=mega.baud) as board:
        for pin in [*MEGA_EVEN, *MEGA_ODD]:
            for level in (True, False):
                await board.gpio(pin).write(level)
                seen = await mega.pin(int(pin))
                assert (seen.ddr, seen.port, seen.level) == (1, int(level), int(level)), pin


async def test_mega_jumpers_carry_1000_random_patterns_both_ways(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    mega = await virtual_uno_factory(
        board="mega2560",
        elf=mega_elf(1_000_000),
        baud=1_000_000,
        fixture="loopback",
        fast=True,
    )
    async with Board.open(mega.port, baudrate=mega.baud, timeout=2.0) as board:
        await check_jumpers(board, MEGA_EVEN, MEGA_ODD)
        await check_jumpers(board, MEGA_ODD, MEGA_EVEN)


async def test_mega_servo_pulses_on_timer1_are_measured_by_the_fixture(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """OC1A/OC1B are D11/D12 on the Mega (D9/D10 on the Uno): the harness captures them."""
    mega = await virtual_uno_factory(board="mega2560", elf=mega_elf(1_000_000), baud=1_000_000)
    async with Mega2560Board.open(mega.port, baudrate=mega.baud) as board:
        servo = await board.servo(D11, pulse_us=1500)
        await board.servo(D12, pulse_us=1000)
        d11, d12 = [await fresh_pulses(mega, pin, 3) for pin in ("D11", "D12")]
        assert all(abs(h - 1500) <= 1 for h in d11.high_us), d11
        assert all(abs(t - 20000) <= 20 for t in d11.period_us), d11
        assert all(abs(h - 1000) <= 1 for h in d12.high_us), d12
        await servo.set_pulse(1234)
        d11 = await fresh_pulses(mega, "D11", 2)
        assert all(abs(h - 1234) <= 1 for h in d11.high_us[1:]), d11


async def test_mega_counters_on_int4_int5_count_generated_pulses_exactly(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    mega = await virtual_uno_factory(board="mega2560", elf=mega_elf(1_000_000), baud=1_000_000)
    async with Mega2560Board.open(mega.port, baudrate=mega.baud) as board:
        rising = await board.counter(D2, edge=p.Edge.RISING)
        falling = await board.counter(D3, edge=p.Edge.FALLING)
        await mega.pulses("D2", count=37, high_us=200, low_us=300)
        await mega.pulses("D3", count=23, high_us=100, low_us=100)
        await mega.wait_pulses()
        assert await rising.read() == 37
        assert await falling.read() == 23


async def test_mega_reads_all_16_analog_inputs_at_the_fixture_voltage(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """A0-A15, A8-A15 through the ADC's MUX5: each input its own voltage, read back."""
    mega = await virtual_uno_factory(
        board="mega2560", elf=mega_elf(1_000_000), baud=1_000_000, fast=True
    )
    volts = [150 + 300 * ch for ch in range(16)]  # all different, so a wrong mux shows
    for ch, mv in enumerate(volts):
        await mega.set_analog(ch, mv)
    async with Mega2560Board.open(mega.port, baudrate=mega.baud) as board:
        for ch, mv in enumerate(volts):
            value = await board.analog(AnalogPin(ch)).read()
            assert abs(value - mv * 1024 / 5000) <= 2, (ch, value, mv)


async def test_mega_i2c_eeprom_write_and_read_back(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The TWI unit (D20/D21 on the Mega) against the fixture's 24C02 at 0x50."""
    mega = await virtual_uno_factory(board="mega2560", elf=mega_elf(1_000_000), baud=1_000_000)
    async with Mega2560Board.open(mega.port, baudrate=mega.baud) as board:
        bus = await board.i2c(p.I2CSpeed.KHZ_400)
        data = bytes(range(0x40, 0x50))
        await bus.write(0x50, 0x20, data[:8])
        await bus.write(0x50, 0x28, data[8:])
        assert await bus.read(0x50, 0x20, 16) == data
        assert await mega.eeprom_i2c(0x20, 16) == data  # the device's own memory
        with pytest.raises(BoardError) as info:
            await bus.read(0x51, 0, 1)
        assert info.value.code is p.ErrorCode.I2C_NACK_ADDRESS


# The shared vectors whose requests and answers do not depend on the board's pin table
# or feature set.  The others (analog, duty, encoder, failsafe, framing, gpio, misc, pwm,
# spi, stream) state the Uno's Table III answers (D9 servo, D14 not a pin, A7 refused, the
# Uno's features) and need Mega variants: notes/w4-mega.md.
BOARD_INDEPENDENT_VECTORS = ("counter", "i2c", "i2c_stream", "stepper", "transaction")


@pytest.mark.parametrize(
    "vf",
    [vf for vf in VECTORS if vf.name in BOARD_INDEPENDENT_VECTORS],
    ids=lambda vf: vf.name,
)
async def test_the_board_independent_vectors_on_the_mega_image(
    vf: VectorFile, virtual_uno_factory: VirtualUnoFactory
) -> None:
    mega = await virtual_uno_factory(
        board="mega2560", elf=mega_elf(BAUD), baud=BAUD, board_id=vf.board_id
    )
    stream = await open_serial_stream(mega.port, BAUD)
    try:
        link = RawLink(stream)
        await wait_answering(link)

        async def drive(pin: int, level: bool) -> None:
            await mega.drive(pin, level)
            start = (await mega.status())["sim_us"]
            with anyio.fail_after(5):
                while (await mega.status())["sim_us"] < start + 50:
                    await anyio.lowlevel.checkpoint()

        await run_vectors(vf, link, drive)
    finally:
        await stream.aclose()


async def test_an_uno_and_a_mega_under_one_manager_by_id(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Each board is found by its ID and described as its own model; each drives its own
    pins (ground truth: each harness's port bit)."""
    uno = await virtual_uno_factory(board_id=7, baud=1_000_000)
    mega = await virtual_uno_factory(
        board="mega2560", elf=mega_elf(1_000_000), baud=1_000_000, board_id=8
    )
    async with BoardManager(ports=[uno.port, mega.port], usb=False, env=False) as boards:
        with anyio.fail_after(10):
            uno_board, mega_board = await boards.get(7), await boards.get(8)
        assert uno_board.model.model_id == p.BoardModelId.UNO_R3
        assert mega_board.model.model_id == p.BoardModelId.MEGA2560
        await mega_board.gpio(DigitalPin(14)).write(True)  # D14: a Mega pin only
        await uno_board.gpio(DigitalPin(13)).write(True)
        assert (await mega.pin(14)).level == 1
        assert (await uno.pin(13)).level == 1
        with pytest.raises(PinCapabilityError):
            await uno_board.gpio(DigitalPin(14)).write(True)  # refused before sending


async def test_arduinoio_sim_board_mega2560_runs_the_mega_image_info_sees_it(
    tmp_path: Path, virtual_uno_factory: VirtualUnoFactory
) -> None:
    """`arduinoio sim --board mega2560` finds the Mega image itself; `arduinoio info`
    finds the board and prints the Mega model it described."""
    mega_elf(1_000_000)  # skips when the image is not built
    await virtual_uno_factory()  # skips here when the simulator is missing
    env = {k: v for k, v in os.environ.items() if k != "ARDUINOIO_PORTS"}
    env["ARDUINOIO_REGISTRY_DIR"] = str(tmp_path / "registry")
    command = [sys.executable, "-m", "arduinoio_async"]
    sim = await anyio.open_process(
        [*command, "sim", "--board", "mega2560", "--id", "0x2560"], env=env
    )
    try:
        assert sim.stdout is not None
        with anyio.fail_after(20):
            line = await BufferedByteReceiveStream(sim.stdout).receive_until(b"\n", 4096)
        port = json.loads(line)["port"]
        found = await anyio.run_process([*command, "info", "--json"], env=env, check=False)
        assert found.returncode == 0, found.stderr.decode()
        info = json.loads(found.stdout)
        assert info["id"] == 0x2560 and info["port"] == port
        assert info["model"]["key"] == MEGA2560.key
    finally:
        sim.terminate()
        with anyio.fail_after(10):
            await sim.wait()
    assert sim.returncode == 0


async def test_an_unknown_board_or_a_profile_on_the_mega_is_refused_at_once() -> None:
    with pytest.raises(ValueError, match="uno or mega2560"):
        VirtualUno(board="leonardo")
    with pytest.raises(SimulatorNotAvailable, match="no profile 'sensing'"):
        VirtualUno(board="mega2560", profile="sensing").command_line()


STK500V2_HEX = REPO / "firmware/bootloader/build/stk500v2-mega2560.hex"
BOOT_SECTION = 0x3E000  # the stk500v2 bootloader's 8 KiB at the top of the flash


def in_application(status: dict[str, Any], resets_before: int) -> bool:
    """The core was reset since ``resets_before`` and runs below the boot section."""
    return int(status["resets"]) > resets_before and int(status["pc"]) < BOOT_SECTION


async def test_arduinoio_flash_board_mega2560_writes_through_the_stk500v2_bootloader(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """A virtual Mega with only Arduino's stk500v2 bootloader (built from arduino-core-avr's
    source, `make bootloader`); `arduinoio flash --board mega2560` writes and verifies the
    Mega image through it (avrdude -c wiring), and after the next reset the application
    answers (ground truth: the core left the boot section, then a raw ID request)."""
    if not STK500V2_HEX.is_file():
        pytest.skip(f"{STK500V2_HEX} missing (make bootloader)")
    mega_elf(115200)
    mega = await virtual_uno_factory(board="mega2560", bootloader=STK500V2_HEX, baud=115200)
    assert await mega.eeprom(0, 2) == b"\xff\xff"  # a new board: nothing but the bootloader
    result = await anyio.run_process(
        [
            *(sys.executable, "-m", "arduinoio_async", "flash", "--board", "mega2560"),
            *("--port", mega.port, "--firmware-baud", "115200"),
        ],
        check=False,
    )
    err = result.stderr.decode()
    assert result.returncode == 0, err
    assert "arduinoio-mega2560-115200.hex" in result.stdout.decode() and "verified" in (
        result.stdout.decode()
    )
    resets = (await mega.status())["resets"]
    stream = await open_serial_stream(mega.port, 115200)  # DTR: a reset into the bootloader
    try:
        with anyio.fail_after(15):  # the reset, its wait for a programmer, the jump to 0
            while not in_application(await mega.status(), resets):  # noqa: ASYNC110
                await anyio.sleep(0.05)  # polls the harness (simulated time)
        link = RawLink(stream)
        reply = p.Decoder.from_board().feed(await link.exchange(p.ReadId().encode()))
        assert isinstance(reply[0], p.ReadIdReply)
    finally:
        await stream.aclose()

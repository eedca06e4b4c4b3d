"""The Firmata side of the peer benchmark: one client, one test, on one port.

Runs in the peers' own virtual environment (``.venv-peers``, from
``benchmarks/peers/requirements.txt``), so the project never depends on the peers; the
raw-pyserial client needs only pyserial and also runs in the project's environment.
``peer_bench.py`` starts the virtual Unos (StandardFirmata 2.4 at 57600 baud, loopback
fixture: D2 jumpered to D3) and calls this script once per (client, test, round):

    python firmata_clients.py --client pymata4 --test a --port /dev/pts/7 --n 50

It prints one line ``RESULT {json}`` (the libraries print banners on stdout).  Every
client is used the way its documentation shows; where a library waits for a board reset
on open, that wait is skipped except in test (e), which measures it.

Tests (the issue's letters):
  a  D2 written, then the time until the client learns D3's new level from Firmata's
     digital port report (pushed by the board, not requested)
  b  one request/response: PIN_STATE_QUERY for D2 (Firmata has no "read" request; this
     is its smallest query with an answer)
  c  A0-A3 reported at the shortest sampling interval the client can ask for (1 ms):
     samples per channel counted for ``--seconds``
  d  D2 toggled ``--n`` times as fast as the client writes; then one query, so every
     write has been processed when the client reports (the harness counts the edges).
     Firmata writes are not acknowledged: the writes queue in the pty and the harness
     (back-pressure) and reach the pin at the link's rate.  ``--n`` is kept within what
     the pty buffers, because pymata-express gives up after a 1 s blocked write
  e  open the port (the board resets on open) until the first command is done
"""

from __future__ import annotations

import argparse
import asyncio
import importlib
import json
import random
import threading
import time
from collections.abc import Callable
from typing import Any

import serial

BAUD = 57600
START_SYSEX, END_SYSEX = 0xF0, 0xF7
DIGITAL_MESSAGE, ANALOG_MESSAGE, REPORT_ANALOG, REPORT_DIGITAL = 0x90, 0xE0, 0xC0, 0xD0
SET_PIN_MODE, REPORT_VERSION = 0xF4, 0xF9
PIN_STATE_QUERY, PIN_STATE_RESPONSE, SAMPLING_INTERVAL = 0x6D, 0x6E, 0x7A
INPUT, OUTPUT = 0, 1
WRITE_PIN, REPORT_PIN = 2, 3  # D2 drives the jumpered D3
CHANNELS = 4


#: The 16U2 bridge's tick (Timer0 overflow, clk/256 * 256 at 16 MHz).
TICK_S = 0.004096


def gap() -> float:
    """The pause between sequential samples: uniform over two whole bridge ticks, so each
    request meets the 16U2's tick at a uniformly random phase whatever the previous reply
    did (a pause over a span that is no multiple of the tick favours some phases).  The
    project's side uses this same function."""
    return random.uniform(0.0, 2 * TICK_S)


# ------------------------------------------------------------------ raw pyserial
class RawFirmata:
    """The floor: blocking pyserial and a 20-line Firmata parser, no threads."""

    def __init__(self, port: str) -> None:
        self.ser = serial.Serial(port, BAUD, timeout=2.0)
        self.port_levels = [0, 0, 0]
        self.analog_counts = [0] * 16
        self.pin_states: list[list[int]] = []
        self.versions = 0

    def close(self) -> None:
        self.ser.close()

    def send(self, *data: int) -> None:
        self.ser.write(bytes(data))

    def read_message(self) -> None:
        """Read and account one message from the board (raises on a 2 s silence)."""
        first = self.ser.read(1)
        if not first:
            raise TimeoutError("no message from the board within 2 s")
        b = first[0]
        if b == START_SYSEX:
            body = self.ser.read_until(bytes([END_SYSEX]))
            if body[:1] == bytes([PIN_STATE_RESPONSE]):
                self.pin_states.append(list(body[1:-1]))
        elif 0x80 <= b < 0xF0 or b == REPORT_VERSION:
            lsb, msb = self.ser.read(2)
            if b & 0xF0 == DIGITAL_MESSAGE:
                self.port_levels[b & 0x0F] = lsb | msb << 7
            elif b & 0xF0 == ANALOG_MESSAGE:
                self.analog_counts[b & 0x0F] += 1
            elif b == REPORT_VERSION:
                self.versions += 1

    def pin_state(self, pin: int) -> list[int]:
        before = len(self.pin_states)
        self.send(START_SYSEX, PIN_STATE_QUERY, pin, END_SYSEX)
        while len(self.pin_states) == before:
            self.read_message()
        return self.pin_states[-1]

    def write_d2(self, level: bool) -> None:
        self.send(DIGITAL_MESSAGE, 1 << WRITE_PIN if level else 0, 0)

    def setup_loopback(self) -> None:
        self.send(SET_PIN_MODE, WRITE_PIN, OUTPUT, SET_PIN_MODE, REPORT_PIN, INPUT)
        self.send(REPORT_DIGITAL | 0, 1)
        self.pin_state(REPORT_PIN)


def raw_test(test: str, port: str, n: int, seconds: float) -> dict[str, Any]:
    if test == "e":
        return {"samples_ms": [raw_open_once(port) for _ in range(n)]}
    fw = RawFirmata(port)
    try:
        fw.ser.reset_input_buffer()
        if test == "a":
            fw.setup_loopback()
            samples, level = [], bool(fw.port_levels[0] >> REPORT_PIN & 1)
            for _ in range(n):
                time.sleep(gap())
                level = not level
                t0 = time.perf_counter()
                fw.write_d2(level)
                while bool(fw.port_levels[0] >> REPORT_PIN & 1) != level:
                    fw.read_message()
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "b":
            fw.pin_state(WRITE_PIN)
            samples = []
            for _ in range(n):
                time.sleep(gap())
                t0 = time.perf_counter()
                fw.pin_state(WRITE_PIN)
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "c":
            fw.send(START_SYSEX, SAMPLING_INTERVAL, 1, 0, END_SYSEX)
            for ch in range(CHANNELS):
                fw.send(REPORT_ANALOG | ch, 1)
            warm = time.monotonic() + 0.5
            while time.monotonic() < warm:
                fw.read_message()
            start_counts, t0 = list(fw.analog_counts[:CHANNELS]), time.monotonic()
            while time.monotonic() - t0 < seconds:
                fw.read_message()
            elapsed = time.monotonic() - t0
            counts = [a - b for a, b in zip(fw.analog_counts, start_counts, strict=False)]
            for ch in range(CHANNELS):
                fw.send(REPORT_ANALOG | ch, 0)
            return {"counts": counts[:CHANNELS], "seconds": elapsed}
        if test == "d":
            fw.send(SET_PIN_MODE, WRITE_PIN, OUTPUT)
            fw.pin_state(WRITE_PIN)
            level, t0 = False, time.monotonic()
            for _ in range(n):
                level = not level
                fw.write_d2(level)
            fw.ser.reset_input_buffer()
            fw.pin_state(WRITE_PIN)  # answered after every write before it
            return {"writes": n, "seconds": time.monotonic() - t0}
    finally:
        fw.close()
    raise ValueError(test)


def raw_open_once(port: str) -> float:
    """Open (the board resets), then ask REPORT_VERSION every 50 ms until it answers."""
    t0 = time.perf_counter()
    ser = serial.Serial(port, BAUD, timeout=0.05)
    try:
        while True:
            ser.write(bytes([REPORT_VERSION]))
            reply = ser.read(3)
            if REPORT_VERSION in reply:
                return (time.perf_counter() - t0) * 1e3
    finally:
        ser.close()
        time.sleep(0.05)  # let the harness see the close before the next open


# ------------------------------------------------------------------ pyfirmata2
def pyfirmata2_test(test: str, port: str, n: int, seconds: float) -> dict[str, Any]:
    lib: Any = importlib.import_module("pyfirmata2")
    module: Any = importlib.import_module("pyfirmata2.pyfirmata2")
    if test == "e":
        samples = []
        for _ in range(n):
            t0 = time.perf_counter()
            board = lib.Arduino(port, baudrate=BAUD)  # waits BOARD_SETUP_WAIT_TIME (5 s)
            board.digital[WRITE_PIN].write(1)
            samples.append((time.perf_counter() - t0) * 1e3)
            board.exit()
            time.sleep(0.05)
        return {"samples_ms": samples}
    module.BOARD_SETUP_WAIT_TIME = 0  # the board is already running: skip the reset wait
    board = lib.Arduino(port, baudrate=BAUD)
    try:
        states: list[tuple[int, ...]] = []
        got_state = threading.Event()

        def on_state(*data: int) -> None:
            states.append(data)
            got_state.set()

        board.add_cmd_handler(PIN_STATE_RESPONSE, on_state)

        def query() -> None:
            got_state.clear()
            board.send_sysex(PIN_STATE_QUERY, [WRITE_PIN])
            if not got_state.wait(2.0):
                raise TimeoutError("no pin state response")

        board.samplingOn(1)  # starts the reader thread (polls the port every 1 ms)
        if test == "a":
            changed = threading.Event()
            seen = {"level": False}

            def on_d3(value: bool) -> None:
                seen["level"] = bool(value)
                changed.set()

            board.digital[WRITE_PIN].mode = lib.OUTPUT
            board.digital[REPORT_PIN].mode = lib.INPUT
            board.digital[REPORT_PIN].register_callback(on_d3)
            board.digital[REPORT_PIN].enable_reporting()
            query()
            samples, level = [], bool(board.digital[WRITE_PIN].value)
            for _ in range(n):
                time.sleep(gap())
                level = not level
                changed.clear()
                t0 = time.perf_counter()
                board.digital[WRITE_PIN].write(level)
                while seen["level"] != level:
                    if not changed.wait(2.0):
                        raise TimeoutError("no D3 report")
                    changed.clear()
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "b":
            query()
            samples = []
            for _ in range(n):
                time.sleep(gap())
                t0 = time.perf_counter()
                query()
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "c":
            counts = [0] * CHANNELS
            counting = {"on": False}

            def counter(ch: int) -> Callable[[float], None]:
                def on_value(value: float) -> None:
                    if counting["on"]:
                        counts[ch] += 1

                return on_value

            for ch in range(CHANNELS):
                board.analog[ch].register_callback(counter(ch))
                board.analog[ch].enable_reporting()
            time.sleep(0.5)
            counting["on"], t0 = True, time.monotonic()
            time.sleep(seconds)
            counting["on"] = False
            elapsed = time.monotonic() - t0
            for ch in range(CHANNELS):
                board.analog[ch].disable_reporting()
            return {"counts": counts, "seconds": elapsed}
        if test == "d":
            board.digital[WRITE_PIN].mode = lib.OUTPUT
            query()
            level, t0 = False, time.monotonic()
            for _ in range(n):
                level = not level
                board.digital[WRITE_PIN].write(level)
            query()
            return {"writes": n, "seconds": time.monotonic() - t0}
    finally:
        board.exit()
    raise ValueError(test)


# ------------------------------------------------------------------ pymata4
def pymata4_test(test: str, port: str, n: int, seconds: float) -> dict[str, Any]:
    lib: Any = importlib.import_module("pymata4.pymata4")
    if test == "e":
        samples = []
        for _ in range(n):
            t0 = time.perf_counter()
            board = lib.Pymata4(com_port=port, baud_rate=BAUD)  # arduino_wait=4 s default
            board.set_pin_mode_digital_output(WRITE_PIN)
            board.digital_write(WRITE_PIN, 1)
            samples.append((time.perf_counter() - t0) * 1e3)
            board.shutdown()
            time.sleep(0.05)
        return {"samples_ms": samples}
    board = lib.Pymata4(com_port=port, baud_rate=BAUD, arduino_wait=0)
    try:
        if test == "a":
            changed = threading.Event()
            seen = {"level": -1}

            def on_d3(data: list[Any]) -> None:
                seen["level"] = int(data[2])
                changed.set()

            board.set_pin_mode_digital_output(WRITE_PIN)
            board.set_pin_mode_digital_input(REPORT_PIN, callback=on_d3)
            board.get_pin_state(REPORT_PIN)
            samples, level = [], 0
            board.digital_write(WRITE_PIN, level)
            for _ in range(n):
                time.sleep(gap())
                level ^= 1
                changed.clear()
                t0 = time.perf_counter()
                board.digital_write(WRITE_PIN, level)
                while seen["level"] != level:
                    if not changed.wait(2.0):
                        raise TimeoutError("no D3 report")
                    changed.clear()
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "b":
            board.get_pin_state(WRITE_PIN)
            samples = []
            for _ in range(n):
                time.sleep(gap())
                t0 = time.perf_counter()
                board.get_pin_state(WRITE_PIN)
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "c":
            counts = [0] * CHANNELS
            counting = {"on": False}

            def on_analog(data: list[Any]) -> None:
                if counting["on"]:
                    counts[int(data[1])] += 1

            board.set_sampling_interval(1)
            for ch in range(CHANNELS):
                # differential 0: a callback for every report, not only for changes
                board.set_pin_mode_analog_input(ch, callback=on_analog, differential=0)
            time.sleep(0.5)
            counting["on"], t0 = True, time.monotonic()
            time.sleep(seconds)
            counting["on"] = False
            elapsed = time.monotonic() - t0
            for ch in range(CHANNELS):
                board.disable_analog_reporting(ch)
            return {"counts": counts, "seconds": elapsed}
        if test == "d":
            board.set_pin_mode_digital_output(WRITE_PIN)
            board.get_pin_state(WRITE_PIN)
            level, t0 = 0, time.monotonic()
            for _ in range(n):
                level ^= 1
                board.digital_write(WRITE_PIN, level)
            board.get_pin_state(WRITE_PIN)
            return {"writes": n, "seconds": time.monotonic() - t0}
    finally:
        board.shutdown()
    raise ValueError(test)


# ------------------------------------------------------------------ pymata-express
async def pymata_express_test(test: str, port: str, n: int, seconds: float) -> dict[str, Any]:
    lib: Any = importlib.import_module("pymata_express.pymata_express")
    loop = asyncio.get_running_loop()

    async def open_board(wait: float | None) -> Any:
        options: dict[str, Any] = {"com_port": port, "baud_rate": BAUD, "autostart": False}
        options.update(loop=loop, close_loop_on_shutdown=False, shutdown_on_exception=False)
        if wait is not None:
            options["arduino_wait"] = wait
        board = lib.PymataExpress(**options)
        await board.start_aio()
        return board

    if test == "e":
        samples = []
        for _ in range(n):
            t0 = time.perf_counter()
            board = await open_board(None)  # arduino_wait=4 s default
            await board.set_pin_mode_digital_output(WRITE_PIN)
            await board.digital_write(WRITE_PIN, 1)
            samples.append((time.perf_counter() - t0) * 1e3)
            await board.shutdown()
            await asyncio.sleep(0.05)
        return {"samples_ms": samples}
    board = await open_board(0)
    try:
        if test == "a":
            changed = asyncio.Event()
            seen = {"level": -1}

            async def on_d3(data: list[Any]) -> None:
                seen["level"] = int(data[2])
                changed.set()

            await board.set_pin_mode_digital_output(WRITE_PIN)
            await board.set_pin_mode_digital_input(REPORT_PIN, callback=on_d3)
            await board.get_pin_state(REPORT_PIN)
            samples, level = [], 0
            await board.digital_write(WRITE_PIN, level)
            for _ in range(n):
                await asyncio.sleep(gap())
                level ^= 1
                changed.clear()
                t0 = time.perf_counter()
                await board.digital_write(WRITE_PIN, level)
                while seen["level"] != level:
                    await asyncio.wait_for(changed.wait(), 2.0)
                    changed.clear()
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "b":
            await board.get_pin_state(WRITE_PIN)
            samples = []
            for _ in range(n):
                await asyncio.sleep(gap())
                t0 = time.perf_counter()
                await board.get_pin_state(WRITE_PIN)
                samples.append((time.perf_counter() - t0) * 1e3)
            return {"samples_ms": samples}
        if test == "c":
            counts = [0] * CHANNELS
            counting = {"on": False}

            async def on_analog(data: list[Any]) -> None:
                if counting["on"]:
                    counts[int(data[1])] += 1

            await board.set_sampling_interval(1)
            for ch in range(CHANNELS):
                await board.set_pin_mode_analog_input(ch, callback=on_analog, differential=0)
            await asyncio.sleep(0.5)
            counting["on"], t0 = True, time.monotonic()
            await asyncio.sleep(seconds)
            counting["on"] = False
            elapsed = time.monotonic() - t0
            for ch in range(CHANNELS):
                await board.disable_analog_reporting(ch)
            return {"counts": counts, "seconds": elapsed}
        if test == "d":
            await board.set_pin_mode_digital_output(WRITE_PIN)
            await board.get_pin_state(WRITE_PIN)
            level, t0 = 0, time.monotonic()
            for _ in range(n):
                level ^= 1
                await board.digital_write(WRITE_PIN, level)
            await board.get_pin_state(WRITE_PIN)
            return {"writes": n, "seconds": time.monotonic() - t0}
    finally:
        await board.shutdown()
    raise ValueError(test)


CLIENTS = ("raw", "pyfirmata2", "pymata4", "pymata_express")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--client", choices=CLIENTS, required=True)
    parser.add_argument("--test", choices=tuple("abcde"), required=True)
    parser.add_argument("--port", required=True)
    parser.add_argument("--n", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args()
    if args.client == "raw":
        result = raw_test(args.test, args.port, args.n, args.seconds)
    elif args.client == "pyfirmata2":
        result = pyfirmata2_test(args.test, args.port, args.n, args.seconds)
    elif args.client == "pymata4":
        result = pymata4_test(args.test, args.port, args.n, args.seconds)
    else:
        result = asyncio.run(pymata_express_test(args.test, args.port, args.n, args.seconds))
    print("RESULT " + json.dumps(result), flush=True)


if __name__ == "__main__":
    main()

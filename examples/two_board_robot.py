"""A two-board robot found by board ID: sensors on one Uno, actuators on the other.

    python examples/two_board_robot.py [--seconds 5]       # USB serial ports, ARDUINOIO_PORTS
    python examples/two_board_robot.py --virtual           # two virtual Unos

Ports change when cables are moved; board IDs do not (``arduinoio set-id`` writes one to
EEPROM).  The manager finds each board by ID, restores its pin roles after a reset or a
replug on any port, and hands back the same Board and handles, so the control loop only
has to wait while a board is away.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio

from arduinoio_async import A0, D9, BoardManager, LinkError, ManagerEvent
from arduinoio_async.sim import start_virtual_unos

ACTUATORS, SENSORS = 0x0001, 0x0002


@asynccontextmanager
async def robot_ports(virtual: bool) -> AsyncIterator[list[str]]:
    """Nothing extra (the manager looks at USB serial devices and ARDUINOIO_PORTS), or the
    ports of two virtual Unos with the robot's board IDs."""
    if not virtual:
        yield []
        return
    async with start_virtual_unos([ACTUATORS, SENSORS]) as unos:
        print("(two virtual Unos)", file=sys.stderr)
        yield [uno.port for uno in unos]


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("--virtual", action="store_true", help="run against two virtual Unos")
    parser.add_argument("--seconds", type=float, default=5.0)
    args = parser.parse_args()

    def report(event: ManagerEvent) -> None:
        print(f"board 0x{event.board_id:04X}: {event.kind} {event.port}", flush=True)

    async with robot_ports(args.virtual) as ports, BoardManager(ports=ports) as boards:
        boards.subscribe(report)
        actuators, sensors = await boards.get(ACTUATORS), await boards.get(SENSORS)
        steering = await actuators.servo(D9, pulse_us=1500)
        distance = sensors.analog(A0)
        cycles = waits = 0
        print("ready: control loop running", flush=True)
        with anyio.move_on_after(args.seconds):
            while True:
                try:
                    volts = await distance.read_volts()
                    await steering.set_pulse(1000 + round(volts * 200))  # 0-5 V -> 1000-2000
                    cycles += 1
                except LinkError:
                    waits += 1  # a board is away: wait until the manager has it back
                    await boards.wait_connected(ACTUATORS)
                    await boards.wait_connected(SENSORS)
                await anyio.sleep(0.02)
        print(f"{cycles} control cycles, {waits} waits for a board")


if __name__ == "__main__":
    anyio.run(main)

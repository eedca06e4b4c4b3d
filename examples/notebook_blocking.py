"""Blocking use, as in a Jupyter notebook or a plain script: no async, no event loop to own.

    python examples/notebook_blocking.py [--port P]

``arduinoio_async.blocking.connect`` opens a board that stays open across notebook cells until
``close()``; every call blocks until the board has answered.  The async library runs
underneath, on an event loop in a worker thread, so the link's heartbeat (and an armed
failsafe) keeps being fed between cells.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager

from anyio.from_thread import start_blocking_portal

from arduinoio_async import A0, D2, D3, VirtualUno
from arduinoio_async.blocking import connect


@contextmanager
def port_or_virtual_uno(port: str | None) -> Iterator[str]:
    if port:
        yield port
        return
    uno = VirtualUno(board_id=1, fixture="loopback")
    with start_blocking_portal() as portal, portal.wrap_async_context_manager(uno):
        yield uno.port


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("--port", help="serial port of the board (default: a virtual Uno)")
    args = parser.parse_args()
    with port_or_virtual_uno(args.port) as port:
        # --- cell 1: open the board once
        board = connect(port)
        print(f"board 0x{board.board_id:04X} open")
        # --- cell 2: outputs and inputs
        led = board.gpio(D2)
        led.write(True)
        print("D3 (jumpered to D2) reads", board.gpio(D3).read())
        # --- cell 3: a quick look at an analog channel, and a few stream samples
        print(f"A0 = {board.analog(A0).read_volts():.2f} V")
        with board.stream(analog=[A0], period_ms=10) as samples:
            values = [sample.analog[A0] for sample, _ in zip(samples, range(5), strict=False)]
        print("five samples of A0:", values)
        # --- last cell: close it (the port is free for other programs again)
        board.close()
        print("closed")


if __name__ == "__main__":
    main()

"""Count presses of a button on D3 (to ground, with the internal pull-up) from latched edges.

    python examples/button_edges.py [--port P] [--presses 3] [--seconds 10]

The board latches rising and falling edges between reads, so even a press shorter than the
polling interval is counted: a press pulls D3 low (a falling edge), a release lets the
pull-up take it high again.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D3
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--presses", type=int, default=3, help="stop after this many")
    parser.add_argument("--seconds", type=float, default=10.0, help="or after this long")
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        button = await board.digital_input(D3, pull_up=True)
        presses = 0
        print("ready: press the button on D3", flush=True)
        with anyio.move_on_after(args.seconds):
            while presses < args.presses:
                state = await button.read()  # level, and edges since the last read
                if state.fell:
                    presses += 1
                    print(f"press {presses} (button {'held' if not state.level else 'up'})")
                if state.rose and presses:
                    print(f"release {presses}")
                await anyio.sleep(0.02)
        print(f"{presses} presses counted")


if __name__ == "__main__":
    anyio.run(main)

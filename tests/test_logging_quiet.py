"""The library logs but never prints: an application that configured no logging sees nothing.

Python's last-resort handler writes WARNING and above to stderr when a logger's hierarchy
has no handler.  A library must not decide that for its application (the logging HOWTO's
"Configuring Logging for a Library"): the package's top logger carries a NullHandler, so
the library's warnings reach stderr only through handlers the application adds.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

# A real warning path: the board loses every reply, so the link loses sync and logs it.
SCRIPT = textwrap.dedent(
    """
    import logging, anyio
    from arduinoio_async.board import Board
    from arduinoio_async.errors import LinkError
    from arduinoio_async.testing import FakeBoard

    async def main():
        async with FakeBoard(board_id=0x42) as fake, Board.connect(
            fake.host_stream, timeout=0.1, ready_timeout=2
        ) as board:
            fake.faults.lose_reply = 1.0
            try:
                await board.read_id()
            except LinkError:
                pass
            assert board.link.last_loss, "no loss of sync: the scenario logged nothing"
        print("done", flush=True)

    {configure}
    anyio.run(main)
    """
)


def run(configure: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", SCRIPT.format(configure=configure)],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_no_stderr_output_without_logging_configuration() -> None:
    result = run("")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "done"
    assert result.stderr == ""


def test_the_application_still_sees_warnings_when_it_configures_logging() -> None:
    """The oracle can fail: with a handler configured the same run does print the warning."""
    result = run("logging.basicConfig(level=logging.WARNING)")
    assert result.returncode == 0, result.stderr
    assert "lost sync" in result.stderr

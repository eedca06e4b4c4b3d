"""The transport tests again, on uvloop (the ``uvloop`` extra, used when installed).

uvloop keeps the asyncio fast path (decoding in the fd-readable callback, the deadline
alarm) but its own clock, handles and futures' loop: the same tests must pass unchanged.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Any

import anyio
import pytest

from tests.transport import test_fast_path, test_serial_urls, test_transport
from tests.transport.test_on_trio import coroutine_tests

pytest.importorskip("uvloop")


@pytest.mark.parametrize(
    "test", coroutine_tests([test_transport, test_serial_urls, test_fast_path])
)
def test_on_uvloop(test: Callable[[], Coroutine[Any, Any, None]]) -> None:
    anyio.run(test, backend="asyncio", backend_options={"use_uvloop": True})

"""Board time -> ROS time: an estimate of the board clock's offset and drift.

The board stamps change events and stream samples with its microsecond clock (32 bits,
wraps after 71.6 minutes; an Uno's ceramic resonator runs up to ~0.5 % off).  ROS wants
``header.stamp`` in the host's clock (nanoseconds since the UNIX epoch).  Each stamped
frame gives one pair (board time, host time when it was decoded); the host time is late
by the frame's transit (serial, USB, the event loop), never early.  So the pairs with the
least transit lie on a line ``host = offset + (1 + drift) * board`` and every other pair
lies above it: the estimator keeps the earliest pair of each ``bucket`` of board time
(the lower envelope) and fits the line through the newest ``buckets`` of them by least
squares (leaving out the bucket still filling once there are two others).  Until two
buckets exist it uses the earliest pair alone with drift 0.

The window is short (20 buckets of 0.25 s by default: 5 s of board time while events
come often, longer when they are sparse) because a clock that wanders, as the virtual
Uno's simulated time does on a loaded machine, is only linear over a few seconds
(``benchmarks/ros2_latency.py``: a 30 s window left stamps up to 56 ms early there).

The error of a stamp (documented in ``docs/ros2.md``, measured in
``tests/ros2/test_clock.py`` and against the harness in ``benchmarks/ros2_latency.py``):
late by the least transit in its buckets (which the fit cannot see), give or take the
scatter of the envelope around the line, which :attr:`BoardClock.spread_ns` reports.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass

__all__ = ["BoardClock"]

_WRAP_US = 1 << 32
#: A step back of the board clock this large is a reset, not frames out of order.
RESET_JUMP_US = 1_000_000
#: When the fitted line moves earlier, stamps advance at this fraction of the board's
#: elapsed time until they meet it again (a slew, as NTP does): they never go back.
SLEW = 0.5


@dataclass
class _Fit:
    offset_ns: float
    rate: float  # host ns per board ns (1 + drift)
    origin_us: int  # board time the offset refers to


class BoardClock:
    """Maps one board's microsecond ticks to host nanoseconds; feed it every stamped frame."""

    def __init__(self, *, bucket_s: float = 0.25, buckets: int = 20) -> None:
        self._bucket_us = int(bucket_s * 1_000_000)
        #: (unwrapped board us, host ns), the earliest of each bucket, newest last.
        self._envelope: collections.deque[tuple[int, int]] = collections.deque(maxlen=buckets)
        self._last_raw: int | None = None
        self._wraps = 0
        self._fit: _Fit | None = None
        #: Largest distance (ns) of an envelope point above the fitted line.
        self.spread_ns = 0
        #: The latest (unwrapped board us, host ns) :meth:`to_host_ns` returned.
        self._last_out: tuple[int, int] | None = None
        #: The newest pair observed: no board time up to it happened after its host time.
        self._latest: tuple[int, int] | None = None

    def unwrap(self, board_us: int) -> int:
        """``board_us`` (32-bit, wrapping) as a count that keeps growing."""
        if self._last_raw is not None and board_us < self._last_raw - _WRAP_US // 2:
            self._wraps += 1
        self._last_raw = board_us
        return board_us + self._wraps * _WRAP_US

    def observe(self, board_us: int, host_ns: int) -> int:
        """Add a pair; returns the unwrapped board time.  Call in the order frames came.

        A board time more than :data:`RESET_JUMP_US` before the newest pair (and not a
        wrap) means the board reset and its clock started again: the estimate starts over.
        """
        board = self.unwrap(board_us)
        if self._envelope and board < self._envelope[-1][0] - RESET_JUMP_US:
            self.reset()
            board = self.unwrap(board_us)
        if self._latest is None or board >= self._latest[0]:
            self._latest = (board, host_ns)
        bucket = board // self._bucket_us
        if self._envelope and self._envelope[-1][0] // self._bucket_us == bucket:
            last_board, last_host = self._envelope[-1]
            if host_ns - board * 1000 >= last_host - last_board * 1000:
                return board  # above the bucket's lowest pair: the line is unchanged
            self._envelope[-1] = (board, host_ns)
            if len(self._envelope) >= 3:
                return board  # the fit leaves the filling bucket out: unchanged
        elif self._envelope and board < self._envelope[-1][0]:
            return board  # a little out of order (another frame kind): nothing to learn
        else:
            self._envelope.append((board, host_ns))
        # Refit only when the points it uses changed: once per bucket in the steady state
        # (a fit on every stamped frame cost ~80 us of each change's way to ROS).
        self._refit()
        return board

    def reset(self) -> None:
        """Forget everything (the board reset: its clock started again at 0)."""
        self._envelope.clear()
        self._last_raw = None
        self._wraps = 0
        self._fit = None
        self.spread_ns = 0
        self._last_out = None
        self._latest = None

    def _refit(self) -> None:
        points = list(self._envelope)
        if len(points) >= 3:
            points.pop()  # the current bucket: its earliest pair may still come
        origin = points[0][0]
        xs = [(board - origin) * 1000.0 for board, _ in points]
        ys = [float(host) for _, host in points]
        n = len(points)
        if n == 1:
            self._fit = _Fit(ys[0] - xs[0], 1.0, origin)
            self.spread_ns = 0
            return
        mean_x, mean_y = sum(xs) / n, sum(ys) / n
        sxx = sum((x - mean_x) ** 2 for x in xs)
        sxy = sum((x - mean_x) * (y - mean_y) for x, y in zip(xs, ys, strict=True))
        rate = 1.0 if sxx == 0 else sxy / sxx
        # The line through the envelope's lowest point with that slope: transit only adds,
        # so the lowest residual is the best offset, not the mean one.
        residuals = [y - rate * x for x, y in zip(xs, ys, strict=True)]
        offset = min(residuals)
        self._fit = _Fit(offset, rate, origin)
        self.spread_ns = int(max(residuals) - offset)

    @property
    def drift_ppm(self) -> float:
        """How much faster the host clock runs than the board's, in parts per million."""
        return 0.0 if self._fit is None else (self._fit.rate - 1.0) * 1e6

    def to_host_ns(self, board_us: int) -> int:
        """The host time (ns) of board time ``board_us`` (unwrapped or raw, recent).

        Monotonic for board times in order: when a refit moved the line earlier, a later
        board time gets a stamp after the previous one (by :data:`SLEW` of the elapsed
        board time) until the line catches up, so stamps never go back; an earlier board
        time than the last converted one gets the line's value.  Not after the host time
        its frame (or a later one) was observed (frames decoded at once: 1 us apart):
        while the first buckets give a poor slope (a simulated clock running in bursts),
        the line can point seconds ahead, and a stamp after its frame's arrival is wrong
        for certain.
        """
        if self._fit is None:
            raise RuntimeError("no stamped frame observed yet")
        fit = self._fit
        board = board_us
        if board < _WRAP_US and self._last_raw is not None:
            board = board_us + self._wraps * _WRAP_US
            if board_us > self._last_raw + _WRAP_US // 2:  # just before the last wrap
                board -= _WRAP_US
        host = int(fit.offset_ns + fit.rate * (board - fit.origin_us) * 1000.0)
        last = self._last_out
        if last is not None and board >= last[0]:
            host = max(host, last[1] + int((board - last[0]) * 1000 * SLEW))
        latest = self._latest
        if latest is not None and board <= latest[0]:
            host = min(host, latest[1])
        if last is not None and board > last[0]:  # frames decoded together: 1 us apart
            host = max(host, last[1] + 1000)
        if last is None or board >= last[0]:
            self._last_out = (board, host)
        return host

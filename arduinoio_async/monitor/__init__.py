"""A live board monitor in the browser (``arduinoio monitor``, extra ``[monitor]``).

One page shows every board handed to it: its ID, firmware, baud, failsafe and stream
state, every pin with its role, live level and edges, live plots of the analog channels
and the counters, with controls for outputs, servo and software-PWM pulses, I2C
registers, reset and the failsafe.  Live data comes from the board's change events
(every edge of every input), counter reports and its firmware-timed stream (analog
plots, outputs) and reaches the page over a WebSocket.  See ``docs/monitor.md``.

``serve_monitor([board])`` serves boards you already hold (an embedded robot program, a
test); ``arduinoio monitor`` finds them for you.
"""

from ._changes import ChangeSource
from ._counts import CountSource
from ._hub import MonitorHub
from ._panel import BoardPanel
from ._server import MonitorServer, new_token, serve_monitor
from ._sources import Activity, ActivitySource, StreamSource

__all__ = [
    "Activity",
    "ActivitySource",
    "BoardPanel",
    "ChangeSource",
    "CountSource",
    "MonitorHub",
    "MonitorServer",
    "StreamSource",
    "new_token",
    "serve_monitor",
]

"""The command table: every request, its reply and the events, one module per class tag.

The modules mirror ``firmware/src`` (``misc``, ``gpio``, ``analog``, ``i2c``, ``pwm``,
``counter``, ``stream``, ``failsafe``, ``stepper``, ``transaction``, ``encoder``, ``spi``),
each holding the frames its C counterpart handles or sends.  Importing this package fills the
tables of ``_messages`` (``REQUEST_TYPES``, ``REPLY_TYPES``, ``EVENT_TYPES``) that the
decoder, the generated C header and the generated docs read; ``arduinoio_async.protocol``
re-exports every module's ``__all__``, which is where users import the messages from.

Descriptor tags of the paper are kept; requests marked *extension* go beyond the paper.
"""

from __future__ import annotations

from typing import Any

from .._messages import REQUEST_TYPES, Request
from . import (
    analog,
    counter,
    encoder,
    failsafe,
    gpio,
    i2c,
    misc,
    pulse_in,
    pwm,
    sonar,
    spi,
    stepper,
    stream,
    transaction,
)

__all__ = ["IDEMPOTENT_WRITES", "MODULES", "READ_ONLY_REQUESTS"]

#: Every command module, in class tag order; importing them filled the command table.
MODULES = (
    misc,
    gpio,
    analog,
    i2c,
    pwm,
    counter,
    stream,
    failsafe,
    stepper,
    transaction,
    encoder,
    sonar,
    spi,
    pulse_in,
)

#: Requests that only read (docs/protocol.md, "Idempotency and retries"), in tag order.
READ_ONLY_REQUESTS: tuple[type[Request[Any]], ...] = tuple(
    cls for _, cls in sorted(REQUEST_TYPES.items()) if cls.READS_ONLY
)
#: Requests that set a state, so a repeat sets the same state again, in tag order; each
#: module says beside a request why it is not here.
IDEMPOTENT_WRITES: tuple[type[Request[Any]], ...] = tuple(
    cls for _, cls in sorted(REQUEST_TYPES.items()) if cls.IDEMPOTENT and not cls.READS_ONLY
)

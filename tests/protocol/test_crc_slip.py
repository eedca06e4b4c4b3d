"""The one-insertion slip that kept CRC-16 framing's residual above 1e-9 for replies with
free values (docs/protocol.md 7.7, "Why temperature and counter replies miss 1e-9"), and
the guard that rejects it: a free-valued reply that ends a read is held until the line
stayed quiet for one byte time (``Received.hold`` / ``Session.release_held``).

The board sends 01 03 01 31 BE 67 (temperature raw 305).  The line inserts 0xC7 after the
third byte: 01 03 01 C7 31 BE | 67.  The first six bytes are a CRC-valid temperature
reply of raw 0x01C7 = 455, inside the sensor's 186-459 bound; the displaced last byte
arrives in the next read, a byte time later.
"""

from __future__ import annotations

from arduinoio_async import protocol as p
from arduinoio_async.protocol.session import free_valued

from .test_framing import CRC, connected, crc_bytes


def test_a_slipped_temperature_reply_is_not_delivered() -> None:
    session, _ = connected()
    session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    exchange, _ = session.send(p.ReadTemperature())
    sent = crc_bytes(p.ReadTemperatureReply(305))
    assert sent == bytes.fromhex("01030131be67")
    on_the_line = sent[:3] + b"\xc7" + sent[3:]  # one inserted byte
    first = session.receive_data(on_the_line[:6])  # the read ends where the slipped frame does
    assert first.hold and not exchange.done
    session.receive_data(on_the_line[6:])  # the displaced last byte, a read later
    assert exchange.reply != p.ReadTemperatureReply(455)


def test_a_held_reply_is_delivered_once_the_line_stays_quiet() -> None:
    session, _ = connected()
    session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    exchange, _ = session.send(p.ReadTemperature())
    out = session.receive_data(crc_bytes(p.ReadTemperatureReply(305)))
    assert out.hold and not exchange.done
    released = session.release_held()
    assert released.done == [exchange]
    assert exchange.reply == p.ReadTemperatureReply(305)
    assert not session.release_held().done  # released once


def test_a_reply_that_only_echoes_is_not_held() -> None:
    # an echo the session checks leaves the slip no free byte: no byte time to wait
    assert not free_valued(p.GpioWrite)
    assert free_valued(p.ReadTemperature) and free_valued(p.CounterRead)
    session, _ = connected()
    session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    exchange, _ = session.send(p.GpioWrite(pin=2, value=True))
    out = session.receive_data(crc_bytes(p.GpioWriteReply(pin=2, value=True)))
    assert not out.hold and exchange.done


def test_xor_framing_never_holds() -> None:
    session, _ = connected(p.Framing.XOR)
    exchange, _ = session.send(p.ReadTemperature())
    out = session.receive_data(p.ReadTemperatureReply(305).encode())
    assert not out.hold and exchange.reply == p.ReadTemperatureReply(305)

"""The served board's per-client policy on its own: no Zenoh session, no loop, no board.

Each answer is checked against what the board (a reply built here) said and what the
policy must make of it for each client: virtual sessions, the failsafe's owner, WriteId
refused, pins held by their client, the one streaming client.
"""

from __future__ import annotations

import pytest

from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError, UsageError
from arduinoio_async.network._client_policy import ClientPolicy

BOARD = 0x0007
BOOT = 0x5A  # the server's own tag of the real board
NO_FLAGS = p.StatusFlags(0)
STATUS = p.ReadStatusReply(NO_FLAGS, BOOT)


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def policy(live: set[str] | None = None) -> ClientPolicy:
    return ClientPolicy(BOARD, Clock(), live if live is not None else set())


def status_for(
    rules: ClientPolicy, client: str, raw: p.ReadStatusReply = STATUS, boot: int = BOOT
) -> int:
    """The session ``client`` is shown when the board answers ``raw`` and the server's
    own tag of the board is ``boot``."""
    frame = rules.after_link(client, p.ReadStatus(), raw, boot)
    (reply,) = p.Decoder.from_board().feed(frame)
    assert isinstance(reply, p.ReadStatusReply)
    return reply.session


def test_each_client_sees_its_own_session_tag_and_zero_after_a_reboot() -> None:
    rules = policy()
    for client, tag in (("a", 0x11), ("b", 0x22)):
        frame = rules.answer_locally(client, p.SetSession(tag), BOOT)
        assert frame == p.SetSessionReply(tag).encode()  # answered here, not by the board
    assert status_for(rules, "a") == 0x11
    assert status_for(rules, "b") == 0x22
    assert status_for(rules, "stranger") == BOOT  # no tag set: the board's own answer
    rebooted = p.ReadStatusReply(NO_FLAGS, 0)
    assert status_for(rules, "a", rebooted) == 0  # a fresh board: a reads a reset
    assert rules.stale
    # Back in service, re-tagged by the manager: a's tag was of the old boot.
    assert status_for(rules, "a", p.ReadStatusReply(NO_FLAGS, BOOT + 1), BOOT + 1) == 0
    assert not rules.stale


def test_a_tag_set_while_the_board_is_stale_belongs_to_the_next_boot() -> None:
    rules = policy()
    assert status_for(rules, "a", p.ReadStatusReply(NO_FLAGS, 0)) == 0  # rebooted, not re-tagged
    rules.answer_locally("a", p.SetSession(0x33), BOOT)
    assert status_for(rules, "a", p.ReadStatusReply(NO_FLAGS, 0)) == 0x33
    # Re-tagged by the manager: the tag is of this boot, and stays a's while it lasts.
    assert status_for(rules, "a", p.ReadStatusReply(NO_FLAGS, BOOT + 1), BOOT + 1) == 0x33
    assert status_for(rules, "a", p.ReadStatusReply(NO_FLAGS, BOOT + 1), BOOT + 1) == 0x33


def test_write_id_is_refused_with_words() -> None:
    with pytest.raises(UsageError, match=r"write_id\(0x0009\) is refused over the network"):
        policy().answer_locally("a", p.WriteId(0x0009), BOOT)


def test_a_pin_held_by_a_live_client_in_another_role_is_refused_as_pin_busy() -> None:
    rules = policy({"a", "b"})
    output = p.GpioConfig(4, p.GpioFlags.OUTPUT)
    assert rules.answer_locally("a", output, BOOT) is None  # goes on to the board
    with pytest.raises(BoardError) as refused:
        rules.answer_locally("b", p.GpioConfig(4, p.GpioFlags(0)), BOOT)
    assert refused.value.code == p.ErrorCode.PIN_BUSY
    assert rules.answer_locally("b", output, BOOT) is None  # the same role is shared
    rules.client_gone("a")
    rules.client_gone("b")
    assert rules.answer_locally("c", p.GpioConfig(4, p.GpioFlags(0)), BOOT) is None


def test_a_claim_the_board_refused_is_undone() -> None:
    rules = policy({"a", "b"})
    rules.answer_locally("a", p.GpioConfig(5, p.GpioFlags.OUTPUT), BOOT)
    rules.refused("a", p.GpioConfig(5, p.GpioFlags.OUTPUT))
    assert rules.answer_locally("b", p.GpioConfig(5, p.GpioFlags(0)), BOOT) is None


def test_the_arming_client_owns_the_failsafe_until_it_disarms() -> None:
    rules = policy()
    arm = p.FailsafeArm(timeout_ms=200)
    assert not rules.needs_client(p.ReadId())
    rules.after_link("a", arm, p.FailsafeArmReply(200), BOOT)
    assert (rules.owner, rules.owner_timeout, rules.arms) == ("a", 0.2, 1)
    assert rules.needs_client(p.ReadId())  # every request's client counts now
    rules.after_link("a", p.FailsafeDisarm(), p.FailsafeDisarmReply(), BOOT)
    assert rules.owner is None and rules.arms == 1


def test_one_client_streams_and_a_refused_start_gives_the_stream_back() -> None:
    rules = policy()
    start = p.StreamStart(analog_mask=1, flags=p.StreamFlags(0), period_us=10_000)
    rules.answer_locally("a", start, BOOT)
    assert rules.streamer == "a"
    rules.answer_locally("b", start, BOOT)
    rules.refused("b", start)
    assert rules.streamer == "a"  # the board kept a's stream
    assert rules.client_gone("b") is False
    assert rules.client_gone("a") is True  # its stream is the caller's to stop
    assert rules.streamer is None


def test_records_of_the_owner_and_live_clients_outlast_the_limit() -> None:
    live = {"live"}
    rules = policy(live)
    rules.tags.limit = rules.last_heard.limit = 2
    rules.after_link("owner", p.FailsafeArm(timeout_ms=100), p.FailsafeArmReply(100), BOOT)
    for client in ("owner", "live", "x", "y", "z"):
        rules.answer_locally(client, p.SetSession(0x40), BOOT)
    assert "owner" in rules.tags and "live" in rules.tags
    assert "x" not in rules.tags and "y" not in rules.tags

"""rmw_zenoh's wire format, byte for byte, against the vectors its documents give.

Sources (docs/ros2.md): rmw_zenoh ``docs/design.md`` gives the ``String`` type hash, the
``/chatter`` key expression and two liveliness tokens verbatim; ``attachment_helpers.cpp``
(Jazzy >= 0.2.4, Kilted >= 0.6.0) fixes the 33-byte attachment.  The CDR vectors are
the OMG CDR rules (little-endian encapsulation ``00 01 00 00``, then each field aligned
to its size from the end of the header), and the RIHS01 hashes are checked against
zenoh-ros2-sdk, which computes them from the message text by its own code.
"""

from __future__ import annotations

import pytest

from arduinoio_async.errors import UsageError
from arduinoio_async.ros2 import _messages as msgs
from arduinoio_async.ros2._wire import (
    Attachment,
    EntityKind,
    Qos,
    decode_attachment,
    encode_attachment,
    endpoint_token,
    fully_qualified,
    node_token,
    topic_key,
)

#: design.md, "Topic and Service name mapping to Zenoh key expressions".
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"


def test_type_hash_of_std_msgs_string_is_the_one_design_md_shows() -> None:
    assert msgs.type_hash("std_msgs/msg/String") == STRING_HASH


def test_topic_key_of_chatter_is_the_one_design_md_shows() -> None:
    key = topic_key(0, "/chatter", "std_msgs/msg/String", STRING_HASH)
    assert key == f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    nested = topic_key(2, "/robot1/chatter", "std_msgs/msg/String", STRING_HASH)
    assert nested == f"2/robot1/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"


def test_node_token_is_the_listener_token_of_design_md() -> None:
    token = node_token(0, "aac3178e146ba6f1fc6e6a4085e77f21", 0, "/", "listener")
    assert token == "@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"


def test_publisher_token_is_the_talker_token_of_design_md() -> None:
    token = endpoint_token(
        0,
        "8b20917502ee955ac4476e0266340d5c",
        0,
        10,
        EntityKind.PUBLISHER,
        "/",
        "talker",
        "/chatter",
        "std_msgs/msg/String",
        STRING_HASH,
        Qos(depth=7),
    )
    assert token == (
        "@ros2_lv/0/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
        f"std_msgs::msg::dds_::String_/{STRING_HASH}/::,7:,:,:,,"
    )


def test_namespaces_and_best_effort_in_a_token() -> None:
    token = endpoint_token(
        3, "ab", 1, 4, EntityKind.SUBSCRIPTION, "/robot", "front", "/robot/front/d2",
        "std_msgs/msg/Bool", "RIHS01_x", Qos(depth=1, best_effort=True),
    )  # fmt: skip
    assert token == (
        "@ros2_lv/3/ab/1/4/MS/%/%robot/front/%robot%front%d2/std_msgs::msg::dds_::Bool_/"
        "RIHS01_x/2::,1:,:,:,,"
    )


def test_attachment_is_33_bytes_sequence_stamp_length_gid() -> None:
    gid = bytes(range(16))
    data = encode_attachment(Attachment(1, 0x0102030405060708, gid))
    assert data.hex() == (
        "0100000000000000" + "0807060504030201" + "10" + "000102030405060708090a0b0c0d0e0f"
    )
    assert decode_attachment(data) == Attachment(1, 0x0102030405060708, gid)


@pytest.mark.parametrize(
    "data", [b"", bytes(16), bytes(17), bytes(16) + b"\x0f" + bytes(15)], ids=len
)
def test_a_foreign_attachment_layout_is_refused(data: bytes) -> None:
    with pytest.raises(UsageError):
        decode_attachment(data)


def test_a_gid_of_the_wrong_size_is_refused() -> None:
    with pytest.raises(UsageError, match="16 bytes"):
        encode_attachment(Attachment(1, 2, bytes(8)))


def test_relative_and_absolute_names() -> None:
    assert fully_qualified("/robot/front", "d2") == "/robot/front/d2"
    assert fully_qualified("/", "d2") == "/d2"
    assert fully_qualified("/robot", "/diagnostics") == "/diagnostics"
    for bad in ("a//b", "d2/", "bad name", "2d", "a/*", "a$b"):
        with pytest.raises(UsageError, match="not a valid ROS name"):
            fully_qualified("/robot", bad)


@pytest.mark.parametrize(
    ("payload", "expected"),
    [
        (msgs.bool_msg(True), "00010000" + "01"),
        (msgs.bool_msg(False), "00010000" + "00"),
        (msgs.float32_msg(1.5), "00010000" + "0000c03f"),
        (msgs.float64_msg(-1.0), "00010000" + "000000000000f0bf"),
        (msgs.int64_msg(5), "00010000" + "0500000000000000"),
    ],
)
def test_cdr_of_the_std_msgs(payload: bytes, expected: str) -> None:
    assert payload.hex() == expected


def test_stamped_messages_decode_to_what_was_encoded() -> None:
    stamp = msgs.Stamp(1_700_000_000_123_456_789)
    imu = msgs.decode(msgs.IMU, msgs.imu(stamp, "imu", (1.0, 2.0, 3.0), (4.0, 5.0, 6.0)))
    assert (imu.header.stamp.sec, imu.header.stamp.nanosec) == (1_700_000_000, 123_456_789)
    assert (imu.angular_velocity.z, imu.linear_acceleration.x) == (3.0, 4.0)
    assert imu.orientation_covariance[0] == -1.0  # no orientation (REP-145)
    battery = msgs.decode(msgs.BATTERY_STATE, msgs.battery_state(stamp, "bat", 11.5))
    assert battery.voltage == pytest.approx(11.5)
    status = msgs.Status(msgs.DIAG_WARN, "/robot/front", "text", "0x0001", {"k": "v"})
    array = msgs.decode(msgs.DIAGNOSTIC_ARRAY, msgs.diagnostic_array(stamp, [status]))
    assert [(s.level, s.name, s.values[0].key) for s in array.status] == [
        (msgs.DIAG_WARN, "/robot/front", "k")
    ]


@pytest.mark.parametrize(
    ("ros_type", "text"),
    [
        (msgs.BOOL, "bool data\n"),
        (msgs.FLOAT32, "float32 data\n"),
        (msgs.FLOAT64, "float64 data\n"),
        (msgs.INT64, "int64 data\n"),
    ],
)
def test_type_hashes_agree_with_an_independent_implementation(ros_type: str, text: str) -> None:
    sdk_utils = pytest.importorskip("zenoh_ros2_sdk.utils")
    assert msgs.type_hash(ros_type) == sdk_utils.get_type_hash(ros_type, text)


@pytest.mark.parametrize(
    "ros_type",
    [msgs.BOOL, msgs.FLOAT32, msgs.FLOAT64, msgs.INT64, msgs.IMU, msgs.RANGE,
     msgs.JOINT_STATE, msgs.BATTERY_STATE, msgs.DIAGNOSTIC_ARRAY],
)  # fmt: skip
def test_one_type_hash_serves_jazzy_and_kilted(ros_type: str) -> None:
    """The bridge hashes with Jazzy's definitions; Kilted's give the same RIHS01 for every
    type it publishes or takes, so the same keys route on both distributions."""
    from rosbags.typesys import Stores, get_typestore

    kilted = get_typestore(Stores.ROS2_KILTED)
    assert msgs.type_hash(ros_type) == kilted.hash_rihs01(ros_type)

"""Sans-IO core of the arduinoio wire protocol: no asyncio, no serial port.

``encode`` a request to bytes, feed received bytes to a :class:`Decoder`, get typed
frames back.  The message classes are the command table; ``docs/protocol.md`` describes
the same table for implementers of either side, and the firmware's header is generated
from it.
"""

from ._constants import (
    ANALOG_CHANNELS,
    ANALOG_MAX,
    BOARD_PAGE_BYTES,
    DEFAULT_BAUD,
    DUTY_FULL,
    ENCODER_SLOTS,
    ERROR_FLAG,
    FAILSAFE_MAX_TIMEOUT_MS,
    FAILSAFE_MIN_TIMEOUT_MS,
    FAST_BAUD,
    FILLER,
    FIRMWARE_BAUDS,
    FIRMWARE_VERSION,
    FRAMING_ERRORS,
    I2C_BLOCK_BYTES,
    I2C_BLOCK_SLOTS,
    I2C_MAX_LENGTH,
    INTER_BYTE_GAP_MS,
    LOW_LATENCY_PAD,
    MAX_BLOB,
    PAPER_BAUD,
    PROTOCOL_VERSION,
    PULSE_IN_SLOTS,
    PULSE_MAX_US,
    PULSE_MIN_US,
    RX_FIFO_SIZE,
    SERVO_DEFAULT_MAX_US,
    SERVO_DEFAULT_MIN_US,
    SERVO_PERIOD_US,
    SOFT_PWM_STEP_US,
    SONAR_DEFAULT_SPEED_DM_S,
    SONAR_NO_ECHO,
    SONAR_NO_READING,
    SONAR_SLOTS,
    SONAR_TIMEOUT_US,
    STEPPER_COUNT,
    STEPPER_MAX_ACCEL,
    STEPPER_MAX_SPEED,
    STREAM_FRAME_OVERHEAD,
    STREAM_LINK_SHARE_DEN,
    STREAM_LINK_SHARE_NUM,
    STREAM_MAX_PERIOD_US,
    STREAM_MAX_VALUES,
    STREAM_MIN_PERIOD_US,
    STREAM_PERIOD_STEP_US,
    TEMP_MV_AT_25C,
    TEMP_MV_PER_C,
    TEMP_REFERENCE_MV,
    TX_BUFFER_SIZE,
    VCC_MV,
    BoardModelId,
    ClassTag,
    Edge,
    EncoderMode,
    ErrorCode,
    Feature,
    Framing,
    GpioFlags,
    GpioState,
    I2CSpeed,
    SafeKind,
    SpiBitOrder,
    SpiClock,
    StatusFlags,
    StepperDoneReason,
    StreamFlags,
)
from ._decoder import Decoded, Decoder, Garbage, InvalidValues
from ._layout import Frame, checksum, crc16, crc_framed
from ._messages import EVENT_TYPES, REPLY_TYPES, REQUEST_TYPES, ErrorReply, Event, Reply, Request
from .commands import (
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
from .commands import descriptions as _descriptions  # noqa: F401 (says requests in errors)
from .commands.analog import *  # noqa: F403
from .commands.counter import *  # noqa: F403
from .commands.encoder import *  # noqa: F403
from .commands.failsafe import *  # noqa: F403
from .commands.gpio import *  # noqa: F403
from .commands.i2c import *  # noqa: F403
from .commands.misc import *  # noqa: F403
from .commands.pulse_in import *  # noqa: F403
from .commands.pwm import *  # noqa: F403
from .commands.sonar import *  # noqa: F403
from .commands.spi import *  # noqa: F403
from .commands.stepper import *  # noqa: F403
from .commands.stream import *  # noqa: F403
from .commands.transaction import *  # noqa: F403


def encode(message: Frame) -> bytes:
    """The wire bytes of a request (or, for board implementations, a reply)."""
    return message.encode()


__all__ = [
    "ANALOG_CHANNELS",
    "ANALOG_MAX",
    "BOARD_PAGE_BYTES",
    "DEFAULT_BAUD",
    "DUTY_FULL",
    "ENCODER_SLOTS",
    "ERROR_FLAG",
    "EVENT_TYPES",
    "FAILSAFE_MAX_TIMEOUT_MS",
    "FAILSAFE_MIN_TIMEOUT_MS",
    "FAST_BAUD",
    "FILLER",
    "FIRMWARE_BAUDS",
    "FIRMWARE_VERSION",
    "FRAMING_ERRORS",
    "I2C_BLOCK_BYTES",
    "I2C_BLOCK_SLOTS",
    "I2C_MAX_LENGTH",
    "INTER_BYTE_GAP_MS",
    "LOW_LATENCY_PAD",
    "MAX_BLOB",
    "PAPER_BAUD",
    "PROTOCOL_VERSION",
    "PULSE_IN_SLOTS",
    "PULSE_MAX_US",
    "PULSE_MIN_US",
    "REPLY_TYPES",
    "REQUEST_TYPES",
    "RX_FIFO_SIZE",
    "SERVO_DEFAULT_MAX_US",
    "SERVO_DEFAULT_MIN_US",
    "SERVO_PERIOD_US",
    "SOFT_PWM_STEP_US",
    "SONAR_DEFAULT_SPEED_DM_S",
    "SONAR_NO_ECHO",
    "SONAR_NO_READING",
    "SONAR_SLOTS",
    "SONAR_TIMEOUT_US",
    "STEPPER_COUNT",
    "STEPPER_MAX_ACCEL",
    "STEPPER_MAX_SPEED",
    "STREAM_FRAME_OVERHEAD",
    "STREAM_LINK_SHARE_DEN",
    "STREAM_LINK_SHARE_NUM",
    "STREAM_MAX_PERIOD_US",
    "STREAM_MAX_VALUES",
    "STREAM_MIN_PERIOD_US",
    "STREAM_PERIOD_STEP_US",
    "TEMP_MV_AT_25C",
    "TEMP_MV_PER_C",
    "TEMP_REFERENCE_MV",
    "TX_BUFFER_SIZE",
    "VCC_MV",
    "BoardModelId",
    "ClassTag",
    "Decoded",
    "Decoder",
    "Edge",
    "EncoderMode",
    "ErrorCode",
    "ErrorReply",
    "Event",
    "Feature",
    "Frame",
    "Framing",
    "Garbage",
    "GpioFlags",
    "GpioState",
    "I2CSpeed",
    "InvalidValues",
    "Reply",
    "Request",
    "SafeKind",
    "SpiBitOrder",
    "SpiClock",
    "StatusFlags",
    "StepperDoneReason",
    "StreamFlags",
    "checksum",
    "crc16",
    "crc_framed",
    "encode",
]
__all__ += misc.__all__
__all__ += gpio.__all__
__all__ += analog.__all__
__all__ += i2c.__all__
__all__ += pwm.__all__
__all__ += counter.__all__
__all__ += stepper.__all__
__all__ += encoder.__all__
__all__ += pulse_in.__all__
__all__ += sonar.__all__
__all__ += stream.__all__
__all__ += failsafe.__all__
__all__ += transaction.__all__
__all__ += spi.__all__

"""Tag values, error codes, flag bits and limits shared by host and firmware.

These numbers are the protocol: the firmware's C header is generated from this module and
the message table (``python -m arduinoio_async.protocol.cheader``), and a test fails when
the committed header drifts from them.  The class and descriptor tags keep the values of the
paper's original implementation; everything marked *extension* goes beyond the paper.
"""

from __future__ import annotations

from enum import IntEnum, IntFlag
from typing import Final

PROTOCOL_VERSION: Final = 1
FIRMWARE_VERSION: Final = (0, 1)


class ClassTag(IntEnum):
    """The first byte of every frame (CT)."""

    MISC = 0x01
    GPIO = 0x02
    ANALOG = 0x03
    I2C = 0x04
    PWM = 0x05
    COUNTER = 0x06
    STREAM = 0x07  # extension
    FAILSAFE = 0x08  # extension
    STEPPER = 0x09  # extension (issue 26)
    ENCODER = 0x0A  # extension: quadrature encoders
    SONAR = 0x0B  # extension: HC-SR04 style ultrasonic rangers
    PULSE_IN = 0x0C  # extension: pulse-width inputs (RC receiver channels)
    SPI = 0x0D  # extension: the SPI master bridge
    EVENT = 0x40  # extension: frames the board sends without a request


#: Set on the class tag of an error reply: ``CT | 0x80, DT, code, CS``.
ERROR_FLAG: Final = 0x80


class ErrorCode(IntEnum):
    """The code byte of an error reply."""

    BAD_CHECKSUM = 0x01
    UNKNOWN_CLASS = 0x02
    UNKNOWN_DESCRIPTOR = 0x03
    INCOMPLETE_FRAME = 0x04
    RX_OVERFLOW = 0x05
    PIN_NOT_CAPABLE = 0x06
    PIN_NOT_CONFIGURED = 0x07
    PIN_BUSY = 0x08
    VALUE_OUT_OF_RANGE = 0x09
    I2C_NACK_ADDRESS = 0x0A
    I2C_NACK_DATA = 0x0B
    I2C_TIMEOUT = 0x0C
    I2C_NOT_CONFIGURED = 0x0D
    LINK_CAPACITY = 0x0E
    FAILSAFE_TRIPPED = 0x0F
    EEPROM_FAILED = 0x10
    #: The request needs a stopped stepper (SET_POSITION while it moves).
    STEPPER_MOVING = 0x11
    #: A served board's server refuses a set-up of a slot (encoder, sonar, pulse input,
    #: I2C block) another live client holds; the board itself never sends it (a set-up of
    #: a slot in use reconfigures it).  A client that did not name the slot takes the next.
    SLOT_BUSY = 0x13
    #: The stream reads I2C blocks: the bus is the stream's until it stops (a one-shot
    #: read or write would collide with the stream's reads).
    I2C_STREAMING = 0x18
    #: The class is known, but this firmware image's build profile leaves it out
    #: (protocol/profiles.py); the capabilities' features word says so beforehand.
    #: An SPI transfer before SPI CONFIG (or after its pins were released).
    SPI_NOT_CONFIGURED = 0x16
    #: The SPI unit left master mode: D10 (the AVR's SS) was pulled low while it was an
    #: input; the board restores master mode, the transfer did not happen.
    SPI_MODE_FAULT = 0x17
    NOT_IN_IMAGE = 0x1A


#: Codes that mean the board could not find the request's frame boundaries: after sending
#: one of these it discards input until the line has been quiet for ``INTER_BYTE_GAP_MS``.
FRAMING_ERRORS: Final = frozenset(
    {
        ErrorCode.BAD_CHECKSUM,
        ErrorCode.UNKNOWN_CLASS,
        ErrorCode.UNKNOWN_DESCRIPTOR,
        ErrorCode.INCOMPLETE_FRAME,
        ErrorCode.RX_OVERFLOW,
    }
)


class GpioFlags(IntFlag):
    """Option bits of a GPIO configuration (the original implementation's layout)."""

    INPUT = 0
    OUTPUT = 0x01
    INITIAL_HIGH = 0x02
    PULL_UP = 0x04


class GpioState(IntFlag):
    """Bits of a GPIO read reply: the level and the edges latched since the last read."""

    LOW = 0
    HIGH = 0x01
    ROSE = 0x02
    FELL = 0x04


class I2CSpeed(IntEnum):
    """I2C bus clock."""

    KHZ_100 = 0
    KHZ_400 = 1


class Edge(IntEnum):
    """Which transition an event counter counts."""

    FALLING = 0
    RISING = 1


class StreamFlags(IntFlag):
    """What a stream sample carries besides the analog channels (extension)."""

    NONE = 0
    LEVELS = 0x01
    EDGES = 0x02
    COUNTERS = 0x04
    #: The i32 position of each of the STEPPER_COUNT stepper slots (extension, issue 26).
    STEPPERS = 0x08
    #: One i32 count per encoder slot (ENCODER_SLOTS of them, slot 0 first; a free
    #: slot reads 0).
    ENCODERS = 0x10
    #: The sonars: a u8 count n (the sonar slots 0..n-1 configured when the stream
    #: started), then per slot a u16 distance in mm (SONAR_NO_ECHO, SONAR_NO_READING) and
    #: a u8 age of that reading in 1.024 ms steps (255: that old or more).
    SONAR = 0x20
    #: The pulse inputs (extension): a u8 count n (the highest configured PULSE_IN slot
    #: + 1 when the stream started), then per slot 0..n-1 a u16 width in microseconds and
    #: a u8 lost flag (1: signal lost, or no input on that slot).
    PULSE_IN = 0x40
    #: The I2C register blocks (I2C_BLOCK_SLOTS of them, slot 0 first): per slot a u8
    #: length (0: a free slot), a u8 status (0: read this period; else the error code of
    #: the failed step) and that many bytes.
    I2C = 0x80


class EncoderMode(IntEnum):
    """Which of a quadrature encoder's four edges per cycle change its count (extension).

    ``X4`` counts every edge of A and B, ``X2`` every edge of A, ``X1`` one edge per cycle
    (A rising while B is low, going forward; the same edge undone going back).  The value
    is the counts per cycle.
    """

    X1 = 1
    X2 = 2
    X4 = 4


class SpiClock(IntEnum):
    """The SPI clock (extension): the system clock (16 MHz on a Uno) divided by 2**(n+1),
    the dividers the AVR's SPI unit has (SPR1:0 and SPI2X)."""

    MHZ_8 = 0
    MHZ_4 = 1
    MHZ_2 = 2
    MHZ_1 = 3
    KHZ_500 = 4
    KHZ_250 = 5
    KHZ_125 = 6

    @property
    def hz(self) -> int:
        """The clock in Hz at the Uno's 16 MHz."""
        return 16_000_000 >> (self.value + 1)


class SpiBitOrder(IntEnum):
    """Which bit of each byte goes out first on MOSI (extension)."""

    MSB_FIRST = 0
    LSB_FIRST = 1


class SafeKind(IntEnum):
    """What the failsafe does to a pin when it fires (extension)."""

    NONE = 0
    LEVEL = 1
    PULSE = 2
    #: A duty-cycle PWM output's duty (0-65535 of the period; 0 = stopped: a motor's safe
    #: state).
    DUTY = 3


class StepperDoneReason(IntEnum):
    """Why a stepper stopped (the StepperDone event, extension, issue 26)."""

    #: A move reached its target exactly.
    TARGET = 0
    #: STOP (decelerated or immediate) or a RUN at speed 0 came to rest.
    STOPPED = 1
    #: The limit switch on the negative side closed while it moved that way.
    LIMIT_MIN = 2
    #: The limit switch on the positive side closed while it moved that way.
    LIMIT_MAX = 3
    #: The failsafe tripped.
    FAILSAFE = 4


class StatusFlags(IntFlag):
    """Bits of the status reply (extension)."""

    NONE = 0
    FAILSAFE_ARMED = 0x01
    FAILSAFE_TRIPPED = 0x02
    STREAMING = 0x04


class Feature(IntFlag):
    """Feature bits of the capabilities reply (extension): a 32-bit word since duty PWM
    and CRC-16 framing took the 16th and 17th bits."""

    NONE = 0
    GPIO = 0x0001
    ANALOG = 0x0002
    I2C = 0x0004
    SERVO_PWM = 0x0008
    SOFT_PWM = 0x0010
    COUNTER = 0x0020
    TEMPERATURE = 0x0040
    EEPROM_ID = 0x0080
    STREAM = 0x0100
    FAILSAFE = 0x0200
    #: GpioWatch and GpioChange events (extension, docs/protocol.md 7.4).
    GPIO_CHANGES = 0x0400
    #: TRANSACTION: several requests in one frame (extension, docs/protocol.md 7.5).
    TRANSACTIONS = 0x0800
    #: COUNTER WATCH and CounterReport events (extension, docs/protocol.md 7.4).
    COUNTER_REPORTS = 0x1000
    #: ANALOG WATCH and AnalogChange events (extension, docs/protocol.md 7.4).
    ANALOG_CHANGES = 0x2000
    #: SET_LOW_LATENCY and filler bytes after replies (extension, docs/protocol.md 7.6).
    LOW_LATENCY = 0x4000
    #: PWM DUTY_CONFIG/DUTY_SET: duty-cycle PWM on the timers' pins (extension).
    DUTY_PWM = 0x8000
    #: SET_FRAMING: frames checked by CRC-16/CCITT-FALSE instead of the XOR byte
    #: (extension, docs/protocol.md 7.7).
    CRC16 = 0x10000
    #: STEPPER class: step/dir steppers with limit switches (extension, issue 26).
    STEPPER = 0x20000
    #: ENCODER class: quadrature encoders on pin-change/external interrupts, their counts
    #: in the stream and EncoderReport events (extension).
    ENCODER = 0x40000
    #: SONAR class: HC-SR04 style rangers fired in turn, echo timed by the board, in the
    #: stream (extension).
    SONAR = 0x80000
    #: PULSE_IN class: high-pulse widths on any digital pin (RC receiver channels), signal
    #: loss events (extension).
    PULSE_IN = 0x100000
    #: SPI class: the hardware SPI master on D11-D13 with any chip select (extension).
    SPI = 0x200000
    #: I2C BLOCK: register blocks the board reads from I2C devices every stream period,
    #: interrupt-driven, in the stream (extension).
    I2C_STREAM = 0x400000
    #: READ_BOARD_DESCRIPTION: the board model and, per function, the pins that can do
    #: it (extension, issue 29; protocol/boards.py).
    BOARD_DESCRIPTION = 0x800000


class Framing(IntEnum):
    """How a frame is checked (extension, docs/protocol.md 7.7; SET_FRAMING).

    ``XOR``: ``CT DT D0..Dn CS`` with one XOR byte, the paper's Eq. 1 (after every boot).
    ``CRC16``: ``CT DT D0..Dn CRCH CRCL``, CRC-16/CCITT-FALSE (polynomial 0x1021, initial
    value 0xFFFF, no reflection, no final XOR) of every byte before it, big-endian.
    """

    XOR = 0
    CRC16 = 1


#: Low-latency mode (extension): after the last reply of a burst the board sends filler
#: bytes of this value until the burst and its filler make ``LOW_LATENCY_PAD`` bytes, so
#: that more than 96 bytes wait in the Uno's 16U2 USB bridge (arduino-usbserial's
#: BUFFER_NEARLY_FULL), which then sends them at once instead of on its 4.096 ms tick.
#: No class tag is 0x00 and its error flag is clear, so a filler byte can never start a
#: frame; the board sends filler only between frames, so a host decoder drops every 0x00
#: found where a frame would start.
FILLER: Final = 0x00
LOW_LATENCY_PAD: Final = 97

#: The firmware answers nothing to a half-received frame until the line has been idle this
#: long; then it sends INCOMPLETE_FRAME and is ready for the next frame.  After a framing
#: error it discards bytes until the line has been idle this long.
INTER_BYTE_GAP_MS: Final = 10

#: Largest variable payload (I2C data, stream values) of any frame.
MAX_BLOB: Final = 32


class BoardModelId(IntEnum):
    """The board model a READ_BOARD_DESCRIPTION reply names (extension, issue 29)."""

    UNO_R3 = 0x01
    MEGA2560 = 0x02


#: Pin-map bytes one READ_BOARD_DESCRIPTION page carries at most: the reply's data is
#: 5 fixed bytes, a length byte and this many map bytes, within the largest reply data
#: (MAX_BLOB + 3 = 35 bytes).  A page holds as many whole function maps as fit.
BOARD_PAGE_BYTES: Final = 29
I2C_MAX_LENGTH: Final = 32

#: Receive FIFO and transmit buffer sizes of the firmware, in bytes.  A host that keeps
#: no more request bytes in flight than RX_FIFO_SIZE never overruns the board.
RX_FIFO_SIZE: Final = 128
TX_BUFFER_SIZE: Final = 192

#: The widths the board accepts (hobby servos travel over 500-2,500 us); a servo handle
#: keeps its own, narrower limits (by default SERVO_DEFAULT_MIN_US-SERVO_DEFAULT_MAX_US).
PULSE_MIN_US: Final = 500
PULSE_MAX_US: Final = 2500
#: A servo handle's limits unless it is given others: every hobby servo takes these
#: without hitting its end stops.
SERVO_DEFAULT_MIN_US: Final = 1000
SERVO_DEFAULT_MAX_US: Final = 2000
#: Duty-cycle PWM: the duty on the wire is 0-DUTY_FULL of the period (0 = always low,
#: DUTY_FULL = always high); the board rounds it to its timer's counts.
DUTY_FULL: Final = 0xFFFF
#: Software PWM widths (D2-D7) are set in steps of this many microseconds; each edge is a
#: timer compare match on the board (protocol extension: the paper's firmware had 100).
SOFT_PWM_STEP_US: Final = 1
SERVO_PERIOD_US: Final = 20000

#: Steppers (extension, issue 26): slots, the fastest step rate of one stepper (the board
#: steps from its 100 us tick, at most one step a tick) and the largest acceleration.
STEPPER_COUNT: Final = 4
STEPPER_MAX_SPEED: Final = 10000
STEPPER_MAX_ACCEL: Final = 1_000_000

ANALOG_MAX: Final = 1023
ANALOG_CHANNELS: Final = 6
VCC_MV: Final = 5000

#: Temperature sensor model (ATmega328P datasheet, typical): 314 mV at 25 C, 1 mV per C,
#: measured against the internal 1.1 V reference.
TEMP_REFERENCE_MV: Final = 1100
TEMP_MV_AT_25C: Final = 314
TEMP_MV_PER_C: Final = 1.0

#: Below 1 ms the board converts with a faster ADC clock (docs/protocol.md, STREAM).
STREAM_MIN_PERIOD_US: Final = 250
STREAM_MAX_PERIOD_US: Final = 60000
STREAM_PERIOD_STEP_US: Final = 50

#: A sample frame is 12 bytes plus its values; a stream may use at most 3/4 of the link's
#: byte rate (10 bit times per byte), leaving room for command replies.
STREAM_FRAME_OVERHEAD: Final = 12
#: Value bytes a sample may carry: the board's largest frame (MAX_BLOB + 7 bytes) less the
#: sample's 11 header bytes and a CRC-16 (with every analog channel, levels, edges and
#: counters a sample has 26; encoders add 4 bytes a slot).  48 carries 4 analog channels,
#: 4 encoders, a 14-byte IMU block (with the blocks' 4 header bytes) and 4 more bytes; the
#: board's sample buffer is this plus 13 bytes (61 B of RAM, 20 more than before).
STREAM_MAX_VALUES: Final = 48
STREAM_LINK_SHARE_NUM: Final = 3
STREAM_LINK_SHARE_DEN: Final = 4

#: I2C register blocks the stream can read each period (I2C BLOCK's slot is 0 to this - 1)
#: and the bytes all of them may hold together (the board's read buffer).
I2C_BLOCK_SLOTS: Final = 2
I2C_BLOCK_BYTES: Final = 16

#: Quadrature encoders the board decodes at once (ENCODER CONFIG's slot is 0 to this - 1).
ENCODER_SLOTS: Final = 4
#: Sonars (trigger + echo pin pairs) the board fires in turn (SONAR CONFIG's slot is 0 to
#: this - 1).
SONAR_SLOTS: Final = 4
#: A sonar's distance when its last firing heard no echo within SONAR_TIMEOUT_US.
SONAR_NO_ECHO: Final = 0xFFFF
#: A sonar's distance before its first firing (or a slot without a sonar, in the stream).
SONAR_NO_READING: Final = 0xFFFE
#: How long the board waits for an echo to end after the trigger (about 5 m away).
SONAR_TIMEOUT_US: Final = 30000
#: The speed of sound the board assumes until told otherwise: 343.0 m/s (dry air, 20 C),
#: in units of 0.1 m/s.
SONAR_DEFAULT_SPEED_DM_S: Final = 3430
#: Pulse-width inputs the board times at once (PULSE_IN CONFIG's slot is 0 to this - 1).
PULSE_IN_SLOTS: Final = 6

FAILSAFE_MIN_TIMEOUT_MS: Final = 20
FAILSAFE_MAX_TIMEOUT_MS: Final = 10000

#: Where the board ID lives in the AVR's EEPROM (big-endian, two bytes).
EEPROM_ID_ADDRESS: Final = 0
#: The paper's rate (Table IV was measured at it): UBRR 16 with U2X, really 117,647 baud.
PAPER_BAUD: Final = 115200
#: The default for new users (docs/performance.md, "Choosing the baud rate"): exact at
#: 16 MHz on both ends of a Uno's link (UBRR 1 with U2X, as the 16U2's own divider gives),
#: reported to work with the stock 16U2 firmware for short request/reply frames, supported
#: by CH340, FTDI and CP2102N bridges, and 8.7x the paper's byte rate.
DEFAULT_BAUD: Final = 1_000_000
#: The fastest exact rate (UBRR 0 with U2X); the stock 16U2 firmware has reported trouble
#: with heavy two-way traffic this fast, so it is a choice, not the default.
FAST_BAUD: Final = 2_000_000
#: Every rate the shipped firmware is built for.
FIRMWARE_BAUDS: Final = (PAPER_BAUD, DEFAULT_BAUD, FAST_BAUD)

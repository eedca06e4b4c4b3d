"""The Uno's three timers: who uses each, and the duty-cycle PWM frequencies they give.

Duty-cycle PWM (``analogWrite`` in Arduino terms) comes from a timer's output compare
units, so a pin's frequency is its timer's, and the pins of one timer share it.  The
firmware already gives every timer a job, which fixes what each can offer
(docs/motors.md, "Timers and pins"):

* **Timer0** (D6 = OC0A, D5 = OC0B) counts the fine alarms of software PWM and stream
  sampling while they run.  Duty PWM on D5/D6 takes the timer over in fast PWM mode, so it
  is refused while a software PWM output or a stream runs, and they are refused while it
  does.  Frequencies: 16 MHz / 256 / prescaler.
* **Timer1** (D9 = OC1A, D10 = OC1B, 16 bits) runs servo PWM; duty PWM uses TOP = ICR1,
  so any frequency in its table, with up to 16-bit resolution.  Servo and duty PWM cannot
  share it (the servo needs a 20 ms period).
* **Timer2** (D3 = OC2B, D11 = OC2A) is the board tick: 100 us periods, TOP = OCR2A.  D3
  can take duty PWM at the tick's own frequency (10 kHz, 200 steps); D11 cannot (OCR2A
  is the tick's period).

The nominal frequencies here are what the wire carries (``PwmDutyConfig.frequency_hz``);
:func:`exact_hz` gives the true value and :func:`duty_steps` the resolution.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Final

from .pins import D3, D5, D6, D9, D10, D11, DigitalPin

__all__ = [
    "DUTY_FREQUENCIES",
    "TIMER_OF",
    "Timer",
    "TimerSetting",
    "duty_steps",
    "exact_hz",
    "nearest_frequency",
    "timer_setting",
]

CPU_HZ: Final = 16_000_000


class Timer(IntEnum):
    """The ATmega328P's timers."""

    TIMER0 = 0
    TIMER1 = 1
    TIMER2 = 2

    def __str__(self) -> str:
        return f"Timer{int(self)}"


#: Which timer's output compare unit drives a pin.
TIMER_OF: Final[dict[DigitalPin, Timer]] = {
    D5: Timer.TIMER0,
    D6: Timer.TIMER0,
    D9: Timer.TIMER1,
    D10: Timer.TIMER1,
    D3: Timer.TIMER2,
    D11: Timer.TIMER2,
}


class TimerSetting(tuple[int, int]):
    """(prescaler, counts per period) of one offered frequency."""

    __slots__ = ()

    @property
    def prescaler(self) -> int:
        """Timer clock = 16 MHz / prescaler."""
        return self[0]

    @property
    def counts(self) -> int:
        """Timer counts in one period (TOP + 1): the duty's resolution in steps."""
        return self[1]


def _s(prescaler: int, counts: int) -> TimerSetting:
    return TimerSetting((prescaler, counts))


#: nominal Hz -> setting, per timer; the firmware's tables (firmware/src/duty.c) match.
_SETTINGS: Final[dict[Timer, dict[int, TimerSetting]]] = {
    Timer.TIMER0: {
        62500: _s(1, 256),
        7812: _s(8, 256),
        976: _s(64, 256),
        244: _s(256, 256),
        61: _s(1024, 256),
    },
    Timer.TIMER1: {
        31250: _s(1, 512),
        20000: _s(1, 800),
        3906: _s(1, 4096),
        976: _s(1, 16384),
        490: _s(1, 32653),
        244: _s(1, 65536),
    },
    Timer.TIMER2: {10000: _s(8, 200)},
}

#: The frequencies (nominal Hz) each timer offers, fastest first.
DUTY_FREQUENCIES: Final[dict[Timer, tuple[int, ...]]] = {
    timer: tuple(table) for timer, table in _SETTINGS.items()
}


def timer_setting(timer: Timer, frequency_hz: int) -> TimerSetting:
    """The prescaler and period of ``frequency_hz`` on ``timer`` (KeyError if not offered)."""
    return _SETTINGS[timer][frequency_hz]


def exact_hz(timer: Timer, frequency_hz: int) -> float:
    """The true frequency behind a nominal one (16 MHz / prescaler / counts)."""
    s = timer_setting(timer, frequency_hz)
    return CPU_HZ / s.prescaler / s.counts


def duty_steps(timer: Timer, frequency_hz: int) -> int:
    """How many steps the duty has at this frequency (timer counts in a period)."""
    return timer_setting(timer, frequency_hz).counts


def nearest_frequency(timer: Timer, wanted_hz: float) -> int:
    """The offered frequency of ``timer`` closest to ``wanted_hz`` (by ratio)."""
    offered = DUTY_FREQUENCIES[timer]
    return min(offered, key=lambda hz: max(hz / wanted_hz, wanted_hz / hz))

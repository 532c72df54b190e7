"""The time base of a table's ``t`` column: its unit, and whether it is plausible.

:func:`check_time_base` looks for the marks of another unit than the one read (epoch
magnitudes, large or whole-number steps, a rate above 100 kHz) and :class:`TimeBaseWatch`
does so for time stamps that come one by one: docs/log-formats.md, section "Time base".
This module imports no other module of gyrodrift.io, so that :mod:`gyrodrift.io.validate`
can import it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from gyrodrift.conventions import TIME_UNITS
from gyrodrift.errors import ConfigError, LogFormatError

__all__ = [
    "MAX_RATE_HZ",
    "MIN_RATE_HZ",
    "EPOCH_LIMIT",
    "MAX_STEP_S",
    "MAX_WHOLE_STEP_S",
    "time_scale",
    "TimeBase",
    "check_time_base",
    "time_base_notes",
    "TimeBaseWatch",
]

#: Highest plausible sample rate, Hz.
MAX_RATE_HZ = 1e5
#: Sample rates below this get a note, Hz.
MIN_RATE_HZ = 1.0
#: Time stamps above this cannot be seconds (3e4 years); seconds since 1970 are about 1.7e9.
EPOCH_LIMIT = 1e12
#: A median time step (in the file's numbers) at or above this is refused without ``time_unit``.
MAX_STEP_S = 1000.0
#: A median step of whole numbers at or above this is refused without ``time_unit``.
MAX_WHOLE_STEP_S = 10.0
#: Seconds since 1970 of years 1990 and 2200: the span that identifies an epoch time base.
_EPOCH_SPAN_S = (6.3e8, 7.3e9)
#: The most ordinary sample rate, Hz: the unit whose rate is nearest it (in log) is suggested.
_TYPICAL_RATE_HZ = 100.0


def time_scale(time_unit: str | None) -> tuple[str | None, float]:
    """The canonical name of ``time_unit`` (None: not given) and its multiplier to s.

    Raises
    ------
    ConfigError
        An unknown unit.
    """
    if time_unit is None:
        return None, 1.0
    key = str(time_unit).strip().lower().replace("µ", "u")
    if key not in TIME_UNITS:
        raise ConfigError(f"unknown time unit {time_unit!r}; use one of: {', '.join(TIME_UNITS)}")
    return key, TIME_UNITS[key]


class TimeBase(NamedTuple):
    """What :func:`check_time_base` found: a refusal, a note, or neither."""

    problem: str | None  #: why the time stamps cannot be in the unit read (None: they can)
    advice: str | None  #: what to do about the problem
    note: str | None  #: a low sample rate read anyway (None: nothing to say)


def _rate_text(rate_hz: float) -> str:
    """``rate_hz`` in Hz, kHz or MHz, three significant digits."""
    if rate_hz < 999.5:  # the unit chosen after rounding to three digits: 999.9999 kHz is 1 MHz
        return f"{rate_hz:.3g} Hz"
    return f"{rate_hz / 1e3:.3g} kHz" if rate_hz < 999.5e3 else f"{rate_hz / 1e6:.3g} MHz"


def _suggest(step_raw: float, t_max_raw: float, unit: str | None) -> str | None:
    """The time unit the numbers are most likely in: from an epoch magnitude, else the
    unit (other than ``unit``) whose sample rate is plausible and nearest 100 Hz."""
    others = [u for u in TIME_UNITS if u != (unit or "s")]
    if t_max_raw > EPOCH_LIMIT:
        for u in others:
            if _EPOCH_SPAN_S[0] <= t_max_raw * TIME_UNITS[u] <= _EPOCH_SPAN_S[1]:
                return u
    best, best_distance = None, math.inf
    for u in others:
        rate_hz = 1.0 / (step_raw * TIME_UNITS[u])
        if MIN_RATE_HZ <= rate_hz <= MAX_RATE_HZ:
            distance = abs(math.log10(rate_hz / _TYPICAL_RATE_HZ))
            if distance < best_distance:
                best, best_distance = u, distance
    return best


def check_time_base(t_raw: np.ndarray, unit: str | None) -> TimeBase:
    """Check that strictly increasing time stamps are plausible in the unit they are read in.

    Parameters
    ----------
    t_raw : numpy.ndarray
        The ``t`` column as in the file (before the unit's factor); one value is judged on
        its magnitude only.
    unit : str or None
        The canonical ``time_unit`` given (None: seconds, not stated; then the marks of
        another unit are looked for too).

    Returns
    -------
    TimeBase
        ``problem`` and ``advice`` when the time base is implausible, else ``note`` when
        the sample rate is below :data:`MIN_RATE_HZ`, else neither.
    """
    t_raw = np.asarray(t_raw, dtype=np.float64)
    if t_raw.size < 2:
        t_max_raw = float(np.max(np.abs(t_raw))) if t_raw.size else 0.0
        if unit is None and t_max_raw > EPOCH_LIMIT:
            suggested = _suggest(math.inf, t_max_raw, unit)
            return TimeBase(f"time stamps up to {t_max_raw:.6g} cannot be seconds (since 1970 or since boot)",
                            _advice(suggested), None)
        return TimeBase(None, None, None)
    step_raw = float(np.median(np.diff(t_raw)))
    step_s = step_raw * TIME_UNITS[unit or "s"]
    rate_hz = 1.0 / step_s
    t_max_raw = float(np.max(np.abs(t_raw)))
    read_as = f"read as {unit}" if unit else "read as seconds"
    problem = None
    if rate_hz > MAX_RATE_HZ:
        problem = f"the median time step {step_raw:.6g} {read_as} gives {_rate_text(rate_hz)}, above {_rate_text(MAX_RATE_HZ)}"
    elif unit is None and t_max_raw > EPOCH_LIMIT:
        problem = f"time stamps up to {t_max_raw:.6g} cannot be seconds (since 1970 or since boot)"
    elif unit is None and (step_raw >= MAX_STEP_S or (step_raw >= MAX_WHOLE_STEP_S and np.all(t_raw == np.floor(t_raw)))):
        problem = f"the median time step {step_raw:.6g} {read_as} gives {_rate_text(rate_hz)}"
    if problem is not None:
        return TimeBase(problem, _advice(_suggest(step_raw, t_max_raw, unit)), None)
    if rate_hz < MIN_RATE_HZ:
        return TimeBase(
            None, None,
            f"sample rate {_rate_text(rate_hz)} (median time step {step_s:.6g} s) is below {MIN_RATE_HZ:g} Hz; "
            "if t is not in seconds, pass --time-unit ms, us or ns (time_unit in Python)",
        )
    return TimeBase(None, None, None)


def _advice(suggested: str | None) -> str:
    """What to do about an implausible time base, the unit it looks like being ``suggested``."""
    if suggested:
        return f"t looks like {suggested}: pass --time-unit {suggested} (time_unit={suggested!r} in Python)"
    return f"check the t column (it must be a time; units: {', '.join(TIME_UNITS)} with --time-unit)"


class TimeBaseWatch:
    """:func:`check_time_base` for time stamps that come one by one, in the canonical ``unit``
    (None: seconds, not stated); when each is judged: docs/log-formats.md, section "Time base"."""

    #: Steps needed before the steps are judged.
    STEPS = 8
    #: Time stamps after which the time base is decided and no longer checked.
    DECIDED = 256

    def __init__(self, unit: str | None) -> None:
        self.unit = unit
        self._first: list[float] = []
        self._noted = False

    @property
    def decided(self) -> bool:
        """True once :data:`DECIDED` time stamps have come (no more are judged)."""
        return len(self._first) >= self.DECIDED

    def add(self, t_raw: float) -> TimeBase | None:
        """Take the next time stamp (in the stream's own unit); what it shows, or None."""
        first = self._first
        if len(first) >= self.DECIDED:
            return None
        first.append(float(t_raw))
        found = self._judged() if len(first) == 1 or len(first) > self.STEPS else None
        if found is not None and found.problem:
            first.pop()  # a refused time stamp is not taken
        return found

    def end(self) -> TimeBase | None:
        """At the end of the stream: the judgement of a stream of fewer than :data:`STEPS` steps."""
        return self._judged() if 1 < len(self._first) <= self.STEPS else None

    def _judged(self) -> TimeBase | None:
        found = check_time_base(np.asarray(self._first), self.unit)
        if found.problem:
            return found
        if found.note and not self._noted:
            self._noted = True
            return found
        return None


def time_base_notes(t_raw: np.ndarray, unit: str | None, name: str) -> tuple[str, ...]:
    """:func:`check_time_base` for the file ``name``: raise its refusal as a :class:`LogFormatError`
    (``<name>: column 't': <problem>; <advice>``), return its note."""
    found = check_time_base(t_raw, unit)
    if found.problem:
        raise LogFormatError(f"{name}: column 't': {found.problem}; {found.advice}")
    return (f"{name}: {found.note}",) if found.note else ()

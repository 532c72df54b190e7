"""The plausible range of every input value, and the check each entry point runs with it.

One definition of each limit, used by the table readers, the binary readers, the
in-memory compensation and the streaming :meth:`gyrodrift.Compensator.push`; the ranges
and why a value outside is refused: docs/log-formats.md, section "Plausible values".
"""

from __future__ import annotations

import math
from typing import Mapping, NamedTuple

import numpy as np

from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, HEADING, MAG_COLS, REF_HEADING, TEMP, TEMP_RANGE_C
from gyrodrift.errors import ConfigError, LogFormatError

__all__ = [
    "TEMP_RANGE_C",
    "GYRO_MAX_DPS",
    "HEADING_MAX_ABS_DEG",
    "MAG_MAX_ABS",
    "ACC_MAX_ABS",
    "LIMITED_COLS",
    "Limit",
    "check_gyro_max_dps",
    "limit_of",
    "first_outside",
    "outside_problem",
    "check_columns",
]

#: Default plausible full scale of a gyro axis, deg/s (``gyro_max_dps`` sets another).
GYRO_MAX_DPS = 10_000.0
#: Largest plausible magnitude of a heading before it is wrapped to [0, 360), deg.
HEADING_MAX_ABS_DEG = 1e6
#: Largest plausible magnitude of a magnetometer component, in any unit.
MAG_MAX_ABS = 1e8
#: Largest plausible magnitude of a specific-force component, g or m/s² (1000 g).
ACC_MAX_ABS = 1e4
#: The input columns that have a plausible range, in the order they are checked.
LIMITED_COLS = (TEMP, GYRO_Z, GYRO_X, GYRO_Y, HEADING) + MAG_COLS + ACC_COLS + (REF_HEADING,)

_GYRO_ADVICE = (
    "check the gyro unit (--gyro-unit) and the column; a rate this large is a corrupt record"
    " or a wrong column: repair or drop the row (gyro_max_dps sets another full scale)"
)


class Limit(NamedTuple):
    """The plausible range of one input column."""

    lo: float  #: smallest plausible value
    hi: float  #: largest plausible value
    unit: str  #: unit of the values, for messages
    advice: str  #: what to do about a value outside, for messages


def check_gyro_max_dps(gyro_max_dps) -> float:
    """Return ``gyro_max_dps`` as a float, or raise :class:`ConfigError` unless it is a
    positive finite number of deg/s."""
    ok = isinstance(gyro_max_dps, (int, float, np.integer, np.floating)) and not isinstance(gyro_max_dps, bool)
    if not (ok and math.isfinite(gyro_max_dps) and gyro_max_dps > 0):
        raise ConfigError(f"gyro_max_dps must be a positive number of deg/s (the gyro's full scale), got {gyro_max_dps!r}")
    return float(gyro_max_dps)


def limit_of(column: str, gyro_max_dps: float = GYRO_MAX_DPS, gyro_scale: float = 1.0,
             gyro_unit: str = "deg/s") -> Limit | None:
    """The plausible range of contract ``column`` (None: a column without one); a gyro column's
    in the unit whose multiplier to deg/s is ``gyro_scale`` (named ``gyro_unit`` in messages)."""
    if column == TEMP:
        lo, hi = TEMP_RANGE_C
        return Limit(lo, hi, "degC", "check the unit and the column (Kelvin? raw sensor counts?)")
    if column in (GYRO_X, GYRO_Y, GYRO_Z):
        hi = gyro_max_dps / gyro_scale
        return Limit(-hi, hi, gyro_unit, _GYRO_ADVICE)
    if column in (HEADING, REF_HEADING):
        return Limit(-HEADING_MAX_ABS_DEG, HEADING_MAX_ABS_DEG, "deg",
                     "give the heading in degrees (any turn count wraps into [0, 360)); the value is corrupt")
    if column in MAG_COLS:
        return Limit(-MAG_MAX_ABS, MAG_MAX_ABS, "(any unit)",
                     "check the magnetometer column; the value is corrupt or not a field reading")
    if column in ACC_COLS:
        return Limit(-ACC_MAX_ABS, ACC_MAX_ABS, "(g or m/s^2)",
                     "check the accelerometer column; the value is corrupt or not a specific force")
    return None


def first_outside(values: np.ndarray, limit: Limit) -> int | None:
    """Index of the first value outside ``limit`` (infinities included, NaN never), or None."""
    values = np.asarray(values, dtype=np.float64)
    # one pass each for the extremes (NaN skipped; NaN itself when all are): most logs stop here
    if values.size == 0 or not (np.fmin.reduce(values) < limit.lo or np.fmax.reduce(values) > limit.hi):
        return None
    with np.errstate(invalid="ignore"):
        outside = np.flatnonzero((values < limit.lo) | (values > limit.hi))
    return int(outside[0]) if outside.size else None


def outside_problem(column: str, value: float, limit: Limit) -> str:
    """The problem part of a message: ``gyro_z = 1e+16 deg/s is outside the plausible
    range -10000..10000 deg/s``."""
    return f"{column} = {float(value)!r} {limit.unit} is outside the plausible range {limit.lo:g}..{limit.hi:g} {limit.unit}"


def check_columns(source: str, columns: Mapping[str, object], gyro_max_dps: float = GYRO_MAX_DPS,
                  row0: int = 0) -> None:
    """Raise :class:`LogFormatError` for the first value outside its plausible range.

    ``columns`` maps contract column names to values (deg/s for the gyro; None skipped; a
    2-d value under ``"mag"`` or ``"acc"`` holds the x, y, z columns); the message names
    ``source``, ``row {row0 + index}`` and the column.
    """
    for name, values in columns.items():
        if values is None:
            continue
        arr = np.asarray(values, dtype=np.float64)
        names = {"mag": MAG_COLS, "acc": ACC_COLS}.get(name, (name,))
        for k, col in enumerate(names):
            limit = limit_of(col, gyro_max_dps)
            column = arr[:, k] if arr.ndim == 2 else arr
            pos = None if limit is None else first_outside(column, limit)
            if pos is not None:
                raise LogFormatError(
                    f"{source}: row {row0 + pos}, column {col!r}: {outside_problem(col, column[pos], limit)};"
                    f" {limit.advice}"
                )

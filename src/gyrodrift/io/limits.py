"""The plausible range of every input value, and the check each entry point runs with it.

One definition of each limit, used by the table readers (:func:`gyrodrift.io.validate.normalise_frame`,
whole or in chunks), the ULog and ROS bag readers (:func:`gyrodrift.io.align.contract_frame`),
:func:`gyrodrift.compensate_arrays` / :func:`gyrodrift.compensate` and the streaming
:meth:`gyrodrift.Compensator.push`:

==========================  =====================================  ===========================
input                       plausible                              why
==========================  =====================================  ===========================
``temp``                    :data:`TEMP_RANGE_C` (-60..150 degC)   gyro die temperature
``gyro_x/y/z``              ``|rate| <= gyro_max_dps``             default :data:`GYRO_MAX_DPS`
``heading``, ref_heading    ``|heading| <= HEADING_MAX_ABS_DEG``   wrapped to [0, 360) after
``mag_x/y/z``               ``|component| <= MAG_MAX_ABS``         any unit (only ratios used)
``acc_x/y/z``               ``|component| <= ACC_MAX_ABS``         g or m/s²
==========================  =====================================  ===========================

A value outside its range is refused, as a temperature outside :data:`TEMP_RANGE_C` always
was: one line naming the file (or the stream), the row and the column, and what to check.
Such a value is no reading of the sensor but a wrong column, a wrong unit or a corrupt
record (a flipped bit in a float gives 5e38), and a single one would otherwise dominate
everything integrated after it: a heading summed from a 1e16 deg/s rate keeps none of the
later rates' digits. An empty cell (NaN) is never out of range: it holds the previous gyro
or temperature value, or means "no compass sample".
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

#: Default plausible full scale of a gyro axis, deg/s. MEMS gyros saturate at 2000 to
#: 4000 deg/s (6000 for the fastest); a larger rate is a wrong unit, a wrong column or a
#: corrupt record. Set another one with ``gyro_max_dps`` (readers, compensate, Compensator).
GYRO_MAX_DPS = 10_000.0
#: Largest plausible magnitude of a heading before it is wrapped to [0, 360), deg (about
#: 2800 turns: an unwrapped yaw of a long log fits; 1e308 does not, and its remainder
#: modulo 360 carries no information).
HEADING_MAX_ABS_DEG = 1e6
#: Largest plausible magnitude of a magnetometer component, in any unit: the Earth's field is
#: about 0.5 gauss, 50 uT or 50 000 nT, and raw counts of a 16-bit sensor stay below 32 768.
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
    """The plausible range of ``column`` (None: a column without one).

    Parameters
    ----------
    column : str
        A contract column name.
    gyro_max_dps : float
        Plausible full scale of the gyro axes, deg/s.
    gyro_scale : float
        Multiplier from the unit the gyro values are in to deg/s (a table's ``gyro_unit``).
    gyro_unit : str
        That unit's name, for messages.
    """
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

    Parameters
    ----------
    source : str
        The name of the data, first in the message.
    columns : mapping of str to array_like
        Contract column name -> values (deg/s for the gyro); columns without a limit
        and None values are skipped; a 2-d value holds the x, y, z columns of ``mag_*``
        or ``acc_*`` (pass ``"mag"`` or ``"acc"`` as the name).
    gyro_max_dps : float
        Plausible full scale of the gyro axes, deg/s.
    row0 : int
        Row number of the first value (``row N`` in the message is ``row0 + index``).
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

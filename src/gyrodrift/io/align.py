"""Helpers shared by the binary-log readers (:mod:`~gyrodrift.io.ulog`,
:mod:`~gyrodrift.io.ardupilot`, :mod:`~gyrodrift.io.rosbag`).

The readers get streams at different rates (a fast gyro, a slow temperature, a
magnetometer in between) and put them on one time base: the gyro samples. The rules
live here so every reader applies them the same way:

* temperature and accelerometer: linear interpolation onto the gyro times, held at
  the first/last value outside the stream (:func:`interp_held`);
* magnetometer: each sample goes to the row of the first gyro sample at or after it,
  the other rows stay NaN (:func:`on_following_rows`);
* attitude heading: interpolated in unwrapped form, NaN outside the attitude stream
  (:func:`interp_heading`).

Times are in seconds, angles in degrees.
"""

from __future__ import annotations

from typing import Mapping, NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.conventions import (
    ACC_COLS,
    GYRO_X,
    GYRO_Y,
    GYRO_Z,
    MAG_COLS,
    REF_HEADING,
    T,
    TEMP,
    TEMP_RANGE_C,
    wrap_360,
)
from gyrodrift.errors import LogFormatError
from gyrodrift.io.limits import GYRO_MAX_DPS, LIMITED_COLS, first_outside, limit_of, outside_problem
from gyrodrift.io.messages import message
from gyrodrift.io.notes import NO_COMPASS, NO_TEMPERATURE_C, add_note, no_compass_note, no_temperature_note

__all__ = [
    "Stream",
    "increasing",
    "median_rate_hz",
    "interp_held",
    "interp_heading",
    "on_following_rows",
    "yaw_deg",
    "check_temperature",
    "contract_frame",
    "binary_log_frame",
    "describe_rate",
]


class Stream(NamedTuple):
    """One sensor stream read from a log: time stamps, values and where they came from."""

    label: str  #: where it came from, e.g. "sensor_gyro instance 0" or "topic '/imu'"
    t: np.ndarray  #: time (s), shape (n,)
    values: np.ndarray  #: values, shape (n,) or (n, k)


def increasing(stream: Stream) -> tuple[Stream, int]:
    """Sort a stream by time and drop samples with a repeated time stamp.

    Parameters
    ----------
    stream : Stream
        Samples in recording order; rows with a NaN time are dropped too.

    Returns
    -------
    Stream
        The same samples with strictly increasing ``t`` (the first sample of each
        repeated time stamp is kept, in recording order).
    int
        Number of samples dropped.
    """
    t = np.asarray(stream.t, dtype=np.float64)
    keep = np.flatnonzero(np.isfinite(t))
    order = keep[np.argsort(t[keep], kind="stable")]
    t_sorted = t[order]
    first = np.ones(t_sorted.size, dtype=bool)
    first[1:] = np.diff(t_sorted) > 0.0
    order = order[first]
    return Stream(stream.label, t[order], np.asarray(stream.values)[order]), int(t.size - order.size)


def median_rate_hz(t: np.ndarray) -> float:
    """Sample rate (Hz) from the median time step (s); 0.0 with fewer than two samples."""
    t = np.asarray(t, dtype=np.float64)
    if t.size < 2:
        return 0.0
    step = float(np.median(np.diff(t)))
    return 1.0 / step if step > 0.0 else float("inf")


def interp_held(t_src: np.ndarray, values: np.ndarray, t_dst: np.ndarray) -> np.ndarray:
    """Linear interpolation onto ``t_dst``, holding the first/last value outside ``t_src``.

    Parameters
    ----------
    t_src : numpy.ndarray
        Increasing source times (s), shape (n,).
    values : numpy.ndarray
        Source values, shape (n,) or (n, k); NaN samples are ignored.
    t_dst : numpy.ndarray
        Target times (s), shape (m,).

    Returns
    -------
    numpy.ndarray
        Shape (m,) or (m, k); all NaN for a column without any finite source value.
    """
    values = np.asarray(values, dtype=np.float64)
    columns = values.reshape(values.shape[0], -1)
    out = np.full((np.size(t_dst), columns.shape[1]), np.nan)
    for k in range(columns.shape[1]):
        ok = np.isfinite(columns[:, k])
        if ok.any():
            out[:, k] = np.interp(t_dst, t_src[ok], columns[ok, k])
    return out if values.ndim > 1 else out[:, 0]


def interp_heading(t_src: np.ndarray, heading_deg: np.ndarray, t_dst: np.ndarray) -> np.ndarray:
    """Interpolate a heading (deg) onto ``t_dst`` without jumps at the 0/360 wrap.

    The heading is unwrapped, interpolated linearly and wrapped to [0, 360) again.
    Target times outside ``[t_src[0], t_src[-1]]`` get NaN (a reference is not
    extrapolated). NaN source samples are ignored.
    """
    heading_deg = np.asarray(heading_deg, dtype=np.float64)
    ok = np.isfinite(heading_deg)
    out = np.full(np.size(t_dst), np.nan)
    if not ok.any():
        return out
    t_ok = t_src[ok]
    unwrapped = np.degrees(np.unwrap(np.radians(heading_deg[ok])))
    inside = (t_dst >= t_ok[0]) & (t_dst <= t_ok[-1])
    out[inside] = wrap_360(np.interp(t_dst[inside], t_ok, unwrapped))
    return out


def on_following_rows(t_rows: np.ndarray, t_src: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, int]:
    """Put each source sample on the row of the first ``t_rows`` at or after it.

    Rows without a sample are NaN. When several samples fall on one row, the latest
    one is kept. Samples before the first row or after the last row are dropped
    (they lie outside the gyro record).

    Parameters
    ----------
    t_rows : numpy.ndarray
        Strictly increasing row times (s), shape (m,).
    t_src : numpy.ndarray
        Increasing sample times (s), shape (n,).
    values : numpy.ndarray
        Samples, shape (n, k).

    Returns
    -------
    numpy.ndarray
        Shape (m, k), NaN on rows without a sample.
    int
        Number of rows that received a sample.
    """
    values = np.asarray(values, dtype=np.float64)
    out = np.full((np.size(t_rows), values.shape[1]), np.nan)
    inside = (t_src >= t_rows[0]) & (t_src <= t_rows[-1])
    rows = np.searchsorted(t_rows, t_src[inside], side="left")
    picked = values[inside]
    # the last sample of each row: first occurrence in the reversed order
    uniq, first_rev = np.unique(rows[::-1], return_index=True)
    out[uniq] = picked[rows.size - 1 - first_rev]
    return out, int(uniq.size)


def yaw_deg(w, x, y, z) -> np.ndarray:
    """Yaw (deg, in [-180, 180]) of a quaternion, Z-Y-X (yaw-pitch-roll) convention.

    ``yaw = atan2(2 (w z + x y), w² + x² − y² − z²)``: the rotation of the body x axis
    about the world z axis. For a unit quaternion the denominator equals the usual
    ``1 − 2 (y² + z²)``; this form also holds for a quaternion that is not normalised.
    In NED this is the heading (clockwise from north); in ENU it is measured
    counter-clockwise from east.
    """
    w, x, y, z = (np.asarray(v, dtype=np.float64) for v in (w, x, y, z))
    return np.degrees(np.arctan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z))


def check_temperature(name: str, where: str, temp_c: np.ndarray) -> None:
    """Raise :class:`LogFormatError` if a temperature (degC) is outside :data:`TEMP_RANGE_C`."""
    lo, hi = TEMP_RANGE_C
    with np.errstate(invalid="ignore"):
        outside = np.flatnonzero((temp_c < lo) | (temp_c > hi))
    if outside.size:
        value = float(temp_c[outside[0]])
        raise LogFormatError(
            message(
                name,
                f"temperature {value!r} degC (sample {int(outside[0]) + 1}) is outside"
                f" the plausible range {lo:g}..{hi:g} degC",
                "check that this is the gyro temperature in degC (not Kelvin or raw counts)",
                where=where,
            )
        )


def contract_frame(
    t: np.ndarray,
    gyro_dps: np.ndarray,
    temp_c: np.ndarray,
    mag: np.ndarray | None,
    acc: np.ndarray | None,
    ref_heading: np.ndarray | None,
    attrs: Mapping[str, object],
    *,
    gyro_max_dps: float = GYRO_MAX_DPS,
) -> pd.DataFrame:
    """Assemble the input-contract DataFrame (all float64) and set ``df.attrs``.

    Every value is checked against its plausible range (:mod:`gyrodrift.io.limits`);
    the first one outside raises :class:`LogFormatError` naming the file
    (``attrs["source"]``), the gyro sample (the row) and its time, and the column.

    Parameters
    ----------
    t : numpy.ndarray
        Time (s), shape (n,).
    gyro_dps : numpy.ndarray
        Rates (deg/s), FRD body axes x, y, z, shape (n, 3).
    temp_c : numpy.ndarray
        Gyro temperature (degC), shape (n,).
    mag, acc : numpy.ndarray or None
        Magnetometer and specific force, FRD, shape (n, 3); None for no columns.
    ref_heading : numpy.ndarray or None
        Reference heading (deg, [0, 360)), shape (n,), or None for no column.
    attrs : mapping
        Copied into ``df.attrs``.
    gyro_max_dps : float
        Plausible full scale of the gyro axes, deg/s.
    """
    columns = {
        T: t,
        GYRO_Z: gyro_dps[:, 2],
        GYRO_X: gyro_dps[:, 0],
        GYRO_Y: gyro_dps[:, 1],
        TEMP: temp_c,
    }
    if mag is not None:
        columns.update({c: mag[:, i] for i, c in enumerate(MAG_COLS)})
    if acc is not None:
        columns.update({c: acc[:, i] for i, c in enumerate(ACC_COLS)})
    if ref_heading is not None:
        columns[REF_HEADING] = ref_heading
    df = pd.DataFrame({k: np.asarray(v, dtype=np.float64) for k, v in columns.items()})
    for col in LIMITED_COLS:
        limit = limit_of(col, gyro_max_dps) if col in df.columns else None
        pos = None if limit is None else first_outside(df[col].to_numpy(), limit)
        if pos is not None:
            raise LogFormatError(
                message(
                    str(attrs.get("source", "log")),
                    outside_problem(col, df[col].iloc[pos], limit),
                    limit.advice,
                    where=f"gyro sample {pos + 1} (t = {float(t[pos]):.6f} s)",
                )
            )
    df.attrs = dict(attrs)
    return df


def describe_rate(t: np.ndarray) -> str:
    """Short text for a stream's sample count and rate, e.g. ``"31 samples, 1.0 Hz"``."""
    return f"{np.size(t)} samples, {median_rate_hz(t):.3g} Hz"


def binary_log_frame(name: str, fmt: str, t, gyro_dps, temp_c, mag, acc, ref_heading, *, topics: dict, summary: str,
                     no_compass_why: str, no_temp_why: str, gyro_max_dps: float, mag_unit: str = "gauss",
                     **extra_attrs) -> pd.DataFrame:
    """The frame of a binary log (:func:`contract_frame`) with the ``attrs`` its reader gives.

    ``attrs`` holds ``source`` (``name``), ``format`` (``fmt``), the units, ``frame``
    "ned", ``compass`` ("mag", or :data:`~gyrodrift.io.notes.NO_COMPASS` when ``mag`` is
    None), ``topics``, ``summary`` and ``extra_attrs``, with a note of a missing compass
    (``no_compass_why`` not empty) and of a missing temperature (``temp_c`` None: every
    row then reads :data:`~gyrodrift.io.notes.NO_TEMPERATURE_C`; ``no_temp_why`` says why).
    """
    attrs = {"source": name, "format": fmt, "gyro_unit": "deg/s", "frame": "ned",
             "compass": NO_COMPASS if mag is None else "mag",
             **({} if mag is None else {"mag_unit": mag_unit}),
             **({} if acc is None else {"acc_unit": "m/s^2"}),
             "topics": topics, "summary": summary, **extra_attrs}
    if no_compass_why:
        add_note(attrs, no_compass_note(name, no_compass_why))
    if temp_c is None:
        add_note(attrs, no_temperature_note(name, no_temp_why))
        temp_c = np.full(t.size, NO_TEMPERATURE_C)
    return contract_frame(t, gyro_dps, temp_c, mag, acc, ref_heading, attrs, gyro_max_dps=gyro_max_dps)

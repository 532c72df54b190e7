"""Helpers shared by the binary-log readers (ULog, DataFlash, telemetry log, ROS bag).

They put streams of different rates on one time base, the gyro samples, by the rules of
docs/log-formats.md, section "Alignment", and word the summary and notes every reader
gives. Times are in seconds, angles in degrees.
"""

from __future__ import annotations

from pathlib import Path
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
from gyrodrift.errors import ConfigError
from gyrodrift.io.limits import GYRO_MAX_DPS, LIMITED_COLS, check_gyro_max_dps, first_outside, limit_of, outside_problem
from gyrodrift.io.messages import log_error, one_line, option_error
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
    "check_instance",
    "check_reader_options",
    "no_instance",
    "measured_temperature",
    "compass_on_rows",
    "compass_parts",
    "reference_heading",
    "read_summary",
    "last_values",
]


class Stream(NamedTuple):
    """One sensor stream read from a log: time stamps, values and where they came from."""

    label: str  #: where it came from, e.g. "sensor_gyro instance 0" or "topic '/imu'"
    t: np.ndarray  #: time (s), shape (n,)
    values: np.ndarray  #: values, shape (n,) or (n, k)


def increasing(stream: Stream) -> tuple[Stream, int]:
    """Sort a stream by time, dropping NaN times and repeated time stamps (the first is kept).

    Returns
    -------
    Stream
        The samples with strictly increasing ``t``, in recording order within a time.
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

    ``values`` has shape (n,) or (n, k); NaN samples are ignored, and a column without
    a finite value gives NaN. Returns shape (m,) or (m, k).
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
    """Interpolate a heading (deg) onto ``t_dst`` in unwrapped form, wrapped to [0, 360).

    Times outside the source record get NaN; NaN source samples are ignored.
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
    """Put each source sample (shape (n, k)) on the row of the first ``t_rows`` at or after it.

    Rows without a sample are NaN; of several samples on one row the latest is kept;
    samples outside ``t_rows[0]..t_rows[-1]`` are dropped.

    Returns
    -------
    numpy.ndarray
        Shape (m, k).
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
    """Yaw (deg, in [-180, 180]) of a quaternion, Z-Y-X convention.

    ``atan2(2 (w z + x y), w² + x² − y² − z²)``, which holds for a quaternion that is
    not normalised (docs/log-formats.md, section "ROS bags").
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
        raise log_error(name, f"temperature {value!r} degC (sample {int(outside[0]) + 1}) is outside"
                        f" the plausible range {lo:g}..{hi:g} degC",
                        "check that this is the gyro temperature in degC (not Kelvin or raw counts)", where=where)


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
    """Assemble the input-contract DataFrame (all float64) with ``df.attrs`` = ``attrs``.

    ``gyro_dps``, ``mag`` and ``acc`` are (n, 3) FRD arrays (None: no columns), ``temp_c``
    and ``ref_heading`` (n,). The first value outside its plausible range
    (:mod:`gyrodrift.io.limits`) raises :class:`LogFormatError` naming the file
    (``attrs["source"]``), the gyro sample, its time and the column.
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
            raise log_error(str(attrs.get("source", "log")), outside_problem(col, df[col].iloc[pos], limit),
                            limit.advice, where=f"gyro sample {pos + 1} (t = {float(t[pos]):.6f} s)")
    df.attrs = dict(attrs)
    return df


def describe_rate(t: np.ndarray) -> str:
    """Short text for a stream's sample count and rate, e.g. ``"31 samples, 1.0 Hz"``."""
    return f"{np.size(t)} samples, {median_rate_hz(t):.3g} Hz"


def binary_log_frame(name: str, fmt: str, t, gyro_dps, temp_c, mag, acc, ref_heading, *, topics: dict, summary: str,
                     no_compass_why: str, no_temp_why: str, gyro_max_dps: float, mag_unit: str = "gauss",
                     **extra_attrs) -> pd.DataFrame:
    """The frame of a binary log (:func:`contract_frame`) with the ``attrs`` its reader gives.

    ``attrs``: ``source``, ``format``, the units, ``frame`` "ned", ``compass`` ("mag", or
    "none" when ``mag`` is None), ``topics``, ``summary``, ``extra_attrs``, and a note for
    a missing compass (``no_compass_why`` not empty) or temperature (``temp_c`` None:
    every row then reads :data:`~gyrodrift.io.notes.NO_TEMPERATURE_C`).
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


def check_instance(value, option: str, allow_none: bool = False) -> None:
    """Raise :class:`ConfigError` unless ``value`` is a non-negative int (or None if allowed)."""
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ConfigError(one_line(f"{option} must be a non-negative integer, got {value!r}"))


def check_reader_options(instances, mag_instance, gyro_max_dps) -> float:
    """Check a reader's ``instances`` (None: all) and ``mag_instance``; return ``gyro_max_dps`` checked."""
    for k in instances or ():
        check_instance(k, "instance")
    check_instance(mag_instance, "mag_instance", allow_none=True)
    return check_gyro_max_dps(gyro_max_dps)


def no_instance(name: str, kind: str, instance: int, present, option: str) -> ConfigError:
    """The error for a sensor ``instance`` the log lacks, listing those ``present``."""
    listed = ", ".join(str(k) for k in sorted(present))
    return option_error(name, f"there is no {kind} instance {instance}; instances present: {listed}",
                        f"choose one of them ({option}=N)")


def measured_temperature(label: str, t: np.ndarray, temp: np.ndarray, said: str = "logs",
                         samples: str = "samples") -> tuple[Stream | None, str]:
    """The samples of a temperature that holds a value; or None and why it counts as not measured
    (exactly 0 or NaN in every sample), worded "``label`` ``said`` 0 degC in all n ``samples``"."""
    ok = np.isfinite(temp)
    if ok.any() and np.any(temp[ok] != 0.0):
        return Stream(label, t[ok], temp[ok]), ""
    what = f"{NO_TEMPERATURE_C:g} degC" if ok.any() else "NaN"
    return None, f"{label} {said} {what} in all {temp.size} {samples}"


def compass_on_rows(t: np.ndarray, mag: Stream | None, acc, no_mag: str, no_acc: str, *, empty: str = "",
                    sample: str = "sample", record: str = "gyro") -> tuple[np.ndarray | None, int, str]:
    """The magnetometer samples on the rows ``t`` (None: no compass), the rows that got one, and
    why there is no compass (``""`` when there is): ``no_mag``, ``no_acc``, ``empty`` (a stream
    without samples, when given) or no ``sample`` within the ``record``."""
    if mag is None:
        return None, 0, no_mag
    if acc is None:
        return None, 0, no_acc
    if empty and mag.t.size == 0:
        return None, 0, empty
    on_rows, rows = on_following_rows(t, mag.t, mag.values)
    if rows == 0:
        return None, 0, f"no {sample} of {mag.label} falls within the {record} record, t = {t[0]:.3f}..{t[-1]:.3f} s"
    return on_rows, rows, ""


def compass_parts(mag: Stream | None, rows: int, acc: str | None) -> list[str]:
    """The compass part of a reader's summary: the magnetometer and accelerometer used (``rows``
    of them got a sample), or "no compass" and the accelerometer ``acc`` (None: none)."""
    if rows:
        return [f"compass: mag from {mag.label} ({describe_rate(mag.t)}, on {rows} rows) + acc from {acc}"]
    return ["no compass"] + ([f"acc from {acc}"] if acc is not None else [])


def reference_heading(ref: Stream | None, t: np.ndarray, reference: bool, source: str,
                      missing: str) -> tuple[np.ndarray | None, list[str]]:
    """``ref_heading`` on the rows ``t`` from the heading stream ``ref`` (None: no reference),
    and the summary's remark: "ref_heading from ``source``", or ``missing`` when asked for."""
    if ref is None:
        return None, [missing] if reference else []
    ref, _ = increasing(ref)
    return interp_heading(ref.t, ref.values, t), [f"ref_heading from {source}"]


def read_summary(name: str, t: np.ndarray, gyro: str, temp: Stream | None, compass: list[str], extra: list[str],
                 *, temp_rate: bool = True) -> str:
    """One line on what a reader read: span and rows, ``gyro``, the temperature (with its rate
    when ``temp_rate``), the ``compass`` parts and the ``extra`` remarks."""
    parts = [f"{Path(name).name}: {t[-1] - t[0]:.1f} s of data from t={t[0]:.3f} s, {t.size} rows", gyro]
    if temp is not None:
        rate = f" ({describe_rate(temp.t)}, interpolated)" if temp_rate else ""
        parts.append(f"temperature {np.min(temp.values):.1f}..{np.max(temp.values):.1f} degC from {temp.label}{rate}")
    else:
        parts.append(f"no gyro temperature (temp set to {NO_TEMPERATURE_C:g} degC)")
    return "; ".join(parts + compass + extra)


def last_values(pairs) -> tuple[dict, set]:
    """``{name: last value}`` of (name, value) pairs, and the names given more than one value."""
    values: dict = {}
    seen: dict[str, set] = {}
    for key, value in pairs:
        values[key] = value
        seen.setdefault(key, set()).add(value)
    return values, {k for k, v in seen.items() if len(v) > 1}

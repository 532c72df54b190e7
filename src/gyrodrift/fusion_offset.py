"""x-io Fusion's gyroscope offset correction and AHRS, run on a log: the ``fusion-offset`` and
``fusion-ahrs`` baselines, through the ``imufusion`` package (a benchmark and test dependency).

What the library does and how a log is fed to it: ``docs/heading_and_axes.md`` (x-io Fusion).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from gyrodrift.conventions import GYRO_X, GYRO_Y, GYRO_Z, T
from gyrodrift.errors import ConfigError

__all__ = [
    "PACKAGE", "available", "fusion_offset_drift", "fusion_ahrs_heading",
]

#: The Python package that runs x-io Fusion.
PACKAGE = "imufusion"


def _imufusion():
    """The ``imufusion`` module with ``Bias`` (1.3 or later), or None."""
    try:
        import imufusion
    except ImportError:
        return None
    return imufusion if hasattr(imufusion, "Bias") else None


def available() -> bool:
    """Whether ``imufusion`` (1.3 or later: ``imufusion.Bias``) can be imported."""
    return _imufusion() is not None


def _library(method: str):
    """The ``imufusion`` module, or a :class:`ConfigError` saying that ``method`` needs it."""
    imufusion = _imufusion()
    if imufusion is None:
        raise ConfigError(f"{method} needs the {PACKAGE} package (1.3 or later): pip install {PACKAGE}")
    return imufusion


def _axis(log: pd.DataFrame, name: str) -> np.ndarray:
    """A gyro column as floats (deg/s), gaps carried forward; zeros when absent or empty."""
    if name not in log.columns:
        return np.zeros(len(log))
    return log[name].ffill().fillna(0.0).to_numpy(float)


def _gyro(log: pd.DataFrame) -> np.ndarray:
    """The (n, 3) gyro of a log, deg/s (:func:`_axis` of x, y and z)."""
    return np.column_stack([_axis(log, GYRO_X), _axis(log, GYRO_Y), _axis(log, GYRO_Z)])


def fusion_offset_drift(
    log: pd.DataFrame,
    *,
    sample_rate_hz: float | None = None,
    stationary_threshold_dps: float | None = None,
    stationary_period_s: float | None = None,
) -> np.ndarray:
    """The gyro z drift that x-io Fusion's offset correction removes at each row, deg/s.

    Parameters
    ----------
    log : DataFrame
        ``t`` (s) and ``gyro_z`` (deg/s); ``gyro_x``, ``gyro_y`` when present, else zero.
    sample_rate_hz : float, optional
        Given to the library (default: one over the median time step).
    stationary_threshold_dps, stationary_period_s : float, optional
        The library's stillness threshold (deg/s, default 3) and period (s, default 3).

    Raises
    ------
    ConfigError
        ``imufusion`` missing, a column missing, fewer than two rows, or a bad setting.
    """
    imufusion = _library("fusion-offset")
    missing = [c for c in (T, GYRO_Z) if c not in log.columns]
    if missing:
        raise ConfigError(f"fusion-offset needs the column(s) {', '.join(missing)}")
    if len(log) < 2:
        raise ConfigError(f"fusion-offset needs at least 2 rows, got {len(log)}")
    settings = imufusion.BiasSettings()
    if sample_rate_hz is None:
        sample_rate_hz = 1.0 / float(np.median(np.diff(log[T].to_numpy(float))))
    for name, value in (("sample_rate_hz", sample_rate_hz), ("stationary_threshold_dps", stationary_threshold_dps),
                        ("stationary_period_s", stationary_period_s)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float, np.floating))
                                  or not math.isfinite(value) or value <= 0):
            raise ConfigError(f"fusion-offset {name} must be a positive number, got {value!r}")
    settings.sample_rate = float(sample_rate_hz)
    if stationary_threshold_dps is not None:
        settings.stationary_threshold = float(stationary_threshold_dps)
    if stationary_period_s is not None:
        settings.stationary_period = float(stationary_period_s)
    bias = imufusion.Bias()
    bias.set_settings(settings)

    gyro = _gyro(log)
    corrected_z = np.empty(len(log))
    update = bias.update
    for i, sample in enumerate(gyro):
        corrected_z[i] = update(sample)[2]
    return gyro[:, 2] - corrected_z


def fusion_ahrs_heading(log: pd.DataFrame, compass_heading: np.ndarray | None = None) -> np.ndarray:
    """Heading (deg, [0, 360)) of x-io Fusion's AHRS with its gyroscope offset correction, per row.

    ``log`` is in the input contract (deg/s, g, any magnetometer unit); ``compass_heading``
    (deg per row, NaN without a sample; default the log's ``heading``) is used when the log has
    no raw magnetometer. The settings: ``docs/heading_and_axes.md`` (x-io Fusion).
    """
    imufusion = _library("fusion-ahrs")
    t = log[T].to_numpy(float)
    if t.size < 2:
        raise ConfigError(f"fusion-ahrs needs at least 2 rows, got {t.size}")
    step = np.diff(t, prepend=t[0] - np.median(np.diff(t)))
    fs_hz = 1.0 / float(np.median(step))
    bias = imufusion.Bias()
    bias.set_settings(imufusion.BiasSettings(sample_rate=fs_hz, stationary_threshold=3.0, stationary_period=5.0))
    ahrs = imufusion.Ahrs()
    ahrs.set_settings(imufusion.AhrsSettings(
        sample_rate=fs_hz, convention=imufusion.CONVENTION_NED, gain=0.5, gyroscope_range=2000.0,
        acceleration_rejection=10.0, magnetic_rejection=10.0, rejection_timeout=int(5 * fs_hz)))
    gyro = _gyro(log)
    raw = all(c in log.columns for c in ("mag_x", "mag_y", "mag_z", "acc_x", "acc_y", "acc_z"))
    if raw:
        mag = log[["mag_x", "mag_y", "mag_z"]].to_numpy(float)
        acc = log[["acc_x", "acc_y", "acc_z"]].ffill().fillna(0.0).to_numpy(float)
        acc = -acc / np.median(np.linalg.norm(acc, axis=1))  # g, whatever the unit; Fusion takes +1 g on z when level (NED)
    else:
        heading = np.asarray(log["heading"] if compass_heading is None else compass_heading, dtype=float)
        level = np.array([0.0, 0.0, 1.0])  # level, as the raw path gives it
    # A compass read slower than the gyro: each update takes the latest sample, as firmware
    # holds its last magnetometer reading, until it is older than a second (an outage).
    has = np.isfinite(mag[:, 0]) if raw else np.isfinite(heading)
    last = np.where(has, np.arange(t.size), -1)
    last = np.maximum.accumulate(last)
    fresh = (last >= 0) & (t - t[np.maximum(last, 0)] <= 1.0)
    out = np.empty(t.size)
    for i in range(t.size):
        g = bias.update(gyro[i])
        ahrs.set_sample_period(float(step[i]))
        j = last[i]
        if not fresh[i]:
            ahrs.update_no_magnetometer(g, acc[i] if raw else level)
        elif raw:
            ahrs.update(g, acc[i], mag[j])
        else:
            ahrs.update_external_heading(g, level, heading[j])
        w, x, y, z = np.asarray(ahrs.get_quaternion(), dtype=float).ravel()[:4]
        out[i] = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return np.mod(np.degrees(out), 360.0)

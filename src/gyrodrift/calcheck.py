"""Apply a parameter file to a log the way the autopilot would, and report the drift left.

``gyrodrift calibrate --check PARAMS LOG``: the rates as the sensor gave them, corrected by
the file as the autopilot would (its slot, clip range, 32-bit floats and sensor frame), and
the drift left per axis, measured as the fit's residual (docs/autopilot-files.md, section
"Checking a file"). A file that makes the autopilot apply nothing has an empty
:attr:`Check.applied`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyrodrift.calibrate import (
    AXES,
    AXIS_COLUMNS,
    BIN_WIDTH_C,
    CalibrationError,
    bin_means,
    smooth_rate,
    sensor_rotation,
    temperature_bins,
    undo_onboard,
)
from gyrodrift.conventions import TEMP, T
from gyrodrift.errors import ConfigError
from gyrodrift.onboard import ardupilot_correction, px4_correction
from gyrodrift.paramfiles import param_file_format, param_values

__all__ = ["AxisLeft", "Check", "check_log"]

_WHO = {"px4": "PX4", "ardupilot": "ArduPilot"}


@dataclass(frozen=True)
class AxisLeft:
    """The drift of one body axis before and after the file, deg/s."""

    axis: str
    before_rms_dps: float  #: RMS of the bin means without the file (ArduPilot: about their average)
    left_rms_dps: float  #: the same with the file
    left_peak_dps: float  #: largest |bin mean| with the file (same reference)


@dataclass(frozen=True)
class Check:
    """The result of :func:`check_log` for one gyro."""

    params: str  #: the parameter file
    log: str  #: the log
    gyro: str  #: which gyro and frame, e.g. "IMU 0 (device id 2164234), AHRS_ORIENTATION=8 (ROLL_180)"
    autopilot: str  #: "px4" or "ardupilot"
    applied: str  #: the parameters the autopilot applies ("" when none)
    why_not: str  #: why the autopilot applies nothing ("" when it applies a correction)
    temp_min_c: float  #: the log's temperatures, degC
    temp_max_c: float
    file_min_c: float  #: the file's TMIN/TMAX for this gyro (NaN when nothing applies)
    file_max_c: float
    axes: tuple  #: AxisLeft per body axis in the log
    notes: tuple = ()  #: what was done to the log first (a correction undone)

    def lines(self) -> list[str]:
        """The report: two lines."""
        who = _WHO[self.autopilot]
        if self.applied:
            head = (f"{self.params} on {self.log}, {self.gyro}: {who} applies {self.applied}, clipped to "
                    f"{self.file_min_c:.1f}..{self.file_max_c:.1f} degC; the log spans "
                    f"{self.temp_min_c:.1f}..{self.temp_max_c:.1f} degC")
        else:
            head = f"{self.params} on {self.log}, {self.gyro}: {who} applies nothing to this gyro ({self.why_not})"
        about = " about its mean (ArduPilot's gyro calibration at boot takes the constant)" \
            if self.autopilot == "ardupilot" else ""
        left = ", ".join(f"{a.axis} {a.left_rms_dps:.4f} ({a.left_peak_dps:.4f})" for a in self.axes)
        before = ", ".join(f"{a.axis} {a.before_rms_dps:.4f}" for a in self.axes)
        return [head, f"drift left{about}, RMS of {BIN_WIDTH_C:g}-degC bin means (peak): {left} deg/s; "
                      f"without the file: {before} deg/s"]


def _correction(autopilot: str, values: dict, onboard, instance: int | None, where: str):
    """The correction the file makes the autopilot apply to the log's gyro, or (None, why)."""
    slot = instance if instance is not None else (onboard.instance if onboard is not None else 0)
    if autopilot == "px4":
        device = onboard.device_id if onboard is not None and instance is None else None
        return px4_correction(values, device, slot=slot, where=where)
    return ardupilot_correction(values, slot, where=where)


def check_log(params_path, log, *, rotation=None, rotation_text: str = "", instance: int | None = None,
              source: str | None = None) -> Check:
    """Apply the parameter file at ``params_path`` to one gyro's ``log`` as the autopilot would.

    Parameters
    ----------
    params_path : str or os.PathLike
        A PX4 ``.params`` or ArduPilot ``.param`` file.
    log : pandas.DataFrame
        One gyro's still heating run in the input contract; ``attrs["onboard"]`` when an
        autopilot's reader read it.
    rotation : 3x3 array_like, optional
        ``v_body = R @ v_sensor`` in place of the log's (identity for a log without ``onboard``).
    rotation_text : str
        Where ``rotation`` comes from.
    instance : int, optional
        The file's slot to apply, in place of the one the autopilot would pick.
    source : str, optional
        Name of the log (default ``attrs["source"]``).

    Returns
    -------
    Check

    Raises
    ------
    ConfigError
        Not an autopilot's parameter file; a file for the other autopilot than the log's;
        a slot that applies lacks a parameter.
    CalibrationError
        An unusable rotation, a correction the log holds that cannot be undone, or no rows
        with a time and a temperature.
    """
    where = str(params_path)
    source = source or str(log.attrs.get("source", "log"))
    autopilot = param_file_format(params_path)
    if autopilot == "json":
        raise ConfigError(f"{where}: --check applies an autopilot's parameter file (PX4 .params or ArduPilot "
                          ".param); a gyrodrift JSON calibration is no autopilot's")
    onboard = log.attrs.get("onboard")
    if onboard is not None and onboard.autopilot != autopilot:
        raise ConfigError(f"{where}: a {_WHO[autopilot]} file, but {source} is a {_WHO[onboard.autopilot]} log; "
                          "check a file on a log of the vehicle it is for")
    R, frame = sensor_rotation(onboard, rotation, rotation_text,
                               (np.eye(3), "no board rotation (the log's axes taken as the sensor's)"))
    log, notes = undo_onboard(log, onboard, R)
    values = param_values(params_path, autopilot)
    correction, why_not = _correction(autopilot, values, onboard, instance, where)
    t, temp = log[T].to_numpy(dtype=float), log[TEMP].to_numpy(dtype=float)
    ok = np.isfinite(t) & np.isfinite(temp)
    if ok.sum() < 2:
        raise CalibrationError(f"{source}: no rows with a time and a temperature to check the file on")
    temp = temp[ok]
    rates = np.column_stack([log[AXIS_COLUMNS[a]].to_numpy(dtype=float)[ok] if AXIS_COLUMNS[a] in log.columns
                             else np.zeros(temp.size) for a in AXES])
    offset = correction.offset_dps(temp, R, float32=True) if correction is not None else np.zeros_like(rates)
    corrected = rates - offset
    axes = []
    for i, a in enumerate(AXES):
        finite = np.isfinite(rates[:, i])
        if AXIS_COLUMNS[a] not in log.columns or finite.sum() < 2:
            continue
        bins = temperature_bins(temp[finite], float(temp[finite].min()))
        before = bin_means(smooth_rate(rates[finite, i]), bins)
        after = bin_means(smooth_rate(corrected[finite, i]), bins)
        if autopilot == "ardupilot":
            before, after = before - before.mean(), after - after.mean()
        axes.append(AxisLeft(a, float(np.sqrt(np.mean(before**2))), float(np.sqrt(np.mean(after**2))),
                             float(np.max(np.abs(after)))))
    gyro = frame if onboard is None else f"{onboard.gyro_name}, {frame}"
    return Check(where, source, gyro, autopilot, correction.names if correction is not None else "", why_not,
                 float(temp.min()), float(temp.max()),
                 correction.temp_min_c if correction is not None else math.nan,
                 correction.temp_max_c if correction is not None else math.nan, tuple(axes), tuple(notes))

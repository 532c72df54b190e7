"""Thermal calibration of the gyro triad, and parameter files for PX4 and ArduPilot.

:func:`fit_calibration` fits, for every gyro axis in a log (``gyro_x``, ``gyro_y``,
``gyro_z``; deg/s, body FRD, :mod:`gyrodrift.conventions`), the drift as a cubic in
temperature about a reference temperature, from a still heating or cooling run, as
the autopilots' own tools do. :func:`write_calibration` writes it for PX4, ArduPilot
or as gyrodrift's JSON; :func:`read_px4_params`, :func:`read_ardupilot_params` and
:func:`read_calibration_json` read those files back into the same
:class:`Calibration`; :func:`prior_config` starts the compensator's z-axis drift model
from one (``gyrodrift compensate --prior``).

The fit
-------
1. Rows with a finite time and temperature; per axis, the finite rates, median
   filtered over :data:`MEDIAN_WINDOW` samples (spikes; exact on a rate that is
   monotonic over the window).
2. ``T_ref`` is the middle of the temperatures seen, ``T_min``/``T_max`` their ends.
3. Weighted least squares of ``sum_k c_k (T - T_ref)**k`` (k = 0..3) over the samples,
   each :data:`BIN_WIDTH_C` temperature bin weighing the same in total, so that a
   plateau does not outweigh a ramp. Exact on noiseless cubic data.
4. The residual RMS (deg/s) of an axis is the RMS over the bins of the bin's mean
   residual: how far the drift departs from a cubic in temperature, with the white
   noise averaged out. :attr:`Calibration.residual_rms_dps` is the largest of the axes.

Refusals (:class:`CalibrationError`, one line naming the log and what to do):

* **span**: the temperatures span less than :data:`MIN_SPAN_C` (5 degC): a cubic over
  a few degrees extrapolates wildly (ArduPilot's onboard learning needs 10 degC,
  ``TEMP_RANGE_MIN`` of ``AP_InertialSensor_tempcal.cpp``);
* **moved**: a still unit's gyro reads only its drift, a smooth function of
  temperature. The unit is taken to have moved when a 1-s mean of any axis's filtered
  rate departs from the fitted curve by more than :data:`STILL_TOL_DPS` (0.5 deg/s,
  ten times the drift departures seen on MEMS fits and far above the noise of a 1-s
  mean), or, when the log has ``acc_x, acc_y, acc_z``, when a 1-s mean of the
  specific force tilts more than :data:`STILL_TILT_DEG` (2 deg) from its median
  direction. A drift that is not a function of temperature alone (heating and
  cooling in one log with hysteresis, a strong dependence on the heating rate) fails
  the rate test too, and the message says so. Known limit: a slow, steady turn about
  the vertical that the cubic can absorb is not detected (no sensor here sees it).

Facts used by the writers and readers (from the autopilots' sources and documentation)
-------------------------------------------------------------------------------------
PX4 (``PX4/PX4-Autopilot``):

* ``TC_G{i}_X{k}_{a}`` is the coefficient of ``(T - TC_G{i}_TREF)**k``, k = 0..3, for
  axis ``a`` = 0, 1, 2 (X, Y, Z) of gyro slot ``i``
  (``src/modules/temperature_compensation/temp_comp_params_gyro_0.yaml``; user guide
  ``en/advanced_config/sensor_thermal_calibration.md``, "Calibration Parameter
  Storage", which says the axes are those of the board frame).
* The offset is ``X0 + X1 d + X2 d**2 + X3 d**3`` with ``d = T - TREF`` and ``T``
  clipped to ``[TMIN, TMAX]`` (``TemperatureCompensation.cpp``,
  ``calc_thermal_offsets_3D``); it is *subtracted*: corrected = rotation x (raw -
  thermal offset - calibration offset), the rotation to the body frame coming after
  (``src/lib/sensor_calibration/Gyroscope.hpp``, ``Correct``). So the coefficients are
  the drift itself, gyrodrift's sign, in the board frame.
* The rates it corrects are ``sensor_gyro.x, y, z``: rad/s, FRD board frame
  (``msg/SensorGyro.msg``); ``Tools/process_sensor_caldata.py`` fits them as "bias
  (rad/s)". The coefficients are therefore rad/s per degC**k.
* ``process_sensor_caldata.py`` sets ``TMIN``/``TMAX`` to the log's extreme
  temperatures and ``TREF = (TMIN + TMAX) / 2``; gyrodrift does the same.
* PX4 subtracts ``CAL_GYRO*_OFF`` too, so ``X0`` must be the offset of the rates the
  log holds: raw ``sensor_gyro`` needs those offsets at 0, as the user guide's offboard
  procedure says; ``sensor_combined`` is already corrected (and thermally compensated
  when ``TC_G_ENABLE`` was 1), which the ULog reader's summary states.
* ``TC_G_ENABLE`` (boolean, reboot required, ``temp_comp_params_gyro.yaml``) must be 1;
  a slot is applied only to the gyro whose device id equals ``TC_G{i}_ID``
  (``TemperatureCompensation::set_sensor_id``): with no match nothing is corrected.
* The file: ``process_sensor_caldata.py`` writes a ``# Vehicle-Id Component-Id Name
  Value Type`` header, then tab-separated ``1 1 NAME VALUE TYPE`` lines, type 6 for
  the id and 9 for the floats: MAVLink ``MAV_PARAM_TYPE_INT32`` and
  ``MAV_PARAM_TYPE_REAL32`` (``common.xml``). This is QGroundControl's parameter file
  (mavros ``param.py``, ``QGroundControlParam``). PX4 keeps the values as 32-bit
  floats (about 7 digits).

ArduPilot (``ArduPilot/ardupilot``):

* ``INS_TCAL{n}_ENABLE`` (0 disabled, 1 enabled, 2 learn; reboot required),
  ``INS_TCAL{n}_TMIN``/``TMAX`` (degC, documented range -70..80) and
  ``INS_TCAL{n}_GYR{k}_X/Y/Z``, the k-th order coefficient, k = 1..3, for IMU ``n``
  (1 = the first) (``libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp``).
* The polynomial has no constant term and a fixed reference of 35 degC
  (``TEMP_REFERENCE``); stored coefficients are scaled by 1e6 (``SCALE_FACTOR``):
  ``P(T) = (GYR1 d + GYR2 d**2 + GYR3 d**3) * 1e-6``, ``d = T - 35``
  (``polynomial_eval``).
* The correction subtracts ``P(T)`` and adds back ``P(T_cal)``, both temperatures
  clamped to ``[TMIN, TMAX]``, ``T_cal`` being that of the gyro offset calibration
  (``correct_sensor``); the gyro offset is subtracted next. So ``P`` is the drift up
  to a constant, gyrodrift's sign; the constant is ArduPilot's own gyro calibration,
  and a file read back gives the curve up to a constant (:attr:`Calibration.offset_known`).
* It corrects the rates after the sensor's own rotation and before the board
  orientation (``AHRS_ORIENTATION``) is applied
  (``AP_InertialSensor_Backend.cpp``, ``_rotate_and_correct_gyro``), in rad/s
  (``Tools/scripts/tempcal_IMU.py`` undoes the board orientation, fits the gyro in
  rad/s against ``T - 35`` and plots it times ``degrees(1)``).
* Third order is what the firmware reads (pull request #16262); a fifth-order variant
  is an open experiment (pull request #27295).
* ``.param`` files: ``NAME,VALUE`` lines with ``#`` comments (Mission Planner; mavros
  ``param.py``, ``MissionPlannerParam``); ``tempcal_IMU.py`` writes ``NAME VALUE``, the
  firmware's persistent dump ``NAME=VALUE``. All three are read. Values are written
  without exponents, as ``tempcal_IMU.py`` intends.

Axis mapping: gyrodrift's ``gyro_x, gyro_y, gyro_z`` (deg/s, body FRD) become the
autopilot's axes 0, 1, 2 (X, Y, Z, rad/s) of its board frame through ``body_to_board``
(3x3 rotation, ``v_board = body_to_board @ v_body``), the identity when the flight
controller is mounted without a board rotation (PX4 ``SENS_BOARD_ROT = 0`` and no level
trims, ArduPilot ``AHRS_ORIENTATION = 0``), which the command line assumes. Numbers are
written with every digit of the double (``repr``), so a file read back gives the same
curve to rounding error.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from gyrodrift import __version__
from gyrodrift._atomic import write_bytes_atomic
from gyrodrift._text import printable
from gyrodrift.config import DRIFT_PARAM_BOUNDS, read_utf8
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, TEMP, T
from gyrodrift.errors import ConfigError, GyroDriftError

__all__ = [
    "AXES", "MIN_SPAN_C", "STILL_TOL_DPS", "STILL_TILT_DEG", "MEDIAN_WINDOW", "BIN_WIDTH_C", "ARDUPILOT_TREF_C",
    "ARDUPILOT_SCALE", "FORMATS", "CalibrationError", "AxisFit", "Calibration", "fit_calibration", "calibrate_file",
    "px4_parameters", "ardupilot_parameters", "calibration_json", "write_calibration", "output_format",
    "read_px4_params", "read_ardupilot_params", "read_calibration_json", "read_prior", "start_temperature",
    "prior_config", "prior_notes",
]

#: Gyro axes, in gyrodrift's column order (body FRD).
AXES = ("x", "y", "z")
_COLUMNS = {"x": GYRO_X, "y": GYRO_Y, "z": GYRO_Z}
#: Smallest temperature span (degC) a calibration is fitted over.
MIN_SPAN_C = 5.0
#: Largest departure (deg/s) of a 1-s mean rate from the fitted drift of a still unit.
STILL_TOL_DPS = 0.5
#: Largest tilt (deg) of a 1-s mean specific force from its median direction.
STILL_TILT_DEG = 2.0
_STILL_WINDOW_S = 1.0
#: Samples of the median filter applied to each rate before the fit (as PX4's tool).
MEDIAN_WINDOW = 31
#: Width (degC) of the temperature bins that weigh the same in the fit and the residual.
BIN_WIDTH_C = 0.25
_ORDER = 3
#: ArduPilot's fixed reference temperature, degC, and the scale of its stored coefficients.
ARDUPILOT_TREF_C = 35.0
ARDUPILOT_SCALE = 1.0e6
_RAD_PER_DEG = math.pi / 180.0
_PX4_INT32, _PX4_REAL32 = 6, 9  # MAVLink MAV_PARAM_TYPE of the id and of the floats
#: Output formats of :func:`write_calibration` and the file endings that name them.
FORMATS = {"px4": (".params",), "ardupilot": (".param", ".parm"), "json": (".json",)}
_JSON_FORMAT, _JSON_VERSION = "gyrodrift-calibration", 1


class CalibrationError(GyroDriftError, ValueError):
    """A log cannot give a thermal calibration (too small a span, the unit moved)."""


@dataclass(frozen=True)
class AxisFit:
    """The fitted drift of one axis.

    Attributes
    ----------
    coeffs : tuple of 4 floats
        ``c_0 .. c_3`` of ``drift = sum_k c_k (T - temp_ref_c)**k``, deg/s per degC**k
        (lowest power first, the order of PX4's ``X0 .. X3``).
    residual_rms_dps : float
        RMS over temperature bins of the mean residual, deg/s (module notes); NaN when
        read from an autopilot's file.
    """

    coeffs: tuple[float, float, float, float]
    residual_rms_dps: float = math.nan


@dataclass(frozen=True)
class Calibration:
    """A thermal calibration of the gyro axes (body FRD, deg/s).

    Attributes
    ----------
    axes : dict of str to AxisFit
        ``"x"``, ``"y"``, ``"z"``: those in the log (a file read back has all three).
    temp_ref_c, temp_min_c, temp_max_c : float
        Reference temperature and calibrated range, degC.
    samples : int
        Log rows used (0 when read from a file).
    source : str
        The log or file it came from.
    offset_known : bool
        False when read from an ArduPilot file: its curves are known up to a constant
        (module notes) and ``c_0`` is then 0 at ``temp_ref_c``.
    """

    axes: dict = field(default_factory=dict)
    temp_ref_c: float = 0.0
    temp_min_c: float = 0.0
    temp_max_c: float = 0.0
    samples: int = 0
    source: str = ""
    offset_known: bool = True

    @property
    def span_c(self) -> float:
        """Temperature span covered, degC."""
        return self.temp_max_c - self.temp_min_c

    @property
    def residual_rms_dps(self) -> float:
        """The largest residual RMS of the axes, deg/s (NaN when unknown)."""
        values = [f.residual_rms_dps for f in self.axes.values() if math.isfinite(f.residual_rms_dps)]
        return max(values) if values else math.nan

    def drift(self, axis: str, temp_c, *, clamp: bool = True) -> np.ndarray:
        """Drift of ``axis`` (deg/s) at ``temp_c`` (degC), clamped to the calibrated
        range as both autopilots do unless ``clamp`` is False."""
        temp = np.asarray(temp_c, dtype=float)
        if clamp:
            temp = np.clip(temp, self.temp_min_c, self.temp_max_c)
        return np.polynomial.polynomial.polyval(temp - self.temp_ref_c, self.axes[axis].coeffs)

    def slope(self, axis: str, temp_c) -> np.ndarray:
        """d(drift)/dT of ``axis`` (deg/s/degC) of the polynomial at ``temp_c`` (not clamped)."""
        deriv = np.polynomial.polynomial.polyder(self.axes[axis].coeffs)
        return np.polynomial.polynomial.polyval(np.asarray(temp_c, dtype=float) - self.temp_ref_c, deriv)

    def summary(self) -> str:
        """One line: axes, samples, temperature span and residuals."""
        each = ", ".join(f"{a} {f.residual_rms_dps:.4f}" for a, f in self.axes.items())
        return (
            f"calibrated gyro {', '.join(self.axes)} from {self.source}: {self.samples} samples, "
            f"{self.temp_min_c:.1f} to {self.temp_max_c:.1f} degC (span {self.span_c:.1f} degC), "
            f"residual RMS {self.residual_rms_dps:.4f} deg/s ({each})"
        )


def _fit_axis(temp: np.ndarray, rate: np.ndarray, temp_ref: float, temp_min: float) -> tuple[np.ndarray, float]:
    """Coefficients (deg/s per degC**k, lowest first) and residual RMS (deg/s) of one axis."""
    bins = np.floor((temp - temp_min) / BIN_WIDTH_C).astype(np.int64)
    counts = np.bincount(bins)
    weight = 1.0 / counts[bins]  # each occupied bin weighs 1 in total
    half = max(0.5 * (float(temp.max()) - float(temp.min())), 1e-9)
    u = (temp - temp_ref) / half  # scaled for conditioning; coefficients scaled back below
    vander = np.vander(u, _ORDER + 1, increasing=True)
    root_w = np.sqrt(weight)
    scaled, *_ = np.linalg.lstsq(vander * root_w[:, None], rate * root_w, rcond=None)
    coeffs = scaled / half ** np.arange(_ORDER + 1)
    residual = rate - np.polynomial.polynomial.polyval(temp - temp_ref, coeffs)
    occupied = counts > 0
    bin_mean = np.bincount(bins, residual)[occupied] / counts[occupied]
    return coeffs, float(np.sqrt(np.mean(bin_mean**2)))


def _window_means(t: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """1-s means of ``values`` (rows) and the mean time of each window."""
    window = np.floor((t - t[0]) / _STILL_WINDOW_S).astype(np.int64)
    counts = np.bincount(window)
    occupied = counts > 0
    t_mean = np.bincount(window, t)[occupied] / counts[occupied]
    cols = values.reshape(len(t), -1)
    means = np.stack([np.bincount(window, c)[occupied] / counts[occupied] for c in cols.T], axis=1)
    return t_mean, means


def _refuse_motion(source: str, t: float, what: str, *, tilted: bool) -> CalibrationError:
    cause = "the unit moved" if tilted else ("the unit moved, or its drift is not a function of temperature "
                                             "alone (heating and cooling mixed, or a fast temperature change)")
    return CalibrationError(
        f"{source}: at t = {t:.1f} s {what}: {cause}; a thermal calibration needs a still run that only heats "
        "(or only cools), slowly: cut the log to such a stretch or record it again without touching the unit"
    )


def _check_tilt(log, ok: np.ndarray, t: np.ndarray, source: str) -> None:
    """Refuse when the 1-s mean specific force tilts more than STILL_TILT_DEG (module notes)."""
    if not all(c in log.columns for c in ACC_COLS):
        return
    acc = log.loc[ok, list(ACC_COLS)].to_numpy(dtype=float)
    rows = np.all(np.isfinite(acc), axis=1)
    if rows.sum() < 2:
        return
    t_mean, means = _window_means(t[rows], acc[rows])
    dirs = means / np.linalg.norm(means, axis=1, keepdims=True)
    ref = np.median(dirs, axis=0)
    ref = ref / np.linalg.norm(ref)
    tilt = np.degrees(np.arccos(np.clip(dirs @ ref, -1.0, 1.0)))
    worst = int(np.argmax(tilt))
    if tilt[worst] > STILL_TILT_DEG:
        raise _refuse_motion(source, t_mean[worst], f"the accelerometer tilted {tilt[worst]:.1f} deg, "
                                                     f"more than {STILL_TILT_DEG:g}", tilted=True)


def fit_calibration(log, *, source: str = "log", min_span_c: float = MIN_SPAN_C,
                    still_tol_dps: float = STILL_TOL_DPS) -> Calibration:
    """Fit the thermal calibration of every gyro axis of a still heating or cooling log.

    Parameters
    ----------
    log : pandas.DataFrame
        A log in the input contract (``t`` s, ``temp`` degC, ``gyro_z`` and, when
        present, ``gyro_x``, ``gyro_y`` in deg/s, body FRD; optional ``acc_*``).
    source : str
        Name of the log, for the messages.
    min_span_c : float
        Smallest temperature span accepted, degC (default :data:`MIN_SPAN_C`).
    still_tol_dps : float
        Largest departure of a 1-s mean rate from the fitted drift, deg/s.

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        Too few samples or too small a temperature span, or the unit moved (module notes).

    Examples
    --------
    >>> import pandas as pd
    >>> t = np.linspace(0.0, 600.0, 6001)
    >>> temp = 20.0 + t / 20.0
    >>> cal = fit_calibration(pd.DataFrame({"t": t, "temp": temp, "gyro_z": 0.1 + 0.02 * (temp - 35.0)}))
    >>> [round(c, 9) + 0.0 for c in cal.axes["z"].coeffs], cal.temp_ref_c
    ([0.1, 0.02, 0.0, 0.0], 35.0)
    """
    t_all = log[T].to_numpy(dtype=float)
    temp_all = log[TEMP].to_numpy(dtype=float)
    ok = np.isfinite(t_all) & np.isfinite(temp_all)
    t, temp = t_all[ok], temp_all[ok]
    if t.size < 2 * MEDIAN_WINDOW:
        raise CalibrationError(f"{source}: {t.size} rows with a time and a temperature; a thermal calibration "
                               f"needs at least {2 * MEDIAN_WINDOW}: give the whole heating run")
    t_min, t_max = float(temp.min()), float(temp.max())
    if t_max - t_min < min_span_c:
        raise CalibrationError(
            f"{source}: the temperature spans only {t_max - t_min:.2f} degC ({t_min:.2f} to {t_max:.2f}); a thermal "
            f"calibration needs at least {min_span_c:g} degC: record a still heating or cooling run over the "
            "temperatures the vehicle will see"
        )
    t_ref = 0.5 * (t_min + t_max)
    from scipy.ndimage import median_filter  # imported here: scipy.ndimage costs 0.2 s at start-up

    axes = {}
    for axis in AXES:
        col = _COLUMNS[axis]
        if col not in log.columns:
            continue
        rate = log[col].to_numpy(dtype=float)[ok]
        finite = np.isfinite(rate)
        if finite.sum() < 2 * MEDIAN_WINDOW:
            continue
        ta, tempa = t[finite], temp[finite]
        smooth = median_filter(rate[finite], size=MEDIAN_WINDOW, mode="nearest")
        coeffs, residual = _fit_axis(tempa, smooth, t_ref, t_min)
        t_mean, means = _window_means(ta, np.column_stack([smooth, tempa]))
        departure = np.abs(means[:, 0] - np.polynomial.polynomial.polyval(means[:, 1] - t_ref, coeffs))
        worst = int(np.argmax(departure))
        if departure[worst] > still_tol_dps:
            raise _refuse_motion(source, t_mean[worst], f"a 1-s mean of {col} departs {departure[worst]:.2f} deg/s "
                                                         f"from the drift curve, more than {still_tol_dps:g}",
                                 tilted=False)
        axes[axis] = AxisFit(tuple(float(c) for c in coeffs), residual)
    if "z" not in axes:
        raise CalibrationError(f"{source}: too few gyro_z values for a thermal calibration; give the whole heating run")
    _check_tilt(log, ok, t, source)
    return Calibration(axes, t_ref, t_min, t_max, int(t.size), source)


def calibrate_file(path, **read_options) -> Calibration:
    """:func:`fit_calibration` of the log at ``path`` (read with :func:`gyrodrift.io.read_log`
    and ``read_options``)."""
    from gyrodrift.io import read_log

    return fit_calibration(read_log(path, **read_options), source=str(path))


# ---------------------------------------------------------------------------- frames and polynomials


def _rotation(body_to_board) -> np.ndarray:
    """The 3x3 rotation ``v_board = R @ v_body`` (identity when None), checked."""
    if body_to_board is None:
        return np.eye(3)
    R = np.asarray(body_to_board, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
            or np.linalg.det(R) <= 0:
        raise ConfigError(f"body_to_board must be a 3x3 rotation matrix (orthonormal, determinant +1), got {R.tolist()}")
    return R


def _board_coeffs(cal: Calibration, R: np.ndarray) -> np.ndarray:
    """Coefficients (deg/s per degC**k) as a (k, board axis) array; axes not in ``cal`` count as 0."""
    body = np.zeros((_ORDER + 1, 3))
    for i, axis in enumerate(AXES):
        if axis in cal.axes:
            body[:, i] = cal.axes[axis].coeffs
    return body @ R.T


def _shift(coeffs: np.ndarray, delta: float) -> np.ndarray:
    """Coefficients about ``ref + delta`` of the polynomial with ``coeffs`` about ``ref`` (rows = powers)."""
    n = coeffs.shape[0]
    out = np.zeros_like(coeffs)
    for j in range(n):
        for k in range(j, n):
            out[j] += coeffs[k] * math.comb(k, j) * delta ** (k - j)
    return out


def _missing_note(cal: Calibration) -> list[str]:
    missing = [_COLUMNS[a] for a in AXES if a not in cal.axes]
    if not missing:
        return []
    return [f"{', '.join(missing)} not in the log: their coefficients are written as 0 (no compensation)"]


def _number(value: float) -> str:
    """Every digit of the double, without an exponent."""
    return np.format_float_positional(float(value), unique=True, trim="-")


# ---------------------------------------------------------------------------- writers


def px4_parameters(cal: Calibration, *, instance: int = 0, device_id: int = 0, body_to_board=None) -> list:
    """PX4's gyro thermal-compensation parameters of ``cal`` (module notes).

    Parameters
    ----------
    cal : Calibration
    instance : int
        Gyro slot ``i`` of ``TC_G{i}_*`` (0..3).
    device_id : int
        ``TC_G{i}_ID``: the device id of the gyro (0 = unknown: PX4 applies nothing).
    body_to_board : 3x3 array_like, optional
        Rotation from gyrodrift's body FRD axes to the board frame (default identity).

    Returns
    -------
    list of (str, int or float, int)
        ``(name, value, MAVLink type)``: ``TC_G_ENABLE`` = 1, ``TC_G{i}_ID``,
        ``TC_G{i}_TMIN``, ``TMAX``, ``TREF`` (degC) and ``TC_G{i}_X{k}_{a}`` (rad/s per
        degC**k, board axis a), in that order.
    """
    if isinstance(instance, bool) or not isinstance(instance, int) or not 0 <= instance <= 3:
        raise ConfigError(f"PX4 gyro slot must be 0 to 3, got {instance!r}")
    if isinstance(device_id, bool) or not isinstance(device_id, int) or not -(2**31) <= device_id < 2**32:
        raise ConfigError(f"PX4 device id must be a 32-bit whole number, got {device_id!r}")
    board = _board_coeffs(cal, _rotation(body_to_board)) * _RAD_PER_DEG
    g = f"TC_G{instance}_"
    params = [("TC_G_ENABLE", 1, _PX4_INT32), (g + "ID", device_id - 2**32 if device_id >= 2**31 else device_id,
                                                _PX4_INT32)]
    params += [(g + "TMIN", cal.temp_min_c, _PX4_REAL32), (g + "TMAX", cal.temp_max_c, _PX4_REAL32),
               (g + "TREF", cal.temp_ref_c, _PX4_REAL32)]
    params += [(f"{g}X{k}_{a}", float(board[k, a]), _PX4_REAL32) for k in range(_ORDER + 1) for a in range(3)]
    return params


def ardupilot_parameters(cal: Calibration, *, instance: int = 0, body_to_board=None) -> list:
    """ArduPilot's gyro temperature-calibration parameters of ``cal`` (module notes).

    Parameters
    ----------
    cal : Calibration
    instance : int
        IMU index from 0; the parameters are ``INS_TCAL{instance + 1}_*`` (1..3).
    body_to_board : 3x3 array_like, optional
        Rotation from gyrodrift's body FRD axes to the board frame (default identity).

    Returns
    -------
    list of (str, float)
        ``INS_TCAL{n}_ENABLE`` = 1, ``TMIN``, ``TMAX`` (degC), then
        ``INS_TCAL{n}_GYR{k}_{X,Y,Z}``: coefficient of ``(T - 35)**k`` in rad/s per
        degC**k times 1e6, k = 1..3. The constant is left to ArduPilot's gyro
        calibration; accelerometer coefficients are not written (those on the vehicle stay).
    """
    if isinstance(instance, bool) or not isinstance(instance, int) or not 0 <= instance <= 2:
        raise ConfigError(f"ArduPilot IMU index must be 0 to 2 (INS_TCAL1..3), got {instance!r}")
    board = _shift(_board_coeffs(cal, _rotation(body_to_board)), ARDUPILOT_TREF_C - cal.temp_ref_c)
    stored = board * _RAD_PER_DEG * ARDUPILOT_SCALE
    p = f"INS_TCAL{instance + 1}_"
    params = [(p + "ENABLE", 1), (p + "TMIN", cal.temp_min_c), (p + "TMAX", cal.temp_max_c)]
    params += [(f"{p}GYR{k}_{'XYZ'[a]}", float(stored[k, a])) for k in range(1, _ORDER + 1) for a in range(3)]
    return params


def calibration_json(cal: Calibration) -> dict:
    """gyrodrift's own calibration document (the fields :func:`read_calibration_json` reads)."""
    def num(v):
        return float(v) if math.isfinite(v) else None

    return {
        "format": _JSON_FORMAT, "version": _JSON_VERSION, "software": f"gyrodrift {__version__}",
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"), "source": cal.source,
        "model": "drift(T) = sum_k coeffs[k] * (clip(T, temp_min_c, temp_max_c) - temp_ref_c)**k, k = 0..3; "
                 "gyro_corrected = gyro - drift",
        "units": {"coeffs": "deg/s per degC**k", "temperatures": "degC", "residual_rms_dps": "deg/s"},
        "frame": "body FRD: gyrodrift's gyro_x, gyro_y, gyro_z",
        "temp_ref_c": cal.temp_ref_c, "temp_min_c": cal.temp_min_c, "temp_max_c": cal.temp_max_c,
        "span_c": cal.span_c, "samples": cal.samples, "offset_known": cal.offset_known,
        "residual_rms_dps": num(cal.residual_rms_dps),
        "axes": {a: {"coeffs": list(f.coeffs), "residual_rms_dps": num(f.residual_rms_dps)} for a, f in cal.axes.items()},
    }


def output_format(path, fmt: str | None = None) -> str:
    """``fmt`` checked, or the format named by the ending of ``path`` (:data:`FORMATS`)."""
    if fmt is not None:
        if fmt not in FORMATS:
            raise ConfigError(f"unknown calibration format {fmt!r}; choose one of: {', '.join(FORMATS)}")
        return fmt
    name = Path(path).name.lower()
    for key, endings in FORMATS.items():
        if name.endswith(endings):
            return key
    raise ConfigError(f"{path}: cannot tell the calibration format from the file name; give --format "
                      f"({', '.join(FORMATS)}) or end it in .params (px4), .param (ardupilot) or .json")


def write_calibration(cal: Calibration, path, fmt: str | None = None, *, instance: int = 0, device_id: int = 0,
                      body_to_board=None) -> list[str]:
    """Write ``cal`` to ``path`` atomically as ``fmt`` (``px4``, ``ardupilot``, ``json``;
    default by the file name, :func:`output_format`).

    Parameters
    ----------
    cal : Calibration
    path : str or os.PathLike
    fmt : str, optional
    instance : int
        Gyro slot (PX4 ``TC_G{instance}``) or IMU index (ArduPilot ``INS_TCAL{instance+1}``).
    device_id : int
        PX4 only: ``TC_G{i}_ID``.
    body_to_board : 3x3 array_like, optional
        Rotation from body FRD to the autopilot's board frame (default identity).

    Returns
    -------
    list of str
        Notes for the user (one sentence each), e.g. axes written as 0 or an unknown
        PX4 device id.
    """
    fmt = output_format(path, fmt)
    notes = [] if fmt == "json" else _missing_note(cal)
    header = f"gyro thermal calibration by gyrodrift {__version__} from {printable(cal.source)}; residual RMS " \
             f"{cal.residual_rms_dps:.4g} deg/s over {cal.temp_min_c:.2f} to {cal.temp_max_c:.2f} degC"
    if fmt == "px4":
        rows = px4_parameters(cal, instance=instance, device_id=device_id, body_to_board=body_to_board)
        lines = [f"# {header}", *(f"# {n}" for n in notes), "#", "# Vehicle-Id Component-Id Name Value Type"]
        lines += [f"1\t1\t{name}\t{value if kind == _PX4_INT32 else _number(value)}\t{kind}" for name, value, kind in rows]
        if device_id == 0:
            notes.append(f"TC_G{instance}_ID is 0: PX4 applies a slot only to the gyro whose device id it holds; "
                         "pass --device-id (the gyro's CAL_GYRO*_ID) or set it before loading the file")
    elif fmt == "ardupilot":
        rows = ardupilot_parameters(cal, instance=instance, body_to_board=body_to_board)
        if cal.temp_min_c < -70.0 or cal.temp_max_c > 80.0:
            notes.append("ArduPilot documents INS_TCAL*_TMIN/TMAX for -70 to 80 degC only; a parameter editor "
                         "may refuse the range written")
        lines = [f"# {header}", *(f"# {n}" for n in notes)] + [f"{name},{_number(value)}" for name, value in rows]
    else:
        lines = [json.dumps(calibration_json(cal), indent=2, allow_nan=False)]
    write_bytes_atomic(path, ("\n".join(lines) + "\n").encode("utf-8"))
    return notes


# ---------------------------------------------------------------------------- readers


def _bad(path, what: str) -> ConfigError:
    return ConfigError(f"{path}: {what}")


def _param_values(path, fmt: str) -> dict[str, float]:
    """``{name: value}`` of a parameter file: QGroundControl lines (``px4``) or
    ``NAME,VALUE`` / ``NAME VALUE`` / ``NAME=VALUE`` lines (``ardupilot``); ``#`` starts a comment line."""
    what = {"px4": "PX4 parameter file", "ardupilot": "ArduPilot parameter file"}[fmt]
    text = read_utf8(path, what)
    values: dict[str, float] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        body = line.strip()
        if not body or body.startswith("#"):
            continue
        fields = body.split("\t") if fmt == "px4" and "\t" in body else re.split(r"\s*[,=]\s*|\s+", body)
        if fmt == "px4" and len(fields) == 5:
            name, value = fields[2].strip(), fields[3].strip()
        elif fmt == "ardupilot" and len(fields) == 2:
            name, value = fields
        else:
            form = "'vehicle component NAME VALUE type' (tab-separated)" if fmt == "px4" else "'NAME,VALUE'"
            raise _bad(path, f"line {number}: expected {form}, got {body[:60]!r}; is it a {what}?")
        try:
            number_value = float(value)
        except ValueError:
            raise _bad(path, f"line {number}: the value of {name} is not a number ({value[:30]!r}); correct it") from None
        if not math.isfinite(number_value):
            raise _bad(path, f"line {number}: the value of {name} is not finite; correct it")
        values[name] = number_value
    return values


def _need(values: dict, names, path, advice: str) -> list[float]:
    missing = [n for n in names if n not in values]
    if missing:
        raise _bad(path, f"{', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''} missing; {advice}")
    return [values[n] for n in names]


def _range(path, t_min: float, t_max: float, names: str) -> None:
    if not t_min < t_max:
        raise _bad(path, f"{names}: the calibrated range {t_min:g} to {t_max:g} degC is empty; correct it")


def _from_board(path, board: np.ndarray, temp_ref: float, t_min: float, t_max: float, body_to_board,
                offset_known: bool) -> Calibration:
    body = board @ _rotation(body_to_board) / _RAD_PER_DEG  # rows: powers; R orthonormal, so R^-1 = R^T
    axes = {a: AxisFit(tuple(float(c) for c in body[:, i])) for i, a in enumerate(AXES)}
    return Calibration(axes, temp_ref, t_min, t_max, 0, str(path), offset_known)


def _instances(values: dict, pattern: str) -> str:
    found = sorted({m.group(1) for n in values if (m := re.fullmatch(pattern, n))})
    return ", ".join(found) if found else "none"


def read_px4_params(path, *, instance: int = 0, body_to_board=None) -> Calibration:
    """Read PX4's gyro thermal-compensation parameters (slot ``TC_G{instance}``) from a
    QGroundControl parameter file into a :class:`Calibration` (body FRD, deg/s).

    Raises
    ------
    ConfigError
        Unreadable file, a malformed line, or parameters of the slot missing (the
        message lists the slots present).
    """
    values = _param_values(path, "px4")
    g = f"TC_G{instance}_"
    slots = _instances(values, r"TC_G(\d)_TREF")
    advice = f"the file has gyro slots: {slots}; choose one with --instance"
    t_ref, t_min, t_max = _need(values, [g + "TREF", g + "TMIN", g + "TMAX"], path, advice)
    _range(path, t_min, t_max, f"{g}TMIN/{g}TMAX")
    names = [f"{g}X{k}_{a}" for k in range(_ORDER + 1) for a in range(3)]
    board = np.array(_need(values, names, path, advice)).reshape(_ORDER + 1, 3)
    return _from_board(path, board, t_ref, t_min, t_max, body_to_board, True)


def read_ardupilot_params(path, *, instance: int = 0, body_to_board=None) -> Calibration:
    """Read ArduPilot's gyro temperature calibration of IMU ``instance`` (``INS_TCAL{instance+1}``)
    from a ``.param`` file into a :class:`Calibration` (body FRD, deg/s, reference 35 degC,
    known up to a constant: ``offset_known`` is False).

    Raises
    ------
    ConfigError
        As :func:`read_px4_params`.
    """
    values = _param_values(path, "ardupilot")
    p = f"INS_TCAL{instance + 1}_"
    imus = _instances(values, r"INS_TCAL(\d)_TMIN")
    advice = f"the file has IMUs: {imus}; choose one with --instance (IMU - 1)"
    t_min, t_max = _need(values, [p + "TMIN", p + "TMAX"], path, advice)
    _range(path, t_min, t_max, f"{p}TMIN/{p}TMAX")
    names = [f"{p}GYR{k}_{'XYZ'[a]}" for k in range(1, _ORDER + 1) for a in range(3)]
    board = np.zeros((_ORDER + 1, 3))
    board[1:] = np.array(_need(values, names, path, advice)).reshape(_ORDER, 3) / ARDUPILOT_SCALE
    return _from_board(path, board, ARDUPILOT_TREF_C, t_min, t_max, body_to_board, False)


def read_calibration_json(path) -> Calibration:
    """Read a calibration written by :func:`write_calibration` as ``json``."""
    try:
        data = json.loads(read_utf8(path, "calibration file"))
    except ValueError as err:
        raise _bad(path, f"cannot read it as JSON ({' '.join(str(err).split())}); write it again") from None
    if not isinstance(data, dict) or data.get("format") != _JSON_FORMAT or data.get("version") != _JSON_VERSION:
        raise _bad(path, f"not a {_JSON_FORMAT} version {_JSON_VERSION} file; write it with gyrodrift calibrate")
    try:
        axes = {}
        for a, f in data["axes"].items():
            coeffs = tuple(float(c) for c in f["coeffs"])
            if a not in AXES or len(coeffs) != _ORDER + 1 or not all(map(math.isfinite, coeffs)):
                raise ValueError(f"axis {a!r}")
            res = f.get("residual_rms_dps")
            axes[a] = AxisFit(coeffs, math.nan if res is None else float(res))
        temps = [float(data[k]) for k in ("temp_ref_c", "temp_min_c", "temp_max_c")]
        cal = Calibration(axes, *temps, int(data.get("samples", 0)), str(path), bool(data.get("offset_known", True)))
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise _bad(path, f"a field is missing or malformed ({err}); write it again with gyrodrift calibrate") from None
    if "z" not in axes or not all(map(math.isfinite, temps)):
        raise _bad(path, "no z axis or a non-finite temperature; write it again with gyrodrift calibrate")
    _range(path, cal.temp_min_c, cal.temp_max_c, "temp_min_c/temp_max_c")
    return cal


def read_prior(path, *, instance: int = 0) -> Calibration:
    """Read a calibration from a PX4 ``.params``, ArduPilot ``.param`` or gyrodrift JSON
    file, told apart by content (JSON object; ``TC_G`` or ``INS_TCAL`` names)."""
    text = read_utf8(path, "parameter file")
    if text.lstrip().startswith("{"):
        return read_calibration_json(path)
    if re.search(r"(^|\s)TC_G\d_", text, re.MULTILINE):
        return read_px4_params(path, instance=instance)
    if re.search(r"^\s*INS_TCAL\d_", text, re.MULTILINE):
        return read_ardupilot_params(path, instance=instance)
    raise _bad(path, "no TC_G* (PX4) or INS_TCAL* (ArduPilot) parameters found; give the file the autopilot's "
                     "thermal calibration was saved in, or one written by gyrodrift calibrate")


# ---------------------------------------------------------------------------- prior for the compensator


def start_temperature(path, read_options: dict | None = None) -> float:
    """The first finite temperature (degC) of the log at ``path``.

    CSV and Parquet logs are read only up to it (in small chunks); ULog and ROS bag logs
    are read whole (:func:`gyrodrift.io.read_log`).
    """
    from gyrodrift.io import log_format, read_log
    from gyrodrift.io.chunked import iter_log_chunks

    opts = dict(read_options or {})
    path = Path(path)
    if log_format(path, opts.get("fmt")) in ("csv", "parquet"):
        table = {k: opts[k] for k in ("fmt", "gyro_unit", "frame", "column_map", "time_unit") if opts.get(k) is not None}
        with iter_log_chunks(path, chunk_rows=4096, **table) as chunks:
            for chunk in chunks:
                temps = chunk[TEMP].to_numpy(dtype=float)
                finite = temps[np.isfinite(temps)]
                if finite.size:
                    return float(finite[0])
        raise ConfigError(f"{path}: no temperature in the log; the temp column must have values")
    temps = read_log(path, **opts)[TEMP].to_numpy(dtype=float)
    return float(temps[np.isfinite(temps)][0])


def prior_config(cal: Calibration, config=None, temp_c: float = math.nan):
    """Settings whose z-axis drift model starts from ``cal``.

    The prior mean ``KalmanConfig.x0 = (a, 0, c)`` is the tangent of the z curve at
    ``temp_c``, the log's starting temperature, clamped to the calibrated range: there
    the filter has learnt nothing yet and the prior is all it has, while later its own
    measurements take over; the start is also known before a log is streamed. Beyond
    the range the tangent at the range's end extends the curve linearly. When the
    curve's constant is unknown (``offset_known`` False, ArduPilot), ``c`` makes the
    prior drift 0 at ``temp_c``, as the default prior. The prior covariance is unchanged.

    Parameters
    ----------
    cal : Calibration
    config : CompensatorConfig, optional
    temp_c : float
        Starting temperature of the log, degC.

    Returns
    -------
    CompensatorConfig

    Raises
    ------
    ConfigError
        No z axis, a non-finite temperature, or a tangent beyond
        :data:`gyrodrift.config.DRIFT_PARAM_BOUNDS`.
    """
    from gyrodrift.compensator import CompensatorConfig

    config = config or CompensatorConfig()
    if "z" not in cal.axes:
        raise _bad(cal.source, "no z-axis coefficients; give a calibration of the heading gyro")
    if not math.isfinite(temp_c):
        raise ConfigError(f"{cal.source}: the log's starting temperature is not known")
    at = min(max(temp_c, cal.temp_min_c), cal.temp_max_c)
    a = float(cal.slope("z", at))
    c = float(cal.drift("z", at, clamp=False)) - a * at if cal.offset_known else -a * temp_c
    bound_a, _, bound_c = DRIFT_PARAM_BOUNDS
    if not (abs(a) <= bound_a and abs(c) <= bound_c):
        raise _bad(cal.source, f"its drift at {at:.1f} degC gives a = {a:.4g} deg/s/degC, c = {c:.4g} deg/s, beyond "
                               f"|a| <= {bound_a:g}, |c| <= {bound_c:g}; check the file's units and instance")
    return replace(config, kalman=replace(config.kalman, x0=(a, 0.0, c)))


def prior_notes(cal: Calibration, temp_range_c) -> list[str]:
    """One sentence when the log's temperatures (lowest, highest; degC) leave the
    calibrated range; empty otherwise."""
    lo, hi = (float(v) for v in temp_range_c)
    if (math.isfinite(lo) and lo < cal.temp_min_c) or (math.isfinite(hi) and hi > cal.temp_max_c):
        return [f"calibrated for {cal.temp_min_c:.1f} to {cal.temp_max_c:.1f} degC (TMIN..TMAX), the log reaches "
                f"{lo:.1f} to {hi:.1f} degC: beyond that range the autopilot holds the drift at its end value and the "
                "starting model is extrapolated; calibrate over the log's temperatures (gyrodrift calibrate)"]
    return []

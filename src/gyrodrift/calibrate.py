"""Thermal calibration of the gyro triad from a still heating or cooling run.

:func:`fit_calibration` fits each gyro axis's drift as a cubic in temperature, as the
autopilots' tools do; :func:`calibrate_log` does so for one gyro of an autopilot's log,
after adding back the autopilot's own correction (:func:`undo_onboard`), keeping the
gyro's identity and sensor frame for :mod:`gyrodrift.paramfiles`; :func:`prior_config`
starts the compensator's z drift model from a calibration (``compensate --prior``). The
fit, its refusals and the prior: docs/autopilot-files.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from gyrodrift.config import DRIFT_PARAM_BOUNDS
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, TEMP, T
from gyrodrift.errors import ConfigError, GyroDriftError
from gyrodrift.kernels.thermal import fit_polynomial

__all__ = [
    "AXES", "AXIS_COLUMNS", "MIN_SPAN_C", "STILL_TOL_DPS", "STILL_TILT_DEG", "MIN_WINDOW_SAMPLES", "MEDIAN_WINDOW",
    "BIN_WIDTH_C", "CalibrationError", "AxisFit", "Calibration", "fit_calibration", "calibrate_log", "undo_onboard",
    "sensor_rotation", "temperature_bins", "bin_means", "smooth_rate", "prior_config",
    "prior_notes",
]

#: Gyro axes, in gyrodrift's column order (body FRD).
AXES = ("x", "y", "z")
#: The contract column of each axis.
AXIS_COLUMNS = {"x": GYRO_X, "y": GYRO_Y, "z": GYRO_Z}
#: Smallest temperature span (degC) a calibration is fitted over.
MIN_SPAN_C = 5.0
#: Largest departure (deg/s) of a window mean rate from the fitted drift of a still unit.
STILL_TOL_DPS = 0.5
#: Largest tilt (deg) of a window mean specific force from its median direction.
STILL_TILT_DEG = 2.0
_STILL_WINDOW_S = 1.0
#: Fewest samples in a window of the stillness checks and in a temperature bin.
MIN_WINDOW_SAMPLES = 10
#: Samples of the median filter applied to each rate before the fit (as PX4's tool).
MEDIAN_WINDOW = 31
#: Width (degC) of the temperature bins that weigh the same in the fit and the residual.
BIN_WIDTH_C = 0.25
_ORDER = 3


class CalibrationError(GyroDriftError, ValueError):
    """A log cannot give a thermal calibration (too small a span, the unit moved)."""


@dataclass(frozen=True)
class AxisFit:
    """The fitted drift of one axis."""

    #: ``c_0 .. c_3`` of ``drift = sum_k c_k (T - temp_ref_c)**k``, deg/s per degC**k
    coeffs: tuple[float, float, float, float]
    #: RMS over temperature bins of the mean residual, deg/s (NaN when read from a file)
    residual_rms_dps: float = math.nan


@dataclass(frozen=True)
class Calibration:
    """A thermal calibration of the gyro axes (body FRD, deg/s)."""

    axes: dict = field(default_factory=dict)  #: "x", "y", "z" -> AxisFit: those in the log (all three from a file)
    temp_ref_c: float = 0.0  #: reference temperature, degC
    temp_min_c: float = 0.0  #: calibrated range, degC
    temp_max_c: float = 0.0
    samples: int = 0  #: log rows used (0 when read from a file)
    source: str = ""  #: the log or file it came from
    offset_known: bool = True  #: False when read from an ArduPilot file (known up to a constant)
    instance: int = 0  #: the gyro: PX4 ``TC_G`` slot, ArduPilot IMU index from 0
    device_id: int | None = None  #: PX4 ``TC_G{instance}_ID`` (None: unknown)
    #: ``R`` with ``v_body = R @ v_sensor``, the frame the autopilot corrects in (None: the identity)
    rotation: tuple | None = None
    rotation_text: str = ""  #: where ``rotation`` comes from

    @property
    def matrix(self) -> np.ndarray:
        """``rotation`` as a 3x3 array (the identity when None)."""
        return np.eye(3) if self.rotation is None else np.array(self.rotation, dtype=float)

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
    bins = temperature_bins(temp, temp_min)
    counts = np.bincount(bins)
    weight = 1.0 / counts[bins]  # each occupied bin weighs 1 in total
    coeffs = fit_polynomial(temp, rate, temp_ref, _ORDER, weight)
    residual = rate - np.polynomial.polynomial.polyval(temp - temp_ref, coeffs)
    return coeffs, float(np.sqrt(np.mean(bin_means(residual, bins) ** 2)))


def bin_means(values: np.ndarray, bins: np.ndarray) -> np.ndarray:
    """Mean of ``values`` in each occupied bin of ``bins`` (:func:`temperature_bins`), in bin order."""
    counts = np.bincount(bins)
    occupied = counts > 0
    return np.bincount(bins, values)[occupied] / counts[occupied]


def smooth_rate(rate: np.ndarray) -> np.ndarray:
    """The rate median filtered over :data:`MEDIAN_WINDOW` samples."""
    from scipy.ndimage import median_filter  # imported here: scipy.ndimage costs 0.2 s at start-up

    return median_filter(rate, size=MEDIAN_WINDOW, mode="nearest")


def _groups(index: np.ndarray) -> np.ndarray:
    """Group of every sample from its bin ``index``: consecutive bins merged until a group holds
    MIN_WINDOW_SAMPLES samples, a short last group joining the one before."""
    counts = np.bincount(index)
    group = np.empty(counts.size, dtype=np.int64)
    number, held = 0, 0
    for b, n in enumerate(counts):
        group[b] = number
        held += n
        if held >= MIN_WINDOW_SAMPLES:
            number, held = number + 1, 0
    if 0 < held and number > 0:
        group[group == number] = number - 1
    return group[index]


def _windows(t: np.ndarray) -> np.ndarray:
    """Window number of every sample: whole seconds from the first, merged by :func:`_groups`."""
    return _groups(np.floor((t - t[0]) / _STILL_WINDOW_S).astype(np.int64))


def temperature_bins(temp: np.ndarray, temp_min: float) -> np.ndarray:
    """Bin number of every sample: :data:`BIN_WIDTH_C` bins from ``temp_min`` (degC),
    merged by :func:`_groups` so that none holds fewer than MIN_WINDOW_SAMPLES samples."""
    return _groups(np.floor((temp - temp_min) / BIN_WIDTH_C).astype(np.int64))


def _window_means(t: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Window means of ``values`` (rows; windows of :func:`_windows`) and the mean time of each."""
    window = _windows(t)
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
    """Refuse when a window mean of the specific force tilts more than STILL_TILT_DEG."""
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

    See docs/autopilot-files.md, section "The fit".

    Parameters
    ----------
    log : pandas.DataFrame
        A log in the input contract (``t``, ``temp``, ``gyro_z`` and optional ``gyro_x``,
        ``gyro_y``, ``acc_*``).
    source : str
        Name of the log, for the messages.
    min_span_c : float
        Smallest temperature span accepted, degC.
    still_tol_dps : float
        Largest departure of a window mean rate from the fitted drift, deg/s.

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        Too few samples, too small a temperature span, or the unit moved.

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
    axes = {}
    for axis in AXES:
        col = AXIS_COLUMNS[axis]
        if col not in log.columns:
            continue
        rate = log[col].to_numpy(dtype=float)[ok]
        finite = np.isfinite(rate)
        if finite.sum() < 2 * MEDIAN_WINDOW:
            continue
        ta, tempa = t[finite], temp[finite]
        smooth = smooth_rate(rate[finite])
        coeffs, residual = _fit_axis(tempa, smooth, t_ref, t_min)
        t_mean, means = _window_means(ta, np.column_stack([smooth, tempa]))
        departure = np.abs(means[:, 0] - np.polynomial.polynomial.polyval(means[:, 1] - t_ref, coeffs))
        worst = int(np.argmax(departure))
        if departure[worst] > still_tol_dps:
            raise _refuse_motion(source, t_mean[worst], f"the window mean of {col} departs {departure[worst]:.2f} deg/s "
                                                         f"from the drift curve, more than {still_tol_dps:g}",
                                 tilted=False)
        axes[axis] = AxisFit(tuple(float(c) for c in coeffs), residual)
    if "z" not in axes:
        raise CalibrationError(f"{source}: too few gyro_z values for a thermal calibration; give the whole heating run")
    _check_tilt(log, ok, t, source)
    return Calibration(axes, t_ref, t_min, t_max, int(t.size), source)


def undo_onboard(log, onboard=None, rotation=None):
    """``log`` with the thermal correction its rates hold added back, and a note for the user.

    ``onboard`` defaults to ``log.attrs["onboard"]`` (none: nothing to undo); ``rotation``
    (``v_body = R @ v_sensor``) replaces the log's own. Returns a new frame when rates
    changed. A correction that cannot be undone is a :class:`CalibrationError`.
    """
    onboard = log.attrs.get("onboard") if onboard is None else onboard
    if onboard is None:
        return log, []
    if onboard.correction_problem:
        raise CalibrationError(onboard.correction_problem)
    if onboard.correction is None:
        return log, []
    R = onboard.matrix if rotation is None else np.asarray(rotation, dtype=float)
    if R is None:
        raise CalibrationError(onboard.rotation_problem)
    added = onboard.correction.offset_dps(log[TEMP].to_numpy(dtype=float), R)
    out = log.copy()
    for i, col in enumerate((GYRO_X, GYRO_Y, GYRO_Z)):
        if col in out.columns:
            out[col] = out[col].to_numpy(dtype=float) + added[:, i]
    who = "PX4's gyro thermal compensation" if onboard.autopilot == "px4" else \
        "ArduPilot's gyro temperature calibration"
    return out, [f"{who} {onboard.correction.names} was on while the log was recorded: its correction was added "
                 "back to the rates before the fit, so the new coefficients replace it (they do not add to it)"]


def sensor_rotation(onboard, rotation, text: str, default: tuple) -> tuple:
    """``R`` (``v_body = R @ v_sensor``) and where it comes from: ``rotation`` (described by
    ``text``), else the log's (``onboard``; unusable: a :class:`CalibrationError`), else ``default``."""
    if rotation is not None:
        return np.asarray(rotation, dtype=float), text
    if onboard is None:
        return default
    if onboard.matrix is None:
        raise CalibrationError(onboard.rotation_problem)
    return onboard.matrix, onboard.rotation_text


def calibrate_log(log, *, source: str | None = None, rotation=None, rotation_text: str = "",
                  min_span_c: float = MIN_SPAN_C, still_tol_dps: float = STILL_TOL_DPS) -> tuple[Calibration, list[str]]:
    """The calibration of one gyro's log, with its identity and frame.

    The correction the autopilot applied while the log was recorded is added back first
    (:func:`undo_onboard`); the fit is then :func:`fit_calibration`'s, in the body frame.

    Parameters
    ----------
    log : pandas.DataFrame
        One gyro's log in the input contract, with ``attrs["onboard"]`` from an autopilot's reader.
    source : str, optional
        Name of the log (default ``attrs["source"]``).
    rotation : 3x3 array_like, optional
        ``v_body = R @ v_sensor``, in place of the log's (identity for a log without ``onboard``).
    rotation_text : str
        Where ``rotation`` comes from.
    min_span_c, still_tol_dps : float
        As :func:`fit_calibration`.

    Returns
    -------
    (Calibration, list of str)
        The calibration and notes for the user.

    Raises
    ------
    CalibrationError
        As :func:`fit_calibration`; an unusable board rotation without ``rotation``; a
        correction the rates hold that cannot be undone.
    """
    source = source or str(log.attrs.get("source", "log"))
    onboard = log.attrs.get("onboard")
    R, text = sensor_rotation(onboard, rotation, rotation_text or "given rotation", (None, rotation_text))
    log, notes = undo_onboard(log, onboard, R)
    cal = fit_calibration(log, source=source, min_span_c=min_span_c, still_tol_dps=still_tol_dps)
    identity = {"instance": onboard.instance, "device_id": onboard.device_id} if onboard is not None else {}
    frame = {"rotation": tuple(tuple(float(v) for v in row) for row in R), "rotation_text": text} \
        if R is not None else {"rotation_text": text}
    return replace(cal, **identity, **frame), notes


# ---------------------------------------------------------------------------- prior for the compensator


def prior_config(cal: Calibration, config=None, temp_c: float = math.nan):
    """Settings whose z-axis drift model starts from ``cal`` at the log's starting temperature
    ``temp_c`` (docs/autopilot-files.md, section "Starting the compensator from a calibration").

    Raises
    ------
    ConfigError
        No z axis, a non-finite temperature, or a tangent beyond
        :data:`gyrodrift.config.DRIFT_PARAM_BOUNDS`.
    """
    from gyrodrift.compensator import CompensatorConfig

    config = config or CompensatorConfig()
    if "z" not in cal.axes:
        raise ConfigError(f"{cal.source}: no z-axis coefficients; give a calibration of the heading gyro")
    if not math.isfinite(temp_c):
        raise ConfigError(f"{cal.source}: the log's starting temperature is not known")
    at = min(max(temp_c, cal.temp_min_c), cal.temp_max_c)
    a = float(cal.slope("z", at))
    c = float(cal.drift("z", at, clamp=False)) - a * at if cal.offset_known else -a * temp_c
    bound_a, _, bound_c = DRIFT_PARAM_BOUNDS
    if not (abs(a) <= bound_a and abs(c) <= bound_c):
        raise ConfigError(f"{cal.source}: its drift at {at:.1f} degC gives a = {a:.4g} deg/s/degC, c = {c:.4g} deg/s, beyond "
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

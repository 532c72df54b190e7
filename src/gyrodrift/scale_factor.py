"""Adaptive estimate of the temperature-dependent gyro scale factor (Feng et al. 2015, Sec. 4.3).

Section 4.3 of the paper compensates the scale factor (SF) "with the adaptive
algorithm" on simulated rotations combined with the static heating data, and shows
the ideal, a fixed-parameter and the adaptive SF (Fig. 10) and the heading error
without SF compensation, with the fixed SF and with the adaptive SF (Fig. 11). It
gives no equations; this module is gyrodrift's design in the spirit of Section 3.

Model
-----
After the drift compensation of :func:`gyrodrift.compensator.compensate`
(``rate_z = gyro_z - bias_z``, eqs. 1, 2, 5), the gyro still reads

    rate_z = SF(T) * true_rate + (drift residual) + noise,
    SF(T) = s0 + s1 * (T - T_ref)                                  (cf. eq. 2)

with ``T`` the measured gyro temperature (degC) and ``T_ref`` = ``t_ref_c``. The
parameters ``x = [s0 (unitless), s1 (1/degC)]`` are the states of a strong tracking
Kalman filter modelled as constant between updates (Φ = Γ = I, Section 3.2): at each
accepted measurement ``P- = s*P + Q`` then a Joseph-form correction (eq. 10,
:func:`gyrodrift.kernels.numeric.correct`), and P is capped at the prior ``P0``
(:func:`gyrodrift.kernels.numeric.cap_covariance`). The SF compensated rate
is ``rate_sf = rate_z / SF(T)``.

Measurement: one per rotation
-----------------------------
The drift filter updates only when the unit is still or straight; the SF filter is
its mirror image and updates only over a **rotation**. A rotation is a run of rows
whose centred ``turn_window_s`` mean of ``rate_z`` exceeds ``turn_rate_dps`` in
magnitude. For
each one, two still windows of ``still_s`` seconds, ``guard_s`` before its start and
``guard_s`` after its end, bracket it; over the compass samples of each window the
gyro heading ``psi_g`` (trapezoid integral of ``rate_z``) and the unwrapped compass
heading ``psi_c`` are averaged (which divides the compass noise variance by the
number of samples). Then

    y = (psi_g(after) - psi_g(before)) / (psi_c(after) - psi_c(before))
      ≈ rate-weighted mean of SF over the rotation,
    H = [1, mean(T - T_ref)]   (mean weighted by |rate_z|, i.e. over the angle turned),
    R = (σ_c² (1/n_before + 1/n_after) + N² Δt + (d_res Δt)²) / Δψ_c²

with σ_c = ``compass_sigma_deg``, N = ``gyro_noise_dps_rthz`` (angle random walk),
d_res = ``residual_drift_dps`` (drift left after the drift compensation), Δt the
time between the window centres, and Δψ_c the compass heading change. The compass
is unwrapped against the gyro: ``psi_c = psi_g + unwrap(wrap_180(compass - psi_g))``,
so a full turn counts 360° (not 0°) and the unwrapping survives compass gaps as long
as compass and gyro disagree by less than 180°.

A rotation counts (``accepted``) only if both windows are still (no moving row within
``guard_s`` of them) and inside the log, each window holds ``min_compass_samples``
compass samples, no compass gap inside the span exceeds ``max_compass_gap_s``, no
row of the span was refused by the drift compensator for a gap, a field anomaly or
magnetic interference, the compass turned by at least ``min_turn_deg`` (a small
turn measures the SF badly, R ∝ 1/Δψ²) and ``|y - 1| <= max_sf_error``. The new
parameters apply from the row after the end of the second window, and the rows up to the
first accepted rotation are compensated with the SF it produced (as the drift
compensator emits the rows of its initialisation window with the parameters the window
gave), so the first turn is not integrated with the bare prior.

Causal and non-causal
---------------------
The default pass of :func:`estimate_scale_factor` (the paper reproduction) is not
strictly causal, in two ways: (1) the rotation test is a centred window, half a
``turn_window_s`` of look-ahead, and the update at the end of the second still window
is decided with the not-still check of the ``guard_s`` after it, so with ``guard_s`` +
``turn_window_s/2`` of look-ahead; (2) the rows up to the first accepted rotation get
that rotation's result retroactively.

``estimate_scale_factor(..., causal=True)``, and :class:`ScaleFactorTracker`, which
computes the same numbers row by row or in chunks with bounded memory (for
:class:`gyrodrift.compensator.Compensator` and streaming), make every row depend only on
itself and the rows before it. The rotations and their measurements are the same; what
differs:

* an update applies from the first row at which it could be decided from the rows so
  far (``guard_s + turn_window_s/2``, 2.5 s by default, after the end of the second
  still window, where the default pass applies it from the row after that end);
* no retroactive initialisation: the prior ``x0`` applies until the first update;
* ``heading_sf`` is NaN before the first compass heading (it cannot be anchored yet);
* a rotation whose rotating rows last longer than ``max_turn_s`` is dropped
  (``long_turn``), which bounds the rows the tracker keeps; a rotation not decided by
  the end of the log is ``edge``;
* an empty temperature cell holds the previous value (the default pass lets it give a
  NaN SF on that row and a NaN ``heading_sf`` from there on).

What the causal pass loses, on the 3-h experiment (:func:`gyrodrift.paper.scale_factor_experiment`,
seed 0, 10 Hz, default settings; causal against default): SF RMS after the first update
2.864e-4 against 2.845e-4 (max 1.379e-3 against 1.359e-3); the SF's share of the
heading error (``sf_heading_rms_deg``) 3.28 against 0.32 deg RMS, and the whole heading
error 4.92 against 2.48 deg RMS. The heading loss is the first turn, integrated with the
prior SF 1 while the true SF is 1.0086: a 3.15-deg offset that the open-loop heading
keeps for the rest of the run. The 2.5-s later updates cost less than 1e-4 deg per
rotation. A prior ``x0`` from a calibration removes most of it.

Where the paper is silent (choices made here)
---------------------------------------------
* Linear SF model in temperature (the paper's SF "model" has unknown form); states
  ``[s0, s1]`` like ``[c, a]`` of eq. (2).
* The measurement is a ratio of heading changes over a turn between still windows;
  the compass heading change must be true, which holds for full turns (the
  deviation is a function of heading) or for a deviation-calibrated compass.
* No fading or process noise is applied between rotations: without a measurement
  there is nothing to discount, so a still unit keeps its SF estimate and covariance.
* "Fixed parameters" (the paper's green line): a one-off calibration, the
  inverse-variance weighted mean of the first ``fixed_turns`` accepted SF
  measurements (at the start temperature), then frozen and applied to the whole run
  (as a calibration done before the run would be). 1.0 if no rotation was accepted.
* The SF compensation does not feed back into the drift filter: the drift filter
  updates only when still, where the SF does not matter.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass, fields
from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy.integrate import cumulative_trapezoid

from gyrodrift import gating
from gyrodrift.compensator import CompensatedSample
from gyrodrift.conventions import TEMP, T, wrap_180, wrap_360
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.kernels.numeric import cap_covariance, correct

__all__ = [
    "ScaleFactorConfig",
    "moving_mask",
    "turn_measurements",
    "sf_filter",
    "fixed_scale_factor",
    "integrate_heading",
    "heading_error",
    "estimate_scale_factor",
    "ScaleFactorTracker",
    "ScaleFactorRow",
    "TRACKER_COLUMNS",
    "CompensatedSFSample",
    "REJECT_GATES",
]

#: Drift-compensator refusals that also refuse an SF measurement over the same rows.
REJECT_GATES = (gating.GAP, gating.FIELD, gating.INTERFERENCE)

# Reasons a detected rotation is not used (the ``reason`` column of the turn table;
# a drift gate of REJECT_GATES is a reason too).
#: A still window falls outside the log, or (causal) the log ends before the decision.
EDGE = "edge"
#: The unit rotates within ``guard_s`` of a still window.
NOT_STILL = "not_still"
#: Too few compass samples in a still window, or a compass gap inside the span.
NO_COMPASS = "no_compass"
#: The compass turned by less than ``min_turn_deg``.
SMALL_TURN = "small_turn"
#: ``|y - 1| > max_sf_error``.
IMPLAUSIBLE = "implausible"
#: Causal pass and tracker: the rotating rows last longer than ``max_turn_s``.
LONG_TURN = "long_turn"


def _pair(name: str, value, *, positive: bool = False, nonneg: bool = False) -> tuple[float, float]:
    try:
        out = tuple(float(v) for v in value)
        ok = len(out) == 2 and all(math.isfinite(v) for v in out)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError(f"ScaleFactorConfig.{name} must be two finite numbers (s0, s1), got {value!r}")
    if positive and not all(v > 0 for v in out):
        raise ConfigError(f"ScaleFactorConfig.{name} must be positive, got {value!r}")
    if nonneg and not all(v >= 0 for v in out):
        raise ConfigError(f"ScaleFactorConfig.{name} must be >= 0, got {value!r}")
    return out


@dataclass(frozen=True, kw_only=True)
class ScaleFactorConfig:
    """Settings of the adaptive scale-factor estimate (see the module notes).

    Attributes
    ----------
    t_ref_c : float
        Reference temperature ``T_ref`` of ``SF = s0 + s1*(T - T_ref)``, degC.
    fading : float
        Fading factor s >= 1 of eq. (10), per accepted rotation; memory is about
        ``1/(1 - 1/s)`` rotations (default 1.25: about 5 rotations, 10 min at one
        turn every 2 min).
    x0 : tuple of 2 floats
        Prior ``[s0 (unitless), s1 (1/degC)]`` (default: the nominal SF 1, no
        temperature dependence).
    p0_sd : tuple of 2 floats
        Prior standard deviations of s0 and s1; ``P0 = diag(p0_sd²)``, also the cap
        of P. Default 5 % and 0.1 %/degC (±3.5 % over 35 degC; ADXRS623: ±3 % over
        temperature). A tighter s1 prior keeps the slope sane while the first
        rotations all happen at nearly one temperature.
    q_sd : tuple of 2 floats
        Process-noise standard deviations of s0 and s1 per accepted rotation.
    turn_rate_dps : float
        A row is rotating when the centred ``turn_window_s`` mean of ``rate_z``
        exceeds this in magnitude, deg/s.
    turn_window_s : float
        Averaging window of the rotation test, s.
    guard_s : float
        Gap between a rotation and its still windows, s.
    still_s : float
        Length of each still window, s.
    min_turn_deg : float
        Smallest compass heading change that counts as a measurement, deg.
    max_sf_error : float
        Largest accepted ``|y - 1|`` of a measurement (unitless).
    min_compass_samples : int
        Fewest compass samples in each still window.
    max_compass_gap_s : float
        Longest gap between compass samples inside a measurement span, s.
    compass_sigma_deg : float
        Compass heading noise standard deviation, deg.
    gyro_noise_dps_rthz : float
        Gyro white-noise density (angle random walk), deg/s/√Hz.
    residual_drift_dps : float
        Typical drift left after the drift compensation, deg/s (enters R). Default
        0.02: the bias error of the drift compensator on the simulated heating run is
        mostly 0.002–0.03 deg/s, up to 0.05 early in the fast heating.
    fixed_turns : int
        Number of first accepted rotations averaged by the fixed (one-off) calibration.
    max_turn_s : float
        Causal pass and :class:`ScaleFactorTracker` only: a rotation whose rotating rows
        last longer than this (s) is dropped with reason ``long_turn`` instead of being
        buffered until it ends, which bounds the memory of the streaming estimate (see
        :attr:`ScaleFactorTracker.buffer_bound_s`). Default 300 s: a full turn at the
        5 deg/s threshold takes 72 s.
    """

    t_ref_c: float = 25.0
    fading: float = 1.25
    x0: tuple[float, float] = (1.0, 0.0)
    p0_sd: tuple[float, float] = (0.05, 1.0e-3)
    q_sd: tuple[float, float] = (1.0e-4, 2.0e-6)
    turn_rate_dps: float = 5.0
    turn_window_s: float = 1.0
    guard_s: float = 2.0
    still_s: float = 5.0
    min_turn_deg: float = 90.0
    max_sf_error: float = 0.2
    min_compass_samples: int = 5
    max_compass_gap_s: float = 1.0
    compass_sigma_deg: float = 0.5
    gyro_noise_dps_rthz: float = 0.04
    residual_drift_dps: float = 0.02
    fixed_turns: int = 3
    max_turn_s: float = 300.0

    def __post_init__(self):
        def number(name):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"ScaleFactorConfig.{name} must be a finite number, got {v!r}")
            return float(v)

        number("t_ref_c")
        if number("fading") < 1.0:
            raise ConfigError(f"ScaleFactorConfig.fading must be >= 1, got {self.fading!r}")
        for name in (
            "turn_rate_dps", "turn_window_s", "guard_s", "still_s", "min_turn_deg", "max_sf_error",
            "max_compass_gap_s", "compass_sigma_deg", "gyro_noise_dps_rthz", "max_turn_s",
        ):
            if number(name) <= 0:
                raise ConfigError(f"ScaleFactorConfig.{name} must be > 0, got {getattr(self, name)!r}")
        if number("residual_drift_dps") < 0:
            raise ConfigError(f"ScaleFactorConfig.residual_drift_dps must be >= 0, got {self.residual_drift_dps!r}")
        for name in ("min_compass_samples", "fixed_turns"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ConfigError(f"ScaleFactorConfig.{name} must be a whole number >= 1, got {v!r}")
        object.__setattr__(self, "x0", _pair("x0", self.x0))
        object.__setattr__(self, "p0_sd", _pair("p0_sd", self.p0_sd, positive=True))
        object.__setattr__(self, "q_sd", _pair("q_sd", self.q_sd, nonneg=True))


# ---------------------------------------------------------------------- rotations


def moving_mask(t_s, rate_dps, config: ScaleFactorConfig = ScaleFactorConfig()) -> np.ndarray:
    """Rows where the unit rotates: centred mean of ``rate_dps`` above ``turn_rate_dps``.

    Parameters
    ----------
    t_s : (N,) array_like
        Time, s, strictly increasing.
    rate_dps : (N,) array_like
        Drift-compensated rate ``rate_z``, deg/s.
    config : ScaleFactorConfig

    Returns
    -------
    (N,) bool ndarray

    Examples
    --------
    >>> t = np.arange(0.0, 20.0, 0.1)
    >>> rate = np.where((t > 8) & (t < 12), 45.0, 0.0)
    >>> m = moving_mask(t, rate)
    >>> float(t[m][0]), float(t[m][-1])
    (7.7, 12.3)
    """
    t = np.asarray(t_s, dtype=float)
    angle = cumulative_trapezoid(np.asarray(rate_dps, dtype=float), t, initial=0.0)
    half = 0.5 * config.turn_window_s
    lo = np.clip(t - half, t[0], t[-1])
    hi = np.clip(t + half, t[0], t[-1])
    span = np.maximum(hi - lo, np.finfo(float).tiny)
    mean = (np.interp(hi, t, angle) - np.interp(lo, t, angle)) / span
    return np.abs(mean) > config.turn_rate_dps


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) row of each run of True."""
    d = np.diff(np.r_[0, mask.astype(np.int8), 0])
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def _window(t: np.ndarray, t0: float, t1: float) -> slice:
    """Rows with t0 <= t <= t1."""
    return slice(int(np.searchsorted(t, t0, "left")), int(np.searchsorted(t, t1, "right")))


def require_columns(out: pd.DataFrame, cols) -> None:
    """Raise if ``out`` lacks any of ``cols``.

    Parameters
    ----------
    out : DataFrame
        A :func:`gyrodrift.compensator.compensate` table.
    cols : iterable of str
        Column names it must have.

    Raises
    ------
    LogFormatError
        Naming the missing columns.
    """
    missing = [c for c in cols if c not in out.columns]
    if missing:
        raise LogFormatError(
            f"scale-factor estimate needs the compensate() output columns {', '.join(missing)}"
        )


def _check_rows(t_s: np.ndarray, rate_dps: np.ndarray, source: str = "scale-factor estimate") -> None:
    """Raise :class:`LogFormatError` naming the first row whose time is not finite or does
    not increase, or whose rate is not finite (both passes, and the tracker row by row)."""
    if t_s.size == 0:
        raise LogFormatError(f"{source}: the table has no rows")
    bad = np.flatnonzero(~np.isfinite(t_s))
    if bad.size:
        i = int(bad[0])
        raise LogFormatError(f"{source}: row {i}: time must be a finite number of seconds, got {float(t_s[i])!r}")
    back = np.flatnonzero(np.diff(t_s) <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise LogFormatError(
            f"{source}: row {i}: time must increase: got t={float(t_s[i])!r} after t={float(t_s[i - 1])!r}"
        )
    bad = np.flatnonzero(~np.isfinite(rate_dps))
    if bad.size:
        i = int(bad[0])
        raise LogFormatError(f"{source}: row {i}: rate_z must be a finite number of deg/s, got {float(rate_dps[i])!r}")


def _held_temperature(temp_c: np.ndarray, source: str = "scale-factor estimate") -> np.ndarray:
    """Each non-finite temperature replaced by the previous finite one (degC), as the drift
    compensator holds an empty temperature cell (both passes and the tracker; the default pass
    gave NaN SF from such a cell on, and NaN parameters for good when it fell in a rotation)."""
    ok = np.isfinite(temp_c)
    if ok.all():
        return temp_c
    if not ok[0]:
        raise LogFormatError(f"{source}: row 0: the first row needs a finite temperature, got {float(temp_c[0])!r}")
    last = np.where(ok, np.arange(temp_c.size), 0)
    np.maximum.accumulate(last, out=last)
    return temp_c[last]


def compensated_columns(out: pd.DataFrame):
    """The columns the SF estimate reads from a compensate() table, checked.

    Parameters
    ----------
    out : DataFrame
        Output of :func:`gyrodrift.compensator.compensate`.

    Returns
    -------
    t : (N,) ndarray
        Time, s.
    rate : (N,) ndarray
        ``rate_z``, deg/s.
    temp : (N,) ndarray
        Temperature, degC; an empty cell holds the previous value, as in the drift
        compensator.
    compass : (N,) ndarray
        Compass heading, deg (NaN = no sample).
    gates : (N,) ndarray of str
        The drift compensator's ``gate_reason`` ('' when the column is absent).

    Raises
    ------
    LogFormatError
        See :func:`estimate_scale_factor` (a column missing, no rows, bad time or rate,
        the first temperature empty).
    """
    require_columns(out, (T, "rate_z", TEMP, "compass_heading"))
    t = out[T].to_numpy(float)
    rate = out["rate_z"].to_numpy(float)
    _check_rows(t, rate)
    temp = _held_temperature(out[TEMP].to_numpy(float))
    compass = out["compass_heading"].to_numpy(float)
    gates = out["gate_reason"].to_numpy(str) if "gate_reason" in out.columns else np.full(t.size, "")
    return t, rate, temp, compass, gates


def _unwrapped_compass(psi_g: np.ndarray, compass: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Compass heading at ``rows`` unwrapped against the gyro heading, deg."""
    d = wrap_180(compass[rows] - psi_g[rows])
    return psi_g[rows] + np.unwrap(d, period=360.0)


def _decision_row(t_s: np.ndarray, t_end_s: float, cfg: ScaleFactorConfig) -> int:
    """First row at which the rotation ending at ``t_end_s`` can be decided from the rows so
    far (causal pass), or -1 if the log ends first.

    The not-still check after the turn reads the rotation test up to ``a1 + guard_s`` (``a1``
    = end of the second still window); the centred test of the last row ``i`` there is known
    once a row at ``t_i + turn_window_s/2`` exists.
    """
    lim = t_end_s + cfg.guard_s + cfg.still_s + cfg.guard_s  # a1 + guard_s, as in measure_turn
    last = int(np.searchsorted(t_s, lim, "right")) - 1
    j = int(np.searchsorted(t_s, t_s[last] + 0.5 * cfg.turn_window_s, "left"))
    return j if j < t_s.size else -1


def turn_measurements(
    out: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig(), *, causal: bool = False
) -> pd.DataFrame:
    """One SF measurement per detected rotation (module notes), accepted or not.

    Parameters
    ----------
    out : DataFrame
        Output of :func:`gyrodrift.compensator.compensate`: ``t`` (s), ``rate_z``
        (deg/s), ``temp`` (degC), ``compass_heading`` (deg, NaN off compass rows)
        and, if present, ``gate_reason``.
    config : ScaleFactorConfig
    causal : bool
        Decide each rotation at the first row at which the rows so far suffice
        (``row_update``; see "Causal and non-causal" in the module notes), drop
        rotations longer than ``max_turn_s`` (``long_turn``) and hold empty
        temperature cells; the measurements themselves are those of the default pass.

    Returns
    -------
    DataFrame
        One row per rotation: ``t_start, t_end`` (s, rotating rows), ``t_update``
        (s) and its row ``row_update`` (default: the end of the second still window,
        the new SF applies from the next row; causal: the row at which the rotation
        is decided, the new SF applies from it; -1 when not decided),
        ``angle_gyro_deg``, ``angle_compass_deg`` (heading changes, deg), ``sf_meas``
        (y, unitless), ``temp_c`` and ``temp_dev_c`` (rate-weighted mean T and
        T - T_ref, degC), ``r`` (variance of y), ``accepted`` (bool) and ``reason``
        ('' when accepted; else ``edge``, ``long_turn`` (causal only), ``not_still``,
        ``no_compass``, a drift gate of :data:`REJECT_GATES`, ``small_turn`` or
        ``implausible``).
    """
    t, rate, temp, compass, gates = compensated_columns(out)
    cfg = config

    psi_g = cumulative_trapezoid(rate, t, initial=0.0)
    c_rows = np.flatnonzero(np.isfinite(compass))
    psi_c = np.full(t.size, np.nan)
    if c_rows.size:
        psi_c[c_rows] = _unwrapped_compass(psi_g, compass, c_rows)
    moving = moving_mask(t, rate, cfg)
    has_c = np.isfinite(psi_c)

    rows = []
    for i0, i1 in _runs(moving):
        i0, i1 = int(i0), int(i1)
        if causal and t[i1] - t[i0] > cfg.max_turn_s:
            rows.append(unmeasured_turn(float(t[i0]), float(t[i1]), LONG_TURN))
            continue
        j = _decision_row(t, float(t[i1]), cfg) if causal else 0
        if j < 0:
            rows.append(unmeasured_turn(float(t[i0]), float(t[i1]), EDGE))
            continue
        row = measure_turn(
            t, rate, temp, psi_g, psi_c, has_c, moving, gates, i0, i1, cfg,
            log_start_s=float(t[0]), log_end_s=float(t[-1]),
        )
        if causal:
            row["row_update"], row["t_update"] = j, float(t[j])
        rows.append(row)
    columns = [
        "t_start", "t_end", "t_update", "row_update", "angle_gyro_deg", "angle_compass_deg",
        "sf_meas", "temp_c", "temp_dev_c", "r", "accepted", "reason",
    ]
    table = pd.DataFrame(rows, columns=columns)
    return table.astype({"row_update": int, "accepted": bool})


def unmeasured_turn(t_start_s: float, t_end_s: float, reason: str) -> dict:
    """A turn-table row (:func:`turn_measurements`) without a measurement.

    Parameters
    ----------
    t_start_s, t_end_s : float
        First and last rotating row of the rotation, s.
    reason : str
        Why it is not used ('' while the measurement is still to be made).

    Returns
    -------
    dict
        The turn-table columns: NaN measurement, ``row_update`` -1, not accepted.
    """
    return {
        "t_start": t_start_s, "t_end": t_end_s, "t_update": math.nan, "row_update": -1,
        "angle_gyro_deg": math.nan, "angle_compass_deg": math.nan, "sf_meas": math.nan,
        "temp_c": math.nan, "temp_dev_c": math.nan, "r": math.nan, "accepted": False, "reason": reason,
    }


def measure_turn(
    t, rate, temp, psi_g, psi_c, has_c, moving, gates, i0, i1, cfg: ScaleFactorConfig, *,
    log_start_s: float, log_end_s: float,
) -> dict:
    """The SF measurement of the rotation on rows i0..i1 (see :func:`turn_measurements`).

    The arrays may be a part of the log (the rows :class:`ScaleFactorTracker` keeps), as long
    as they hold every row from ``guard_s`` before the first still window to ``guard_s`` after
    the second.

    Parameters
    ----------
    t, rate, temp : (N,) ndarray
        Time (s), ``rate_z`` (deg/s) and temperature (degC) of the rows.
    psi_g, psi_c : (N,) ndarray
        Gyro heading and compass heading unwrapped against it (NaN off compass rows), deg.
    has_c : (N,) bool ndarray
        Rows with a compass heading.
    moving : (N,) bool ndarray
        The rotation test (:func:`moving_mask`).
    gates : (N,) ndarray of str
        The drift compensator's ``gate_reason``.
    i0, i1 : int
        First and last rotating row, indices into the arrays.
    cfg : ScaleFactorConfig
    log_start_s, log_end_s : float
        Times of the log's first and last rows (the edge test).

    Returns
    -------
    dict
        The turn-table row; ``row_update``/``t_update`` are the end of the second still
        window (the default pass).
    """
    ts, te = float(t[i0]), float(t[i1])
    b0, b1 = ts - cfg.guard_s - cfg.still_s, ts - cfg.guard_s
    a0, a1 = te + cfg.guard_s, te + cfg.guard_s + cfg.still_s
    row = unmeasured_turn(ts, te, "")
    if b0 < log_start_s or a1 > log_end_s:
        row["reason"] = EDGE
        return row
    span = _window(t, b0, a1)
    row["row_update"] = span.stop - 1
    row["t_update"] = float(t[span.stop - 1])
    if moving[_window(t, b0 - cfg.guard_s, b1)].any() or moving[_window(t, a0, a1 + cfg.guard_s)].any():
        row["reason"] = NOT_STILL
        return row
    before, after = _window(t, b0, b1), _window(t, a0, a1)
    cb = np.flatnonzero(has_c[before]) + before.start
    ca = np.flatnonzero(has_c[after]) + after.start
    c_span = np.flatnonzero(has_c[span]) + span.start
    if min(cb.size, ca.size) < cfg.min_compass_samples or np.diff(t[c_span]).max() > cfg.max_compass_gap_s:
        row["reason"] = NO_COMPASS
        return row

    d_gyro = float(np.mean(psi_g[ca]) - np.mean(psi_g[cb]))
    d_compass = float(np.mean(psi_c[ca]) - np.mean(psi_c[cb]))
    turn = _window(t, b1, a0)
    weight = np.abs(rate[turn])
    temp_c = float(np.average(temp[turn], weights=weight)) if weight.sum() > 0 else float(np.mean(temp[turn]))
    dt = float(np.mean(t[ca]) - np.mean(t[cb]))
    var = (
        cfg.compass_sigma_deg**2 * (1.0 / cb.size + 1.0 / ca.size)
        + cfg.gyro_noise_dps_rthz**2 * dt
        + (cfg.residual_drift_dps * dt) ** 2
    )
    y = d_gyro / d_compass if d_compass != 0.0 else math.inf
    row.update(
        angle_gyro_deg=d_gyro, angle_compass_deg=d_compass, sf_meas=y, temp_c=temp_c,
        temp_dev_c=temp_c - cfg.t_ref_c, r=var / d_compass**2 if d_compass != 0.0 else math.inf,
    )
    refused = [g for g in REJECT_GATES if np.any(gates[span] == g)]
    if refused:
        row["reason"] = refused[0]
    elif abs(d_compass) < cfg.min_turn_deg:
        row["reason"] = SMALL_TURN
    elif not abs(y - 1.0) <= cfg.max_sf_error:
        row["reason"] = IMPLAUSIBLE
    else:
        row["accepted"] = True
    return row


# ---------------------------------------------------------------------- estimates


def sf_filter(turns: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig()):
    """Run the SF STKF (eq. 10 with Φ = I) over the accepted rotations, in order.

    Parameters
    ----------
    turns : DataFrame
        From :func:`turn_measurements`.
    config : ScaleFactorConfig

    Returns
    -------
    params : (K + 1, 2) ndarray
        ``[s0, s1]`` before the first and after each of the K accepted rotations.
    cov : (K + 1, 2, 2) ndarray
        The matching covariances (capped at ``P0``).

    Examples
    --------
    Three measurements of SF = 1.02 at 25 degC pull s0 from 1 towards 1.02:

    >>> turns = pd.DataFrame({"sf_meas": [1.02] * 3, "temp_dev_c": [0.0] * 3,
    ...                       "r": [1e-8] * 3, "accepted": [True] * 3})
    >>> x, P = sf_filter(turns)
    >>> round(float(x[-1, 0]), 4)
    1.02
    """
    x = np.array(config.x0, dtype=float)
    P = np.diag(np.square(config.p0_sd))
    xs, Ps = [x], [P]
    for _, m in turns[turns["accepted"]].iterrows():
        x, P = sf_correct(x, P, float(m["sf_meas"]), float(m["temp_dev_c"]), float(m["r"]), config)
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


def sf_correct(x: np.ndarray, P: np.ndarray, sf_meas: float, temp_dev_c: float, r: float,
                config: ScaleFactorConfig):
    """One accepted rotation: ``P- = s*P + Q`` capped at ``P0``, then the Joseph-form
    correction of eq. (10) with ``H = [1, T - T_ref]`` (Sec. 3.2), capped again.

    Parameters
    ----------
    x : (2,) ndarray
        ``[s0, s1]`` (unitless, 1/degC) before the rotation.
    P : (2, 2) ndarray
        Their covariance.
    sf_meas : float
        The measurement y (unitless).
    temp_dev_c : float
        Its mean ``T - T_ref``, degC.
    r : float
        Its variance.
    config : ScaleFactorConfig

    Returns
    -------
    x : (2,) ndarray
        The new ``[s0, s1]``.
    P : (2, 2) ndarray
        The new covariance.
    """
    Q = np.diag(np.square(config.q_sd))
    cap = np.square(np.array(config.p0_sd))
    H = np.array([[1.0, float(temp_dev_c)]])
    P_prior = cap_covariance(float(config.fading) * P + Q, cap)
    x, P_post = correct(np.asarray(x, dtype=float), P_prior, np.array([float(sf_meas)]), H, np.array([[float(r)]]))
    return x, cap_covariance(P_post, cap)


def fixed_scale_factor(turns: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig()) -> float:
    """One-off calibration: weighted mean SF of the first ``fixed_turns`` accepted rotations.

    Inverse-variance weights; 1.0 (the nominal SF) if no rotation was accepted.
    """
    first = turns[turns["accepted"]].head(config.fixed_turns)
    if first.empty:
        return 1.0
    w = 1.0 / first["r"].to_numpy(float)
    return float(np.sum(w * first["sf_meas"].to_numpy(float)) / np.sum(w))


def integrate_heading(t_s, rate_dps, anchor_row: int, anchor_heading_deg: float) -> np.ndarray:
    """Heading (deg, [0, 360)) integrated from ``rate_dps`` by the trapezoid rule.

    Equal to ``anchor_heading_deg`` at ``anchor_row``, as the compensator anchors its
    heading on the first compass sample.
    """
    angle = cumulative_trapezoid(np.asarray(rate_dps, dtype=float), np.asarray(t_s, dtype=float), initial=0.0)
    return wrap_360(anchor_heading_deg + (angle - angle[anchor_row]))


def heading_anchor(out: pd.DataFrame) -> tuple[int, float]:
    """Row and value of the first compass heading, where the compensator anchors its heading.

    Parameters
    ----------
    out : DataFrame
        A compensate() table with ``compass_heading``.

    Returns
    -------
    row : int
    heading_deg : float

    Raises
    ------
    LogFormatError
        No compass heading at all.
    """
    rows = np.flatnonzero(out["compass_heading"].notna().to_numpy())
    if rows.size == 0:
        raise LogFormatError("scale-factor estimate: no compass heading to anchor the heading")
    return int(rows[0]), float(out["compass_heading"].iloc[rows[0]])


def heading_error(heading_deg, ref_heading_deg) -> np.ndarray:
    """Heading minus reference, wrapped to [-180, 180), deg."""
    return wrap_180(np.asarray(heading_deg, dtype=float) - np.asarray(ref_heading_deg, dtype=float))


def estimate_scale_factor(
    out: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig(), *, causal: bool = False
) -> pd.DataFrame:
    """Adaptive and fixed scale factor, and the SF-compensated rate and heading, per row.

    Parameters
    ----------
    out : DataFrame
        Output of :func:`gyrodrift.compensator.compensate` (columns ``t, rate_z,
        temp, compass_heading``, optionally ``gate_reason``).
    config : ScaleFactorConfig
    causal : bool
        False (default, the paper reproduction): the pass of the module notes, which
        looks ahead (centred rotation test, update decided with ``guard_s`` + half a
        window of look-ahead) and initialises the rows up to the first update with its
        result. True: every row depends on that row and the rows before it only, as
        :class:`ScaleFactorTracker` computes it row by row (same numbers): an update
        applies from the first row at which it could be decided, the prior applies until
        the first update, ``heading_sf`` is NaN before the first compass heading,
        rotations longer than ``max_turn_s`` are dropped and an empty temperature cell
        holds the previous value. See "Causal and non-causal" in the module notes.

    Returns
    -------
    DataFrame
        Same index as ``out``: ``t`` (s); ``sf`` (adaptive SF in force,
        ``s0 + s1*(T - T_ref)`` with the parameters of the last update before the
        row, or of the first update for the rows up to it; causal: of the last update
        at or before the row, or the prior; unitless); ``sf_sd``
        (its standard deviation); ``sf_s0``, ``sf_s1`` (parameters, unitless and
        1/degC); ``sf_fixed`` (the one-off calibration, the same in both passes: a
        calibration done before the run);
        ``rate_sf = rate_z / sf`` and ``rate_sf_fixed`` (deg/s); ``heading_sf`` and
        ``heading_sf_fixed`` (deg, integrated from the first compass heading like
        the compensator's ``heading``, which is the heading without SF
        compensation); ``sf_update`` (1 on the row whose measurement updated the
        filter; the new SF applies from the next row, causal: from that row). ``attrs``
        holds ``turns`` (:func:`turn_measurements`), ``sf_fixed``, ``final_params`` and
        ``final_cov``.

    Raises
    ------
    LogFormatError
        A column is missing, the table is empty, time is not finite or does not
        increase, ``rate_z`` is not finite, the first temperature is empty; default pass:
        no compass heading at all.
    """
    turns = turn_measurements(out, config, causal=causal)
    params, covs = sf_filter(turns, config)
    sf_fixed = fixed_scale_factor(turns, config)

    t, rate, temp, compass, _ = compensated_columns(out)
    dev = temp - config.t_ref_c
    update_rows = turns.loc[turns["accepted"], "row_update"].to_numpy(int)
    if causal:
        k = np.searchsorted(update_rows, np.arange(t.size), "right")  # updates at or before each row
    else:
        k = np.searchsorted(update_rows, np.arange(t.size), "left")  # updates strictly before each row
        if update_rows.size:  # initialisation: rows up to the first update use its result
            k = np.maximum(k, 1)
    s0, s1 = params[k, 0], params[k, 1]
    sf = s0 + s1 * dev
    P = covs[k]
    sf_var = P[:, 0, 0] + 2.0 * dev * P[:, 0, 1] + dev**2 * P[:, 1, 1]
    update = np.zeros(t.size, dtype=int)
    update[update_rows] = 1

    rate_sf = rate / sf
    rate_fixed = rate / sf_fixed
    if causal:
        heading_sf, heading_fixed = _causal_heading(t, rate_sf, compass), _causal_heading(t, rate_fixed, compass)
    else:
        anchor, anchor_deg = heading_anchor(out)
        heading_sf = integrate_heading(t, rate_sf, anchor, anchor_deg)
        heading_fixed = integrate_heading(t, rate_fixed, anchor, anchor_deg)
    table = pd.DataFrame(
        {
            "t": t,
            "sf": sf,
            "sf_sd": np.sqrt(np.maximum(sf_var, 0.0)),
            "sf_s0": s0,
            "sf_s1": s1,
            "sf_fixed": np.full(t.size, sf_fixed),
            "rate_sf": rate_sf,
            "rate_sf_fixed": rate_fixed,
            "heading_sf": heading_sf,
            "heading_sf_fixed": heading_fixed,
            "sf_update": update,
        },
        index=out.index,
    )
    table.attrs = {"turns": turns, "sf_fixed": sf_fixed, "final_params": params[-1], "final_cov": covs[-1]}
    return table


def _causal_heading(t_s: np.ndarray, rate_dps: np.ndarray, compass_deg: np.ndarray) -> np.ndarray:
    """:func:`integrate_heading` from the first compass heading, NaN before it (and
    everywhere without one): a causal pass cannot anchor rows before their heading is known."""
    rows = np.flatnonzero(np.isfinite(compass_deg))
    if rows.size == 0:
        return np.full(t_s.size, np.nan)
    heading = integrate_heading(t_s, rate_dps, int(rows[0]), float(compass_deg[rows[0]]))
    heading[: rows[0]] = np.nan
    return heading


# ---------------------------------------------------------------------- streaming


class ScaleFactorRow(NamedTuple):
    """One row of :class:`ScaleFactorTracker`: the columns of the causal
    :func:`estimate_scale_factor` (``sf`` unitless, ``sf_s1`` 1/degC, ``rate_sf`` deg/s,
    ``heading_sf`` deg, ``sf_update`` 0/1)."""

    sf: float
    sf_sd: float
    sf_s0: float
    sf_s1: float
    rate_sf: float
    heading_sf: float
    sf_update: int


#: Columns of :class:`ScaleFactorTracker` output, in order.
TRACKER_COLUMNS = ScaleFactorRow._fields


@dataclass(frozen=True)
class CompensatedSFSample(CompensatedSample):
    """A :class:`gyrodrift.compensator.CompensatedSample` with the scale factor of Sec. 4.3, as
    :class:`gyrodrift.compensator.Compensator` returns it when given ``scale_factor``: ``sf``
    (unitless), ``sf_sd``, ``rate_sf`` (deg/s) and ``heading_sf`` (deg) of
    :class:`ScaleFactorTracker`."""

    sf: float = math.nan
    sf_sd: float = math.nan
    rate_sf: float = math.nan
    heading_sf: float = math.nan

    @classmethod
    def of(cls, sample: CompensatedSample, row: ScaleFactorRow) -> "CompensatedSFSample":
        """``sample`` with the SF columns of ``row``."""
        base = {f.name: getattr(sample, f.name) for f in fields(CompensatedSample)}
        return cls(**base, sf=row.sf, sf_sd=row.sf_sd, rate_sf=row.rate_sf, heading_sf=row.heading_sf)


def _wrap_360_f(angle_deg: float) -> float:
    """:func:`~gyrodrift.conventions.wrap_360` of one float (Python's float ``%`` is numpy's
    ``mod``: fmod and the sign rule, so the same bits)."""
    m = angle_deg % 360.0
    return m - 360.0 if m >= 360.0 else m


class ScaleFactorTracker:
    """The causal SF estimate (Sec. 4.3, module notes) fed one compensated row at a time.

    Feed the rows of :func:`gyrodrift.compensator.compensate` (or of
    :class:`gyrodrift.compensator.Compensator`) in time order with :meth:`push` (one row),
    :meth:`push_arrays` or :meth:`push_frame` (chunks of any size); every row comes back at
    once with the SF in force. The numbers are those of
    ``estimate_scale_factor(out, config, causal=True)`` on the whole table, bit for bit,
    however the rows are chunked.

    What it keeps: the running gyro heading, compass unwrapping and SF-compensated heading
    (a few floats), the filter state, and the rows that a rotation still to be decided
    needs (from ``2*guard_s + still_s`` before it starts to ``turn_window_s/2`` after its
    second still window and guard). A rotation whose rotating rows last longer than
    ``max_turn_s`` is dropped (reason ``long_turn``) rather than buffered until it ends,
    so the kept rows never span more than :attr:`buffer_bound_s` (plus 64 rows, the
    amortised trimming), whatever the log's length.

    Parameters
    ----------
    config : ScaleFactorConfig, optional
    source : str
        Name used in error messages.

    Examples
    --------
    A still unit keeps the prior SF 1 and the first compass heading; 100 s at 10 Hz, of
    which the tracker keeps the last 10 s or so:

    >>> tr = ScaleFactorTracker()
    >>> rows = [tr.push(0.1 * i, 0.0, 30.0, 40.0 if i % 10 == 0 else math.nan) for i in range(1000)]
    >>> rows[-1].sf, rows[-1].heading_sf, tr.buffered_rows < 200
    (1.0, 40.0, True)
    """

    _TRIM_ROWS = 64

    def __init__(self, config: ScaleFactorConfig | None = None, *, source: str = "scale-factor stream"):
        cfg = ScaleFactorConfig() if config is None else config
        if not isinstance(cfg, ScaleFactorConfig):
            raise ConfigError(f"ScaleFactorTracker needs a ScaleFactorConfig, got {type(cfg).__name__}")
        self.config = cfg
        self.source = source
        self._half = 0.5 * cfg.turn_window_s
        self._x = np.array(cfg.x0, dtype=float)
        self._P = np.diag(np.square(cfg.p0_sd))
        self._floats()
        # rows kept (parallel lists; element 0 is absolute row self._base)
        self._base = 0
        self._n = 0
        self._t: list[float] = []
        self._rate: list[float] = []
        self._temp: list[float] = []
        self._psi_g: list[float] = []
        self._psi_c: list[float] = []
        self._gate: list[str] = []
        self._moving: list[bool] = []
        self._t_first = math.nan
        # the centred rotation test: next row to decide, interpolation rows of its window
        self._next = 0
        self._p_lo = 0
        self._p_hi = 0
        self._run_start = -1  # first row of the rotation in progress, -1: none
        self._run_dropped = False
        self._pending: deque[tuple[int, int, float]] = deque()  # (first, last row, a1 + guard_s)
        # compass unwrapped against the gyro (np.unwrap, continued)
        self._c_count = 0
        self._c_prev = math.nan
        self._c_corr = 0.0
        # SF-compensated heading
        self._angle = 0.0
        self._rate_sf_prev = math.nan
        self._anchor_angle = math.nan
        self._anchor_deg = math.nan
        #: Number of accepted rotations (filter updates) so far.
        self.n_updates = 0
        #: Decided rotations by reason ('' = accepted), counts.
        self.reasons: dict[str, int] = {}
        #: The turn-table row (:func:`turn_measurements`) of the last decided rotation, or None.
        self.last_turn: dict | None = None

    # -- state
    def _floats(self) -> None:
        self._s0, self._s1 = float(self._x[0]), float(self._x[1])
        self._P00, self._P01, self._P11 = float(self._P[0, 0]), float(self._P[0, 1]), float(self._P[1, 1])

    @property
    def params(self) -> np.ndarray:
        """``[s0 (unitless), s1 (1/degC)]`` now in force."""
        return self._x.copy()

    @property
    def cov(self) -> np.ndarray:
        """Covariance of :attr:`params`."""
        return self._P.copy()

    @property
    def buffered_rows(self) -> int:
        """Number of rows kept for the rotations still to be decided."""
        return len(self._t)

    @property
    def buffer_bound_s(self) -> float:
        """Longest time span the kept rows can cover, s: ``max_turn_s + 4*guard_s +
        2*still_s + turn_window_s`` (the kept rows also include up to 64 rows of trimming
        slack and the row just before the span)."""
        c = self.config
        return c.max_turn_s + 4.0 * c.guard_s + 2.0 * c.still_s + c.turn_window_s

    # -- input
    def push(self, t_s, rate_z_dps, temp_c, compass_heading_deg=math.nan, gate_reason: str = "") -> ScaleFactorRow:
        """Add one compensated row; return its SF columns.

        Parameters
        ----------
        t_s : float
            Time, s (finite, strictly increasing).
        rate_z_dps : float
            Drift-compensated rate ``rate_z``, deg/s (finite).
        temp_c : float
            Gyro temperature, degC (NaN: hold the previous value; the first row needs one).
        compass_heading_deg : float, optional
            Compass heading, deg (NaN: no compass sample on this row).
        gate_reason : str, optional
            The drift compensator's ``gate_reason`` of the row ('' = none).

        Returns
        -------
        ScaleFactorRow

        Raises
        ------
        LogFormatError
            Time not finite or not increasing, rate not finite, first temperature empty.
        """
        cfg = self.config
        t, rate, temp = float(t_s), float(rate_z_dps), float(temp_c)
        compass = math.nan if compass_heading_deg is None else float(compass_heading_deg)
        n = self._n
        if not math.isfinite(t):
            raise LogFormatError(f"{self.source}: row {n}: time must be a finite number of seconds, got {t_s!r}")
        if n:
            t_prev = self._t[-1]
            if not t > t_prev:
                raise LogFormatError(f"{self.source}: row {n}: time must increase: got t={t!r} after t={t_prev!r}")
        if not math.isfinite(rate):
            raise LogFormatError(f"{self.source}: row {n}: rate_z must be a finite number of deg/s, got {rate_z_dps!r}")
        if not math.isfinite(temp):
            if not n:
                raise LogFormatError(f"{self.source}: row 0: the first row needs a finite temperature, got {temp_c!r}")
            temp = self._temp[-1]

        # gyro heading: scipy's cumulative_trapezoid, continued (the same operations)
        if n == 0:
            psi = 0.0
            self._t_first = t
        else:
            inc = (t - t_prev) * (rate + self._rate[-1]) / 2.0
            psi = inc if n == 1 else self._psi_g[-1] + inc
        # compass unwrapped against the gyro: numpy's unwrap, continued
        psi_c = math.nan
        has_compass = math.isfinite(compass)
        if has_compass:
            d = _wrap_360_f(compass - psi + 180.0) - 180.0
            if self._c_count == 0:
                up = d
            else:
                dd = d - self._c_prev
                ddmod = (dd + 180.0) % 360.0 - 180.0
                if ddmod == -180.0 and dd > 0.0:
                    ddmod = 180.0
                corr = 0.0 if abs(dd) < 180.0 else ddmod - dd
                self._c_corr = corr if self._c_count == 1 else self._c_corr + corr
                up = d + self._c_corr
            self._c_prev = d
            self._c_count += 1
            psi_c = psi + up
        self._t.append(t)
        self._rate.append(rate)
        self._temp.append(temp)
        self._psi_g.append(psi)
        self._psi_c.append(psi_c)
        self._gate.append(gate_reason if isinstance(gate_reason, str) else str(gate_reason))
        self._moving.append(False)
        self._n = n + 1

        self._decide_rotation_test(t)
        update = 0
        while self._pending:
            first, last, lim = self._pending[0]
            nxt = self._next - self._base
            if nxt >= len(self._t) or not self._t[nxt] > lim:
                break
            self._pending.popleft()
            update |= self._decide_turn(first, last, t)
        self._trim()

        # the row's SF and SF-compensated heading (estimate_scale_factor's operations)
        dev = temp - cfg.t_ref_c
        sf = self._s0 + self._s1 * dev
        var = self._P00 + 2.0 * dev * self._P01 + dev * dev * self._P11
        rate_sf = rate / sf
        if n:
            inc = (t - t_prev) * (rate_sf + self._rate_sf_prev) / 2.0
            self._angle = inc if n == 1 else self._angle + inc
        self._rate_sf_prev = rate_sf
        if has_compass and self._anchor_deg != self._anchor_deg:  # first compass heading
            self._anchor_deg, self._anchor_angle = compass, self._angle
        heading = _wrap_360_f(self._anchor_deg + (self._angle - self._anchor_angle))
        return ScaleFactorRow(
            sf, math.sqrt(var) if var > 0.0 else 0.0, self._s0, self._s1, rate_sf, heading, update
        )

    def push_arrays(self, t_s, rate_z_dps, temp_c, compass_heading_deg=None, gate_reason=None) -> dict:
        """Add a chunk of rows (arrays of one length; see :meth:`push`); return a dict of
        the :data:`TRACKER_COLUMNS` arrays."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        n = t.size
        rate = np.atleast_1d(np.asarray(rate_z_dps, dtype=float))
        temp = np.atleast_1d(np.asarray(temp_c, dtype=float))
        compass = (np.full(n, np.nan) if compass_heading_deg is None
                   else np.atleast_1d(np.asarray(compass_heading_deg, dtype=float)))
        gates = [""] * n if gate_reason is None else [str(g) for g in np.atleast_1d(np.asarray(gate_reason))]
        sizes = {rate.size, temp.size, compass.size, len(gates)}
        if sizes != {n}:
            raise LogFormatError(f"{self.source}: the chunk's columns differ in length ({n}, {sorted(sizes)})")
        rows = [self.push(*r) for r in zip(t.tolist(), rate.tolist(), temp.tolist(), compass.tolist(), gates)]
        cols = list(zip(*rows)) if rows else [()] * len(TRACKER_COLUMNS)
        return {
            name: np.array(col, dtype=int if name == "sf_update" else float)
            for name, col in zip(TRACKER_COLUMNS, cols)
        }

    def push_frame(self, out: pd.DataFrame) -> pd.DataFrame:
        """Add a chunk of a compensate() table (``t, rate_z, temp, compass_heading`` and,
        if present, ``gate_reason``); return the :data:`TRACKER_COLUMNS` with its index."""
        require_columns(out, (T, "rate_z", TEMP, "compass_heading"))
        gates = out["gate_reason"].to_numpy(str) if "gate_reason" in out.columns else None
        cols = self.push_arrays(out[T].to_numpy(float), out["rate_z"].to_numpy(float), out[TEMP].to_numpy(float),
                                out["compass_heading"].to_numpy(float), gates)
        return pd.DataFrame(cols, index=out.index)

    # -- steps
    def _interp(self, x: float, p: int) -> tuple[float, int]:
        """``np.interp(x, t, psi_g)`` on the kept rows (the same operations), and the row
        ``p`` with ``t[p] <= x < t[p + 1]`` found by walking forward from ``p``."""
        t, fp, b = self._t, self._psi_g, self._base
        last = len(t) - 1
        j = p - b
        while j < last and t[j + 1] <= x:
            j += 1
        if j == last or t[j] == x:
            return fp[j], j + b
        slope = (fp[j + 1] - fp[j]) / (t[j + 1] - t[j])
        return slope * (x - t[j]) + fp[j], j + b

    def _decide_rotation_test(self, t_now: float) -> None:
        """The centred rotation test (:func:`moving_mask`) of every row whose window has
        ended by ``t_now``; rotations started, ended, or dropped as too long."""
        cfg, half, b = self.config, self._half, self._base
        t = self._t
        while self._next < self._n:
            i = self._next
            ti = t[i - b]
            hi = ti + half
            if hi > t_now:
                break
            lo = ti - half
            if lo < self._t_first:
                lo = self._t_first
            a_hi, self._p_hi = self._interp(hi, self._p_hi)
            a_lo, self._p_lo = self._interp(lo, self._p_lo)
            span = hi - lo
            if span < _TINY:
                span = _TINY
            moving = abs((a_hi - a_lo) / span) > cfg.turn_rate_dps
            self._moving[i - b] = moving
            if moving:
                if self._run_start < 0:
                    self._run_start, self._run_dropped = i, False
                elif not self._run_dropped and ti - t[self._run_start - b] > cfg.max_turn_s:
                    self._run_dropped = True
                    self._count(unmeasured_turn(t[self._run_start - b], ti, LONG_TURN))
            elif self._run_start >= 0:
                if not self._run_dropped:
                    te = t[i - 1 - b]
                    self._pending.append((self._run_start, i - 1, te + cfg.guard_s + cfg.still_s + cfg.guard_s))
                self._run_start = -1
            self._next = i + 1

    def _decide_turn(self, first: int, last: int, t_now: float) -> int:
        """Measure the rotation on rows first..last (shared with the batch pass) and update
        the filter if it is accepted; return 1 if it was."""
        b = self._base
        psi_c = np.array(self._psi_c)
        row = measure_turn(
            np.array(self._t), np.array(self._rate), np.array(self._temp), np.array(self._psi_g), psi_c,
            np.isfinite(psi_c), np.array(self._moving), np.array(self._gate), first - b, last - b, self.config,
            log_start_s=self._t_first, log_end_s=t_now,
        )
        row["row_update"], row["t_update"] = self._n - 1, t_now
        self._count(row)
        if not row["accepted"]:
            return 0
        self._x, self._P = sf_correct(self._x, self._P, row["sf_meas"], row["temp_dev_c"], row["r"], self.config)
        self._floats()
        self.n_updates += 1
        return 1

    def _count(self, row: dict) -> None:
        self.reasons[row["reason"]] = self.reasons.get(row["reason"], 0) + 1
        self.last_turn = row

    def _trim(self) -> None:
        """Forget the rows no rotation still to be decided can need."""
        cfg, b, t = self.config, self._base, self._t
        nxt = min(self._next, self._n - 1) - b
        t_next = t[nxt]
        cut = min(t_next - self._half, t_next - cfg.guard_s - cfg.still_s - cfg.guard_s)
        starts = [self._pending[0][0]] if self._pending else []
        if self._run_start >= 0 and not self._run_dropped:
            starts.append(self._run_start)
        for s in starts:
            cut = min(cut, t[s - b] - cfg.guard_s - cfg.still_s - cfg.guard_s)
        keep = bisect.bisect_right(t, cut) - 1  # the last row at or before the cut
        keep = min(keep, self._p_lo - b, self._p_hi - b)
        if keep >= self._TRIM_ROWS:
            for col in (self._t, self._rate, self._temp, self._psi_g, self._psi_c, self._gate, self._moving):
                del col[:keep]
            self._base = b + keep


_TINY = float(np.finfo(float).tiny)


"""Adaptive estimate of the temperature-dependent gyro scale factor (Feng et al. 2015, Sec. 4.3).

Section 4.3 of the paper compensates the scale factor (SF) "with the adaptive
algorithm" on simulated rotations combined with the static heating data, and shows
the ideal, a fixed-parameter and the adaptive SF (Fig. 10) and the heading error
without SF compensation, with the fixed SF and with the adaptive SF (Fig. 11). It
gives no equations; this module is gyrodrift's design in the spirit of Section 3.

Model
-----
After the drift compensation of :func:`gyrodrift.compensate.compensate`
(``rate_z = gyro_z - bias_z``, eqs. 1, 2, 5), the gyro still reads

    rate_z = SF(T) * true_rate + (drift residual) + noise,
    SF(T) = s0 + s1 * (T - T_ref)                                  (cf. eq. 2)

with ``T`` the measured gyro temperature (degC) and ``T_ref`` = ``t_ref_c``. The
parameters ``x = [s0 (unitless), s1 (1/degC)]`` are the states of a strong tracking
Kalman filter modelled as constant between updates (Φ = Γ = I, Section 3.2): at each
accepted measurement ``P- = s*P + Q`` then a Joseph-form correction (eq. 10, the
kernels of :mod:`gyrodrift.estimators._kalman`), and P is capped at the prior
``P0`` (:func:`~gyrodrift.estimators._kalman.cap_covariance`). The SF compensated rate
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
parameters apply from the row after the end of the second window, so the estimate
is causal, except for the initialisation: the rows up to the first accepted
rotation are compensated with the SF it produced (as the drift compensator emits the
rows of its initialisation window with the parameters the window gave), so the
first turn is not integrated with the bare prior.

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

Examples
--------
The 3-h experiment at 10 Hz (about a second):

>>> res = scale_factor_experiment(seed=0, fs_hz=10.0)
>>> sorted(res)
['config', 'fig10', 'fig11', 'log', 'out', 'sf', 'summary', 'turns']
>>> res["summary"]["sf_rms"]["adaptive"] < 1e-3 < res["summary"]["sf_rms"]["fixed"]
True
>>> part = res["summary"]["sf_heading_rms_deg"]
>>> bool(part["adaptive"] < part["fixed"] < part["none"])
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.integrate import cumulative_trapezoid

from gyrodrift import gating
from gyrodrift.conventions import REF_HEADING, TEMP, T, wrap_180, wrap_360
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.estimators._kalman import cap_covariance, correct, predict

__all__ = [
    "ScaleFactorConfig",
    "moving_mask",
    "turn_measurements",
    "sf_filter",
    "fixed_scale_factor",
    "integrate_heading",
    "heading_error",
    "estimate_scale_factor",
    "scale_factor_experiment",
    "REJECT_GATES",
]

#: Drift-compensator refusals that also refuse an SF measurement over the same rows.
REJECT_GATES = (gating.GAP, gating.FIELD, gating.INTERFERENCE)

# Reasons a detected rotation is not used (the ``reason`` column of the turn table).
_EDGE = "edge"
_NOT_STILL = "not_still"
_NO_COMPASS = "no_compass"
_SMALL = "small_turn"
_IMPLAUSIBLE = "implausible"


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
            "max_compass_gap_s", "compass_sigma_deg", "gyro_noise_dps_rthz",
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


def _require(out: pd.DataFrame, cols) -> None:
    missing = [c for c in cols if c not in out.columns]
    if missing:
        raise LogFormatError(
            f"scale-factor estimate needs the compensate() output columns {', '.join(missing)}"
        )


def _unwrapped_compass(psi_g: np.ndarray, compass: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Compass heading at ``rows`` unwrapped against the gyro heading, deg."""
    d = wrap_180(compass[rows] - psi_g[rows])
    return psi_g[rows] + np.unwrap(d, period=360.0)


def turn_measurements(out: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig()) -> pd.DataFrame:
    """One SF measurement per detected rotation (module notes), accepted or not.

    Parameters
    ----------
    out : DataFrame
        Output of :func:`gyrodrift.compensate.compensate`: ``t`` (s), ``rate_z``
        (deg/s), ``temp`` (degC), ``compass_heading`` (deg, NaN off compass rows)
        and, if present, ``gate_reason``.
    config : ScaleFactorConfig

    Returns
    -------
    DataFrame
        One row per rotation: ``t_start, t_end`` (s, rotating rows), ``t_update``
        (s, end of the second still window) and its row ``row_update``,
        ``angle_gyro_deg``, ``angle_compass_deg`` (heading changes, deg), ``sf_meas``
        (y, unitless), ``temp_c`` and ``temp_dev_c`` (rate-weighted mean T and
        T - T_ref, degC), ``r`` (variance of y), ``accepted`` (bool) and ``reason``
        ('' when accepted; else ``edge``, ``not_still``, ``no_compass``, a drift
        gate of :data:`REJECT_GATES`, ``small_turn`` or ``implausible``).
    """
    _require(out, (T, "rate_z", TEMP, "compass_heading"))
    t = out[T].to_numpy(float)
    rate = out["rate_z"].to_numpy(float)
    temp = out[TEMP].to_numpy(float)
    compass = out["compass_heading"].to_numpy(float)
    gates = out["gate_reason"].to_numpy(str) if "gate_reason" in out.columns else np.full(t.size, "")
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
        rows.append(_one_turn(t, rate, temp, psi_g, psi_c, has_c, moving, gates, int(i0), int(i1), cfg))
    columns = [
        "t_start", "t_end", "t_update", "row_update", "angle_gyro_deg", "angle_compass_deg",
        "sf_meas", "temp_c", "temp_dev_c", "r", "accepted", "reason",
    ]
    table = pd.DataFrame(rows, columns=columns)
    return table.astype({"row_update": int, "accepted": bool})


def _one_turn(t, rate, temp, psi_g, psi_c, has_c, moving, gates, i0, i1, cfg: ScaleFactorConfig) -> dict:
    """The SF measurement of the rotation on rows i0..i1 (see :func:`turn_measurements`)."""
    ts, te = float(t[i0]), float(t[i1])
    b0, b1 = ts - cfg.guard_s - cfg.still_s, ts - cfg.guard_s
    a0, a1 = te + cfg.guard_s, te + cfg.guard_s + cfg.still_s
    row = {
        "t_start": ts, "t_end": te, "t_update": math.nan, "row_update": -1,
        "angle_gyro_deg": math.nan, "angle_compass_deg": math.nan, "sf_meas": math.nan,
        "temp_c": math.nan, "temp_dev_c": math.nan, "r": math.nan, "accepted": False, "reason": "",
    }
    if b0 < t[0] or a1 > t[-1]:
        row["reason"] = _EDGE
        return row
    span = _window(t, b0, a1)
    row["row_update"] = span.stop - 1
    row["t_update"] = float(t[span.stop - 1])
    if moving[_window(t, b0 - cfg.guard_s, b1)].any() or moving[_window(t, a0, a1 + cfg.guard_s)].any():
        row["reason"] = _NOT_STILL
        return row
    before, after = _window(t, b0, b1), _window(t, a0, a1)
    cb = np.flatnonzero(has_c[before]) + before.start
    ca = np.flatnonzero(has_c[after]) + after.start
    c_span = np.flatnonzero(has_c[span]) + span.start
    if min(cb.size, ca.size) < cfg.min_compass_samples or np.diff(t[c_span]).max() > cfg.max_compass_gap_s:
        row["reason"] = _NO_COMPASS
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
        row["reason"] = _SMALL
    elif not abs(y - 1.0) <= cfg.max_sf_error:
        row["reason"] = _IMPLAUSIBLE
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
    Q = np.diag(np.square(config.q_sd))
    cap = np.square(np.array(config.p0_sd))
    xs, Ps = [x], [P]
    for _, m in turns[turns["accepted"]].iterrows():
        H = np.array([[1.0, float(m["temp_dev_c"])]])
        P_prior = cap_covariance(predict(P, Q, config.fading), cap)
        x, P_post, _, _ = correct(x, P_prior, np.array([float(m["sf_meas"])]), H, np.array([[float(m["r"])]]))
        P = cap_covariance(P_post, cap)
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


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


def _anchor(out: pd.DataFrame) -> tuple[int, float]:
    """Row and value (deg) of the first compass heading, where the compensator anchors its heading."""
    rows = np.flatnonzero(out["compass_heading"].notna().to_numpy())
    if rows.size == 0:
        raise LogFormatError("scale-factor estimate: no compass heading to anchor the heading")
    return int(rows[0]), float(out["compass_heading"].iloc[rows[0]])


def heading_error(heading_deg, ref_heading_deg) -> np.ndarray:
    """Heading minus reference, wrapped to [-180, 180), deg."""
    return wrap_180(np.asarray(heading_deg, dtype=float) - np.asarray(ref_heading_deg, dtype=float))


def estimate_scale_factor(out: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig()) -> pd.DataFrame:
    """Adaptive and fixed scale factor, and the SF-compensated rate and heading, per row.

    Parameters
    ----------
    out : DataFrame
        Output of :func:`gyrodrift.compensate.compensate` (columns ``t, rate_z,
        temp, compass_heading``, optionally ``gate_reason``).
    config : ScaleFactorConfig

    Returns
    -------
    DataFrame
        Same index as ``out``: ``t`` (s); ``sf`` (adaptive SF in force,
        ``s0 + s1*(T - T_ref)`` with the parameters of the last update before the
        row, or of the first update for the rows up to it; unitless); ``sf_sd``
        (its standard deviation); ``sf_s0``, ``sf_s1`` (parameters, unitless and
        1/degC); ``sf_fixed`` (the one-off calibration);
        ``rate_sf = rate_z / sf`` and ``rate_sf_fixed`` (deg/s); ``heading_sf`` and
        ``heading_sf_fixed`` (deg, integrated from the first compass heading like
        the compensator's ``heading``, which is the heading without SF
        compensation); ``sf_update`` (1 on the row whose measurement updated the
        filter; the new SF applies from the next row). ``attrs`` holds ``turns``
        (:func:`turn_measurements`), ``sf_fixed``, ``final_params`` and ``final_cov``.
    """
    turns = turn_measurements(out, config)
    params, covs = sf_filter(turns, config)
    sf_fixed = fixed_scale_factor(turns, config)

    t = out[T].to_numpy(float)
    rate = out["rate_z"].to_numpy(float)
    dev = out[TEMP].to_numpy(float) - config.t_ref_c
    update_rows = turns.loc[turns["accepted"], "row_update"].to_numpy(int)
    k = np.searchsorted(update_rows, np.arange(t.size), "left")  # updates strictly before each row
    if update_rows.size:  # initialisation: rows up to the first update use its result
        k = np.maximum(k, 1)
    s0, s1 = params[k, 0], params[k, 1]
    sf = s0 + s1 * dev
    P = covs[k]
    sf_var = P[:, 0, 0] + 2.0 * dev * P[:, 0, 1] + dev**2 * P[:, 1, 1]
    update = np.zeros(t.size, dtype=int)
    update[update_rows] = 1

    anchor, anchor_deg = _anchor(out)
    rate_sf = rate / sf
    rate_fixed = rate / sf_fixed
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
            "heading_sf": integrate_heading(t, rate_sf, anchor, anchor_deg),
            "heading_sf_fixed": integrate_heading(t, rate_fixed, anchor, anchor_deg),
            "sf_update": update,
        },
        index=out.index,
    )
    table.attrs = {"turns": turns, "sf_fixed": sf_fixed, "final_params": params[-1], "final_cov": covs[-1]}
    return table


# ---------------------------------------------------------------------- experiment


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else math.nan


def _max_abs(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x))) if x.size else math.nan


def scale_factor_experiment(
    seed: int = 0,
    duration_s: float | None = None,
    fs_hz: float = 50.0,
    *,
    device=None,
    compass=None,
    config: ScaleFactorConfig | None = None,
    compensator_config=None,
) -> dict:
    """Section 4.3 on simulated data: drift compensation, then fixed and adaptive SF.

    Simulates the ``scale-factor`` scenario (:func:`gyrodrift.simulate.simulate`),
    compensates the drift (:func:`gyrodrift.compensate.compensate`) and estimates the
    scale factor (:func:`estimate_scale_factor`).

    Parameters
    ----------
    seed : int
        Seed of the simulation.
    duration_s : float, optional
        Run length, s (default: the scenario's 3 h).
    fs_hz : float
        Gyro sample rate, Hz.
    device : DeviceModel, optional
        Gyro model; scale-factor coefficients left ``None`` take the scenario's
        (about 3 % over 23–58 degC).
    compass : CompassModel, optional
    config : ScaleFactorConfig, optional
    compensator_config : CompensatorConfig, optional
        Settings of the drift compensator.

    Returns
    -------
    dict
        ``log`` (simulated), ``out`` (compensated), ``sf`` (:func:`estimate_scale_factor`),
        ``turns`` (the rotation measurements); ``fig10``: ``t`` (s), ``temp`` (degC),
        ``sf_ideal`` (true SF), ``sf_fixed``, ``sf_adaptive`` (unitless); ``fig11``:
        ``t`` (s) and the heading errors against the reference ``err_none``,
        ``err_fixed``, ``err_adaptive`` and ``err_ideal`` (compensated with the true
        SF: what the drift compensation alone leaves), deg; ``summary``:

        * ``heading_rms_deg``, ``heading_max_deg``: dicts none/fixed/adaptive/ideal
          of the heading error over the whole run (Fig. 11);
        * ``sf_heading_rms_deg``, ``sf_heading_max_deg``: dicts none/fixed/adaptive
          of the heading minus the ideal heading, the part of the heading error due
          to the SF estimate alone (the drift residual, common to all, cancels);
        * ``sf_rms``, ``sf_max``: dicts none/fixed/adaptive of the SF error against
          the true SF, over the rows after the first SF update (the rows before it
          have no measurement of their own);
        * ``turns`` (rotations detected), ``sf_updates`` (accepted), ``sf_fixed``;

        and ``config``.

    Notes
    -----
    The heading is integrated open loop for the whole run, so the drift left by the
    drift compensator accumulates into every line of Fig. 11 alike (``err_ideal``);
    over a 3-h run it is of the same order as the SF errors and adds to or cancels
    them by chance. ``sf_heading_*`` isolates the SF's share.
    """
    from gyrodrift.compensate import compensate
    from gyrodrift.simulate import TRUE_SF, simulate

    config = config or ScaleFactorConfig()
    log = simulate(
        "scale-factor", seed=seed, duration_s=duration_s, fs_hz=fs_hz, device=device, compass=compass
    )
    out = compensate(log, compensator_config)
    sf = estimate_scale_factor(out, config)
    turns = sf.attrs["turns"]

    t = out[T].to_numpy(float)
    ref = out[REF_HEADING].to_numpy(float)
    true_sf = out[TRUE_SF].to_numpy(float)
    fig10 = pd.DataFrame(
        {
            "t": t,
            "temp": out[TEMP].to_numpy(float),
            "sf_ideal": true_sf,
            "sf_fixed": sf["sf_fixed"].to_numpy(),
            "sf_adaptive": sf["sf"].to_numpy(),
        }
    )
    heading_ideal = integrate_heading(t, out["rate_z"].to_numpy(float) / true_sf, *_anchor(out))
    headings = {
        "none": out["heading"].to_numpy(float),
        "fixed": sf["heading_sf_fixed"].to_numpy(),
        "adaptive": sf["heading_sf"].to_numpy(),
    }
    errors = {k: heading_error(h, ref) for k, h in headings.items()}
    errors["ideal"] = heading_error(heading_ideal, ref)
    sf_part = {k: heading_error(h, heading_ideal) for k, h in headings.items()}
    fig11 = pd.DataFrame({"t": t, **{f"err_{k}": v for k, v in errors.items()}})

    ups = np.flatnonzero(sf["sf_update"].to_numpy())
    after = slice(int(ups[0]) + 1 if ups.size else t.size, t.size)
    sf_err = {
        "none": 1.0 - true_sf[after],
        "fixed": fig10["sf_fixed"].to_numpy()[after] - true_sf[after],
        "adaptive": fig10["sf_adaptive"].to_numpy()[after] - true_sf[after],
    }
    summary = {
        "heading_rms_deg": {k: _rms(v) for k, v in errors.items()},
        "heading_max_deg": {k: _max_abs(v) for k, v in errors.items()},
        "sf_heading_rms_deg": {k: _rms(v) for k, v in sf_part.items()},
        "sf_heading_max_deg": {k: _max_abs(v) for k, v in sf_part.items()},
        "sf_rms": {k: _rms(v) for k, v in sf_err.items()},
        "sf_max": {k: _max_abs(v) for k, v in sf_err.items()},
        "turns": int(len(turns)),
        "sf_updates": int(turns["accepted"].sum()),
        "sf_fixed": float(sf.attrs["sf_fixed"]),
    }
    return {
        "log": log,
        "out": out,
        "sf": sf,
        "turns": turns,
        "fig10": fig10,
        "fig11": fig11,
        "summary": summary,
        "config": config,
    }

"""Rotations and their scale-factor measurements (``docs/scale_factor.md``, measurement).

:func:`moving_mask` is the rotation test; :func:`turn_measurements` measures every rotation
of a compensated log, :func:`measure_turn` one of them (also for the tracker's kept rows).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.integrate import cumulative_trapezoid

from gyrodrift import gating
from gyrodrift.conventions import TEMP, T, wrap_180
from gyrodrift.errors import LogFormatError
from gyrodrift.scale_factor.config import ScaleFactorConfig

__all__ = [
    "REJECT_GATES", "EDGE", "NOT_STILL", "NO_COMPASS", "SMALL_TURN", "IMPLAUSIBLE", "LONG_TURN", "moving_mask",
    "require_columns", "read_columns", "compensated_columns", "turn_measurements", "unmeasured_turn", "measure_turn",
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


def moving_mask(t_s, rate_dps, config: ScaleFactorConfig = ScaleFactorConfig()) -> np.ndarray:
    """Rows where the unit rotates: the centred ``turn_window_s`` mean of ``rate_dps`` (deg/s, the
    compensated ``rate_z`` at times ``t_s``, increasing) above ``turn_rate_dps`` in magnitude."""
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
    """Raise :class:`LogFormatError` naming the columns of ``cols`` that ``out`` lacks."""
    missing = [c for c in cols if c not in out.columns]
    if missing:
        raise LogFormatError(f"scale-factor estimate needs the compensate() output columns {', '.join(missing)}")


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
    compensator holds an empty temperature cell (both passes and the tracker)."""
    ok = np.isfinite(temp_c)
    if ok.all():
        return temp_c
    if not ok[0]:
        raise LogFormatError(f"{source}: row 0: the first row needs a finite temperature, got {float(temp_c[0])!r}")
    last = np.where(ok, np.arange(temp_c.size), 0)
    np.maximum.accumulate(last, out=last)
    return temp_c[last]


def read_columns(out: pd.DataFrame):
    """The columns the SF estimate reads from a compensate() table, as they are.

    Returns ``t`` (s), ``rate`` (``rate_z``, deg/s), ``temp`` (degC), ``compass`` (deg, NaN:
    no sample) and ``gates`` (``gate_reason``, '' when absent).
    """
    require_columns(out, (T, "rate_z", TEMP, "compass_heading"))
    gates = out["gate_reason"].to_numpy(str) if "gate_reason" in out.columns else np.full(len(out), "")
    return (*(out[c].to_numpy(float) for c in (T, "rate_z", TEMP, "compass_heading")), gates)


def compensated_columns(out: pd.DataFrame):
    """:func:`read_columns`, checked (:func:`_check_rows`), empty temperature cells held."""
    t, rate, temp, compass, gates = read_columns(out)
    _check_rows(t, rate)
    return t, rate, _held_temperature(temp), compass, gates


def _unwrapped_compass(psi_g: np.ndarray, compass: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Compass heading at ``rows`` unwrapped against the gyro heading, deg."""
    d = wrap_180(compass[rows] - psi_g[rows])
    return psi_g[rows] + np.unwrap(d, period=360.0)


def _decision_row(t_s: np.ndarray, t_end_s: float, cfg: ScaleFactorConfig) -> int:
    """First row at which the rotation ending at ``t_end_s`` can be decided from the rows so far
    (causal pass; ``docs/scale_factor.md``), or -1 if the log ends first."""
    lim = t_end_s + cfg.guard_s + cfg.still_s + cfg.guard_s  # a1 + guard_s, as in measure_turn
    last = int(np.searchsorted(t_s, lim, "right")) - 1
    j = int(np.searchsorted(t_s, t_s[last] + 0.5 * cfg.turn_window_s, "left"))
    return j if j < t_s.size else -1


def turn_measurements(
    out: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig(), *, causal: bool = False
) -> pd.DataFrame:
    """One SF measurement per detected rotation, accepted or not: the turn table of ``docs/scale_factor.md``.

    ``out`` is a :func:`gyrodrift.compensator.compensate` table; ``causal`` decides each
    rotation at the first row at which the rows so far suffice and drops rotations longer
    than ``max_turn_s`` (the measurements are those of the default pass).
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
    table = pd.DataFrame(rows, columns=list(unmeasured_turn(0.0, 0.0, "")))
    return table.astype({"row_update": int, "accepted": bool})


def unmeasured_turn(t_start_s: float, t_end_s: float, reason: str) -> dict:
    """A turn-table row of the rotation from ``t_start_s`` to ``t_end_s`` without a measurement, for ``reason``."""
    return {
        "t_start": t_start_s, "t_end": t_end_s, "t_update": math.nan, "row_update": -1,
        "angle_gyro_deg": math.nan, "angle_compass_deg": math.nan, "sf_meas": math.nan,
        "temp_c": math.nan, "temp_dev_c": math.nan, "r": math.nan, "accepted": False, "reason": reason,
    }


def measure_turn(
    t, rate, temp, psi_g, psi_c, has_c, moving, gates, i0, i1, cfg: ScaleFactorConfig, *,
    log_start_s: float, log_end_s: float,
) -> dict:
    """The turn-table row of the rotation on rows ``i0..i1`` (``row_update``: the end of the second still window).

    The arrays (time, ``rate_z``, temperature, gyro heading, unwrapped compass heading, compass
    rows, rotation test, drift gates) may be a part of the log, holding every row from ``guard_s``
    before the first still window to ``guard_s`` after the second; ``log_start_s`` and
    ``log_end_s`` bound the log for the edge test.
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

"""The default estimator's model run backwards: fixed-interval smoothing for recorded logs.

A Rauch–Tung–Striebel smoother over the drift states the model recorded at its epoch ends,
and the log recompensated with them (:func:`smooth_output`, ``gyrodrift compensate
--smooth``; not causal). The model and what changes: ``docs/heading_and_axes.md`` (smoothing).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from gyrodrift.conventions import wrap_360
from gyrodrift.errors import ConfigError
from gyrodrift.kernels.evloop import H_DT, H_DTEMP, H_JUMP, H_P, H_T, H_X, N_DRIFT, N_HIST
from gyrodrift.kernels.integrate import trapezoid
from gyrodrift.model import ElapsedClock

__all__ = ["SmoothedDrift", "smooth_epochs", "smooth_output"]


@dataclass(frozen=True)
class SmoothedDrift:
    """Smoothed drift states, one set per epoch end.

    ``t`` (K,) epoch ends, s; ``states`` (K, 5) ``[a (deg/s/degC), b (deg/s per degC/s),
    c' (deg/s at T_ref), r (deg/s²), a2 (deg/s/degC²)]`` (the drift ``a (T - T_ref) + a2 (T -
    T_ref)² + b T' + c'``); ``cov`` (K, 5, 5) their covariance; ``filtered`` (K, 5) the forward
    pass's states, for comparison.
    """

    t: np.ndarray
    states: np.ndarray
    cov: np.ndarray
    filtered: np.ndarray


def _unpack(hist: np.ndarray):
    """States (K, N_DRIFT) and covariances (K, N_DRIFT, N_DRIFT) of the epoch history."""
    x = hist[:, H_X:H_X + N_DRIFT].copy()
    P = np.empty((hist.shape[0], N_DRIFT, N_DRIFT))
    m = 0
    for r in range(N_DRIFT):
        for c in range(r, N_DRIFT):
            P[:, r, c] = P[:, c, r] = hist[:, H_P + m]
            m += 1
    return x, P


def _transition(dt: float, dtemp: float, jump: float, st, clock: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of the drift states over an epoch of ``dt`` s and ``dtemp`` degC (clock units
    where ``clock``), a jump kept with chance ``jump``; r's as :func:`gyrodrift.kernels.evidence.r_walk`."""
    phi = np.exp(-dt / st.drift_rate_s)
    F = np.eye(N_DRIFT)
    F[2, 3] = st.drift_rate_s * (1.0 - phi)
    F[3, 3] = phi
    if clock:
        q_r = st.drift_rate_dps2**2 * (1.0 - phi * phi)
    else:
        q_r = (st.drift_rate_dps2**2 * (1.0 - np.exp(-2.0 * dtemp / st.drift_rate_degc))
               + st.drift_rate_time_dps2**2 * (1.0 - phi * phi))
    Q = np.diag([st.slope_walk**2 * dtemp, st.rate_walk**2 * dt, st.drift_walk**2 * dt + st.drift_walk_temp**2 * dtemp
                  + jump * st.drift_jump_dps**2, q_r, 0.0])  # a2: constant
    return F, Q


def smooth_epochs(hist: np.ndarray, config=None, clock: bool = False) -> SmoothedDrift:
    """Rauch–Tung–Striebel smoothing of the model's drift states over its epoch history.

    ``hist`` is the engine's ``out.attrs["epochs"]`` (K, N_HIST); ``config`` the
    :class:`~gyrodrift.compensator.CompensatorConfig` the log was compensated with; ``clock``
    whether its T was the clock (``out.attrs["drift_regressor"]``).
    """
    from gyrodrift.compensator import CompensatorConfig

    config = config or CompensatorConfig()
    hist = np.asarray(hist, dtype=float)
    if hist.ndim != 2 or hist.shape[1] != N_HIST or not np.all(np.isfinite(hist)):
        raise ConfigError(f"smoothing needs the model's epoch history: a finite (K, {N_HIST}) array")
    x, P = _unpack(hist)
    xs, Ps = x.copy(), P.copy()
    st = config.adaptive
    for k in range(x.shape[0] - 2, -1, -1):
        F, Q = _transition(hist[k + 1, H_DT], hist[k + 1, H_DTEMP], hist[k + 1, H_JUMP], st, clock)
        Pm = F @ P[k] @ F.T + Q
        C = np.linalg.solve(Pm.T, (P[k] @ F.T).T).T  # P F^T Pm^-1 (Pm symmetric)
        xs[k] = x[k] + C @ (xs[k + 1] - F @ x[k])
        Ps[k] = P[k] + C @ (Ps[k + 1] - Pm) @ C.T
        Ps[k] = 0.5 * (Ps[k] + Ps[k].T)
    return SmoothedDrift(hist[:, H_T].copy(), xs, Ps, x)


def _held(values: np.ndarray) -> np.ndarray:
    """Non-finite cells replaced by the last finite value (the first finite one before it)."""
    s = pd.Series(values, dtype=float).where(np.isfinite(values))
    return s.ffill().bfill().to_numpy()


def smooth_output(out: pd.DataFrame, config=None) -> pd.DataFrame:
    """The compensated log recompensated with the smoothed drift (non-causal).

    Parameters
    ----------
    out : DataFrame
        :func:`gyrodrift.compensate` output of the default estimator on a recorded log (with its
        ``attrs["epochs"]`` and ``attrs["temp_ref_c"]``, and ``temp`` unless T was the clock).
    config : CompensatorConfig, optional
        The settings ``out`` was compensated with.

    Returns
    -------
    DataFrame
        A copy of ``out`` with the drift columns smoothed (``docs/heading_and_axes.md``) and
        ``attrs["smoothed"]``, the :class:`SmoothedDrift`.
    """
    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.kernels.layout import UNOBSERVABLE_NAMES, UNOBS_A, UNOBS_B, UNOBSERVABLE_SD_FRACTION

    config = config or CompensatorConfig()
    hist = out.attrs.get("epochs")
    if hist is None or "temp_ref_c" not in out.attrs:
        raise ConfigError("smoothing is the default estimator's (adaptive): compensate the log with it "
                          "(its output carries the model's epoch history)")
    t = out["t"].to_numpy(float)
    if len(hist) == 0:
        return out.copy()
    clock = out.attrs.get("drift_regressor") == "clock"
    if clock:  # the model's T was the elapsed time
        T = ElapsedClock(config.gate.max_gap_s)(t)
    elif "temp" not in out.columns:
        raise ConfigError("smoothing needs the input 'temp' column (degC) in the compensated table")
    else:
        T = _held(out["temp"].to_numpy(float))
    sm = smooth_epochs(hist, config, clock)
    tref = float(out.attrs["temp_ref_c"])
    Tp = out["temp_rate"].to_numpy(float)
    k = np.minimum(np.searchsorted(sm.t, t, side="left"), sm.t.size - 1)
    a, b, c, a2 = sm.states[k, 0], sm.states[k, 1], sm.states[k, 2], sm.states[k, 4]
    bias = a * (T - tref) + a2 * (T - tref) ** 2 + b * Tp + c
    old_bias = out["bias_z"].to_numpy(float)
    hold = (out["gate_reason"].astype(str) == "gap").to_numpy()
    res = out.copy()
    a_tangent = a + 2.0 * a2 * (T - tref)  # eq. (2)'s a: the slope at T
    res["a"], res["b"], res["c"] = a_tangent, b, bias - a_tangent * T - b * Tp
    res["bias_z"] = bias
    # the drift's change at full weight: the model's scale factor (σ, causal, within 3 %) would
    # take its share of it, which is far below the drift's own uncertainty
    res["rate_z"] = out["rate_z"].to_numpy(float) + (old_bias - bias)
    res["heading"] = wrap_360(out["heading"].to_numpy(float) + trapezoid(t, old_bias - bias, hold))
    h = np.stack([T - tref, Tp, np.ones(t.size), np.zeros(t.size), (T - tref) ** 2], axis=1)
    bias_sd = np.sqrt(np.maximum(np.einsum("ni,nij,nj->n", h, sm.cov[k], h), 0.0))
    res["bias_sd"] = bias_sd
    if "heading_sd" in out.columns:  # the forward variance with the smoothed bias_sd integrated instead
        old_sd = out["bias_sd"].to_numpy(float)
        var = out["heading_sd"].to_numpy(float) ** 2
        anchor = np.isfinite(var)
        if anchor.any():
            i0 = int(np.argmax(anchor))
            old_int = trapezoid(t[i0:], old_sd[i0:], hold[i0:])
            new_int = trapezoid(t[i0:], bias_sd[i0:], hold[i0:])
            var[i0:] = np.maximum(var[i0:] - old_int**2 + new_int**2, 0.0)
        res["heading_sd"] = np.sqrt(var)
    prior_a, prior_b = (float(v) for v in config.kalman.p0_sd[:2])
    sd_a, sd_b = np.sqrt(np.maximum(sm.cov[:, 0, 0], 0.0)), np.sqrt(np.maximum(sm.cov[:, 1, 1], 0.0))
    codes = (np.where(sd_a > UNOBSERVABLE_SD_FRACTION * prior_a, UNOBS_A, 0)
             + np.where(sd_b > UNOBSERVABLE_SD_FRACTION * prior_b, UNOBS_B, 0)).astype(np.int8)
    res["unobservable"] = pd.Categorical.from_codes(codes[k], categories=list(UNOBSERVABLE_NAMES))
    res.attrs = dict(out.attrs)
    res.attrs["smoothed"] = sm
    return res

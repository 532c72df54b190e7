"""Fixed-interval smoothing of the drift estimate, for recorded logs (non-causal).

The compensator (:mod:`gyrodrift.compensator`) is causal: the drift of a row is what the
filter knew *then*, so on a recorded log the first minutes, and the rows before an
outage, are compensated with less than the log tells. On a recorded log the whole of
it is available. This module re-estimates the drift from every accepted measurement,
before and after each row, with a Rauch–Tung–Striebel smoother, and recompensates
the log with it (:func:`smooth_output`, ``gyrodrift compensate --smooth``).

Model (units deg/s, degC, s)
----------------------------
The states are those of the ``adaptive`` estimator (:mod:`gyrodrift.estimators.adaptive`):
``z = [a, b, c']`` with the temperature centred on a reference ``T_ref`` that moves to
the temperature of each epoch (``c' = a*T_ref + c``, the drift at ``T_ref``; the
paper's model, eq. 2, is unchanged). The epochs are the times of the accepted
measurements and, on recorded logs, every update interval in between (refused ones
too, at the mean temperature of the interval), so that through an outage the states
follow the temperature path. Between two epochs ``k-1`` and ``k``::

    z_k = J_k z_{k-1} + w_k,   J_k = I with J[2, 0] = T_k - T_{k-1}   (move T_ref)
    w_k ~ N(0, n_k Q + diag(q_T² |T_k - T_{k-1}|, 0, 0))

``n_k = (t_k - t_{k-1}) / update_interval_s`` (so a refused interval adds ``Q`` as
the filter's ``hold`` does), ``Q = diag(q_sd²)`` and ``q_T`` is
``AdaptiveConfig.slope_q_per_rtc`` (the slope random walk in temperature); without the
``adaptive`` process noise (``q_sd = None``) ``KalmanConfig.q_sd`` and no slope term.
A measurement (eq. 6, or a zero-rate one) is ``m = [T - T_k, T', 1] z_k + v`` with
``v ~ N(0, r)``; measurements at the same time (the initial stack) form one update.
The prior is ``KalmanConfig.x0`` and ``p0_sd``. The filter's fading (eq. 10, ``s``) and
covariance cap are left out: they protect a causal filter from its own lag, which a
smoother that sees both sides does not have.

Forward: a Kalman filter (Joseph form). Backward: for ``k = K-2 … 0``::

    C_k = P_k Jᵀ_{k+1} (P⁻_{k+1})⁻¹
    z̃_k = z_k + C_k (z̃_{k+1} - z⁻_{k+1})
    P̃_k = P_k + C_k (P̃_{k+1} - P⁻_{k+1}) Cᵀ_k

which is the minimum-variance estimate of every ``z_k`` from all ``K`` measurements
(the tests check it against the solution of the whole linear system at once).

A measurement at time ``t_k`` is the drift over the interval ending at ``t_k``, so the
rows in ``(t_{k-1}, t_k]`` are compensated with ``z̃_k``, and the rows after the last
epoch with the last.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from gyrodrift.conventions import wrap_360
from gyrodrift.errors import ConfigError
from gyrodrift.model import ElapsedClock

__all__ = ["SmoothedDrift", "smooth_drift", "smooth_output"]


@dataclass(frozen=True)
class SmoothedDrift:
    """Smoothed drift parameters, one set per measurement time.

    Attributes
    ----------
    t : (K,) ndarray
        Measurement times, s (increasing, distinct).
    params : (K, 3) ndarray
        Absolute ``[a (deg/s/degC), b (deg/s per degC/s), c (deg/s)]`` (eq. 2).
    cov : (K, 3, 3) ndarray
        Their covariance.
    filtered : (K, 3) ndarray
        The forward (causal) filter's absolute parameters, for comparison.
    """

    t: np.ndarray
    params: np.ndarray
    cov: np.ndarray
    filtered: np.ndarray


def _process_noise(config) -> tuple[np.ndarray, float]:
    """``Q`` per update interval and the slope random walk ``q_T`` (see module notes)."""
    st = config.adaptive
    if st.q_sd is not None:
        return np.diag(np.square(np.asarray(st.q_sd, dtype=float))), float(st.slope_q_per_rtc)
    return np.diag(np.square(np.asarray(config.kalman.q_sd, dtype=float))), 0.0


def _groups(meas: pd.DataFrame, epochs=None):
    """Measurements grouped by time, merged with the extra epochs.

    Returns a list of ``(t, T_ref, m, temp, temp_rate, r)`` in time order: ``T_ref`` the
    mean temperature of the group's measurements, or the epoch's temperature for an epoch
    without measurements (empty arrays).
    """
    t = meas["t"].to_numpy(float)
    cols = [meas[c].to_numpy(float) for c in ("m", "temp", "temp_rate", "r")]
    if not np.all(np.isfinite(t)) or any(not np.all(np.isfinite(c)) for c in cols):
        raise ConfigError("smoothing needs finite measurements; got NaN or inf in the accepted measurements")
    if np.any(np.diff(t) < 0):
        raise ConfigError("smoothing needs measurements in time order")
    groups = []
    if t.size:
        starts = np.flatnonzero(np.r_[True, np.diff(t) > 0])
        ends = np.r_[starts[1:], t.size]
        groups = [(t[s], float(np.mean(cols[1][s:e])), *(c[s:e] for c in cols)) for s, e in zip(starts, ends)]
    if epochs is not None:
        e_t, e_temp = (np.asarray(v, dtype=float) for v in epochs)
        have = {g[0] for g in groups}
        empty = np.empty(0)
        groups += [(float(a), float(b), empty, empty, empty, empty)
                   for a, b in zip(e_t, e_temp) if a not in have and np.isfinite(a) and np.isfinite(b)]
        groups.sort(key=lambda g: g[0])
    return groups


def smooth_drift(measurements: pd.DataFrame, config=None, epochs=None) -> SmoothedDrift:
    """Rauch–Tung–Striebel smoothing of the drift parameters over every accepted measurement.

    Parameters
    ----------
    measurements : DataFrame
        ``out.attrs["measurements"]`` of :func:`gyrodrift.compensator.compensate`: columns
        ``t`` (s), ``m`` (deg/s), ``temp`` (degC), ``temp_rate`` (degC/s), ``r`` ((deg/s)²).
    config : CompensatorConfig, optional
        Prior (``kalman``), process noise (``adaptive``) and ``update_interval_s``.
    epochs : (t_s, temp_c) pair of arrays, optional
        Extra times (s) with their temperatures (degC) at which to estimate the
        parameters although nothing was measured there (refused intervals): the smoother
        then carries the temperature path through an outage instead of jumping over it.

    Returns
    -------
    SmoothedDrift
        One entry per measurement time and per extra epoch, in time order.

    Raises
    ------
    ConfigError
        No measurement, or non-finite ones.
    """
    from gyrodrift.compensator import CompensatorConfig

    config = config or CompensatorConfig()
    groups = _groups(measurements, epochs)
    if not any(g[2].size for g in groups):
        raise ConfigError("smoothing needs at least one accepted drift measurement; the log had none "
                          "(every interval was refused: see gate_reason)")
    Q, q_T = _process_noise(config)
    P, _, _ = config.kalman.matrices()
    a0, b0, c0 = (float(v) for v in config.kalman.x0)
    K = len(groups)
    tref = np.empty(K)
    z_prior = np.empty((K, 3))
    P_prior = np.empty((K, 3, 3))
    z_post = np.empty((K, 3))
    P_post = np.empty((K, 3, 3))
    J = np.empty((K, 3, 3))
    z = None
    for k, (t_k, T_k, m, temp, temp_rate, r) in enumerate(groups):
        Jk = np.eye(3)
        if z is None:
            z = np.array([a0, b0, c0 + a0 * T_k])
            Pk = P.copy()
        else:
            Jk[2, 0] = T_k - tref[k - 1]
            Qk = (t_k - groups[k - 1][0]) / config.update_interval_s * Q
            Qk[0, 0] += q_T**2 * abs(T_k - tref[k - 1])
            z = Jk @ z
            Pk = Jk @ P @ Jk.T + Qk
        tref[k], J[k], z_prior[k], P_prior[k] = T_k, Jk, z, Pk
        P = Pk
        if m.size:
            H = np.column_stack([temp - T_k, temp_rate, np.ones(m.size)])
            S = H @ Pk @ H.T + np.diag(r)
            gain = np.linalg.solve(S, H @ Pk).T
            A = np.eye(3) - gain @ H
            z = z + gain @ (m - H @ z)
            P = A @ Pk @ A.T + gain @ np.diag(r) @ gain.T
            P = 0.5 * (P + P.T)
        z_post[k], P_post[k] = z, P
    z_s = z_post.copy()
    P_s = P_post.copy()
    for k in range(K - 2, -1, -1):
        C = np.linalg.solve(P_prior[k + 1], J[k + 1] @ P_post[k]).T  # P_k Jᵀ (P⁻_{k+1})⁻¹
        z_s[k] = z_post[k] + C @ (z_s[k + 1] - z_prior[k + 1])
        Ps = P_post[k] + C @ (P_s[k + 1] - P_prior[k + 1]) @ C.T
        P_s[k] = 0.5 * (Ps + Ps.T)
    to_abs = np.repeat(np.eye(3)[None], K, axis=0)
    to_abs[:, 2, 0] = -tref
    params = np.einsum("kij,kj->ki", to_abs, z_s)
    cov = to_abs @ P_s @ to_abs.transpose(0, 2, 1)
    filtered = np.einsum("kij,kj->ki", to_abs, z_post)
    return SmoothedDrift(t=np.array([g[0] for g in groups]), params=params, cov=cov, filtered=filtered)


def _held(values: np.ndarray) -> np.ndarray:
    """Non-finite cells replaced by the last finite value (the first finite one before it)."""
    s = pd.Series(values, dtype=float).where(np.isfinite(values))
    return s.ffill().bfill().to_numpy()


def _cumtrapz(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.zeros(y.size)
    if y.size > 1:
        np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t), out=out[1:])
    return out


def smooth_output(out: pd.DataFrame, config=None) -> pd.DataFrame:
    """The compensated log recompensated with the smoothed drift (non-causal).

    Parameters
    ----------
    out : DataFrame
        Output of :func:`gyrodrift.compensator.compensate` on a recorded log (with its
        ``attrs["measurements"]`` and the input ``temp`` column).
    config : CompensatorConfig, optional
        The settings ``out`` was compensated with.

    Returns
    -------
    DataFrame
        A copy of ``out`` in which ``a, b, c``, ``bias_z``, ``rate_z``, ``heading``,
        ``bias_sd`` and ``heading_sd`` come from the smoothed drift; ``unobservable``
        is recomputed from the smoothed covariance. Every other column (gating, the
        causal ``heading_fused``) is unchanged. ``attrs["smoothed"]`` holds the
        :class:`SmoothedDrift`.

    Notes
    -----
    ``heading`` keeps its anchor and integration (trapezoid, as the compensator):
    ``heading_smoothed = heading + ∫(bias_z − bias_smoothed) dt``. ``heading_sd`` is
    recomputed as the compensator does (:mod:`gyrodrift.fusion`) with the smoothed
    ``bias_sd``.
    """
    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.kernels.aiding import unobservable_code
    from gyrodrift.kernels.layout import UNOBSERVABLE_NAMES

    config = config or CompensatorConfig()
    meas = out.attrs.get("measurements")
    if meas is None:
        raise ConfigError("smoothing needs the accepted measurements (attrs['measurements'] of compensate())")
    t = out["t"].to_numpy(float)
    if out.attrs.get("drift_regressor") == "clock":  # the model's T was the elapsed time
        T = ElapsedClock(config.gate.max_gap_s)(t)
    elif "temp" not in out.columns:
        raise ConfigError("smoothing needs the input 'temp' column (degC) in the compensated table")
    else:
        T = _held(out["temp"].to_numpy(float))
    sm = smooth_drift(meas, config, epochs=_interval_epochs(meas["t"].to_numpy(float), t, T,
                                                            config.update_interval_s))
    Tp = out["temp_rate"].to_numpy(float)
    k = np.minimum(np.searchsorted(sm.t, t, side="left"), sm.t.size - 1)
    a, b, c = sm.params[k, 0], sm.params[k, 1], sm.params[k, 2]
    bias = a * T + b * Tp + c
    old_bias = out["bias_z"].to_numpy(float)
    res = out.copy()
    res["a"], res["b"], res["c"] = a, b, c
    res["bias_z"] = bias
    res["rate_z"] = out["rate_z"].to_numpy(float) + (old_bias - bias)
    res["heading"] = wrap_360(out["heading"].to_numpy(float) + _cumtrapz(old_bias - bias, t))
    h = np.stack([T, Tp, np.ones(t.size)], axis=1)
    bias_sd = np.sqrt(np.maximum(np.einsum("ni,nij,nj->n", h, sm.cov[k], h), 0.0))
    res["bias_sd"] = bias_sd
    if "heading_sd" in out.columns:
        res["heading_sd"] = _heading_sd(out, t, bias_sd, config)
    prior_a, prior_b = (float(v) for v in config.kalman.p0_sd[:2])
    codes = np.array([unobservable_code(np.ascontiguousarray(C), prior_a, prior_b) for C in sm.cov], dtype=np.int8)
    res["unobservable"] = pd.Categorical.from_codes(codes[k], categories=list(UNOBSERVABLE_NAMES))
    res.attrs = dict(out.attrs)
    res.attrs["smoothed"] = sm
    return res


def _interval_epochs(t_meas: np.ndarray, t: np.ndarray, T: np.ndarray, interval_s: float):
    """Epochs every ``interval_s`` from the first measurement to the last row, except within
    half an interval of a measurement, each with the mean temperature (degC) of the rows
    of the interval it ends."""
    if t_meas.size == 0 or t.size == 0:
        return np.empty(0), np.empty(0)
    grid = t_meas[0] + interval_s * np.arange(1, int((t[-1] - t_meas[0]) // interval_s) + 1)
    near = np.searchsorted(t_meas, grid)
    gap = np.minimum(np.abs(grid - t_meas[np.minimum(near, t_meas.size - 1)]),
                     np.abs(grid - t_meas[np.maximum(near - 1, 0)]))
    grid = grid[gap >= 0.5 * interval_s]
    cum = np.r_[0.0, np.cumsum(T)]
    hi = np.searchsorted(t, grid, side="right")
    lo = np.searchsorted(t, grid - interval_s, side="right")
    ok = hi > lo
    temp = np.where(ok, (cum[hi] - cum[lo]) / np.maximum(hi - lo, 1), np.nan)
    return grid[ok], temp[ok]


def _heading_sd(out: pd.DataFrame, t: np.ndarray, bias_sd: np.ndarray, config) -> np.ndarray:
    """``heading_sd`` (deg) with the smoothed ``bias_sd``: the formula of :mod:`gyrodrift.fusion`
    (compass σ at the anchor, gyro white noise, bias_sd integrated as fully correlated)."""
    heading = out["heading"].to_numpy(float)
    started = np.isfinite(out["heading_sd"].to_numpy(float)) & np.isfinite(heading)
    sd = np.full(t.size, np.nan)
    if not started.any():
        return sd
    i0 = int(np.argmax(started))
    tt = t[i0:]
    integral = _cumtrapz(bias_sd[i0:], tt)
    var = (config.fusion_settings.heading_sigma_deg**2 + config.gyro_noise_dps_rthz**2 * (tt - tt[0]) + integral**2)
    sd[i0:] = np.sqrt(var)
    return sd

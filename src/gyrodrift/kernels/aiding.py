"""Compass aiding of the paper's filters: the drift measurements of eqs. (4)–(6), the gates,
the interval decision, lock-out recovery and the initialisation (``docs/engine.md``, "The
paper's filters, row by row"; the gates: ``docs/conventions.md``).
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels import kalman
from gyrodrift.kernels.layout import (
    C_COMPASS_SD, C_GYRO_NOISE, C_INTERF, C_INTERVAL, C_MAX_AGE, C_PRIOR_A, C_PRIOR_B, C_STILL_HEADING, C_STILL_STD,
    F_COV, F_PA, F_S0, F_S1, I_AFTER_INT, I_N_ACC, I_PENDING, I_REFUSED_N, I_S0_OK, I_S1_OK, I_STACK_N,
    I_STICKY, I_UNOBS, K_DEPTH, K_MODE, K_RELOCK, MODE_EXTERNAL, N_SNAP, NO_STICKY, PENDING_HOLD, PENDING_UPDATE,
    R_FIELD, R_GAP, R_INTERFERENCE, R_NO_COMPASS, R_NONE, R_TURNING, S_HEADING, S_IBIAS, S_IRAW, S_IT, S_ITP, S_T,
    UNOBS_A, UNOBS_B, UNOBSERVABLE_SD_FRACTION,
)
from gyrodrift.kernels.numeric import wrap180

__all__ = ["compass_measurement", "row_condition", "field_anomaly", "field_reference", "unobservable_code",
           "steady_disagreement", "begin", "close", "push_measurement", "stacked", "in_force", "init_measurements"]


# -------------------------------------------------------------- measurements


@jit
def compass_measurement(s0, s1, compass_sd, gyro_noise):
    """Eqs. (4)–(6) between two snaps: the drift measurement ``m = Δ(∫gyro − compass)/Δt``
    (deg/s; the sign that measures the drift, see :mod:`gyrodrift.compensator`), the
    interval means of T and T' (the row of H), its variance ``r = 2 compass_sd²/Δt² +
    N²/Δt``, and the residual: compass minus compensated-gyro heading change, deg.
    Returns (m, h_T, h_T', r, residual_deg)."""
    dt = s1[S_T] - s0[S_T]
    d_diff = wrap180((s1[S_IRAW] - s1[S_HEADING]) - (s0[S_IRAW] - s0[S_HEADING]))
    m = d_diff / dt
    h0 = (s1[S_IT] - s0[S_IT]) / dt
    h1 = (s1[S_ITP] - s0[S_ITP]) / dt
    r = 2.0 * compass_sd**2 / dt**2 + gyro_noise**2 / dt
    return m, h0, h1, r, d_diff - (s1[S_IBIAS] - s0[S_IBIAS])


# ------------------------------------------------------------------- gates


@jit(inline=True)
def row_condition(gap, field, resid, mean_rate, turn_rate, interf):
    """The refusal a row shows, by priority gap > field > turning > interference, or
    NO_STICKY. ``resid`` (deg; NaN without a compass sample) is the compass minus
    compensated-gyro heading change since the interval start, ``mean_rate`` the 1-s mean
    compensated rate (deg/s)."""
    if gap:
        return R_GAP
    if field:
        return R_FIELD
    if abs(mean_rate) > turn_rate:
        return R_TURNING
    if abs(resid) > interf:  # False for NaN
        return R_INTERFERENCE
    return NO_STICKY


@jit(inline=True)
def field_anomaly(norm, dip, ref_norm, ref_dip, norm_tol, dip_tol):
    """True when the field strength or dip (raw magnetometer) departs from the reference
    of the init window (interference); False without a reference or a finite norm."""
    if not math.isfinite(norm) or math.isnan(ref_norm):
        return False
    return abs(norm / ref_norm - 1.0) > norm_tol or abs(dip - ref_dip) > dip_tol


@jit
def field_reference(norm, dip, n):
    """Median field strength and dip of the first ``n`` rows with both finite (NaN, NaN: none)."""
    ok = np.isfinite(norm[:n]) & np.isfinite(dip[:n])
    if not ok.any():
        return math.nan, math.nan
    return np.median(norm[:n][ok]), np.median(dip[:n][ok])


@jit
def unobservable_code(C, prior_a, prior_b):
    """UNOBS_A + UNOBS_B for the parameters whose standard deviation (covariance ``C``) is
    above :data:`~gyrodrift.kernels.layout.UNOBSERVABLE_SD_FRACTION` of the prior's."""
    code = 0
    if math.sqrt(max(C[0, 0], 0.0)) > UNOBSERVABLE_SD_FRACTION * prior_a:
        code += UNOBS_A
    if math.sqrt(max(C[1, 1], 0.0)) > UNOBSERVABLE_SD_FRACTION * prior_b:
        code += UNOBS_B
    return code


@jit
def steady_disagreement(rate, rates, held, n):
    """Lock-out recovery: whether the last ``n`` refused intervals and this one agree on one
    steady sensor-minus-gyro rate (same sign, spread below half the mean): a drift change
    the filter has not followed, not a disturbance, so this interval is accepted.

    ``rates`` keeps the rates of the refusals so far (``held`` of them, at most its size);
    ``rate`` is added. Returns (accept, rates now held). ``n`` = 0 turns the recovery off.
    """
    if n == 0:
        return False, held
    enough = held >= n
    last = np.empty(n + 1)
    if enough:
        for j in range(n):
            last[j] = rates[held - n + j] if held <= rates.size else rates[rates.size - n + j]
        last[n] = rate
    if held < rates.size:  # keep the newest rates.size rates
        rates[held] = rate
    else:
        for j in range(rates.size - 1):
            rates[j] = rates[j + 1]
        rates[rates.size - 1] = rate
    held = min(held + 1, rates.size)
    if not enough:
        return False, held
    mean = np.mean(last)
    if np.std(last) >= 0.5 * abs(mean):
        return False, held
    for j in range(n + 1):
        if np.sign(last[j]) != np.sign(mean):
            return False, held
    return True, held


# --------------------------------------------------------- interval decision


@jit
def begin(t_boundary, fs, ist, cfg):
    """Open the next interval at a boundary row: its start snap is the last compass
    sample if not older than ``compass_max_age_s`` (else the interval is refused,
    ``no_compass``)."""
    if ist[I_S1_OK] == 1 and not (t_boundary - fs[F_S1] > cfg[C_MAX_AGE]):
        for j in range(N_SNAP):
            fs[F_S0 + j] = fs[F_S1 + j]
        ist[I_S0_OK] = 1
        ist[I_STICKY] = NO_STICKY
    else:
        ist[I_S0_OK] = 0
        ist[I_STICKY] = R_NO_COMPASS


@jit
def push_measurement(t_boundary, m, h0, h1, r, ist, stack, acc, depth):
    """A new accepted measurement: first row of the stack (eq. 3, the newest first, at most
    ``depth`` rows) and the next row of ``acc``; returns the rows now stacked."""
    n = min(ist[I_STACK_N] + 1, depth)
    for j in range(n - 1, 0, -1):
        for c in range(5):
            stack[j, c] = stack[j - 1, c]
    stack[0, 0] = m
    stack[0, 1] = h0
    stack[0, 2] = h1
    stack[0, 3] = 1.0
    stack[0, 4] = r
    ist[I_STACK_N] = n
    a = ist[I_N_ACC]
    acc[a, 0] = t_boundary
    acc[a, 1] = m
    acc[a, 2] = h0
    acc[a, 3] = h1
    acc[a, 4] = r
    ist[I_N_ACC] = a + 1
    return n


@jit
def stacked(stack, n):
    """The observation of the first ``n`` stacked measurements: (y, H, R)."""
    y = np.empty(n)
    H = np.empty((n, 3))
    R = np.zeros((n, n))
    for j in range(n):
        y[j] = stack[j, 0]
        H[j, 0] = stack[j, 1]
        H[j, 1] = stack[j, 2]
        H[j, 2] = stack[j, 3]
        R[j, j] = stack[j, 4]
    return y, H, R


@jit
def close(t_boundary, fs, ist, cfg, icfg, stack, refused, acc, ef, ei, intervals):
    """Decide the interval ending at a boundary row (``docs/engine.md``, "The paper's filters,
    row by row") and update the estimator (``ef``, ``ei``) with the stacked measurements (eq. 3)
    or hold it for ``intervals`` intervals; in MODE_EXTERNAL the caller does it
    (``ist[I_PENDING]``). Returns (update, reason)."""
    mode = icfg[K_MODE]
    reason = ist[I_STICKY]
    end_ok = ist[I_S1_OK] == 1 and not (t_boundary - fs[F_S1] > cfg[C_MAX_AGE])
    s0 = fs[F_S0:F_S0 + N_SNAP]
    s1 = fs[F_S1:F_S1 + N_SNAP]
    m = 0.0
    h0 = 0.0
    h1 = 0.0
    r = 0.0
    resid = 0.0
    have_meas = False
    if reason == NO_STICKY:
        if (not end_ok) or fs[F_S1] - fs[F_S0] < 0.5 * cfg[C_INTERVAL]:
            reason = R_NO_COMPASS
        else:
            m, h0, h1, r, resid = compass_measurement(s0, s1, cfg[C_COMPASS_SD], cfg[C_GYRO_NOISE])
            have_meas = True
            if abs(resid) > cfg[C_INTERF]:
                reason = R_INTERFERENCE
    if reason == R_INTERFERENCE and ist[I_S0_OK] == 1 and end_ok:
        if not have_meas:
            m, h0, h1, r, resid = compass_measurement(s0, s1, cfg[C_COMPASS_SD], cfg[C_GYRO_NOISE])
        accept, ist[I_REFUSED_N] = steady_disagreement(resid / (fs[F_S1] - fs[F_S0]), refused, ist[I_REFUSED_N],
                                                       icfg[K_RELOCK])
        if accept:
            reason = NO_STICKY
    if reason != R_INTERFERENCE:
        ist[I_REFUSED_N] = 0
    if reason == NO_STICKY:
        n = push_measurement(t_boundary, m, h0, h1, r, ist, stack, acc, icfg[K_DEPTH])
        if mode == MODE_EXTERNAL:
            ist[I_PENDING] = PENDING_UPDATE
        else:
            y, H, R = stacked(stack, n)
            kalman.update(ef, ei, y, H, R)
        ist[I_AFTER_INT] = 0
        return 1, R_NONE
    if mode == MODE_EXTERNAL:
        ist[I_PENDING] = PENDING_HOLD
    else:
        kalman.hold(ef, ei, intervals)
    ist[I_AFTER_INT] = 1 if reason == R_INTERFERENCE else 0
    return 0, reason


@jit
def in_force(fs, ist, cfg, ef, ei):
    """The parameters and covariance of a kernel estimator into ``fs`` (F_PA.., F_COV) and
    the unobservable code into ``ist``."""
    kalman.put_state(ef, ei, fs, F_PA, F_COV)
    ist[I_UNOBS] = unobservable_code(kalman.cov(ef, ei), cfg[C_PRIOR_A], cfg[C_PRIOR_B])


# ------------------------------------------------------------ initialisation


@jit
def init_measurements(t, g, T, Tp, heading, e, n_windows, init_s, cfg, ist, stack, acc, depth):
    """The drift measurements of the init window, rows ``0..e`` (inclusive), into the
    stack and ``acc``: one per motionless sub-window (``docs/engine.md``, "Initialisation").
    Returns (measurements, anchor row: the window's first compass sample, -1 without one).
    """
    n = e + 1
    I_raw = np.zeros(n)
    I_T = np.zeros(n)
    I_Tp = np.zeros(n)
    for i in range(1, n):
        dt = t[i] - t[i - 1]
        I_raw[i] = I_raw[i - 1] + 0.5 * (g[i] + g[i - 1]) * dt
        I_T[i] = I_T[i - 1] + 0.5 * (T[i] + T[i - 1]) * dt
        I_Tp[i] = I_Tp[i - 1] + 0.5 * (Tp[i] + Tp[i - 1]) * dt
    edges = np.empty(n_windows + 1, dtype=np.int64)
    edges[0] = 0
    for j in range(1, n_windows):
        edges[j] = np.searchsorted(t[:n], t[0] + j * init_s / n_windows)
    edges[n_windows] = e
    found = 0
    for w in range(n_windows):
        r0 = edges[w]
        r1 = edges[w + 1]
        if r1 <= r0:
            continue
        dt = t[r1] - t[r0]
        compass = heading[r0:r1 + 1][np.isfinite(heading[r0:r1 + 1])]
        turned = 0.0
        if compass.size >= 3:
            third = compass.size // 3
            rel = np.empty(compass.size)
            for k in range(compass.size):
                rel[k] = wrap180(compass[k] - compass[0])
            turned = abs(np.median(rel[compass.size - third:]) - np.median(rel[:third]))
        if np.std(g[r0:r1 + 1]) <= cfg[C_STILL_STD] and turned <= cfg[C_STILL_HEADING]:
            push_measurement(t[e], (I_raw[r1] - I_raw[r0]) / dt, (I_T[r1] - I_T[r0]) / dt,
                             (I_Tp[r1] - I_Tp[r0]) / dt, cfg[C_GYRO_NOISE] ** 2 / dt, ist, stack, acc, depth)
            found += 1
    anchor = -1
    for i in range(n):
        if not math.isnan(heading[i]):
            anchor = i
            break
    return found, anchor

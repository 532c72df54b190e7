"""Compiled mirror of the ``adaptive`` estimator and its aiding (numba; see :mod:`gyrodrift._engine`).

Each function mirrors one Python function of the reference, under the same name, so
that a change there is ported here one function at a time:

============================  ====================================================
here                          reference
============================  ====================================================
:func:`add`                   ``compensate._Aiding.add`` (the compass window)
:func:`_edge`                 ``compensate._Aiding._edge`` (fix 1, edge averaging)
:func:`_edge_variance`        ``compensate._Aiding._edge_variance``
:func:`_compass_measurement`  ``compensate._compass_measurement`` (eqs. 4–6)
:func:`_zaru_measurement`     ``compensate._Aiding._zaru_measurement`` (fixes 3, 4)
:func:`_flat_compass`         ``compensate._flat_compass``
:func:`_gyro_still`           ``compensate._gyro_still``
:func:`update`                ``AdaptiveKalman.update`` (eq. 10 with adaptive λ)
:func:`hold`                  ``AdaptiveKalman.hold`` (the outage anchor, fix 2)
:func:`_recentre`             ``AdaptiveKalman._recentre``
:func:`_centre`               ``AdaptiveKalman._centre``
:func:`_own_params`           ``AdaptiveKalman._own_params``
:func:`params`, :func:`cov`   ``AdaptiveKalman.params``, ``.cov``
============================  ====================================================

``_Aiding.close`` itself is :func:`gyrodrift._kernels._close`, which calls these.

Numbers: means are numpy's pairwise sums (:func:`gyrodrift._common_kernels.pairwise_sum`)
and the dot products of the window statistics ``np.dot`` (the same BLAS call as
numpy's), so the stillness and edge tests usually give the reference's bits; the
filter's 3×3 algebra is plain loops (:func:`gyrodrift._common_kernels.matmul` and
``solve``: a BLAS call costs more than the product), equal to numpy's to the last
bits. The tests hold the mirror to rounding.

State
-----
The estimator and its long-memory twin (``outage_memory``) are two rows of the same
arrays, the tuple ``ak = (z, P, V, nis, af, ai, Q, max_var, fset, bset)``:

* ``z`` (2, 3): centred states [a, b, c'] (c' the drift at T_ref); ``P`` (2, 3, 3);
* ``V`` (2, d, d): Zhou's innovation covariance (``normalised=False``), d the depth;
* ``nis`` (2, w): the last ``innovation_window`` normalised innovations, oldest first;
* ``af`` (2, N_AF) floats and ``ai`` (2, N_AI) integers: the scalars (``AF_*``, ``AI_*``);
* ``Q`` (2, 3, 3), ``max_var`` (2, 3): process noise and cap of each filter;
* ``fset`` (N_FSET) floats and ``bset`` (N_BSET) integers: the settings (``FS_*``, ``BS_*``).

The compass window of ``_Aiding.window`` is a buffer ``win`` of ``N_WIN`` rows and
``cap`` columns, one column per compass sample, oldest first, given with its head
(first column in use) and its length: rows (t, heading, I_raw, I_T, I_Tp, I_bias) (a
snap, as :class:`gyrodrift.compensate._Snap`), then the time step and the mean gyro
rate from the sample before (``np.diff`` of t and ``np.diff(I_raw) / np.diff(t)`` of
:func:`_zaru_measurement`, computed once as the sample comes). A window of it is a
range of columns (times increase), so each of its rows is a contiguous array, read
in place. :func:`add` moves the samples in use to the front when the end is reached
(the engine keeps ``cap`` at least twice the length).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from gyrodrift._common_kernels import (cap_covariance, correct, matmul, matmul_t, matvec, pairwise_sum, solve, std_of,
                                      wrap180)

# ------------------------------------------------------------------ layouts

#: Filter scalars (per row of ``af``): T_ref, last λ, last measurement's T, the last
#: interval means (T, T') of ``_last_h``, the outage parameters a, b, c (``_anchor``).
AF_TREF, AF_LAMBDA, AF_LAST_T, AF_LAST_H_T, AF_LAST_H_TP, AF_ANCHOR = 0, 1, 2, 3, 4, 5
N_AF = 8
#: Filter flags and counts (per row of ``ai``): T_ref set, rows of V, last T set,
#: last_h set, anchor set, number of NIS values held.
AI_TREF_SET, AI_V_N, AI_LAST_T_SET, AI_LAST_H_SET, AI_ANCHOR_SET, AI_NIS_N = 0, 1, 2, 3, 4, 5
N_AI = 6
MAIN, TWIN = 0, 1

#: Float settings: β, λ_max, ρ, slope random walk (0 when off), edge_s, window length
#: (max(zaru_window_s, edge_s)), zaru_window_s, zaru_slope_k, zaru_resid_k,
#: GateConfig.still_std_dps.
FS_SOFTENING, FS_LAMBDA_MAX, FS_RHO, FS_SLOPE_Q, FS_EDGE_S, FS_WINDOW_S = 0, 1, 2, 3, 4, 5
FS_ZARU_WINDOW_S, FS_ZARU_SLOPE_K, FS_ZARU_RESID_K, FS_STILL_STD = 6, 7, 8, 9
N_FSET = 10
#: Integer settings (0/1): the estimator is ``adaptive``, normalised test, recentre,
#: twin, ZARU, zaru_hold, edge averaging, compass window collected (``_Aiding.collects``).
BS_ON, BS_NORMALISED, BS_RECENTRE, BS_TWIN, BS_ZARU, BS_ZARU_HOLD, BS_EDGE, BS_COLLECTS = 0, 1, 2, 3, 4, 5, 6, 7
N_BSET = 8

#: Values of a snap (start/end of a measurement; rows of the window buffer).
W_T, W_HEADING, W_IRAW, W_IT, W_ITP, W_IBIAS = 0, 1, 2, 3, 4, 5
N_SNAP = 6
#: Rows of the window buffer after the snap: time step and mean gyro rate from the sample before.
W_DT, W_RATE = 6, 7
N_WIN = 8

#: χ²₁ at 99 %: the ZARU consistency threshold of ``_zaru_measurement``.
ZARU_NIS = 6.63


# ------------------------------------------------------------ state in Python


def new_state(depth: int, innovation_window: int) -> tuple:
    """Empty state arrays (the tuple ``ak``) for measurements of up to ``depth`` rows."""
    return (np.zeros((2, 3)), np.zeros((2, 3, 3)), np.zeros((2, depth, depth)), np.zeros((2, innovation_window)),
            np.zeros((2, N_AF)), np.zeros((2, N_AI), dtype=np.int64), np.zeros((2, 3, 3)), np.ones((2, 3)),
            np.zeros(N_FSET), np.zeros(N_BSET, dtype=np.int64))


def load(ak: tuple, estimator, aid) -> None:
    """Fill ``ak`` from an :class:`~gyrodrift.estimators.adaptive.AdaptiveKalman` and its
    :class:`~gyrodrift.compensate._Aiding` (settings and the state after initialisation)."""
    z, P, V, nis, af, ai, Q, max_var, fset, bset = ak
    st = estimator.engine_state()
    s = estimator.settings
    fset[FS_SOFTENING] = st["softening"]
    fset[FS_LAMBDA_MAX] = st["lambda_max"]
    fset[FS_RHO] = st["rho"]
    fset[FS_SLOPE_Q] = st["slope_q"]
    fset[FS_EDGE_S] = s.edge_s
    fset[FS_WINDOW_S] = max(s.zaru_window_s, s.edge_s)
    fset[FS_ZARU_WINDOW_S] = s.zaru_window_s
    fset[FS_ZARU_SLOPE_K] = s.zaru_slope_k
    fset[FS_ZARU_RESID_K] = s.zaru_resid_k
    fset[FS_STILL_STD] = aid.cfg.gate.still_std_dps
    bset[BS_ON] = 1
    bset[BS_NORMALISED] = int(bool(st["normalised"]))
    bset[BS_RECENTRE] = int(bool(st["recentre"]))
    bset[BS_TWIN] = int(st["twin"] is not None)
    bset[BS_ZARU] = int(bool(s.zaru))
    bset[BS_ZARU_HOLD] = int(bool(s.zaru_hold))
    bset[BS_EDGE] = int(s.edge_s > 0.0)
    bset[BS_COLLECTS] = int(bool(aid.collects))
    for row, part in ((MAIN, st), (TWIN, st["twin"])):
        if part is None:
            continue
        z[row] = part["x"]
        P[row] = part["P"]
        Q[row] = part["Q"]
        max_var[row] = part["max_var"]
        if part["V"] is not None:
            n = part["V"].shape[0]
            V[row, :n, :n] = part["V"]
            ai[row, AI_V_N] = n
        if part["temp_ref_c"] is not None:
            af[row, AF_TREF] = part["temp_ref_c"]
            ai[row, AI_TREF_SET] = 1
        af[row, AF_LAMBDA] = part["last_lambda"]
        if part["last_temp_c"] is not None:
            af[row, AF_LAST_T] = part["last_temp_c"]
            ai[row, AI_LAST_T_SET] = 1
        if part["last_h"] is not None:
            af[row, AF_LAST_H_T], af[row, AF_LAST_H_TP] = part["last_h"]
            ai[row, AI_LAST_H_SET] = 1
        if part["anchor"] is not None:
            af[row, AF_ANCHOR:AF_ANCHOR + 3] = part["anchor"]
            ai[row, AI_ANCHOR_SET] = 1
        values = list(part["nis"])
        nis[row, :len(values)] = values
        ai[row, AI_NIS_N] = len(values)


def export(ak: tuple) -> dict:
    """The state of ``ak`` for :meth:`~gyrodrift.estimators.adaptive.AdaptiveKalman.set_engine_state`."""
    z, P, V, nis, af, ai, Q, max_var, fset, bset = ak

    def one(row: int) -> dict:
        n = int(ai[row, AI_V_N])
        return {
            "x": z[row].copy(), "P": P[row].copy(),
            "V": V[row, :n, :n].copy() if n else None,
            "temp_ref_c": float(af[row, AF_TREF]) if ai[row, AI_TREF_SET] else None,
            "last_lambda": float(af[row, AF_LAMBDA]),
            "last_temp_c": float(af[row, AF_LAST_T]) if ai[row, AI_LAST_T_SET] else None,
            "last_h": (float(af[row, AF_LAST_H_T]), float(af[row, AF_LAST_H_TP])) if ai[row, AI_LAST_H_SET] else None,
            "anchor": af[row, AF_ANCHOR:AF_ANCHOR + 3].copy() if ai[row, AI_ANCHOR_SET] else None,
            "nis": [float(v) for v in nis[row, : ai[row, AI_NIS_N]]],
        }

    out = one(MAIN)
    out["twin"] = one(TWIN) if bset[BS_TWIN] else None
    return out


# ----------------------------------------------------------------- the window


@njit(cache=True, nogil=True, inline="always")
def add(win, head, n, t, heading, I_raw, I_T, I_Tp, I_bias, window_s):
    """Append a compass sample to the window, drop those older than ``window_s`` before it
    (``_Aiding.add``); returns the new (head, n). The buffer must have room for one more
    (``n < cap``); the samples in use move to the front when its end is reached."""
    cap = win.shape[1]
    pos = head + n
    if pos >= cap:
        for c in range(N_WIN):
            for j in range(n):
                win[c, j] = win[c, head + j]
        head = 0
        pos = n
    win[W_T, pos] = t
    win[W_HEADING, pos] = heading
    win[W_IRAW, pos] = I_raw
    win[W_IT, pos] = I_T
    win[W_ITP, pos] = I_Tp
    win[W_IBIAS, pos] = I_bias
    if n > 0:  # np.diff(t) and np.diff(I_raw) / np.diff(t) of the window, at this sample
        step = t - win[W_T, pos - 1]
        win[W_DT, pos] = step
        win[W_RATE, pos] = (I_raw - win[W_IRAW, pos - 1]) / step
    else:  # the first sample: never the second of a pair in a window
        win[W_DT, pos] = math.nan
        win[W_RATE, pos] = math.nan
    n += 1
    while win[W_T, head] < t - window_s:
        head += 1
        n -= 1
    return head, n


@njit(cache=True, nogil=True, inline="always")
def _span(win, head, n, t_lo, t_hi, strict_lo):
    """The columns ``lo:hi`` of the window with ``t_lo < t <= t_hi`` (``t_lo <= t`` when not
    ``strict_lo``; no lower bound for NaN), found from the newest (times increase)."""
    hi = head + n
    while hi > head and win[W_T, hi - 1] > t_hi:
        hi -= 1
    if math.isnan(t_lo):
        return head, hi
    lo = hi
    if strict_lo:
        while lo > head and win[W_T, lo - 1] > t_lo:
            lo -= 1
    else:
        while lo > head and win[W_T, lo - 1] >= t_lo:
            lo -= 1
    return lo, hi


# -------------------------------------------------------------- measurements


@njit(cache=True, nogil=True)
def _compass_measurement(s0, s1, compass_sd, gyro_noise, var0, var1, end_var):
    """Eqs. (4)–(6) between two snaps (``compensate._compass_measurement``); with ``end_var``
    the compass variances of the ends are ``var0``, ``var1`` (edge means), else
    ``compass_sd²`` each. Returns (m, h_T, h_T', r, residual_deg)."""
    dt = s1[W_T] - s0[W_T]
    d_diff = wrap180((s1[W_IRAW] - s1[W_HEADING]) - (s0[W_IRAW] - s0[W_HEADING]))
    m = d_diff / dt
    h0 = (s1[W_IT] - s0[W_IT]) / dt
    h1 = (s1[W_ITP] - s0[W_ITP]) / dt
    if end_var:
        r = (var0 + var1) / dt**2 + gyro_noise**2 / dt
    else:
        r = 2.0 * compass_sd**2 / dt**2 + gyro_noise**2 / dt
    return m, h0, h1, r, d_diff - (s1[W_IBIAS] - s0[W_IBIAS])


@njit(cache=True, nogil=True, inline="always")
def _wrap180_diff(x, y, lo, ref, out, single=False):
    """``out[j] = wrap180(x[lo + j] - y[lo + j] - ref)`` (``wrap180(x[lo + j] - ref)`` when
    ``single``) for every j of ``out`` whose angle is already in range, which is what
    :func:`wrap180` gives for it; returns True when some angle is not, and ``out`` must
    then be made with :func:`wrap180` itself. (A loop with the general case inside is
    vectorised with ``fmod`` called on every lane, whether needed or not: 20 times slower.)"""
    bad = False
    for j in range(out.size):
        v = (x[lo + j] - ref) if single else (x[lo + j] - y[lo + j] - ref)
        a = v + 180.0
        bad |= not (0.0 <= a < 360.0)
        out[j] = a - 180.0
    return bad


@njit(cache=True, nogil=True)
def _edge(win, head, n, snap, edge_s, interval_s, compass_sd):
    """The compass averaged over the ``edge_s`` seconds up to ``snap`` and its variance
    (``_Aiding._edge``, fix 1): returns (edge snap (6,), variance deg²)."""
    lo, hi = _span(win, head, n, snap[W_T] - edge_s, snap[W_T], True)
    src = win
    if hi == lo or win[W_T, hi - 1] != snap[W_T]:  # the window must end at this sample
        src = np.empty((N_WIN, 1))
        for c in range(N_SNAP):
            src[c, 0] = snap[c]
        lo = 0
        hi = 1
    k = hi - lo
    d_ref = snap[W_IRAW] - snap[W_HEADING]
    d = np.empty(k)
    if _wrap180_diff(src[W_IRAW], src[W_HEADING], lo, d_ref, d):
        for j in range(k):
            d[j] = wrap180(src[W_IRAW, lo + j] - src[W_HEADING, lo + j] - d_ref)
    for j in range(k):
        d[j] = d[j] + d_ref
    I_raw = pairwise_sum(src[W_IRAW], lo, k) / k
    edge = np.empty(N_SNAP)
    edge[W_T] = pairwise_sum(src[W_T], lo, k) / k
    edge[W_HEADING] = I_raw - pairwise_sum(d, 0, k) / k
    edge[W_IRAW] = I_raw
    edge[W_IT] = pairwise_sum(src[W_IT], lo, k) / k
    edge[W_ITP] = pairwise_sum(src[W_ITP], lo, k) / k
    edge[W_IBIAS] = pairwise_sum(src[W_IBIAS], lo, k) / k
    return edge, _edge_variance(win, head, n, snap, d_ref, k, interval_s, compass_sd)


@njit(cache=True, nogil=True)
def _edge_variance(win, head, n, snap, d_ref, k, interval_s, compass_sd):
    """Variance (deg²) of an edge mean of ``k`` compass samples, from the compass scatter
    over the last update interval (``_Aiding._edge_variance``): ``σ_w²/k + σ_s²``."""
    lo, hi = _span(win, head, n, snap[W_T] - interval_s, snap[W_T], True)
    size = hi - lo
    if size < 10:
        return compass_sd**2 / k
    buf = np.empty((3, size))
    d = buf[0]
    tc = buf[1]
    dm = buf[2]
    if _wrap180_diff(win[W_IRAW], win[W_HEADING], lo, d_ref, d):
        for j in range(size):
            d[j] = wrap180(win[W_IRAW, lo + j] - win[W_HEADING, lo + j] - d_ref)
    t_mean = pairwise_sum(win[W_T], lo, size) / size
    for j in range(size):
        tc[j] = win[W_T, lo + j] - t_mean
    d_mean = pairwise_sum(d, 0, size) / size
    for j in range(size):
        dm[j] = d[j] - d_mean
    slope = np.dot(tc, dm) / np.dot(tc, tc)
    for j in range(size):  # the residuals, over d - mean(d)
        dm[j] = dm[j] - slope * tc[j]
    total = np.dot(dm, dm) / (size - 2)
    hf = buf[1, : size - 1]  # np.diff(d), over tc
    for j in range(size - 1):
        hf[j] = d[j + 1] - d[j]
    hf_mean = pairwise_sum(hf, 0, size - 1) / (size - 1)
    dev = buf[2, : size - 1]
    for j in range(size - 1):
        dev[j] = hf[j] - hf_mean
    white = 0.5 * np.dot(dev, dev) / (size - 2)
    if total < white:  # min(white, total)
        white = total
    return white / k + (total - white)


@njit(cache=True, nogil=True)
def _zaru_measurement(win, head, n, start, end, a, b, c, cov, still_chain, gyro_noise, compass_sd, fset, bset):
    """Zero-rate measurement of the interval from ``start`` to ``end`` when the unit is still
    (``_Aiding._zaru_measurement``, fixes 3 and 4).

    ``a, b, c`` are the parameters in force (``estimator.drift``), ``cov`` the covariance
    (``estimator.cov``). Returns (found, m, h_T, h_T', r, still_chain, held): the mean gyro rate
    over the interval measures the drift (eq. 1 with zero true rate), variance ``N²/Δt``
    (plus the squared slope standard error of a verified flat compass); ``held``: found by
    ``zaru_hold`` with a compass that is not flat (the compass moved, not the unit).
    The window is read in place (its columns ``lo:hi``), its rates as :func:`add` stored them.
    """
    if bset[BS_ZARU] == 0:
        return False, 0.0, 0.0, 0.0, 0.0, still_chain, False
    lo, hi = _span(win, head, n, math.nan, end[W_T], True)
    if hi - lo < 10 or end[W_T] - win[W_T, lo] < 0.8 * fset[FS_ZARU_WINDOW_S]:
        return False, 0.0, 0.0, 0.0, 0.0, False, False
    dt = end[W_T] - start[W_T]
    m = (end[W_IRAW] - start[W_IRAW]) / dt
    h = np.empty(3)
    h[0] = (end[W_IT] - start[W_IT]) / dt
    h[1] = (end[W_ITP] - start[W_ITP]) / dt
    h[2] = 1.0
    r = gyro_noise**2 / dt
    gamma = m - (a * h[0] + b * h[1] + c)
    consistent = gamma * gamma <= ZARU_NIS * (np.dot(np.dot(h, cov), h) + r)
    still = _gyro_still(win, lo, hi, start[W_T], fset[FS_STILL_STD], fset[FS_ZARU_RESID_K])
    # The chain of stillness breaks on evidence of rotation: a mean rate the drift does not
    # explain. A wobble the Allan test sees only skips this interval.
    still_chain = still_chain and consistent
    if not still:
        return False, 0.0, 0.0, 0.0, 0.0, still_chain, False
    slope_se = _flat_compass(win, lo, hi, compass_sd, fset[FS_ZARU_SLOPE_K], fset[FS_ZARU_RESID_K])
    if slope_se >= 0.0:
        return True, m, h[0], h[1], r + slope_se**2, True, False
    if bset[BS_ZARU_HOLD] == 1 and still_chain:
        return True, m, h[0], h[1], r, still_chain, True
    return False, 0.0, 0.0, 0.0, 0.0, still_chain, False


@njit(cache=True, nogil=True)
def _flat_compass(win, lo, hi, compass_sd, slope_k, resid_k):
    """Standard error (deg/s) of the slope of a flat compass heading over the stillness
    window (columns ``lo:hi``), or -1 when it is not flat (``compensate._flat_compass``,
    which returns None). The scatter and slope tests come before the white-noise one, which
    needs another two passes (the same answer: the three are tested together there)."""
    size = hi - lo
    buf = np.empty((3, size))
    d = buf[0]
    tc = buf[1]
    dm = buf[2]
    h0 = win[W_HEADING, lo]
    if _wrap180_diff(win[W_HEADING], win[W_HEADING], lo, h0, d, True):
        for j in range(size):
            d[j] = wrap180(win[W_HEADING, lo + j] - h0)
    t_mean = pairwise_sum(win[W_T], lo, size) / size
    for j in range(size):
        tc[j] = win[W_T, lo + j] - t_mean
    sxx = np.dot(tc, tc)
    d_mean = pairwise_sum(d, 0, size) / size
    for j in range(size):
        dm[j] = d[j] - d_mean
    slope = np.dot(tc, dm) / sxx
    for j in range(size):  # the residuals, over d - mean(d)
        dm[j] = dm[j] - slope * tc[j]
    dof = max(size - 2, 1)
    resid_var = np.dot(dm, dm) / dof
    slope_se = math.sqrt(resid_var / sxx)
    if resid_var > (2.0 * compass_sd) ** 2 or abs(slope) > slope_k * slope_se:
        return -1.0
    hf = buf[1, : size - 1]  # np.diff(d), over tc
    for j in range(size - 1):
        hf[j] = d[j + 1] - d[j]
    hf_mean = pairwise_sum(hf, 0, size - 1) / (size - 1)
    dev = buf[2, : size - 1]
    for j in range(size - 1):
        dev[j] = hf[j] - hf_mean
    noise_var = 0.5 * np.dot(dev, dev) / max(size - 2, 1)
    if resid_var > noise_var * (1.0 + resid_k * math.sqrt(2.0 / dof)):
        return -1.0
    return slope_se


@njit(cache=True, nogil=True)
def _median(x):
    """``np.median`` of a 1-d float64 array without NaN."""
    s = np.sort(x)
    n = s.size
    if n % 2 == 1:
        return s[n // 2]
    return (s[n // 2 - 1] + s[n // 2]) / 2.0


@njit(cache=True, nogil=True)
def _allan(rates, lo, size, m):
    """``allan(m)`` of ``_gyro_still`` over ``rates[lo:lo + size]``: half the mean squared
    difference of successive means of ``m`` rates."""
    nb = size // m
    d = np.empty(nb)
    if m < 8:  # numpy adds fewer than 8 numbers one after the other
        for j in range(nb):
            b = lo + j * m
            total = 0.0
            for i in range(m):
                total += rates[b + i]
            d[j] = total / m
    else:
        for j in range(nb):
            d[j] = pairwise_sum(rates, lo + j * m, m) / m
    for j in range(nb - 1):  # np.diff of the means, in place
        d[j] = d[j + 1] - d[j]
    dd = d[: nb - 1]
    return 0.5 * np.dot(dd, dd) / (nb - 1)


@njit(cache=True, nogil=True)
def _gyro_still(win, lo, hi, interval_start_s, max_std_dps, k):
    """Whether the gyro saw no motion over the stillness window, columns ``lo:hi``
    (``compensate._gyro_still``): the rates of this interval vary less than ``max_std_dps``
    and the Allan variance at 2 s is within ``k`` standard errors of a quarter of that at
    0.5 s (white noise). The rates are ``win[W_RATE, lo + 1:hi]`` (stored by :func:`add`)."""
    nr = hi - lo - 1
    r0 = lo + 1
    # rates[t[1:] > interval_start_s]: a run at the end (times increase)
    j0 = nr
    while j0 > 0 and win[W_T, lo + j0] > interval_start_s:
        j0 -= 1
    if nr - j0 >= 2 and std_of(win[W_RATE], r0 + j0, nr - j0) > max_std_dps:
        return False
    # round(0.5 / median(np.diff(t))): the same for every time step between the smallest
    # and the largest when those two give the same (division and rounding are monotonic)
    lo_dt = math.inf
    hi_dt = -math.inf
    for j in range(r0, hi):
        step = win[W_DT, j]
        if step < lo_dt:
            lo_dt = step
        if step > hi_dt:
            hi_dt = step
    steps = np.rint(0.5 / hi_dt)
    if np.rint(0.5 / lo_dt) != steps:
        steps = np.rint(0.5 / _median(win[W_DT, r0:hi]))
    small = max(1, int(steps))
    big = 4 * small
    nb = nr // big
    if nb < 6:
        return True
    rates = win[W_RATE]
    return _allan(rates, r0, nr, big) <= 0.25 * _allan(rates, r0, nr, small) * (1.0 + k * math.sqrt(2.0 / (nb - 1)))


# ------------------------------------------------------------------- the filter


@njit(cache=True, nogil=True, inline="always")
def _own_params(z, af):
    """The filter's absolute [a, b, c] (``AdaptiveKalman._own_params``): c = c' − a T_ref."""
    out = np.empty(3)
    out[0] = z[0]
    out[1] = z[1]
    out[2] = z[2] - z[0] * af[AF_TREF]
    return out


@njit(cache=True, nogil=True)
def params(z, af, ai):
    """Parameters in force (``AdaptiveKalman.params``): the outage anchor while one is set."""
    if ai[AI_ANCHOR_SET] == 1:
        return af[AF_ANCHOR:AF_ANCHOR + 3].copy()
    return _own_params(z, af)


@njit(cache=True, nogil=True)
def cov(P, af):
    """Covariance of the absolute [a, b, c] (``AdaptiveKalman.cov``): ``J P Jᵀ``."""
    J = np.eye(3)
    J[2, 0] = -af[AF_TREF]
    return matmul_t(matmul(J, P), J)


@njit(cache=True, nogil=True)
def _recentre(z, P, af, temp_c):
    """Move T_ref to ``temp_c`` (``AdaptiveKalman._recentre``; the drift model is unchanged)."""
    J = np.eye(3)
    J[2, 0] = temp_c - af[AF_TREF]
    z[:] = matvec(J, z)
    P[:, :] = matmul_t(matmul(J, P), J)
    af[AF_TREF] = temp_c


@njit(cache=True, nogil=True, inline="always")
def _column_mean(H, c):
    """``np.mean(H[:, c])`` (numpy adds fewer than 8 numbers one after the other)."""
    m = H.shape[0]
    if m >= 8:
        return pairwise_sum(np.ascontiguousarray(H[:, c]), 0, m) / m
    total = 0.0
    for r in range(m):
        total += H[r, c]
    return total / m


@njit(cache=True, nogil=True)
def _centre(z, af, ai, H):
    """H with T centred on T_ref, which the first observation sets (``AdaptiveKalman._centre``)."""
    m = H.shape[0]
    if ai[AI_TREF_SET] == 0:
        af[AF_TREF] = _column_mean(H, 0)
        ai[AI_TREF_SET] = 1
        z[2] = z[2] + z[0] * af[AF_TREF]  # z is still the prior x0 here
    Hc = H.copy()
    for r in range(m):
        Hc[r, 0] -= af[AF_TREF]
    return Hc


@njit(cache=True, nogil=True)
def update(z, P, V, nis, af, ai, Q, max_var, slope_q, y, H, R, fset, bset):
    """One accepted observation (``AdaptiveKalman.update``), state in place.

    The fading factor λ of ``P⁻ = λ P + Q`` (eq. 10 with λ for the paper's s): with
    ``normalised``, from the mean NIS of the last ``innovation_window`` updates against
    β; else Zhou's recursive innovation covariance ``V``. ``slope_q`` adds the slope's
    random walk in temperature to Q (0 for the twin).
    """
    m = y.size
    temp_c = _column_mean(H, 0)
    Qk = Q
    if ai[AI_LAST_T_SET] == 1 and slope_q > 0.0:
        Qk = Q.copy()
        Qk[0, 0] += slope_q**2 * abs(temp_c - af[AF_LAST_T])
    af[AF_LAST_T] = temp_c
    ai[AI_LAST_T_SET] = 1
    af[AF_LAST_H_T] = temp_c
    af[AF_LAST_H_TP] = _column_mean(H, 1)
    ai[AI_LAST_H_SET] = 1
    ai[AI_ANCHOR_SET] = 0
    if bset[BS_RECENTRE] == 1 and ai[AI_TREF_SET] == 1:
        _recentre(z, P, af, temp_c)
    Hc = _centre(z, af, ai, H)
    gamma = y - matvec(Hc, z)
    M = matmul_t(matmul(Hc, P), Hc)
    trM = np.trace(M)
    if bset[BS_NORMALISED] == 1:
        S = M + matmul_t(matmul(Hc, Qk), Hc) + R
        x = solve(S, gamma)
        value = gamma[0] * x[0]
        for j in range(1, m):
            value += gamma[j] * x[j]
        value /= m
        w = nis.size
        n = ai[AI_NIS_N]
        if n < w:
            nis[n] = value
            n += 1
            ai[AI_NIS_N] = n
        else:
            for j in range(w - 1):
                nis[j] = nis[j + 1]
            nis[w - 1] = value
        total = 0.0
        for j in range(n):
            total += nis[j]
        excess = total / n - fset[FS_SOFTENING]
        lam = 1.0 + excess * (np.trace(S) / trM) if trM > 0 else 1.0
    else:
        if ai[AI_V_N] != m:
            for i in range(m):
                for j in range(m):
                    V[i, j] = gamma[i] * gamma[j]
            ai[AI_V_N] = m
        else:
            rho = fset[FS_RHO]
            for i in range(m):
                for j in range(m):
                    V[i, j] = (rho * V[i, j] + gamma[i] * gamma[j]) / (1.0 + rho)
        N = V[:m, :m] - matmul_t(matmul(Hc, Qk), Hc) - fset[FS_SOFTENING] * R
        lam = np.trace(N) / trM if trM > 0 else 1.0
    # min(max(1, λ), λ_max) as Python evaluates it
    if not lam > 1.0:
        lam = 1.0
    if fset[FS_LAMBDA_MAX] < lam:
        lam = fset[FS_LAMBDA_MAX]
    af[AF_LAMBDA] = lam
    P_prior = cap_covariance(lam * P + Qk, max_var)
    z_post, P_post = correct(z, P_prior, y, Hc, R)
    z[:] = z_post
    P[:, :] = cap_covariance(P_post, max_var)


@njit(cache=True, nogil=True)
def hold(ak):
    """One refused interval (``AdaptiveKalman.hold``): ``P ← cap(P + Q)``, the twin alike, and
    at the first refusal after an update the outage anchor: the twin's a and b from the
    drift last tracked at the last measurement's (T, T') (fix 2, eq. 5 through the outage)."""
    z, P, V, nis, af, ai, Q, max_var, fset, bset = ak
    P[MAIN] = cap_covariance(1.0 * P[MAIN] + Q[MAIN], max_var[MAIN])
    if bset[BS_TWIN] == 1:
        P[TWIN] = cap_covariance(1.0 * P[TWIN] + Q[TWIN], max_var[TWIN])
        if ai[MAIN, AI_ANCHOR_SET] == 0 and ai[MAIN, AI_LAST_H_SET] == 1:
            T0 = af[MAIN, AF_LAST_H_T]
            Tp0 = af[MAIN, AF_LAST_H_TP]
            tw = _own_params(z[TWIN], af[TWIN])
            a = tw[0]
            b = tw[1]
            h = np.empty(3)
            h[0] = T0
            h[1] = Tp0
            h[2] = 1.0
            drift0 = np.dot(_own_params(z[MAIN], af[MAIN]), h)
            af[MAIN, AF_ANCHOR] = a
            af[MAIN, AF_ANCHOR + 1] = b
            af[MAIN, AF_ANCHOR + 2] = drift0 - a * T0 - b * Tp0
            ai[MAIN, AI_ANCHOR_SET] = 1


@njit(cache=True, nogil=True)
def update_both(ak, y, H, R):
    """``AdaptiveKalman.update`` of the estimator, whose first step updates its twin."""
    z, P, V, nis, af, ai, Q, max_var, fset, bset = ak
    if bset[BS_TWIN] == 1:
        update(z[TWIN], P[TWIN], V[TWIN], nis[TWIN], af[TWIN], ai[TWIN], Q[TWIN], max_var[TWIN], 0.0,
               y, H, R, fset, bset)
    update(z[MAIN], P[MAIN], V[MAIN], nis[MAIN], af[MAIN], ai[MAIN], Q[MAIN], max_var[MAIN], fset[FS_SLOPE_Q],
           y, H, R, fset, bset)

"""Compiled kernels of the fast batch engine (numba; see :mod:`gyrodrift._engine`).

Every function here is a loop over samples, or a small-matrix Kalman step, written
once and compiled with numba (``nopython``, no ``fastmath``: IEEE arithmetic in the
order written). They mirror, operation for operation where it matters, the reference
implementation in :mod:`gyrodrift.compensate`, :mod:`gyrodrift.model`,
:mod:`gyrodrift.gating` and :mod:`gyrodrift.estimators`; the tests hold the two to
agree. They are resumable: each takes its state arrays, updates them in place and
can stop early (returning the next row to do) when an output buffer is full, so a
log may be fed in chunks of any size with identical results.

The ``adaptive`` estimator and its aiding are in :mod:`gyrodrift._adaptive_kernels`
(called from :func:`_close`, :func:`_begin` and the row loop), the helpers both use in
:mod:`gyrodrift._common_kernels`.

Importing this module imports numba (about 0.5 s); :mod:`gyrodrift._engine` does it
only when the fast engine runs.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from gyrodrift import _adaptive_kernels as AK
from gyrodrift import _fusion_kernels as FZ
from gyrodrift._common_kernels import cap_covariance, correct, wrap180, wrap360

# ---------------------------------------------------------------- state layouts

# Float state of the main kernel (index names).
F_T, F_G, F_TEMP, F_TP, F_BIAS, F_RATE = 0, 1, 2, 3, 4, 5
F_IRAW, F_IT, F_ITP, F_IBIAS, F_IRATE = 6, 7, 8, 9, 10
F_K, F_TSTART, F_ANCHOR = 11, 12, 13
F_S0 = 14  # start snap: t, heading, I_raw, I_T, I_Tp, I_bias (6 values)
F_S1 = 20  # last compass snap: same 6 values
F_PA, F_PB, F_PC = 26, 27, 28  # absolute a, b, c in force
F_E0 = 29  # start edge (``_Aiding.start_edge``, adaptive edge averaging): a snap (6 values)
F_E0_VAR = 35  # and its compass variance, deg²
F_E1 = 36  # the end edge of the interval just closed (the next start edge): a snap (6 values)
F_E1_VAR = 42  # and its compass variance, deg²
N_FSTATE = 43

# Integer state of the main kernel.
I_S0_OK, I_S1_OK, I_STICKY, I_AFTER_INT = 0, 1, 2, 3
I_STACK_N, I_REFUSED_N, I_LB_HEAD, I_LB_N, I_UNOBS, I_N_ACC = 4, 5, 6, 7, 8, 9
I_WIN_HEAD, I_WIN_N, I_E0_OK, I_STILL_CHAIN = 10, 11, 12, 13  # compass window, start edge, still chain
I_E1_OK = 14  # F_E1 holds the edge of the last compass snap, computed at this boundary by _close
N_ISTATE = 15

# Settings (float) of the main kernel.
C_INTERVAL, C_COMPASS_SD, C_GYRO_NOISE, C_TURN_RATE, C_TURN_WIN = 0, 1, 2, 3, 4
C_INTERF, C_MAX_AGE, C_FADING, C_PRIOR_A, C_PRIOR_B = 5, 6, 7, 8, 9
N_CFG = 10

# Integer settings: lock-out recovery intervals, estimator, measurements per update
# (``_Aiding.depth``).
K_RELOCK, K_MODE, K_DEPTH = 0, 1, 2
N_KCFG = 3
#: MODE_FIXED: the linear drift filter with a fixed fading factor (``stkf``, ``stkf-s1``,
#: ``kf``; state x, P); MODE_ADAPTIVE: :mod:`gyrodrift._adaptive_kernels` (state ``ak``).
MODE_FIXED, MODE_ADAPTIVE = 0, 1

# Reason codes (gate_reason categories, in this order).
R_NONE, R_INIT, R_GAP, R_NO_COMPASS, R_FIELD, R_TURNING, R_INTERFERENCE = 0, 1, 2, 3, 4, 5, 6
NO_STICKY = -1

# T' tracker state.
TF_T0, TF_SUM_T, TF_SUM_TEMP, TF_RATE = 0, 1, 2, 3
TI_BIN, TI_N, TI_HEAD, TI_LEN, TI_STARTED = 0, 1, 2, 3, 4


# ------------------------------------------------------------------------ T'


@njit(cache=True, nogil=True)
def temp_rate_kernel(t, temp, window_bins, bin_s, tf, ti, bins, out):
    """T' (degC/s) of every sample, resumable (mirror of :class:`gyrodrift.model.TempRateTracker`).

    ``bins`` is a ring of (bin number, mean time, mean temperature) of the closed bins,
    at least ``window_bins + 2`` rows. The state lives in locals during the loop.
    """
    cap = bins.shape[0]
    if t.size and ti[TI_STARTED] == 0:
        tf[TF_T0] = t[0]
        ti[TI_STARTED] = 1
        ti[TI_BIN] = math.floor((t[0] - tf[TF_T0]) / bin_s)
    t0 = tf[TF_T0]
    sum_t, sum_T, rate = tf[TF_SUM_T], tf[TF_SUM_TEMP], tf[TF_RATE]
    cur, count, head, length = ti[TI_BIN], ti[TI_N], ti[TI_HEAD], ti[TI_LEN]
    # below t_near the bin number cannot have changed (margin for the rounding of the division)
    t_near = _near_boundary(t0, float(cur), bin_s)
    for i in range(t.size):
        ti_ = t[i]
        b = cur
        if ti_ >= t_near:
            b = math.floor((ti_ - t0) / bin_s)
        if count > 0 and b != cur:
            # close the bin: its mean time and temperature
            tb = sum_t / count
            Tb = sum_T / count
            pos = (head + length) % cap
            bins[pos, 0] = cur
            bins[pos, 1] = tb
            bins[pos, 2] = Tb
            length += 1
            while bins[head, 0] < cur - window_bins:
                head = (head + 1) % cap
                length -= 1
            rate = _ring_slope(bins, head, length)
            sum_t = 0.0
            sum_T = 0.0
            count = 0
        if b != cur:
            cur = b
            t_near = _near_boundary(t0, float(cur), bin_s)
        sum_t += ti_
        sum_T += temp[i]
        count += 1
        out[i] = rate
    tf[TF_SUM_T], tf[TF_SUM_TEMP], tf[TF_RATE] = sum_t, sum_T, rate
    ti[TI_BIN], ti[TI_N], ti[TI_HEAD], ti[TI_LEN] = cur, count, head, length


@njit(cache=True, nogil=True)
def _ring_slope(bins, head, n):
    """Least-squares slope of column 2 against column 1 over ``n`` ring rows; 0 if undetermined."""
    if n < 2:
        return 0.0
    cap = bins.shape[0]
    st = 0.0
    sT = 0.0
    r = head
    for _ in range(n):  # oldest first, the ring's wrap without a division per row
        st += bins[r, 1]
        sT += bins[r, 2]
        r += 1
        if r == cap:
            r = 0
    mt = st / n
    mT = sT / n
    sxx = 0.0
    sxy = 0.0
    r = head
    for _ in range(n):
        dt = bins[r, 1] - mt
        sxx += dt * dt
        sxy += dt * (bins[r, 2] - mT)
        r += 1
        if r == cap:
            r = 0
    if sxx <= 0.0:
        return 0.0
    return sxy / sxx


@njit(cache=True, nogil=True)
def prepare_kernel(t, g, T, heading, t_prev, first_chunk, max_gap_s, gap):
    """Per-row checks of a chunk (the reference ``compensate_arrays`` set-up), reading only.

    Writes ``gap`` (time step above ``max_gap_s``). Returns ``(bad, fix)``: ``bad`` is -1
    or the first row whose time is not finite or does not increase; ``fix`` has bit 1
    when a gyro cell is not finite, 2 for temperature (hold them: :func:`hold_kernel`),
    4 when a compass heading is infinite or outside [0, 360) (:func:`wrap_kernel`). Most
    logs need no copy of any column.
    """
    prev = t_prev
    fix = 0
    for i in range(t.size):
        ti = t[i]
        if not math.isfinite(ti):
            return i, fix
        step = 0.0
        if i > 0 or not first_chunk:
            step = ti - prev
            if not step > 0.0:
                return i, fix
        prev = ti
        gap[i] = step > max_gap_s
        if not math.isfinite(g[i]):
            fix |= 1
        if not math.isfinite(T[i]):
            fix |= 2
        h = heading[i]
        if math.isinf(h) or not (math.isnan(h) or 0.0 <= h < 360.0):
            fix |= 4
    return -1, fix


@njit(cache=True, nogil=True)
def hold_kernel(x, last, gap, out):
    """``out`` = ``x`` with every non-finite cell holding the previous finite value (``last``
    before the chunk); such rows are flagged in ``gap``."""
    for i in range(x.size):
        v = x[i]
        if math.isfinite(v):
            last = v
        else:
            gap[i] = True
        out[i] = last


@njit(cache=True, nogil=True)
def wrap_kernel(heading, out):
    """Compass headings wrapped to [0, 360); NaN where absent or not finite."""
    for i in range(heading.size):
        h = heading[i]
        out[i] = wrap360(h) if math.isfinite(h) else math.nan


# -------------------------------------------------------------------- Kalman


@njit(cache=True, nogil=True)
def _sub(P, active):
    n = active.size
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = P[active[i], active[j]]
    return out


@njit(cache=True, nogil=True)
def _put(P, active, Pa):
    n = active.size
    for i in range(n):
        for j in range(n):
            P[active[i], active[j]] = Pa[i, j]


@njit(cache=True, nogil=True)
def hold(P, Q, max_var, active):
    """No aiding: ``P <- cap(P + Q)`` on the active states."""
    Pa = _sub(P, active)
    Qa = _sub(Q, active)
    _put(P, active, cap_covariance(1.0 * Pa + Qa, max_var[active]))


@njit(cache=True, nogil=True)
def kalman_update(x, P, Q, max_var, active, y, H, R, fading):
    """One accepted update of the linear drift filter (``KalmanDrift.update``): ``P- = cap(s P + Q)``
    (eq. 10, ``stkf``/``stkf-s1``/``kf``), then the Joseph-form correction; x, P in place."""
    m = y.size
    na = active.size
    Ha = np.empty((m, na))
    for r in range(m):
        for j in range(na):
            Ha[r, j] = H[r, active[j]]
    xa = np.empty(na)
    for j in range(na):
        xa[j] = x[active[j]]
    Pa = _sub(P, active)
    Qa = _sub(Q, active)
    mv = max_var[active]
    P_prior = cap_covariance(fading * Pa + Qa, mv)
    xa, P_post = correct(xa, P_prior, y, Ha, R)
    _put(P, active, cap_covariance(P_post, mv))
    for j in range(na):
        x[active[j]] = xa[j]


@njit(cache=True, nogil=True)
def in_force(x, P, fs, mode, ak):
    """The parameters in force into ``fs`` (F_PA..F_PC: the estimator's ``params``) and its
    covariance ``cov`` of the absolute [a, b, c], which bias_sd and ``unobservable`` report.

    ``adaptive``: the outage anchor while one is set, and ``J P Jᵀ`` of the centred states.
    """
    if mode == MODE_ADAPTIVE:
        z, Pa, V, nis, af, ai, Q, max_var, fset, bset = ak
        p = AK.params(z[AK.MAIN], af[AK.MAIN], ai[AK.MAIN])
        fs[F_PA] = p[0]
        fs[F_PB] = p[1]
        fs[F_PC] = p[2]
        return AK.cov(Pa[AK.MAIN], af[AK.MAIN])
    fs[F_PA] = x[0]
    fs[F_PB] = x[1]
    fs[F_PC] = x[2]
    return P.copy()


# ---------------------------------------------------------------- main loop


@njit(cache=True, nogil=True)
def _unobservable_code(C, prior_a, prior_b):
    code = 0
    if math.sqrt(max(C[0, 0], 0.0)) > 0.5 * prior_a:
        code += 1
    if math.sqrt(max(C[1, 1], 0.0)) > 0.5 * prior_b:
        code += 2
    return code


@njit(cache=True, nogil=True, inline="always")
def _row_condition(gap, field, resid, mean_rate, turn_rate, interf):
    if gap:
        return R_GAP
    if field:
        return R_FIELD
    if abs(mean_rate) > turn_rate:
        return R_TURNING
    if abs(resid) > interf:  # False for NaN
        return R_INTERFERENCE
    return NO_STICKY


@njit(cache=True, nogil=True)
def compensate_kernel(
    t, g, T, Tp, heading, gap, field, i0,
    fs, ist, cfg, kcfg, x, P, Q, max_var, active, stack, refused, lb, win, ak,
    Cabs,
    out_bias, out_rate, out_heading, out_a, out_b, out_c, out_update, out_reason, out_bias_sd, out_unobs,
    acc, fst, fcfg, fuse_interference, out_hf, out_hf_sd, out_h_sd,
):
    """Compensate rows ``i0..`` of a chunk after initialisation (mirror of ``Compensator._step``).

    The fused heading (:func:`gyrodrift._fusion_kernels.step`, state ``fst``, settings
    ``fcfg``) is computed on the same pass; the compass of a row is refused to it for
    ``field``, and for ``interference`` when ``fuse_interference``.

    The estimator is the linear filter ``x, P`` (``kcfg[K_MODE]`` MODE_FIXED) or the
    ``adaptive`` one, state ``ak`` (:mod:`gyrodrift._adaptive_kernels`), whose aiding
    keeps the compass samples of the last ``max(zaru_window_s, edge_s)`` in the buffer
    ``win`` (``_Aiding.add``; layout in :mod:`gyrodrift._adaptive_kernels`) when it
    needs them (``_Aiding.collects``).

    Returns the next row to do: ``t.size`` when done, less when the turn-window ring
    ``lb`` or the accepted-measurement buffer ``acc`` is full, or the compass window
    ``win`` half full (grow it and call again).

    The per-row state lives in local variables (kept in registers) and goes back to
    ``fs``/``ist`` around each interval decision and at the end.
    """
    interval = cfg[C_INTERVAL]
    turn_win = cfg[C_TURN_WIN]
    turn_rate = cfg[C_TURN_RATE]
    interf = cfg[C_INTERF]
    t_start = fs[F_TSTART]
    anchor = fs[F_ANCHOR]
    depth = kcfg[K_DEPTH]
    lb_cap = lb.shape[0]
    acc_cap = acc.shape[0]
    win_cap = win.shape[1]
    collects = ak[9][AK.BS_COLLECTS] == 1
    window_s = ak[8][AK.FS_WINDOW_S]
    # carry
    c_t, c_g, c_T, c_Tp, c_bias, c_rate = fs[F_T], fs[F_G], fs[F_TEMP], fs[F_TP], fs[F_BIAS], fs[F_RATE]
    I_raw, I_T, I_Tp, I_bias, I_rate = fs[F_IRAW], fs[F_IT], fs[F_ITP], fs[F_IBIAS], fs[F_IRATE]
    k_cur = fs[F_K]
    pa, pb, pc = fs[F_PA], fs[F_PB], fs[F_PC]
    s0_heading, s0_Iraw, s0_Ibias = fs[F_S0 + 1], fs[F_S0 + 2], fs[F_S0 + 5]
    s0_ok = ist[I_S0_OK] == 1
    sticky = ist[I_STICKY]
    after_int = ist[I_AFTER_INT] == 1
    unobs = ist[I_UNOBS]
    lb_head, lb_n = ist[I_LB_HEAD], ist[I_LB_N]
    win_head, win_n = ist[I_WIN_HEAD], ist[I_WIN_N]
    C00, C01, C02 = Cabs[0, 0], Cabs[0, 1], Cabs[0, 2]
    C10, C11, C12 = Cabs[1, 0], Cabs[1, 1], Cabs[1, 2]
    C20, C21, C22 = Cabs[2, 0], Cabs[2, 1], Cabs[2, 2]
    t_near = _near_boundary(t_start, k_cur, interval)
    f_psi, f_P, f_tp, f_rp, f_started = fst[FZ.PSI], fst[FZ.P], fst[FZ.TPREV], fst[FZ.RPREV], fst[FZ.STARTED]
    f_t0, f_isd, f_sdp, f_rej = fst[FZ.T0], fst[FZ.ISD], fst[FZ.SDPREV], fst[FZ.REJ_T]
    fR, fN2, ftau, fgate, frelock = fcfg[0], fcfg[1], fcfg[2], fcfg[3], fcfg[4]
    seg = i0  # first row whose a, b, c and unobservable code are still to write (_fill_params)
    # bias and bias_sd of the last (T, T'), reused while they repeat (a quantised temperature)
    m_T = math.nan
    m_Tp = math.nan
    m_bias = 0.0
    m_sd = 0.0
    stop = t.size
    for i in range(i0, t.size):
        if lb_n >= lb_cap or ist[I_N_ACC] >= acc_cap or 2 * win_n >= win_cap:
            stop = i
            break
        ix = np.uint64(i)  # an unsigned index: no negative-index fix-up on every access
        t_s = t[ix]
        gi = g[ix]
        Ti = T[ix]
        Tpi = Tp[ix]
        h = heading[ix]
        if Ti != m_T or Tpi != m_Tp:
            m_T = Ti
            m_Tp = Tpi
            m_bias = pa * Ti + pb * Tpi + pc
            # bias_sd with the covariance in force for this row
            var = ((C00 * Ti + C01 * Tpi + C02) * Ti
                   + (C10 * Ti + C11 * Tpi + C12) * Tpi
                   + (C20 * Ti + C21 * Tpi + C22))
            m_sd = math.sqrt(max(var, 0.0))
        bias = m_bias
        bias_sd = m_sd
        rate = gi - bias
        dt = t_s - c_t
        I_raw = I_raw + 0.5 * (gi + c_g) * dt
        I_T = I_T + 0.5 * (Ti + c_T) * dt
        I_Tp = I_Tp + 0.5 * (Tpi + c_Tp) * dt
        I_bias = I_bias + 0.5 * (bias + c_bias) * dt
        I_rate = I_rate + 0.5 * (rate + c_rate) * dt
        c_t, c_g, c_T, c_Tp, c_bias, c_rate = t_s, gi, Ti, Tpi, bias, rate
        has_compass = not math.isnan(h)
        if has_compass:
            fs[F_S1] = t_s
            fs[F_S1 + 1] = h
            fs[F_S1 + 2] = I_raw
            fs[F_S1 + 3] = I_T
            fs[F_S1 + 4] = I_Tp
            fs[F_S1 + 5] = I_bias
            ist[I_S1_OK] = 1
            if collects:
                win_head, win_n = AK.add(win, win_head, win_n, t_s, h, I_raw, I_T, I_Tp, I_bias, window_s)
        # 1-s mean compensated rate, from the oldest row inside the window
        window_start = t_s - turn_win
        while lb_n > 1 and lb[np.uint64(lb_head), 0] < window_start:
            lb_head += 1
            if lb_head == lb_cap:
                lb_head = 0
            lb_n -= 1
        lb_t0 = lb[np.uint64(lb_head), 0]
        lb_I0 = lb[np.uint64(lb_head), 1]
        pos = lb_head + lb_n
        if pos >= lb_cap:
            pos -= lb_cap
        lb[np.uint64(pos), 0] = t_s
        lb[np.uint64(pos), 1] = I_rate
        lb_n += 1
        if sticky == NO_STICKY:
            resid = math.nan
            if has_compass and s0_ok:
                d = wrap180((I_raw - h) - (s0_Iraw - s0_heading))
                resid = d - (I_bias - s0_Ibias)
            # |mean rate| > turn_rate: 0 stands for a rate clearly below it (no division; exact)
            num = abs(I_rate - lb_I0)
            lim = turn_rate * (t_s - lb_t0)
            if num < lim * (1.0 - 1e-12):
                mean_rate = 0.0
            else:
                mean_rate = (I_rate - lb_I0) / (t_s - lb_t0)
            sticky = _row_condition(gap[ix], field[ix], resid, mean_rate, turn_rate, interf)
        update = 0
        if sticky != NO_STICKY:
            reason = sticky
        elif after_int:
            reason = R_INTERFERENCE
        else:
            reason = R_NONE
        out_bias_sd[ix] = bias_sd
        out_bias[ix] = bias
        out_rate[ix] = rate
        out_heading[ix] = wrap360(anchor + I_rate)
        # the interval number floor((t - t_start)/interval), computed only near a boundary
        k = k_cur
        if t_s >= t_near:
            k = math.floor((t_s - t_start) / interval)
        if k > k_cur:
            _fill_params(out_a, out_b, out_c, out_unobs, seg, i + 1, pa, pb, pc, unobs)
            seg = i + 1
            k_cur = k
            ist[I_STICKY] = sticky
            ist[I_AFTER_INT] = 1 if after_int else 0
            ist[I_WIN_HEAD], ist[I_WIN_N] = win_head, win_n
            update, reason = _close(t_s, fs, ist, cfg, kcfg, x, P, Q, max_var, active, stack, refused, acc, depth,
                                    win, Cabs, ak)
            C = in_force(x, P, fs, kcfg[K_MODE], ak)
            for r in range(3):
                for c in range(3):
                    Cabs[r, c] = C[r, c]
            C00, C01, C02 = C[0, 0], C[0, 1], C[0, 2]
            C10, C11, C12 = C[1, 0], C[1, 1], C[1, 2]
            C20, C21, C22 = C[2, 0], C[2, 1], C[2, 2]
            unobs = _unobservable_code(C, cfg[C_PRIOR_A], cfg[C_PRIOR_B])
            _begin(t_s, fs, ist, cfg, win, ak)
            pa, pb, pc = fs[F_PA], fs[F_PB], fs[F_PC]
            s0_heading, s0_Iraw, s0_Ibias = fs[F_S0 + 1], fs[F_S0 + 2], fs[F_S0 + 5]
            s0_ok = ist[I_S0_OK] == 1
            sticky = ist[I_STICKY]
            after_int = ist[I_AFTER_INT] == 1
            t_near = _near_boundary(t_start, k_cur, interval)
            m_T = math.nan  # new parameters and covariance: recompute
        out_update[ix] = update
        out_reason[ix] = reason
        allow = reason != R_FIELD and not (fuse_interference and reason == R_INTERFERENCE)
        f_psi, f_P, f_tp, f_rp, f_started, f_t0, f_isd, f_sdp, f_rej, hf, hf_sd, h_sd = FZ.step(
            f_psi, f_P, f_tp, f_rp, f_started, f_t0, f_isd, f_sdp, f_rej, t_s, rate, h, allow, bias_sd,
            fR, fN2, ftau, fgate, frelock,
        )
        out_hf[ix] = hf
        out_hf_sd[ix] = hf_sd
        out_h_sd[ix] = h_sd
    _fill_params(out_a, out_b, out_c, out_unobs, seg, stop, pa, pb, pc, unobs)
    fs[F_T], fs[F_G], fs[F_TEMP], fs[F_TP], fs[F_BIAS], fs[F_RATE] = c_t, c_g, c_T, c_Tp, c_bias, c_rate
    fs[F_IRAW], fs[F_IT], fs[F_ITP], fs[F_IBIAS], fs[F_IRATE] = I_raw, I_T, I_Tp, I_bias, I_rate
    fs[F_K] = k_cur
    ist[I_STICKY] = sticky
    ist[I_AFTER_INT] = 1 if after_int else 0
    ist[I_UNOBS] = unobs
    ist[I_LB_HEAD], ist[I_LB_N] = lb_head, lb_n
    ist[I_WIN_HEAD], ist[I_WIN_N] = win_head, win_n
    fst[FZ.PSI], fst[FZ.P], fst[FZ.TPREV], fst[FZ.RPREV], fst[FZ.STARTED] = f_psi, f_P, f_tp, f_rp, f_started
    fst[FZ.T0], fst[FZ.ISD], fst[FZ.SDPREV], fst[FZ.REJ_T] = f_t0, f_isd, f_sdp, f_rej
    return stop


@njit(cache=True, nogil=True)
def _fill_params(out_a, out_b, out_c, out_unobs, lo, hi, pa, pb, pc, unobs):
    """The parameters in force and the unobservable code of rows ``lo:hi`` (constant
    through an interval: written at its end, each column in one pass)."""
    for j in range(lo, hi):  # unsigned indices: plain vector stores (signed ones vectorise as scatters)
        out_a[np.uint64(j)] = pa
    for j in range(lo, hi):
        out_b[np.uint64(j)] = pb
    for j in range(lo, hi):
        out_c[np.uint64(j)] = pc
    for j in range(lo, hi):
        out_unobs[np.uint64(j)] = unobs


@njit(cache=True, nogil=True)
def _near_boundary(t_start, k_cur, interval):
    """A time safely before the start of interval ``k_cur + 1``: below it the interval
    number cannot have changed (the margin covers the rounding of the division)."""
    t_next = t_start + (k_cur + 1.0) * interval
    return t_next - 1e-9 * (abs(t_next) + abs(t_start) + interval)


@njit(cache=True, nogil=True)
def _begin(t_boundary, fs, ist, cfg, win, ak):
    """Open the next interval at a boundary row (``_Aiding.begin``): the start snap, and its
    edge mean when ``adaptive`` averages the compass at the interval edges (``start_edge``)."""
    if ist[I_S1_OK] == 1 and not (t_boundary - fs[F_S1] > cfg[C_MAX_AGE]):
        for j in range(6):
            fs[F_S0 + j] = fs[F_S1 + j]
        ist[I_S0_OK] = 1
        ist[I_STICKY] = NO_STICKY
    else:
        ist[I_S0_OK] = 0
        ist[I_STICKY] = R_NO_COMPASS
    fset, bset = ak[8], ak[9]
    ist[I_E0_OK] = 0
    if ist[I_S0_OK] == 1 and bset[AK.BS_ON] == 1 and bset[AK.BS_EDGE] == 1:
        if ist[I_E1_OK] == 1:  # the end edge _close just computed: the same snap and window
            for j in range(6):
                fs[F_E0 + j] = fs[F_E1 + j]
            fs[F_E0_VAR] = fs[F_E1_VAR]
        else:
            edge, var = AK._edge(win, ist[I_WIN_HEAD], ist[I_WIN_N], fs[F_S0:F_S0 + 6], fset[AK.FS_EDGE_S],
                                 cfg[C_INTERVAL], cfg[C_COMPASS_SD])
            for j in range(6):
                fs[F_E0 + j] = edge[j]
            fs[F_E0_VAR] = var
        ist[I_E0_OK] = 1
    ist[I_E1_OK] = 0


@njit(cache=True, nogil=True)
def _close(t_boundary, fs, ist, cfg, kcfg, x, P, Q, max_var, active, stack, refused, acc, depth, win, Cabs, ak):
    """Decide the interval ending at a boundary row (``_Aiding.close``); returns (update, reason).

    With the ``adaptive`` estimator: the compass measurement between edge means
    (``start_edge``), the stationarity (ZARU) measurement, which replaces it when the
    unit is still, and :func:`gyrodrift._adaptive_kernels.update`/``hold``. ``Cabs`` and
    ``fs[F_PA:F_PC+1]`` are the estimator's ``cov`` and ``params`` before this interval.
    """
    adaptive = kcfg[K_MODE] == MODE_ADAPTIVE
    reason = ist[I_STICKY]
    ist[I_E1_OK] = 0
    end_ok = ist[I_S1_OK] == 1 and not (t_boundary - fs[F_S1] > cfg[C_MAX_AGE])
    s0 = fs[F_S0:F_S0 + 6]
    s1 = fs[F_S1:F_S1 + 6]
    have_meas = False
    m = 0.0
    h0 = 0.0
    h1 = 0.0
    r = 0.0
    resid = 0.0
    if reason == NO_STICKY:
        if (not end_ok) or fs[F_S1] - fs[F_S0] < 0.5 * cfg[C_INTERVAL]:
            reason = R_NO_COMPASS
        else:
            m, h0, h1, r, resid = _measurement(fs, cfg)
            if ist[I_E0_OK] == 1:
                end_edge, end_var = AK._edge(win, ist[I_WIN_HEAD], ist[I_WIN_N], s1, ak[8][AK.FS_EDGE_S],
                                             cfg[C_INTERVAL], cfg[C_COMPASS_SD])
                for j in range(6):  # kept for _begin, whose start snap this is
                    fs[F_E1 + j] = end_edge[j]
                fs[F_E1_VAR] = end_var
                ist[I_E1_OK] = 1
                m, h0, h1, r, resid = AK._compass_measurement(fs[F_E0:F_E0 + 6], end_edge, cfg[C_COMPASS_SD],
                                                              cfg[C_GYRO_NOISE], fs[F_E0_VAR], end_var, True)
            have_meas = True
            if abs(resid) > cfg[C_INTERF]:
                reason = R_INTERFERENCE
    zaru = False
    compass_moved = False
    if adaptive and (reason == NO_STICKY or reason == R_INTERFERENCE) and ist[I_S0_OK] == 1 and end_ok:
        zaru, zm, zh0, zh1, zr, chain, compass_moved = AK._zaru_measurement(
            win, ist[I_WIN_HEAD], ist[I_WIN_N], s0, s1, fs[F_PA], fs[F_PB], fs[F_PC], Cabs,
            ist[I_STILL_CHAIN] == 1, cfg[C_GYRO_NOISE], cfg[C_COMPASS_SD], ak[8], ak[9],
        )
        ist[I_STILL_CHAIN] = 1 if chain else 0
        if zaru:  # still: the drift moved, not the heading; no lock-out
            m, h0, h1, r = zm, zh0, zh1, zr
            reason = NO_STICKY
    if not zaru and reason == R_INTERFERENCE and ist[I_S0_OK] == 1 and end_ok:
        if not have_meas:
            m, h0, h1, r, resid = _measurement(fs, cfg)
            have_meas = True
        if _drift_not_interference(resid / (fs[F_S1] - fs[F_S0]), ist, refused, kcfg[K_RELOCK]):
            reason = NO_STICKY
    if reason != R_INTERFERENCE:
        ist[I_REFUSED_N] = 0
    if reason == NO_STICKY:
        # stack.appendleft
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
        y = np.empty(n)
        H = np.empty((n, 3))
        R = np.zeros((n, n))
        for j in range(n):
            y[j] = stack[j, 0]
            H[j, 0] = stack[j, 1]
            H[j, 1] = stack[j, 2]
            H[j, 2] = stack[j, 3]
            R[j, j] = stack[j, 4]
        if adaptive:
            AK.update_both(ak, y, H, R)
        else:
            kalman_update(x, P, Q, max_var, active, y, H, R, cfg[C_FADING])
        # a still unit whose compass moved: the compass is suspect for the next interval
        ist[I_AFTER_INT] = 1 if compass_moved else 0
        return 1, R_NONE
    if adaptive:
        AK.hold(ak)
    else:
        hold(P, Q, max_var, active)
    ist[I_AFTER_INT] = 1 if reason == R_INTERFERENCE else 0
    return 0, reason


@njit(cache=True, nogil=True)
def _measurement(fs, cfg):
    """Eqs. (4)–(6) between the start and end snaps (``_compass_measurement`` without ``end_var``)."""
    return AK._compass_measurement(fs[F_S0:F_S0 + 6], fs[F_S1:F_S1 + 6], cfg[C_COMPASS_SD], cfg[C_GYRO_NOISE],
                                   0.0, 0.0, False)


@njit(cache=True, nogil=True)
def _drift_not_interference(rate, ist, refused, n):
    """Lock-out recovery (``_Aiding._drift_not_interference``); ``refused`` keeps the last n rates."""
    if n == 0:
        return False
    have = ist[I_REFUSED_N]
    enough = have >= n
    if enough:
        rates = np.empty(n + 1)
        for j in range(n):
            rates[j] = refused[have - n + j] if have <= refused.size else refused[refused.size - n + j]
        rates[n] = rate
    # append, keeping only the last n
    if have < refused.size:
        refused[have] = rate
    else:
        for j in range(refused.size - 1):
            refused[j] = refused[j + 1]
        refused[refused.size - 1] = rate
    ist[I_REFUSED_N] = min(have + 1, refused.size)
    if not enough:
        return False
    total = 0.0
    for j in range(n + 1):
        total += rates[j]
    mean = total / (n + 1)
    ss = 0.0
    for j in range(n + 1):
        ss += abs(rates[j] - mean) ** 2
    std = math.sqrt(ss / (n + 1))
    for j in range(n + 1):
        if np.sign(rates[j]) != np.sign(mean):
            return False
    return std < 0.5 * abs(mean)

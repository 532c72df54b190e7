"""The row loop of the paper's filters: every sample of a log, in chunks of any size, resumable.

:func:`prepare` checks a chunk and derives its inputs (held cells, wrapped compass, T');
:func:`run_chunk` then compensates its rows (Feng, Li, Zhang 2015, Sections 2–3: eq. 5,
the trapezoid heading, the gates, the interval decisions, the fused heading). What a row and an
interval go through: ``docs/engine.md`` ("The paper's filters, row by row"). The state lives
in the arrays of :mod:`gyrodrift.kernels.layout`.
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels import aiding, drift, fusion
from gyrodrift.kernels.layout import (
    C_DIP_TOL, C_FIELD_NORM_TOL, C_FUSION_CONSISTENT, C_FUSION_GATE, C_FUSION_N2, C_FUSION_R, C_FUSION_RELOCK, C_FUSION_TAU,
    C_INTERF, C_INTERVAL, C_MAX_GAP, C_TP_BIN_S, C_TURN_RATE, C_TURN_WIN, F_ANCHOR, F_BIAS, F_COV, F_FIELD_DIP,
    F_FIELD_NORM, F_FUSION, F_FZ_CONS_T, F_FZ_NU0, F_G, F_IBIAS, F_IRATE, F_IRAW, F_IT, F_ITP, F_K, F_LAST_G, F_LAST_T,
    F_LAST_TEMP, F_PA, F_PB, F_PC, F_RATE, F_S0, F_S1, F_T, F_TEMP, F_TP, F_TSTART, FZ_ISD, FZ_P, FZ_PSI, FZ_REJ_T,
    FZ_RPREV, FZ_SDPREV, FZ_STARTED, FZ_T0, FZ_TPREV, I_AFTER_INT, I_ANCHOR_ROW, I_INIT_END, I_INIT_UPDATED, I_LB_HEAD,
    I_LB_N, I_N_ACC, I_PENDING, I_ROWS, I_S0_OK, I_S1_OK, I_STICKY, I_UNOBS, K_FUSE_INTERFERENCE, K_MODE,
    K_TP_SHORT_BINS, K_TP_WINDOW_BINS, MODE_EXTERNAL, NO_STICKY, O_A, O_B, O_BIAS, O_BIAS_SD, O_C, O_FUSED, O_FUSED_SD,
    O_HEADING, O_HEADING_SD, O_RATE, OC_REASON, OC_UNOBS, OC_UPDATE, PENDING_NONE, R_FIELD, R_GAP, R_INIT,
    R_INTERFERENCE, R_NONE,
)
from gyrodrift.kernels.numeric import near_boundary, wrap180, wrap360

__all__ = ["prepare", "run_chunk"]


#: Longest time step a log may take, s (about 32 years): a longer one is no sample spacing but a
#: broken time column, and its variances would overflow.
MAX_STEP_S = 1e9


@jit
def prepare(t, g, T, heading, fs, ist, cfg, icfg, bins, g_held, T_held, h_wrapped, Tp, gap):
    """Check a chunk and derive its inputs; returns ``(bad, fix)``.

    ``bad`` is -1, or the first row whose time is not finite or does not increase, or
    increases by more than :data:`MAX_STEP_S` (then nothing else is done). Writes ``gap`` (time step above ``max_gap_s``, or a held
    cell) and ``Tp`` (T', degC/s). ``fix`` has bit 1 when a gyro cell is not finite, 2 for
    temperature: those hold the previous value, written to ``g_held``/``T_held``; bit 4
    when a compass heading is infinite or outside [0, 360): ``h_wrapped`` has them
    wrapped (NaN where not finite). Without a bit, the input array is used as it is.
    """
    first = ist[I_ROWS] == 0
    prev = fs[F_LAST_T]
    fix = 0
    for i in range(t.size):
        ti = t[i]
        if not math.isfinite(ti):
            return i, fix
        step = 0.0
        if i > 0 or not first:
            step = ti - prev
            if not 0.0 < step <= MAX_STEP_S:
                return i, fix
        prev = ti
        gap[i] = step > cfg[C_MAX_GAP]
        if not math.isfinite(g[i]):
            fix |= 1
        if not math.isfinite(T[i]):
            fix |= 2
        h = heading[i]
        if math.isinf(h) or not (math.isnan(h) or 0.0 <= h < 360.0):
            fix |= 4
    if fix & 1:
        _hold(g, fs[F_LAST_G], gap, g_held)
    if fix & 2:
        _hold(T, fs[F_LAST_TEMP], gap, T_held)
    if fix & 4:
        for i in range(heading.size):
            h = heading[i]
            h_wrapped[i] = wrap360(h) if math.isfinite(h) else math.nan
    temps = T_held if fix & 2 else T
    drift.temp_rate_chunk(t, temps, icfg[K_TP_WINDOW_BINS], icfg[K_TP_SHORT_BINS], cfg[C_TP_BIN_S], fs, ist, bins, Tp)
    n = t.size
    if n:
        fs[F_LAST_T] = t[n - 1]
        fs[F_LAST_G] = g_held[n - 1] if fix & 1 else g[n - 1]
        fs[F_LAST_TEMP] = temps[n - 1]
        ist[I_ROWS] += n
    return -1, fix


@jit
def _hold(x, last, gap, out):
    """``out`` = ``x`` with every non-finite cell holding the previous finite value (``last``
    before the chunk); such rows are flagged in ``gap``."""
    for i in range(x.size):
        v = x[i]
        if math.isfinite(v):
            last = v
        else:
            gap[i] = True
        out[i] = last


@jit
def run_chunk(t, g, T, Tp, heading, gap, norm, dip, i0,
              fs, ist, cfg, icfg, lb, stack, refused, acc, ef, ei, out, codes, cap):
    """Compensate rows ``i0..`` of a prepared chunk into ``out``/``codes`` (columns ``cap``
    apart); returns the next row to do (``t.size`` when done).

    ``norm``, ``dip``: field strength and dip of the raw magnetometer per row, or empty
    arrays without one. Returns early when the turning ring ``lb`` is full, the accepted
    measurements ``acc`` are full, or (MODE_EXTERNAL)
    after an interval end: ``ist[I_PENDING]`` then says whether the caller must update or
    hold its estimator and put the new parameters in force (``fs[F_PA..]``, ``F_COV``).
    """
    interval = cfg[C_INTERVAL]
    turn_win = cfg[C_TURN_WIN]
    turn_rate = cfg[C_TURN_RATE]
    interf = cfg[C_INTERF]
    norm_tol = cfg[C_FIELD_NORM_TOL]
    dip_tol = cfg[C_DIP_TOL]
    ref_norm = fs[F_FIELD_NORM]
    ref_dip = fs[F_FIELD_DIP]
    has_field = norm.size == t.size
    t_start = fs[F_TSTART]
    anchor = fs[F_ANCHOR]
    external = icfg[K_MODE] == MODE_EXTERNAL
    max_gap = cfg[C_MAX_GAP]
    init_end = ist[I_INIT_END]
    lb_cap = lb.shape[0]
    acc_cap = acc.shape[0]
    fuse_interference = icfg[K_FUSE_INTERFERENCE] == 1
    # the previous row and the integrals
    c_t, c_g, c_T, c_Tp, c_bias, c_rate = fs[F_T], fs[F_G], fs[F_TEMP], fs[F_TP], fs[F_BIAS], fs[F_RATE]
    I_raw, I_T, I_Tp, I_bias, I_rate = fs[F_IRAW], fs[F_IT], fs[F_ITP], fs[F_IBIAS], fs[F_IRATE]
    if init_end >= 0 and i0 == 0:  # the log's first row: no step before it
        c_t, c_g, c_T, c_Tp = t[0], g[0], T[0], Tp[0]
    k_cur = fs[F_K]
    pa, pb, pc = fs[F_PA], fs[F_PB], fs[F_PC]
    s0_heading, s0_Iraw, s0_Ibias = fs[F_S0 + 1], fs[F_S0 + 2], fs[F_S0 + 5]
    s0_ok = ist[I_S0_OK] == 1
    sticky = ist[I_STICKY]
    after_int = ist[I_AFTER_INT] == 1
    unobs = ist[I_UNOBS]
    lb_head, lb_n = ist[I_LB_HEAD], ist[I_LB_N]
    C00, C01, C02 = fs[F_COV], fs[F_COV + 1], fs[F_COV + 2]
    C10, C11, C12 = fs[F_COV + 3], fs[F_COV + 4], fs[F_COV + 5]
    C20, C21, C22 = fs[F_COV + 6], fs[F_COV + 7], fs[F_COV + 8]
    t_near = near_boundary(t_start, k_cur, interval)
    zf = F_FUSION
    f_psi, f_P, f_tp, f_rp, f_started = fs[zf + FZ_PSI], fs[zf + FZ_P], fs[zf + FZ_TPREV], fs[zf + FZ_RPREV], fs[zf + FZ_STARTED]
    f_t0, f_isd, f_sdp, f_rej = fs[zf + FZ_T0], fs[zf + FZ_ISD], fs[zf + FZ_SDPREV], fs[zf + FZ_REJ_T]
    f_nu0, f_cons = fs[F_FZ_NU0], fs[F_FZ_CONS_T]
    fR, fN2, ftau = cfg[C_FUSION_R], cfg[C_FUSION_N2], cfg[C_FUSION_TAU]
    fgate, frelock, fconsistent = cfg[C_FUSION_GATE], cfg[C_FUSION_RELOCK], cfg[C_FUSION_CONSISTENT]
    # column offsets, unsigned like the row index (a mixed sum would be signed: a negative-index check per store)
    o_bias, o_rate, o_heading = np.uint64(O_BIAS * cap), np.uint64(O_RATE * cap), np.uint64(O_HEADING * cap)
    o_sd, o_hf, o_hf_sd = np.uint64(O_BIAS_SD * cap), np.uint64(O_FUSED * cap), np.uint64(O_FUSED_SD * cap)
    o_h_sd, oc_update, oc_reason = np.uint64(O_HEADING_SD * cap), np.uint64(OC_UPDATE * cap), np.uint64(OC_REASON * cap)
    seg = i0  # first row whose a, b, c and unobservable code are still to write (_fill_params)
    # bias and bias_sd of the last (T, T'), reused while they repeat (a quantised temperature)
    m_T = math.nan
    m_Tp = math.nan
    m_bias = 0.0
    m_sd = 0.0
    stop = t.size
    for i in range(i0, t.size):
        if lb_n >= lb_cap or ist[I_N_ACC] >= acc_cap:
            stop = i
            break
        ix = np.uint64(i)  # an unsigned index: no negative-index fix-up on every access
        t_s = t[ix]
        gi = g[ix]
        Ti = T[ix]
        Tpi = Tp[ix]
        h = heading[ix]
        in_init = i <= init_end
        if Ti != m_T or Tpi != m_Tp:
            m_T = Ti
            m_Tp = Tpi
            m_bias = drift.bias(pa, pb, pc, Ti, Tpi)
            m_sd = drift.bias_sd(C00, C01, C02, C10, C11, C12, C20, C21, C22, Ti, Tpi)
        bias = m_bias
        bias_sd = m_sd
        rate = gi - bias
        dt = t_s - c_t
        if dt > max_gap:  # across a time gap the unit is taken as still: the gyro read its drift
            I_raw = I_raw + 0.5 * (bias + c_bias) * dt
        else:
            I_raw = I_raw + 0.5 * (gi + c_g) * dt
            I_rate = I_rate + 0.5 * (rate + c_rate) * dt
        I_T = I_T + 0.5 * (Ti + c_T) * dt
        I_Tp = I_Tp + 0.5 * (Tpi + c_Tp) * dt
        I_bias = I_bias + 0.5 * (bias + c_bias) * dt
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
        out[o_bias + ix] = bias
        out[o_rate + ix] = rate
        out[o_sd + ix] = bias_sd
        update = 0
        if in_init:
            reason = R_INIT
            out[o_heading + ix] = I_rate  # anchored when the window is done
            if i == init_end:
                reason = R_NONE
                update = ist[I_INIT_UPDATED]
        else:
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
                field = has_field and aiding.field_anomaly(norm[ix], dip[ix], ref_norm, ref_dip, norm_tol, dip_tol)
                sticky = aiding.row_condition(gap[ix], field, resid, mean_rate, turn_rate, interf)
            elif gap[ix]:  # a gap outranks the refusal already seen (the priority of row_condition)
                sticky = R_GAP
            if sticky != NO_STICKY:
                reason = sticky
            elif after_int:
                reason = R_INTERFERENCE
            else:
                reason = R_NONE
            out[o_heading + ix] = wrap360(anchor + I_rate)
        # the interval number floor((t - t_start)/interval), computed only near a boundary
        k = k_cur
        if not in_init and t_s >= t_near:
            k = math.floor((t_s - t_start) / interval)
        boundary = k > k_cur or i == init_end
        if boundary:
            _fill_params(out, codes, cap, seg, i + 1, pa, pb, pc, unobs)
            seg = i + 1
            if i == init_end:
                anchor = _anchor(heading, out, O_HEADING * cap, ist[I_ANCHOR_ROW], i)
                k = math.floor((t_s - t_start) / interval)
                ist[I_INIT_END] = -1
                init_end = -1
            else:
                ist[I_STICKY] = sticky
                ist[I_AFTER_INT] = 1 if after_int else 0
                closed, reason = aiding.close(t_s, fs, ist, cfg, icfg, stack, refused, acc, ef, ei, float(k - k_cur))
                update = closed
                if not external:
                    aiding.in_force(fs, ist, cfg, ef, ei)
            k_cur = k
            aiding.begin(t_s, fs, ist, cfg)
            pa, pb, pc = fs[F_PA], fs[F_PB], fs[F_PC]
            C00, C01, C02 = fs[F_COV], fs[F_COV + 1], fs[F_COV + 2]
            C10, C11, C12 = fs[F_COV + 3], fs[F_COV + 4], fs[F_COV + 5]
            C20, C21, C22 = fs[F_COV + 6], fs[F_COV + 7], fs[F_COV + 8]
            unobs = ist[I_UNOBS]
            s0_heading, s0_Iraw, s0_Ibias = fs[F_S0 + 1], fs[F_S0 + 2], fs[F_S0 + 5]
            s0_ok = ist[I_S0_OK] == 1
            sticky = ist[I_STICKY]
            after_int = ist[I_AFTER_INT] == 1
            t_near = near_boundary(t_start, k_cur, interval)
            m_T = math.nan  # new parameters and covariance: recompute
        codes[oc_update + ix] = update
        codes[oc_reason + ix] = reason
        allow = reason != R_FIELD and not (fuse_interference and reason == R_INTERFERENCE)
        f_psi, f_P, f_tp, f_rp, f_started, f_t0, f_isd, f_sdp, f_rej, f_nu0, f_cons, hf, hf_sd, h_sd = fusion.step(
            f_psi, f_P, f_tp, f_rp, f_started, f_t0, f_isd, f_sdp, f_rej, f_nu0, f_cons, t_s, rate, h, allow,
            bias_sd, fR, fN2, ftau, fgate, frelock, fconsistent, dt > max_gap,
        )
        out[o_hf + ix] = hf
        out[o_hf_sd + ix] = hf_sd
        out[o_h_sd + ix] = h_sd
        if boundary and external and ist[I_PENDING] != PENDING_NONE:
            stop = i + 1
            break
    _fill_params(out, codes, cap, seg, stop, pa, pb, pc, unobs)
    fs[F_T], fs[F_G], fs[F_TEMP], fs[F_TP], fs[F_BIAS], fs[F_RATE] = c_t, c_g, c_T, c_Tp, c_bias, c_rate
    fs[F_IRAW], fs[F_IT], fs[F_ITP], fs[F_IBIAS], fs[F_IRATE] = I_raw, I_T, I_Tp, I_bias, I_rate
    fs[F_K] = k_cur
    fs[F_ANCHOR] = anchor
    ist[I_STICKY] = sticky
    ist[I_AFTER_INT] = 1 if after_int else 0
    ist[I_UNOBS] = unobs
    ist[I_LB_HEAD], ist[I_LB_N] = lb_head, lb_n
    fs[zf + FZ_PSI], fs[zf + FZ_P], fs[zf + FZ_TPREV], fs[zf + FZ_RPREV], fs[zf + FZ_STARTED] = f_psi, f_P, f_tp, f_rp, f_started
    fs[zf + FZ_T0], fs[zf + FZ_ISD], fs[zf + FZ_SDPREV], fs[zf + FZ_REJ_T] = f_t0, f_isd, f_sdp, f_rej
    fs[F_FZ_NU0], fs[F_FZ_CONS_T] = f_nu0, f_cons
    return stop


@jit
def _anchor(heading, out, o_heading, anchor_row, last):
    """The heading anchor at the end of the init window (rows ``0..last``): the first
    compass sample minus the integrated rate there (without a compass sample, ``anchor_row``
    -1: 0, the heading is relative to the first row); the init rows' heading (written as the
    integrated rate) becomes ``anchor + ∫rate``, wrapped. Returns the anchor."""
    anchor = 0.0 if anchor_row < 0 else heading[anchor_row] - out[o_heading + anchor_row]
    for j in range(last + 1):
        out[o_heading + j] = wrap360(anchor + out[o_heading + j])
    return anchor


@jit
def _fill_params(out, codes, cap, lo, hi, pa, pb, pc, unobs):
    """The parameters in force and the unobservable code of rows ``lo:hi`` (constant
    through an interval: written at its end, each column in one pass)."""
    a0, b0, c0, u0 = O_A * cap, O_B * cap, O_C * cap, OC_UNOBS * cap
    for j in range(lo, hi):  # unsigned indices: plain vector stores (signed ones vectorise as scatters)
        out[np.uint64(a0 + j)] = pa
    for j in range(lo, hi):
        out[np.uint64(b0 + j)] = pb
    for j in range(lo, hi):
        out[np.uint64(c0 + j)] = pc
    for j in range(lo, hi):
        codes[np.uint64(u0 + j)] = unobs

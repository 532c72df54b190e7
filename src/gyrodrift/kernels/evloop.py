"""The row loop of the default estimator's model (:mod:`gyrodrift.kernels.evidence`).

Per row: the drift in force (eq. 5, the mixture's a, b, c), the compensated rate, the
trapezoid integrals and the epoch's sums; the model's step at each epoch end and at each time
gap; the outputs and codes of :mod:`gyrodrift.kernels.layout`. What each output, code and
gap rule is: ``docs/model.md`` ("The row loop"). State: ``mf`` (the model) and ``rf`` (the
rows, ``RF_*``).
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels import evidence as ev
from gyrodrift.kernels.evidence import (
    MF_DIP_REF, MF_E_DD2, MF_E_DG2, MF_E_DIP, MF_E_DREF, MF_E_G, MF_E_GAP, MF_E_H2, MF_E_H4, MF_E_NC, MF_E_NDD,
    MF_E_NDG, MF_E_NF, MF_E_NORM, MF_E_SD, MF_E_SG, MF_E_ST, MF_E_STC, MF_E_STP, MF_E_T0, MF_E_T_START, MF_E_TC,
    MF_E_TP, MF_FIELD_DOM, MF_H_L, MF_H_N, MF_H_S, MF_LAST_D, MF_LAST_D_T, MF_NORM_REF, MF_PC, MF_PDIST,
    MF_PSTILL, MF_SIG_S2, MF_SIG_W2, MF_TREF, MF_UPDATED, MF_XC, MC_COMPASS_SD, MC_EPOCH, MC_GAP_FACTOR,
    MC_GYRO_NOISE, NX, X_A, X_B, X_C, X_DELTA,
)
from gyrodrift.kernels.layout import (
    O_A, O_B, O_BIAS, O_BIAS_SD, O_C, O_FUSED, O_FUSED_SD, O_HEADING, O_HEADING_SD, O_RATE, OC_REASON, OC_UNOBS,
    OC_UPDATE, R_FIELD, R_GAP, R_INIT, R_INTERFERENCE, R_NO_COMPASS, R_NONE, R_TURNING, UNOBS_A, UNOBS_B,
    UNOBSERVABLE_SD_FRACTION,
)
from gyrodrift.kernels.numeric import wrap180, wrap360

__all__ = ["run", "settle", "RF_N", "RF_CLOCKED", "RC_N", "N_HIST"]

#: The log's own spacing is its mean time step over about this long (s): the forgotten sum of
#: its steps over their forgotten count. A mean per sample, not per second, so a logger that
#: timestamps its samples as they arrive in clusters (a serial link's buffer, a FIFO) keeps the
#: spacing of its sample rate, and the pauses between the clusters are no gaps.
SPACING_MEMORY_S = 60.0
#: A log whose typical step (the geometric mean of its steps) is below this share of its mean
#: step is stamped as its rows arrive, in clusters: its rows are timed by a sample clock
#: (:func:`run`; ``docs/model.md``, "Time gaps").
CLUSTER_RATIO = 0.5
#: Steps the log's spacing is first taken from (each counted at most ``gap_factor`` times the mean
#: of the others but the longest, so that a pause among them weighs as a gap would) before a step can be a gap by it, or
#: the rows be judged clustered: more than a cluster's rows, so that a pause between the first
#: clusters is seen against the log's rate and not against its clusters' steps.
SPACING_MIN_STEPS = ev.N_FIRST_STEPS

# ------------------------------------------------------------------ row state
RF_T, RF_G, RF_TEMP, RF_TP, RF_BIAS, RF_RATE = 0, 1, 2, 3, 4, 5  # the previous row
RF_IRAW, RF_IRATE, RF_IBIAS = 6, 7, 8  # integrals to it (deg)
RF_ANCHOR, RF_T_ANCHOR, RF_ISD = 9, 10, 11  # gyro-alone heading: anchor, its time, ∫bias_sd since
RF_IRAW_E, RF_IBIAS_E = 12, 13  # the integrals at the last epoch end
RF_MEAN_RATE = 14  # the averaged compensated rate (turning)
RF_T_COMPASS = 15  # time of the last compass sample
RF_STARTED, RF_SEEN = 16, 17  # a row was taken; a compass sample came (1.0)
RF_UNOBS = 18  # unobservable code in force
RF_FUSED_ON = 19  # an epoch with a compass sample has closed: the fused heading is known (1.0)
#: The first epoch: its last row (-1 until it closes) and the drift learned by its end: a, b,
#: c', a2 and their covariance (upper triangle: aa ab ac aa2 bb bc ba2 cc ca2 a2a2).
RF_FIRST_ROW = 20
RF_FIRST_DRIFT = 21
RF_HIST_N = RF_FIRST_DRIFT + 14  # epochs recorded in the history
RF_INIT_RAW = RF_HIST_N + 1  # 1.0 while the init window is held: the heading column holds ∫rate (settle anchors it)
#: The gyro's noise as the turning label sees it, moving or not: half the squared successive
#: differences and their count, forgotten over RATE_SWITCH_S (a motion's character changes)
RF_TURN_S, RF_TURN_W = RF_INIT_RAW + 1, RF_INIT_RAW + 2
RF_T_STAMP = RF_INIT_RAW + 3  # the previous row's time as the log stamped it (RF_T: as the model timed it)
RF_CLOCKED = RF_INIT_RAW + 4  # rows timed by the sample clock (stamped in clusters)
RF_N = RF_INIT_RAW + 5

# ------------------------------------------------------------------ epoch history
#: One row per epoch, for the smoother: end time (s), length (s), temperature change (degC), the
#: drift states [a, b, c', r, a2] (N_DRIFT), their covariance (upper triangle, row by row), P(jump).
N_DRIFT = 5
H_T, H_DT, H_DTEMP, H_X = 0, 1, 2, 3
H_P = H_X + N_DRIFT
H_JUMP = H_P + N_DRIFT * (N_DRIFT + 1) // 2
N_HIST = H_JUMP + 1

# ------------------------------------------------------------------ row settings
RC_TURN_RATE, RC_TURN_WIN, RC_MAX_AGE, RC_PRIOR_A, RC_PRIOR_B = 0, 1, 2, 3, 4
RC_N = 5
#: The turning threshold in standard deviations of the averaged rate's noise: the averaging is
#: as short as the gyro's learned noise allows while noise alone crosses the threshold at a row
#: with a chance of about 6e-7 (5 sd, either sign), and never longer than half the turn window.
TURN_NOISE_SDS = 5.0


@jit(inline=True)
def _open(mf, t, temp):
    """A new epoch from ``t``."""
    mf[MF_E_T0] = t
    mf[MF_E_T_START] = temp
    for k in (MF_E_G, MF_E_TC, MF_E_TP, MF_E_H2, MF_E_H4, MF_E_NC, MF_E_SD, MF_E_STC, MF_E_STP, MF_E_ST, MF_E_SG,
              MF_E_DG2, MF_E_NDG, MF_E_NORM, MF_E_DIP, MF_E_NF, MF_E_DD2, MF_E_NDD, MF_E_GAP, ev.MF_E_S1, ev.MF_E_S2,
              ev.MF_E_NG, ev.MF_E_TC2, ev.MF_E_STC2, ev.MF_E_H3, ev.MF_E_SB, ev.MF_E_SB1, ev.MF_E_NC1, ev.MF_E_TD,
              ev.MF_E_TV, ev.MF_E_NT):
        mf[k] = 0.0


@jit
def _close(mf, mc, rf, rc, t, temp, I_raw, I_bias, hist):
    """The model's step for the epoch ending at ``t``, then the field reference and the
    unobservable code; the integrals at the epoch end are kept for the fused heading, and the
    drift states in the history (when it has columns)."""
    dt = t - mf[MF_E_T0]
    dtemp = abs(temp - mf[MF_E_T_START]) if mc[ev.MC_CLOCK] == 1.0 else abs(mf[ev.MF_E_TP])
    if mf[MF_E_NF] > 0.0 and not math.isfinite(mf[MF_NORM_REF]):
        mf[MF_NORM_REF] = mf[MF_E_NORM] / mf[MF_E_NF]
        mf[MF_DIP_REF] = mf[MF_E_DIP] / mf[MF_E_NF]
    ev.epoch(mf, mc, t, temp)
    if mf[MF_E_NDG] >= 1.0 and dt > 0.0:
        keep = math.exp(-dt / ev.RATE_SWITCH_S)
        rf[RF_TURN_S] = keep * rf[RF_TURN_S] + 0.5 * mf[MF_E_DG2]
        rf[RF_TURN_W] = keep * rf[RF_TURN_W] + mf[MF_E_NDG]
    if mf[MF_E_NF] > 0.0 and mf[MF_PDIST] < 0.1:  # the reference follows a clean field slowly
        mf[MF_NORM_REF] += 0.01 * (mf[MF_E_NORM] / mf[MF_E_NF] - mf[MF_NORM_REF])
        mf[MF_DIP_REF] += 0.01 * (mf[MF_E_DIP] / mf[MF_E_NF] - mf[MF_DIP_REF])
    rf[RF_IRAW_E] = I_raw
    rf[RF_IBIAS_E] = I_bias
    if mf[MF_E_NC] > 0.0:
        rf[RF_FUSED_ON] = 1.0
    rf[RF_UNOBS] = unobservable(mf, rc)
    if hist.shape[1] == N_HIST and dt > 0.0:
        Pc = mf[MF_PC:MF_PC + NX * NX]
        k = int(rf[RF_HIST_N])
        hist[k, H_T] = t
        hist[k, H_DT] = dt
        hist[k, H_DTEMP] = dtemp
        hist[k, H_JUMP] = mf[ev.MF_JUMP]
        xs = (X_A, X_B, X_C, ev.X_R, ev.X_A2)
        m = 0
        for r in range(N_DRIFT):
            hist[k, H_X + r] = mf[MF_XC + xs[r]]
            for c in range(r, N_DRIFT):
                hist[k, H_P + m] = Pc[xs[r] * NX + xs[c]]
                m += 1
        rf[RF_HIST_N] = k + 1


@jit
def run(t, g, T, Tp, heading, held, norm, dip, tilt_diff, i0, mf, mc, rf, rc, out, codes, cap, hist):
    """Compensate rows ``i0..`` of a prepared chunk into ``out``/``codes`` (columns ``cap``
    apart); returns the next row to do: ``t.size``, or earlier when the epoch history
    ``hist`` (N_HIST columns; none: not recorded) has room for fewer than two more epochs
    (the caller grows it and calls again from that row).

    ``held``: rows whose gyro or temperature cell was empty (held from the row before:
    a gap). ``norm``, ``dip``: field strength and dip of a raw magnetometer per row, or
    empty arrays; ``tilt_diff``: the difference of each compass sample's headings tilted by the
    accelerometer and by the gyro-aided gravity (deg; NaN: none known), or an empty array.
    """
    has_field = norm.size == t.size
    has_tilt = tilt_diff.size == t.size
    tref = mf[MF_TREF]
    c_t, c_g, c_T, c_Tp, c_bias, c_rate = rf[RF_T], rf[RF_G], rf[RF_TEMP], rf[RF_TP], rf[RF_BIAS], rf[RF_RATE]
    I_raw, I_rate, I_bias = rf[RF_IRAW], rf[RF_IRATE], rf[RF_IBIAS]
    epoch_s = mc[MC_EPOCH]
    half_epoch = 0.5 * epoch_s
    gap_factor = mc[MC_GAP_FACTOR]
    log_gap, log_cluster = math.log(gap_factor), math.log(CLUSTER_RATIO)
    tau_turn = 0.5 * rc[RC_TURN_WIN]
    w_noise = turn_weight(mf, rf, rc[RC_TURN_RATE])
    xc = mf[MF_XC:MF_XC + NX]
    Pc = mf[MF_PC:MF_PC + NX * NX].reshape((NX, NX))
    o_bias, o_rate, o_heading = O_BIAS * cap, O_RATE * cap, O_HEADING * cap
    stop = t.size
    recording = hist.shape[1] == N_HIST
    # the step's weight in the averaged rate and in the spacing, kept while the step repeats (to the bit)
    h_known = stamp_known = math.nan
    weight_h = forget_h = log_step = 0.0
    for i in range(i0, t.size):
        if recording and rf[RF_HIST_N] + 2 > hist.shape[0]:
            stop = i
            break
        ti, gi, Ti, Tpi, hi = t[i], g[i], T[i], Tp[i], heading[i]
        first = rf[RF_STARTED] == 0.0
        if first:
            c_t, c_g, c_T, c_Tp = ti, gi, Ti, Tpi
            rf[RF_STARTED] = 1.0
            rf[RF_T_STAMP] = ti
            _open(mf, ti, Ti)
        a, b, c, a2 = xc[X_A], xc[X_B], xc[X_C], xc[ev.X_A2]
        bias = a * (Ti - tref) + b * Tpi + c + a2 * (Ti - tref) ** 2
        rate = (gi - bias) * (1.0 - xc[ev.X_S])  # less the scale factor's share of the turn
        gap = False
        reason_gap = False
        if not first:
            gap = held[i]
            stamp = ti - rf[RF_T_STAMP]  # the step between the log's own stamps
            rf[RF_T_STAMP] = ti
            if stamp != stamp_known:
                stamp_known = stamp
                forget_h = math.exp(-stamp / SPACING_MEMORY_S)
                log_step = math.log(stamp)
            seen = mf[ev.MF_H_SEEN]
            if seen < SPACING_MIN_STEPS:  # the first steps: kept; no gap judged by them yet
                if seen == 0.0:  # the gyro noise per sample, from the first step
                    ev.seed_noise(mf, mc, mc[MC_GYRO_NOISE] ** 2 / stamp)
                mf[ev.MF_H_FIRST + int(seen)] = stamp
                mf[ev.MF_H_SEEN] = seen + 1.0
                _first_spacing(mf, int(seen) + 1, gap_factor)
            else:  # a gap counts as gap_factor mean steps in the spacing
                mean_step = mf[MF_H_S] / mf[MF_H_N]
                log_mean = math.log(mean_step)
                longest = gap_factor * mean_step
                gap = gap or stamp > longest
                if not gap and mf[MF_H_L] / mf[MF_H_N] < log_cluster + log_mean:
                    # stamped on arrival, in clusters: the sample clock runs at the mean step, never
                    # later than the row's stamp nor a gap's length earlier
                    ti = max(min(ti, c_t + mean_step), ti - longest)
                    rf[RF_CLOCKED] += 1.0
                mf[MF_H_S] = forget_h * mf[MF_H_S] + min(stamp, longest)
                mf[MF_H_L] = forget_h * mf[MF_H_L] + min(log_step, log_gap + log_mean)
                mf[MF_H_N] = forget_h * mf[MF_H_N] + 1.0
        h = ti - c_t
        if not first:
            if h != h_known:
                h_known = h
                weight_h = 1.0 - math.exp(-h / tau_turn)
            reason_gap = gap
            if gap:
                if mf[MF_E_NDG] > 0.0 or mf[MF_E_NC] > 0.0:  # close the epoch before the gap
                    _close(mf, mc, rf, rc, c_t, c_T, I_raw, I_bias, hist)
                _open(mf, c_t, c_T)
                mf[MF_E_GAP] = 1.0
                # across the gap the integrals follow the likelier platform: still, the gyro read
                # its drift and the heading holds; moving, the trapezoid of the two samples
                if mf[MF_PSTILL] >= 0.5:
                    inc = 0.5 * (bias + c_bias) * h
                else:
                    inc = 0.5 * (gi + c_g) * h
                    I_rate += 0.5 * (rate + c_rate) * h
                    mf[MF_E_H2] += h * h  # the trapezoid's noise, for the moving modes
                I_raw += inc
                mf[MF_E_G] += inc
            else:
                I_raw += 0.5 * (gi + c_g) * h
                I_rate += 0.5 * (rate + c_rate) * h
                mf[MF_E_G] += 0.5 * (gi + c_g) * h
                mf[MF_E_H2] += h * h
                mf[ev.MF_E_H3] += h * h * h
                mf[MF_E_H4] += h * h * h * h
                dg = gi - c_g
                mf[MF_E_DG2] += dg * dg
                mf[MF_E_NDG] += 1.0
                if mf[ev.MF_E_NG] == 0.0:  # the epoch's gyro samples, from the one before its first step
                    mf[ev.MF_E_G0] = c_g
                    mf[ev.MF_E_NG] = 1.0
                dv = gi - mf[ev.MF_E_G0]
                mf[ev.MF_E_S1] += dv
                mf[ev.MF_E_S2] += dv * dv
                mf[ev.MF_E_NG] += 1.0
            I_bias += 0.5 * (bias + c_bias) * h
            mf[MF_E_TC] += 0.5 * (Ti + c_T - 2.0 * tref) * h
            mf[ev.MF_E_TC2] += 0.5 * ((Ti - tref) ** 2 + (c_T - tref) ** 2) * h
            mf[MF_E_TP] += 0.5 * (Tpi + c_Tp) * h
            rf[RF_MEAN_RATE] += max(weight_h, w_noise) * (rate - rf[RF_MEAN_RATE])
        c_t, c_g, c_T, c_Tp, c_bias, c_rate = ti, gi, Ti, Tpi, bias, rate
        if not math.isnan(hi):  # a compass sample: D = compass - ∫gyro
            D = hi - I_raw
            if mf[MF_E_NC] == 0.0:
                mf[MF_E_DREF] = D
            dD_ref = wrap180(D - mf[MF_E_DREF])
            mf[MF_E_SD] += dD_ref
            t_in = ti - mf[MF_E_T0]
            db = dD_ref + bias * t_in  # D less the drift's part, for the halves
            mf[ev.MF_E_SB] += db
            if t_in < half_epoch:
                mf[ev.MF_E_SB1] += db
                mf[ev.MF_E_NC1] += 1.0
            mf[MF_E_STC] += mf[MF_E_TC]
            mf[ev.MF_E_STC2] += mf[ev.MF_E_TC2]
            mf[MF_E_STP] += mf[MF_E_TP]
            mf[MF_E_ST] += ti - mf[MF_E_T0]
            mf[MF_E_SG] += mf[MF_E_G]
            mf[MF_E_NC] += 1.0
            if rf[RF_SEEN] == 1.0 and ti - mf[MF_LAST_D_T] <= 2.0:
                dD = wrap180(D - mf[MF_LAST_D]) + bias * (ti - mf[MF_LAST_D_T])
                # clipped at 4 sd of a difference: a disturbance's step is no white noise
                mf[MF_E_DD2] += min(dD * dD, 32.0 * mf[MF_SIG_W2])
                mf[MF_E_NDD] += 1.0
            mf[MF_LAST_D] = D
            mf[MF_LAST_D_T] = ti
            if has_tilt and math.isfinite(tilt_diff[i]):  # the compass's tilt error (docs/model.md)
                mf[ev.MF_E_TD] += tilt_diff[i]
                mf[ev.MF_E_TV] += tilt_diff[i] * tilt_diff[i]
                mf[ev.MF_E_NT] += 1.0
            if has_field and math.isfinite(norm[i]) and math.isfinite(dip[i]):
                mf[MF_E_NORM] += norm[i]
                mf[MF_E_DIP] += dip[i]
                mf[MF_E_NF] += 1.0
            if rf[RF_SEEN] == 0.0:  # the gyro-alone heading starts here, and the model's
                ev.seed_heading(mf, D)  # heading prior is centred on it
                rf[RF_SEEN] = 1.0
                rf[RF_ANCHOR] = hi - I_rate
                rf[RF_T_ANCHOR] = ti
                rf[RF_ISD] = 0.0
            rf[RF_T_COMPASS] = ti
        updated = 0
        if gap or (not first and ti - mf[MF_E_T0] >= epoch_s):
            _close(mf, mc, rf, rc, ti, Ti, I_raw, I_bias, hist)
            w_noise = turn_weight(mf, rf, rc[RC_TURN_RATE])  # the noise learned by the epoch
            if rf[RF_FIRST_ROW] < 0.0:
                rf[RF_FIRST_ROW] = i
                xs = (X_A, X_B, X_C, ev.X_A2)
                m = 4
                for r in range(4):
                    rf[RF_FIRST_DRIFT + r] = xc[xs[r]]
                    for c_ in range(r, 4):
                        rf[RF_FIRST_DRIFT + m] = Pc[xs[r], xs[c_]]
                        m += 1
            updated = 1 if mf[MF_UPDATED] == 1.0 and not gap else 0
            _open(mf, ti, Ti)
        bsd = math.sqrt(ev.bias_var(Pc, Ti - tref, Tpi, (Ti - tref) ** 2))
        if rf[RF_SEEN] == 1.0:
            rf[RF_ISD] += bsd * h
        ix = np.uint64(i)
        out[o_bias + ix] = bias
        out[o_rate + ix] = rate
        out[O_BIAS_SD * cap + ix] = bsd
        a_tangent = xc[X_A] + 2.0 * xc[ev.X_A2] * (Ti - tref)  # eq. (2)'s a: the slope at T
        out[O_A * cap + ix] = a_tangent
        out[O_B * cap + ix] = xc[X_B]
        out[O_C * cap + ix] = bias - a_tangent * Ti - xc[X_B] * Tpi
        out[o_heading + ix] = I_rate if rf[RF_INIT_RAW] == 1.0 else wrap360(rf[RF_ANCHOR] + I_rate)
        sig_w = mc[MC_COMPASS_SD]
        if rf[RF_FUSED_ON] == 1.0:
            turn = I_raw - rf[RF_IRAW_E] - (I_bias - rf[RF_IBIAS_E])  # since the epoch end, less the drift
            out[O_FUSED * cap + ix] = wrap360(rf[RF_IRAW_E] + xc[X_DELTA] + (1.0 - xc[ev.X_S]) * turn)
            out[O_FUSED_SD * cap + ix] = math.sqrt(max(Pc[X_DELTA, X_DELTA], 0.0))
        else:
            out[O_FUSED * cap + ix] = math.nan
            out[O_FUSED_SD * cap + ix] = math.nan
        if rf[RF_SEEN] == 1.0:
            since = ti - rf[RF_T_ANCHOR]
            out[O_HEADING_SD * cap + ix] = math.sqrt(sig_w * sig_w + mf[MF_SIG_S2] * mf[MF_H_S] / mf[MF_H_N] * since
                                                     + rf[RF_ISD] ** 2) if math.isfinite(mf[MF_H_S]) else sig_w
        else:
            out[O_HEADING_SD * cap + ix] = math.nan
        if reason_gap:
            reason = R_GAP
        elif rf[RF_SEEN] == 0.0 or ti - rf[RF_T_COMPASS] > rc[RC_MAX_AGE]:
            reason = R_NO_COMPASS
        elif abs(rf[RF_MEAN_RATE]) > rc[RC_TURN_RATE] + bsd:  # beyond what the drift leaves unknown
            reason = R_TURNING
        elif mf[MF_PDIST] >= 0.5 and mf[MF_FIELD_DOM] == 1.0:  # the field's own verdict
            reason = R_FIELD
        elif mf[ev.MF_PLABEL] >= 0.5:  # a disturbance moves the heading by more than LABEL_DEG
            reason = R_INTERFERENCE
        else:
            reason = R_NONE
        codes[OC_UPDATE * cap + ix] = updated
        codes[OC_REASON * cap + ix] = reason
        codes[OC_UNOBS * cap + ix] = int(rf[RF_UNOBS])
    rf[RF_T], rf[RF_G], rf[RF_TEMP], rf[RF_TP], rf[RF_BIAS], rf[RF_RATE] = c_t, c_g, c_T, c_Tp, c_bias, c_rate
    rf[RF_IRAW], rf[RF_IRATE], rf[RF_IBIAS] = I_raw, I_rate, I_bias
    return stop


@jit(inline=True)
def _first_spacing(mf, n, gap_factor):
    """The spacing (``MF_H_S``, ``MF_H_L``, ``MF_H_N``) from the log's first ``n`` steps, each
    counted at most ``gap_factor`` times the mean of the others but the longest (a median would
    be a cluster's step where the rows come in clusters)."""
    first = mf[ev.MF_H_FIRST:ev.MF_H_FIRST + n]
    longest = first.max()
    cap = gap_factor * ((first.sum() - longest) / (n - 1) if n > 1 else longest)
    s = s_log = 0.0
    for k in range(n):
        step = min(first[k], cap)
        s += step
        s_log += math.log(step)
    mf[MF_H_S] = s
    mf[MF_H_L] = s_log
    mf[MF_H_N] = float(n)


@jit(inline=True)
def turn_weight(mf, rf, turn_rate):
    """The weight of a row in the averaged rate that puts ``turn_rate`` (deg/s)
    :data:`TURN_NOISE_SDS` standard deviations of its noise away from 0. The noise is the
    gyro's variance per sample over the last epochs, still or moving (``RF_TURN_S``; before
    the first epoch the model's prior), in the long run (the model's learned colour); an
    exponential average of weight w keeps w / (2 - w) of it, about h / 2τ."""
    s2 = ev.long_run(mf, rf[RF_TURN_S] / rf[RF_TURN_W] if rf[RF_TURN_W] > 0.0 else mf[MF_SIG_S2])
    if not s2 > 0.0:
        return 1.0
    # w / (2 - w) = v  <=>  w = 2v / (1 + v), v the share of s² allowed
    v = min((turn_rate / TURN_NOISE_SDS) ** 2 / s2, 1.0)
    return 2.0 * v / (1.0 + v)


@jit
def unobservable(mf, rc):
    """The ``unobservable`` code of the model's state: a and/or b while their standard
    deviation is above ``UNOBSERVABLE_SD_FRACTION`` of the prior's."""
    Pc = mf[MF_PC:MF_PC + NX * NX]
    code = 0
    if math.sqrt(max(Pc[X_A * NX + X_A], 0.0)) > UNOBSERVABLE_SD_FRACTION * rc[RC_PRIOR_A]:
        code += UNOBS_A
    if math.sqrt(max(Pc[X_B * NX + X_B], 0.0)) > UNOBSERVABLE_SD_FRACTION * rc[RC_PRIOR_B]:
        code += UNOBS_B
    return float(code)


@jit
def settle(t, g, T, Tp, heading, last, n_init, tref, rf, out, codes, cap):
    """Settle the init window's rows ``0..last`` once it is complete (``docs/model.md``, "The
    init window"): the first epoch's rows again with the drift learned by its end, reason
    ``init`` and ``updated`` 0 on the first ``n_init`` rows, the integrated rate corrected, and
    the gyro-alone heading anchored on the window's first compass sample."""
    first = int(rf[RF_FIRST_ROW])
    d = rf[RF_FIRST_DRIFT:RF_FIRST_DRIFT + 14]
    a, b, c, a2 = d[0], d[1], d[2], d[3]
    corr = 0.0
    prev = 0.0
    hv = np.empty(4)
    for i in range(min(first + 1, last + 1)):
        hT = T[i] - tref
        hTp = Tp[i]
        bias = a * hT + b * hTp + c + a2 * hT * hT
        db = bias - out[O_BIAS * cap + i]
        if i > 0 and codes[OC_REASON * cap + i] != R_GAP:
            corr -= 0.5 * (db + prev) * (t[i] - t[i - 1])
        prev = db
        hv[0], hv[1], hv[2], hv[3] = hT, hTp, 1.0, hT * hT
        var = 0.0
        m = 4
        for r in range(4):
            for c_ in range(r, 4):
                var += (1.0 if r == c_ else 2.0) * d[m] * hv[r] * hv[c_]
                m += 1
        a_tangent = a + 2.0 * a2 * hT
        out[O_BIAS * cap + i] = bias
        out[O_RATE * cap + i] = g[i] - bias
        out[O_A * cap + i] = a_tangent
        out[O_B * cap + i] = b
        out[O_C * cap + i] = bias - a_tangent * T[i] - b * hTp
        out[O_BIAS_SD * cap + i] = math.sqrt(max(var, 0.0))
        out[O_HEADING * cap + i] += corr
    end = min(first, last)
    if 0 <= end < last:  # the step after the epoch: the loop integrated the row's old rate
        if codes[OC_REASON * cap + end + 1] != R_GAP:
            corr -= 0.5 * prev * (t[end + 1] - t[end])
    elif end == last and end >= 0:  # the loop resumes from the settled row
        rf[RF_BIAS] = out[O_BIAS * cap + end]
        rf[RF_RATE] = out[O_RATE * cap + end]
    for i in range(first + 1, last + 1):
        out[O_HEADING * cap + i] += corr
    for i in range(n_init):  # the window's rows are the init's (as streamed provisional rows)
        codes[OC_UPDATE * cap + i] = 0
        if codes[OC_REASON * cap + i] == R_NONE:
            codes[OC_REASON * cap + i] = R_INIT
    rf[RF_IRATE] += corr
    anchor = 0.0
    for i in range(last + 1):
        if not math.isnan(heading[i]):
            anchor = heading[i] - out[O_HEADING * cap + i]
            break
    if rf[RF_SEEN] == 1.0:
        rf[RF_ANCHOR] = anchor
    for i in range(last + 1):
        out[O_HEADING * cap + i] = wrap360(anchor + out[O_HEADING * cap + i])
    rf[RF_INIT_RAW] = 0.0

"""Compass aiding: the drift measurements of eqs. (4)–(6), the gates, and the interval decision.

Every update interval (10 s) the change of (gyro heading − compass heading) measures the
drift: ``m = Δ(∫gyro − compass)/Δt`` with H the interval means of ``[T, T', 1]``
(:func:`compass_measurement`). The interval is refused (:func:`row_condition`, first
reason seen; :func:`close`) for a gap, a field anomaly, turning, or a compass that
disagrees with the compensated gyro; refused intervals hold the parameters (eq. 5).
Lock-out recovery (:func:`steady_disagreement`) accepts an interval after a run of
refusals whose compass-minus-gyro rates agree: the drift moved, not the compass — unless
(with ZARU) the gyro saw no motion and its mean rate agrees with the drift in force: then
the compass moved.

The ``adaptive`` estimator's aiding adds (settings ``K_ZARU``, ``K_EDGE``, ...):

* edge averaging: each end of a compass measurement is the mean over the compass
  samples of the last ``edge_s`` seconds (:func:`_edge`), with a variance from the
  compass's own scatter (:func:`_edge_variance`);
* zero-rate (ZARU) measurements when the unit is still (:func:`zaru_measurement`):
  the mean gyro rate is the drift, with only the gyro's white noise.

Those read the compass window ``win``: one column per compass sample of the last
``max(zaru_window_s, edge_s)`` seconds, oldest first, from column ``head`` for ``n``
columns; rows (t, heading, I_raw, I_T, I_Tp, I_bias) (a snap), then the time step and the
mean gyro rate from the sample before (``W_*``). :func:`add` moves the samples in use to
the front when the end is reached (the engine keeps the buffer at most half full).

Initialisation (:func:`init_measurements`): the first ``init_s`` seconds split into
``stack_depth`` sub-windows; each motionless one gives one drift measurement, its mean
gyro rate (the paper's y1..y3).
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels import kalman
from gyrodrift.kernels.layout import (
    C_COMPASS_SD, C_DIP_TOL, C_FIELD_NORM_TOL, C_GYRO_NOISE, C_INTERF, C_INTERVAL, C_MAX_AGE, C_PRIOR_A,
    C_PRIOR_B, C_QS_DEG, C_QS_S, C_RUN_MIN_S, C_STILL_HEADING, C_STILL_STD, C_ZARU_RESID_K, C_ZARU_SLOPE_K, C_ZARU_WINDOW_S, C_EDGE_S, F_COV,
    F_E0, F_E1, F_NOISE_SUM, F_NOISE_W, F_PA, F_PB, F_PC, F_QS_IRAW0, F_QS_IT0, F_QS_ITP0, F_QS_PTS, F_S0, F_S1, I_AFTER_INT, I_E0_OK, I_E1_OK, I_N_ACC, I_PENDING, I_QS_N, I_REFUSED_N,
    I_S0_OK, I_S1_OK, I_STACK_N, I_STICKY, I_STILL_CHAIN, I_UNOBS, I_WIN_HEAD, I_WIN_N, K_DEPTH, K_EDGE, K_MODE,
    K_RELOCK, K_ZARU, K_ZARU_HOLD, MODE_ADAPTIVE, MODE_EXTERNAL, N_SNAP, N_WIN, NO_STICKY, PENDING_HOLD,
    NOISE_MIN_STEPS, PENDING_UPDATE, QS_MAX, R_FIELD, R_GAP, R_INTERFERENCE, R_NO_COMPASS, R_NONE, R_TURNING, UNOBS_A, UNOBS_B,
    UNOBSERVABLE_SD_FRACTION, W_DT, W_HEADING, W_IBIAS, W_IRAW, W_IT, W_ITP, W_RATE, W_T, ZARU_NIS,
)
from gyrodrift.kernels.numeric import wrap180

__all__ = ["add", "compass_measurement", "zaru_measurement", "flat_compass", "gyro_still", "row_condition",
           "field_anomaly", "field_reference", "unobservable_code", "steady_disagreement", "begin", "close",
           "push_measurement", "stacked", "close_still_run", "quasi_static", "gyro_noise", "note_still_noise",
           "in_force", "init_measurements"]


# ----------------------------------------------------------------- the window


@jit(inline=True)
def add(win, head, n, t, heading, I_raw, I_T, I_Tp, I_bias, window_s):
    """Append a compass sample to the window, drop those older than ``window_s`` before it;
    returns the new (head, n). The buffer must have room for one more
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


@jit(inline=True)
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


@jit
def compass_measurement(s0, s1, compass_sd, gyro_noise, var0, var1, end_var):
    """Eqs. (4)–(6) between two snaps: the drift measurement ``m = Δ(∫gyro − compass)/Δt``
    (deg/s; the sign that measures the drift, see :mod:`gyrodrift.compensator`), the
    interval means of T and T' (the row of H), its variance
    ``r = (var0 + var1)/Δt² + N²/Δt`` (with ``end_var``: the compass variances of edge
    means; else ``2 compass_sd²/Δt²``), and the residual: compass minus compensated-gyro
    heading change, deg. Returns (m, h_T, h_T', r, residual_deg)."""
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


@jit(inline=True)
def _angle_diffs(x, y, lo, ref, out, single):
    """``out[j] = wrap180(x[lo + j] - y[lo + j] - ref)`` (``wrap180(x[lo + j] - ref)`` when
    ``single``). Angles already in range take a plain pass, vectorised (a loop with the
    general case inside calls ``fmod`` on every lane: 20 times slower); the rest, if any,
    are wrapped after."""
    bad = False
    for j in range(out.size):
        v = (x[lo + j] - ref) if single else (x[lo + j] - y[lo + j] - ref)
        a = v + 180.0
        bad |= not (0.0 <= a < 360.0)
        out[j] = a - 180.0
    if bad:
        for j in range(out.size):
            out[j] = wrap180((x[lo + j] - ref) if single else (x[lo + j] - y[lo + j] - ref))


@jit
def _line_scatter(t, d):
    """The least-squares line of ``d`` against ``t``: (slope, Σ(t − t̄)², Σ residual², and
    Σ(Δd − mean Δd)² of the successive differences, in which slow motion cancels)."""
    tc = t - np.mean(t)
    dm = d - np.mean(d)
    sxx = np.dot(tc, tc)
    slope = np.dot(tc, dm) / sxx
    resid = dm - slope * tc
    step = d[1:] - d[:-1]
    dev = step - np.mean(step)
    return slope, sxx, np.dot(resid, resid), np.dot(dev, dev)


@jit
def _edge(win, head, n, snap, edge_s, interval_s, compass_sd):
    """The compass averaged over the ``edge_s`` seconds up to ``snap`` and its variance:
    returns (edge snap (6,), variance deg²).

    ``D = ∫gyro − compass`` of every compass sample in the edge window is averaged, with
    time and the other integrals: the edge is a point ``(t̄, D̄)`` of the same line a
    single sample lies on (D moves at the drift rate), with the compass noise divided by
    the number of samples. Consecutive intervals share their edge, so the measurements
    still telescope."""
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
    _angle_diffs(src[W_IRAW], src[W_HEADING], lo, d_ref, d, False)
    edge = np.empty(N_SNAP)
    for c in (W_T, W_IRAW, W_IT, W_ITP, W_IBIAS):
        edge[c] = np.mean(src[c, lo:hi])
    edge[W_HEADING] = edge[W_IRAW] - (np.mean(d) + d_ref)
    return edge, _edge_variance(win, head, n, snap, d_ref, k, interval_s, compass_sd)


@jit
def _edge_variance(win, head, n, snap, d_ref, k, interval_s, compass_sd):
    """Variance (deg²) of an edge mean of ``k`` compass samples, from the compass itself.

    Over the last update interval the scatter of D about its least-squares line is the
    compass error; successive differences give its white part σ_w², the rest σ_s² is
    slower (tilt while braking, deviation during a sway) and does not average down:
    ``σ_w²/k + σ_s²``. With fewer than 10 samples: ``compass_sd²/k``."""
    lo, hi = _span(win, head, n, snap[W_T] - interval_s, snap[W_T], True)
    size = hi - lo
    if size < 10:
        return compass_sd**2 / k
    d = np.empty(size)
    _angle_diffs(win[W_IRAW], win[W_HEADING], lo, d_ref, d, False)
    _, _, resid_ss, step_ss = _line_scatter(win[W_T, lo:hi], d)
    total = resid_ss / (size - 2)
    white = min(0.5 * step_ss / (size - 2), total)
    return white / k + (total - white)


@jit
def zaru_measurement(win, head, n, start, end, a, b, c, cov, still_chain, gyro_noise, cfg, icfg):
    """Zero-rate measurement of the interval from ``start`` to ``end`` when the unit is still.

    Still: the gyro saw no motion over the last ``zaru_window_s`` (:func:`gyro_still`) and
    either the compass heading fits a flat line over that window (stillness verified),
    or (``zaru_hold``) every interval since the last verification was still by the gyro
    and this one's mean rate agrees with the predicted drift (NIS below 6.63, χ²₁ at 99 %):
    the compass moved, not the unit (slowly wandering interference).

    ``a, b, c`` are the parameters in force (``estimator.drift``), ``cov`` the covariance
    (``estimator.cov``). Returns (found, m, h_T, h_T', r, still_chain, held, explained, agrees): the mean
    gyro rate over the interval measures the drift (eq. 1 with zero true rate), variance
    ``N²/Δt`` (plus the squared slope standard error of a verified flat compass); ``held``:
    found by ``zaru_hold`` with a compass that is not flat (the compass moved, not the unit);
    ``explained``: the gyro saw no motion and its mean rate agrees with the predicted drift,
    found or not (a compass that disagrees then moved itself); ``agrees``: the mean rate
    agrees with the predicted drift, whether the gyro saw motion or not.
    The window is read in place (its columns ``lo:hi``), its rates as :func:`add` stored them.
    ``gyro_noise`` is N, deg/s/√Hz (:func:`gyro_noise`).
    """
    if icfg[K_ZARU] == 0:
        return False, 0.0, 0.0, 0.0, 0.0, still_chain, False, False, False
    lo, hi = _span(win, head, n, math.nan, end[W_T], True)
    if hi - lo < 10 or end[W_T] - win[W_T, lo] < 0.8 * cfg[C_ZARU_WINDOW_S]:
        return False, 0.0, 0.0, 0.0, 0.0, False, False, False, False
    dt = end[W_T] - start[W_T]
    m = (end[W_IRAW] - start[W_IRAW]) / dt
    h = np.empty(3)
    h[0] = (end[W_IT] - start[W_IT]) / dt
    h[1] = (end[W_ITP] - start[W_ITP]) / dt
    h[2] = 1.0
    r = gyro_noise**2 / dt
    gamma = m - (a * h[0] + b * h[1] + c)
    consistent = gamma * gamma <= ZARU_NIS * (np.dot(np.dot(h, cov), h) + r)
    still = gyro_still(win, lo, hi, start[W_T], cfg[C_STILL_STD], cfg[C_ZARU_RESID_K])
    # The chain of stillness breaks on evidence of rotation: a mean rate the drift does not
    # explain. A wobble the Allan test sees only skips this interval.
    still_chain = still_chain and consistent
    if not still:
        return False, 0.0, 0.0, 0.0, 0.0, still_chain, False, False, consistent
    slope_se = flat_compass(win, lo, hi, cfg[C_COMPASS_SD], cfg[C_ZARU_SLOPE_K], cfg[C_ZARU_RESID_K])
    if slope_se >= 0.0:
        return True, m, h[0], h[1], r + slope_se**2, True, False, consistent, consistent
    if icfg[K_ZARU_HOLD] == 1 and still_chain:
        return True, m, h[0], h[1], r, still_chain, True, True, True
    return False, 0.0, 0.0, 0.0, 0.0, still_chain, False, consistent, consistent


@jit
def flat_compass(win, lo, hi, compass_sd, slope_k, resid_k):
    """Standard error (deg/s) of the slope of a flat compass heading over the stillness
    window (columns ``lo:hi``), or -1 when it is not flat.

    Flat: slope within ``slope_k`` standard errors of zero, scatter about the line within
    two compass sigmas and not above the compass white noise (from successive
    differences, in which slow motion cancels) by more than ``resid_k`` standard errors of
    a variance ratio: a heading that wanders inside the window, even about a flat line,
    fails."""
    size = hi - lo
    d = np.empty(size)
    _angle_diffs(win[W_HEADING], win[W_HEADING], lo, win[W_HEADING, lo], d, True)
    slope, sxx, resid_ss, step_ss = _line_scatter(win[W_T, lo:hi], d)
    dof = max(size - 2, 1)
    resid_var = resid_ss / dof
    slope_se = math.sqrt(resid_var / sxx)
    noise_var = 0.5 * step_ss / dof
    if (resid_var > (2.0 * compass_sd) ** 2 or abs(slope) > slope_k * slope_se
            or resid_var > noise_var * (1.0 + resid_k * math.sqrt(2.0 / dof))):
        return -1.0
    return slope_se


@jit
def _allan(rates, m):
    """Half the mean squared difference of successive means of ``m`` rates (the Allan
    variance at ``m`` steps)."""
    nb = rates.size // m
    means = rates[: nb * m].reshape((nb, m)).sum(axis=1) / m
    d = means[1:] - means[:-1]
    return 0.5 * np.dot(d, d) / (nb - 1)


@jit
def gyro_still(win, lo, hi, interval_start_s, max_std_dps, k):
    """Whether the gyro saw no motion over the stillness window, columns ``lo:hi``.

    Still: the rates of this interval (after ``interval_start_s``) vary less than
    ``max_std_dps``, and the Allan variance of the rates at 2 s is no more than white
    noise allows, a quarter of that at 0.5 s, within ``k`` standard errors of a variance
    ratio (Allan variances ignore a slowly moving drift). A yaw wander of a few hundredths
    of a deg/s that the compass cannot see fails this. The rates are
    ``win[W_RATE, lo + 1:hi]`` (stored by :func:`add`)."""
    rates = win[W_RATE, lo + 1:hi]
    inside = rates[win[W_T, lo + 1:hi] > interval_start_s]
    if inside.size >= 2 and np.std(inside) > max_std_dps:
        return False
    small = max(1, int(np.rint(0.5 / np.median(win[W_DT, lo + 1:hi]))))
    big = 4 * small
    nb = rates.size // big
    if nb < 6:
        return True
    return _allan(rates, big) <= 0.25 * _allan(rates, small) * (1.0 + k * math.sqrt(2.0 / (nb - 1)))


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
def begin(t_boundary, fs, ist, cfg, icfg, win):
    """Open the next interval at a boundary row: its start snap is the last compass
    sample if not older than ``compass_max_age_s`` (else the interval is refused,
    ``no_compass``), and, with edge averaging, its edge mean."""
    if ist[I_S1_OK] == 1 and not (t_boundary - fs[F_S1] > cfg[C_MAX_AGE]):
        for j in range(N_SNAP):
            fs[F_S0 + j] = fs[F_S1 + j]
        ist[I_S0_OK] = 1
        ist[I_STICKY] = NO_STICKY
    else:
        ist[I_S0_OK] = 0
        ist[I_STICKY] = R_NO_COMPASS
    ist[I_E0_OK] = 0
    if ist[I_S0_OK] == 1 and icfg[K_EDGE] == 1:
        if ist[I_E1_OK] == 1:  # the end edge close() just computed: the same snap and window
            for j in range(N_SNAP + 1):
                fs[F_E0 + j] = fs[F_E1 + j]
        else:
            edge, var = _edge(win, ist[I_WIN_HEAD], ist[I_WIN_N], fs[F_S0:F_S0 + N_SNAP], cfg[C_EDGE_S],
                              cfg[C_INTERVAL], cfg[C_COMPASS_SD])
            for j in range(N_SNAP):
                fs[F_E0 + j] = edge[j]
            fs[F_E0 + N_SNAP] = var
        ist[I_E0_OK] = 1
    ist[I_E1_OK] = 0


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
def close(t_boundary, fs, ist, cfg, icfg, stack, refused, acc, win, ef, ei, intervals):
    """Decide the interval ending at a boundary row and update or hold the estimator;
    returns (update, reason).

    Accepted: no refusal seen in it and a compass sample at both ends at least half an
    interval apart; the measurement (eqs. 4–6, between edge means with edge averaging) is
    then refused for interference when its residual exceeds ``interference_deg``. With
    ZARU a still interval gives the zero-rate measurement instead, accepted even when the
    compass disagrees; after an interval where a still unit's compass moved, an interval
    without its own zero-rate measurement whose mean gyro rate agrees with the drift is
    refused for interference. The estimator (``ef``, ``ei``) is updated with the stacked
    measurements (``depth`` rows, eq. 3) or held for ``intervals`` intervals (more than one
    when a time gap skipped some); in MODE_EXTERNAL the caller does it (``ist[I_PENDING]``,
    one hold).
    """
    mode = icfg[K_MODE]
    reason = ist[I_STICKY]
    ist[I_E1_OK] = 0
    end_ok = ist[I_S1_OK] == 1 and not (t_boundary - fs[F_S1] > cfg[C_MAX_AGE])
    s0 = fs[F_S0:F_S0 + N_SNAP]
    s1 = fs[F_S1:F_S1 + N_SNAP]
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
            m, h0, h1, r, resid = compass_measurement(s0, s1, cfg[C_COMPASS_SD], gyro_noise(cfg, fs), 0.0, 0.0, False)
            if ist[I_E0_OK] == 1:
                end_edge, end_var = _edge(win, ist[I_WIN_HEAD], ist[I_WIN_N], s1, cfg[C_EDGE_S], cfg[C_INTERVAL],
                                          cfg[C_COMPASS_SD])
                for j in range(N_SNAP):  # kept for begin(), whose start snap this is
                    fs[F_E1 + j] = end_edge[j]
                fs[F_E1 + N_SNAP] = end_var
                ist[I_E1_OK] = 1
                m, h0, h1, r, resid = compass_measurement(fs[F_E0:F_E0 + N_SNAP], end_edge, cfg[C_COMPASS_SD],
                                                           gyro_noise(cfg, fs), fs[F_E0 + N_SNAP], end_var, True)
            have_meas = True
            if abs(resid) > cfg[C_INTERF]:
                reason = R_INTERFERENCE
    zaru = False
    compass_moved = False
    explained = False
    agrees = False
    if icfg[K_ZARU] == 1 and (reason == NO_STICKY or reason == R_INTERFERENCE) and ist[I_S0_OK] == 1 and end_ok:
        zaru, zm, zh0, zh1, zr, chain, compass_moved, explained, agrees = zaru_measurement(
            win, ist[I_WIN_HEAD], ist[I_WIN_N], s0, s1, fs[F_PA], fs[F_PB], fs[F_PC],
            fs[F_COV:F_COV + 9].reshape((3, 3)), ist[I_STILL_CHAIN] == 1, gyro_noise(cfg, fs), cfg, icfg,
        )
        ist[I_STILL_CHAIN] = 1 if chain else 0
        if zaru:  # still: the drift moved, not the heading; no lock-out
            m, h0, h1, r = zm, zh0, zh1, zr
            reason = NO_STICKY
    if not zaru and reason == NO_STICKY and ist[I_AFTER_INT] == 1 and agrees:
        # the compass moved while the unit was still in the last interval (its rows here are
        # labelled interference) and the gyro's mean rate agrees with the drift: refused as such
        reason = R_INTERFERENCE
    if not zaru and reason == R_INTERFERENCE and ist[I_S0_OK] == 1 and end_ok:
        if not have_meas:
            m, h0, h1, r, resid = compass_measurement(s0, s1, cfg[C_COMPASS_SD], gyro_noise(cfg, fs), 0.0, 0.0, False)
            have_meas = True
        accept, ist[I_REFUSED_N] = steady_disagreement(resid / (fs[F_S1] - fs[F_S0]), refused, ist[I_REFUSED_N],
                                                       icfg[K_RELOCK])
        if accept and not explained:  # a still gyro that agrees with the drift: the compass moved, not the drift
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
        # a still unit whose compass moved: the compass is suspect for the next interval
        ist[I_AFTER_INT] = 1 if compass_moved else 0
        return 1, R_NONE
    if mode == MODE_EXTERNAL:
        ist[I_PENDING] = PENDING_HOLD
    else:
        kalman.hold(ef, ei, intervals)
    ist[I_AFTER_INT] = 1 if reason == R_INTERFERENCE else 0
    return 0, reason


@jit
def close_still_run(t_end, d_raw, d_T, d_Tp, duration, n, gyro_sum, gyro_sq, fs, ist, cfg, icfg, stack, acc, ef, ei):
    """A still run ending at ``t_end``: ``duration`` s, ``n`` rows, integrals over it ``d_raw``
    (gyro, deg), ``d_T``, ``d_Tp``; ``gyro_sum``, ``gyro_sq`` the sums of the gyro minus its
    first value and of their squares. Returns whether it measured the drift.

    A run at least ``still_run_s`` long whose gyro varied less than ``still_std_dps``
    (standard deviation) is a zero-rate measurement: with the unit still, its mean gyro
    rate is the drift (eq. 1), H the run's means of [T, T', 1], variance ``N²/Δt``. The
    estimator takes it at once (or, MODE_EXTERNAL, the caller).
    """
    if n < 2 or duration < cfg[C_RUN_MIN_S]:
        return False
    mean = gyro_sum / n
    if gyro_sq / n - mean * mean > cfg[C_STILL_STD] ** 2:
        return False
    _take_now(t_end, d_raw / duration, d_T / duration, d_Tp / duration, gyro_noise(cfg, fs) ** 2 / duration,
              fs, ist, cfg, icfg, stack, acc, ef, ei)
    return True


@jit
def gyro_noise(cfg, fs):
    """The gyro's white-noise density N in use, deg/s/√Hz: the setting ``gyro_noise_dps_rthz``,
    or the noise measured from the log's still runs (:func:`note_still_noise`, once they
    hold ``NOISE_MIN_STEPS`` steps) when that is larger. The variances of the gyro-based
    measurements after the init window (eq. 6's gyro term, zero-rate, still runs,
    quasi-static windows) use it, so a gyro noisier than its setting is not over-trusted.
    A quieter gyro keeps the setting: the filter's process noise was tuned against it, and
    the Monte Carlo lost bias accuracy when a quiet gyro's own noise was used (docs/results.md)."""
    if fs[F_NOISE_W] >= NOISE_MIN_STEPS:
        return max(math.sqrt(fs[F_NOISE_SUM] / fs[F_NOISE_W]), cfg[C_GYRO_NOISE])
    return cfg[C_GYRO_NOISE]


@jit
def note_still_noise(d2, n, duration, fs):
    """A closed still run of ``n`` rows over ``duration`` s whose gyro steps (row to row)
    have the sum of squares ``d2``: for white noise of density N sampled every δ s a step
    has variance 2N²/δ, so the run measures ``N² = d2 δ / (2 (n-1))`` with ``δ =
    duration / (n-1)``; added to the log's estimate with weight ``n - 1``. Steps, not
    deviations from the mean, so a slow sway or drift change does not count as noise."""
    if n < 3 or duration <= 0.0:
        return
    steps = n - 1.0
    fs[F_NOISE_SUM] += 0.5 * d2 * duration / steps
    fs[F_NOISE_W] += steps


@jit
def _take_now(t, m, h_T, h_Tp, r, fs, ist, cfg, icfg, stack, acc, ef, ei):
    """One drift measurement taken between interval ends (a still run, a quasi-static
    window): alone, not stacked; the estimator updated and put in force at once (or,
    MODE_EXTERNAL, by the caller)."""
    rows = push_measurement(t, m, h_T, h_Tp, r, ist, stack, acc, 1)
    if icfg[K_MODE] == MODE_EXTERNAL:
        ist[I_PENDING] = PENDING_UPDATE
    else:
        y, H, R = stacked(stack, rows)
        kalman.update(ef, ei, y, H, R)
        in_force(fs, ist, cfg, ef, ei)


@jit
def quasi_static(t_b, accepted, reason, I_raw, I_T, I_Tp, I_rate, fs, ist, cfg, icfg, stack, acc, ef, ei):
    """The quasi-static window at an interval end ``t_b``: returns whether it measured the drift.

    Through refused intervals (no compass, interference, a field anomaly, turning) a
    platform that is parked, moored or on a bench keeps its heading within a bounded sway:
    over a window of ``quasi_static_s`` seconds its mean true rate is at most the sway's
    peak-to-peak over the window length, so the window's mean gyro rate measures the drift
    (eq. 1) with that uncertainty. The window collects the compensated heading ``I_rate``
    at each interval end; when it is long enough, the heading minus its straight-line fit
    (a drift error is a straight line) must stay within ``quasi_static_deg`` peak to peak
    (``p2p``), seen at four interval ends at least. The measurement is the mean gyro rate with H the window's means of
    ``[T, T', 1]`` and variance ``(p2p / 2Δt)² + N²/Δt``; it is taken only when it agrees
    with the drift in force (NIS below 6.63, χ²₁ at 99 %): a slow real turn is a mean
    rate the drift model does not explain, and is refused (so is a drift the model has
    badly lost: the compass then has to find it). An accepted interval (``accepted``) or a
    gap closes the window; a new one opens at ``t_b``.
    """
    length = cfg[C_QS_S]
    n = ist[I_QS_N]
    if length <= 0.0:
        return False
    if accepted or reason == R_GAP or n == 0 or n >= QS_MAX:
        _qs_open(t_b, I_raw, I_T, I_Tp, I_rate, fs, ist)
        return False
    fs[F_QS_PTS + 2 * n] = t_b
    fs[F_QS_PTS + 2 * n + 1] = I_rate
    n += 1
    ist[I_QS_N] = n
    t0 = fs[F_QS_PTS]
    span = t_b - t0
    if span < length and n < QS_MAX:
        return False
    p2p = _detrended_p2p(fs[F_QS_PTS:F_QS_PTS + 2 * n].reshape((n, 2)))
    if n < 4:  # intervals as long as the window: too few points to see a sway
        p2p = math.inf
    m = (I_raw - fs[F_QS_IRAW0]) / span
    h_T = (I_T - fs[F_QS_IT0]) / span
    h_Tp = (I_Tp - fs[F_QS_ITP0]) / span
    _qs_open(t_b, I_raw, I_T, I_Tp, I_rate, fs, ist)  # the next window starts here, measured or not
    if not p2p <= cfg[C_QS_DEG]:
        return False
    r = (0.5 * p2p / span) ** 2 + gyro_noise(cfg, fs) ** 2 / span
    h = np.array([h_T, h_Tp, 1.0])
    cov = fs[F_COV:F_COV + 9].reshape((3, 3))
    gamma = m - (fs[F_PA] * h_T + fs[F_PB] * h_Tp + fs[F_PC])
    if gamma * gamma > ZARU_NIS * (np.dot(np.dot(h, cov), h) + r):
        return False
    _take_now(t_b, m, h_T, h_Tp, r, fs, ist, cfg, icfg, stack, acc, ef, ei)
    return True


@jit
def _qs_open(t_b, I_raw, I_T, I_Tp, I_rate, fs, ist):
    """A new quasi-static window from ``t_b``: its start integrals and first point."""
    fs[F_QS_IRAW0] = I_raw
    fs[F_QS_IT0] = I_T
    fs[F_QS_ITP0] = I_Tp
    fs[F_QS_PTS] = t_b
    fs[F_QS_PTS + 1] = I_rate
    ist[I_QS_N] = 1


@jit
def _detrended_p2p(pts):
    """Peak-to-peak of ``pts[:, 1]`` about its least-squares line in ``pts[:, 0]``."""
    t = pts[:, 0] - pts[0, 0]
    y = pts[:, 1] - pts[0, 1]
    tm = np.mean(t)
    ym = np.mean(y)
    stt = np.sum((t - tm) ** 2)
    slope = np.sum((t - tm) * (y - ym)) / stt if stt > 0.0 else 0.0
    resid = y - ym - slope * (t - tm)
    return np.max(resid) - np.min(resid)


@jit
def in_force(fs, ist, cfg, ef, ei):
    """The parameters and covariance of a kernel estimator into ``fs`` (F_PA.., F_COV) and
    the unobservable code into ``ist``."""
    p = kalman.params(ef, ei)
    C = kalman.cov(ef, ei)
    fs[F_PA] = p[0]
    fs[F_PB] = p[1]
    fs[F_PC] = p[2]
    for r in range(3):
        for c in range(3):
            fs[F_COV + 3 * r + c] = C[r, c]
    ist[I_UNOBS] = unobservable_code(C, cfg[C_PRIOR_A], cfg[C_PRIOR_B])


# ------------------------------------------------------------ initialisation


@jit
def init_measurements(t, g, T, Tp, heading, e, n_windows, init_s, cfg, ist, stack, acc, depth):
    """The drift measurements of the init window, rows ``0..e`` (inclusive), into the
    stack and ``acc``; returns (measurements, anchor row).

    The window is split at ``t[0] + j init_s / n_windows``; a sub-window is motionless
    when the gyro standard deviation is at most ``still_std_dps`` and the compass turned
    at most ``still_heading_deg`` (median of its last third against its first third);
    each motionless one gives its mean gyro rate (trapezoid integral over the
    sub-window) with H the means of [T, T', 1] and variance ``N²/Δt``. The anchor row is
    the first compass sample of the window (-1: none; the heading cannot be anchored).
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

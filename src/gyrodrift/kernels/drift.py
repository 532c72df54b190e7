"""The drift model, eq. (2)/(5) ``B_d = a T + b T' + c``, and the T' estimate
(``docs/conventions.md``, "How T' is computed"), resumable across chunks: its state is in
``fs``/``ist`` (``F_TP_*``, ``I_TP_*``) and the ring ``bins`` of closed bins (bin number, mean
time, mean temperature; at least ``window_bins + 2`` rows).
"""

from __future__ import annotations

import math

from gyrodrift.kernels import jit
from gyrodrift.kernels.layout import (
    F_TP_PREV, F_TP_RATE, F_TP_RES, F_TP_SUM_T, F_TP_SUM_TEMP, F_TP_T0, I_TP_BIN, I_TP_HEAD, I_TP_LEN, I_TP_N,
    I_TP_STARTED,
)
from gyrodrift.kernels.numeric import near_boundary

__all__ = ["bias", "bias_sd", "temp_rate_chunk"]


@jit(inline=True)
def bias(a, b, c, temp_c, temp_rate_cps):
    """Eq. (2)/(5): the drift (deg/s) at T (degC) and T' (degC/s)."""
    return a * temp_c + b * temp_rate_cps + c


@jit(inline=True)
def bias_sd(C00, C01, C02, C10, C11, C12, C20, C21, C22, temp_c, temp_rate_cps):
    """Standard deviation (deg/s) of the drift ``h x``, ``h = [T, T', 1]``: ``sqrt(h C hᵀ)``
    with C the covariance of [a, b, c] (0 where rounding makes the variance negative)."""
    var = ((C00 * temp_c + C01 * temp_rate_cps + C02) * temp_c
           + (C10 * temp_c + C11 * temp_rate_cps + C12) * temp_rate_cps
           + (C20 * temp_c + C21 * temp_rate_cps + C22))
    return math.sqrt(max(var, 0.0))


@jit
def temp_rate_chunk(t, temp, window_bins, short_bins, bin_s, fs, ist, bins, out):
    """T' (degC/s) of every sample of a chunk into ``out``, resumable across chunks.

    Until two bins have closed T' is 0. With ``short_bins`` > 0, the window's slope moves
    towards the slope over the last ``short_bins`` bins as far as the two differ beyond the
    short one's noise (:func:`_short_slope`), and then towards a quadratic's slope at the
    newest of them (:func:`_end_slope`). The tracker's state lives in locals during the
    loop and goes back to ``fs``/``ist`` at the end.
    """
    cap = bins.shape[0]
    if t.size and ist[I_TP_STARTED] == 0:
        fs[F_TP_T0] = t[0]
        fs[F_TP_PREV] = temp[0]
        ist[I_TP_STARTED] = 1
        ist[I_TP_BIN] = math.floor((t[0] - fs[F_TP_T0]) / bin_s)
    t0 = fs[F_TP_T0]
    sum_t, sum_T, rate = fs[F_TP_SUM_T], fs[F_TP_SUM_TEMP], fs[F_TP_RATE]
    res, prev = fs[F_TP_RES], fs[F_TP_PREV]
    cur, count, head, length = ist[I_TP_BIN], ist[I_TP_N], ist[I_TP_HEAD], ist[I_TP_LEN]
    t_near = near_boundary(t0, float(cur), bin_s)
    for i in range(t.size):
        ti = t[i]
        if short_bins > 0:  # the temperature's resolution: its smallest step between rows
            step = abs(temp[i] - prev)
            if step > 0.0 and (res == 0.0 or step < res):
                res = step
            prev = temp[i]
        b = cur
        if ti >= t_near:
            b = math.floor((ti - t0) / bin_s)
        if count > 0 and b != cur:
            # close the bin: its mean time and temperature
            pos = (head + length) % cap
            bins[pos, 0] = cur
            bins[pos, 1] = sum_t / count
            bins[pos, 2] = sum_T / count
            length += 1
            while bins[head, 0] < cur - window_bins:
                head = (head + 1) % cap
                length -= 1
            rate = _ring_slope(bins, head, length)
            if short_bins > 0:
                rate = _short_slope(bins, head, length, cur - short_bins, rate, res)
            sum_t = 0.0
            sum_T = 0.0
            count = 0
        if b != cur:
            cur = b
            t_near = near_boundary(t0, float(cur), bin_s)
        sum_t += ti
        sum_T += temp[i]
        count += 1
        out[i] = rate
    fs[F_TP_SUM_T], fs[F_TP_SUM_TEMP], fs[F_TP_RATE] = sum_t, sum_T, rate
    fs[F_TP_RES], fs[F_TP_PREV] = res, prev
    ist[I_TP_BIN], ist[I_TP_N], ist[I_TP_HEAD], ist[I_TP_LEN] = cur, count, head, length


@jit
def _ring_slope(bins, head, n):
    """Least-squares slope of column 2 against column 1 over ``n`` ring rows; 0 if undetermined."""
    if n < 2:
        return 0.0
    cap = bins.shape[0]
    st = 0.0
    sT = 0.0
    r = head
    for _ in range(n):
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


@jit
def _short_slope(bins, head, n, first_bin, rate, res):
    """The window's slope ``rate`` moved towards the slope over the ring rows from bin number
    ``first_bin`` on, as far as their difference is beyond the short slope's noise.

    With d the difference and v the short slope's variance (a least-squares slope's from the
    short rows' residuals, and at least the square of the slope one step of the reading by its
    resolution ``res`` gives at the worst place in the short window: one step is no change of
    T'), the result is ``rate + (1 - v/d²) d`` where d² > v, else ``rate``: the window's lag
    taken as d² - v, the two slopes weighed by it and by v (the minimum-variance blend of a
    lagging and a noisy estimate). That result then goes through :func:`_end_slope` over the
    same rows.
    """
    cap = bins.shape[0]
    r = (head + n - 1) % cap  # the newest row, then back while in the short window
    m = 0
    st = 0.0
    sT = 0.0
    while m < n and bins[r, 0] >= first_bin:
        st += bins[r, 1]
        sT += bins[r, 2]
        m += 1
        r = (r - 1) % cap
    if m < 3:
        return rate
    mt = st / m
    mT = sT / m
    sxx = 0.0
    sxy = 0.0
    r = (head + n - 1) % cap
    for _ in range(m):
        dt = bins[r, 1] - mt
        sxx += dt * dt
        sxy += dt * (bins[r, 2] - mT)
        r = (r - 1) % cap
    if sxx <= 0.0:
        return rate
    slope = sxy / sxx
    ss = 0.0
    after = 0.0  # Σ (t - mean t) over the newest rows: a unit step before them moves the slope by after/sxx
    step_slope = 0.0
    r = (head + n - 1) % cap
    for _ in range(m):
        dt = bins[r, 1] - mt
        e = bins[r, 2] - mT - slope * dt
        ss += e * e
        after += dt
        step_slope = max(step_slope, after / sxx)
        r = (r - 1) % cap
    var = max(ss / (m - 2) / sxx, (res * step_slope) ** 2)  # the short slope's variance
    diff2 = (slope - rate) ** 2
    if diff2 > var:
        rate = rate + (1.0 - var / diff2) * (slope - rate)
    return _end_slope(bins, head, n, m, rate, res)


@jit
def _end_slope(bins, head, n, m, rate, res):
    """``rate`` moved towards the slope at the newest of the last ``m`` ring rows of a
    least-squares quadratic through them, as far as the two differ beyond that slope's noise
    (its variance from the residuals, and at least that of one step of the reading by ``res``
    at the worst place): the short window's own lag where the temperature bends."""
    if m < 5:
        return rate
    cap = bins.shape[0]
    newest = bins[(head + n - 1) % cap, 1]
    y_new = bins[(head + n - 1) % cap, 2]  # temperatures from the newest: a flat one fits exactly
    s0 = s1 = s2 = s3 = s4 = y0 = y1 = y2 = 0.0
    r = (head + n - 1) % cap
    for _ in range(m):
        u = bins[r, 1] - newest
        y = bins[r, 2] - y_new
        s0 += 1.0
        s1 += u
        s2 += u * u
        s3 += u * u * u
        s4 += u * u * u * u
        y0 += y
        y1 += u * y
        y2 += u * u * y
        r = (r - 1) % cap
    # the inverse of the normal equations' matrix (symmetric, by its adjugate)
    i00, i01, i02 = s2 * s4 - s3 * s3, s2 * s3 - s1 * s4, s1 * s3 - s2 * s2
    i11, i12, i22 = s0 * s4 - s2 * s2, s1 * s2 - s0 * s3, s0 * s2 - s1 * s1
    det = s0 * i00 + s1 * i01 + s2 * i02
    if not abs(det) > 0.0:
        return rate
    c0 = (i00 * y0 + i01 * y1 + i02 * y2) / det
    c1 = (i01 * y0 + i11 * y1 + i12 * y2) / det
    c2 = (i02 * y0 + i12 * y1 + i22 * y2) / det
    ss = 0.0
    after = 0.0  # Σ of c1's weights over the newest rows: a unit step before them moves c1 by it
    step = 0.0
    r = (head + n - 1) % cap
    for _ in range(m):
        u = bins[r, 1] - newest
        e = bins[r, 2] - y_new - (c0 + (c1 + c2 * u) * u)
        ss += e * e
        after += (i01 + (i11 + i12 * u) * u) / det
        step = max(step, abs(after))
        r = (r - 1) % cap
    var = max(ss / (m - 3) * i11 / det, (res * step) ** 2)
    d = c1 - rate
    if d * d <= var:
        return rate
    return rate + (1.0 - var / (d * d)) * d

"""The x and y gyro axes: their drift, aided by gravity, row by row.

:func:`run` is the row loop of :class:`gyrodrift.triad.TriadCompensator` for chunks of any
size; :func:`close` decides an interval. The method (Euler kinematics, edge windows, the
measurement, the gates): ``docs/heading_and_axes.md`` ("The x and y gyro axes"); the state
arrays and why :func:`close` is inlined: ``docs/engine.md``.
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels import kalman
from gyrodrift.kernels.aiding import steady_disagreement
from gyrodrift.kernels.drift import bias
from gyrodrift.kernels.layout import (
    N_XE, N_XU, PENDING_HOLD, PENDING_UPDATE, XC_ACC_NOISE, XC_EDGE_S, XC_GYRO_NOISE, XC_INTERVAL, XC_MAX_GAP,
    XC_MAX_TILT, XC_NORM_TOL, XC_RESID_DEG, XC_RESID_K, XC_SPREAD, XC_TURN_RATE, XC_TURN_WIN, XE_IK1, XE_IK2,
    XE_IPHI, XE_IT, XE_ITH, XE_ITP, XE_N, XE_NORM, XE_PITCH, XE_ROLL, XE_SPREAD, XE_T, XE_TILT, XF_COV, XF_EDGE,
    XF_GX, XF_GY, XF_I, XF_K, XF_MEAS, XF_PARAMS, XF_RELOCK, XF_SCALE, XF_T0, XF_T_MEAS, XF_TEMP, XF_TLAST,
    XF_TP, XF_U, XG_ACCEL, XG_GAP, XG_NONE, XG_RESIDUAL, XG_TILT, XG_TURNING, XI_DECIDED, XI_EDGE_OK,
    XI_GATED, XI_HEAD, XI_N, XI_BAD, XI_PENDING, XI_REASONS, XI_REFUSALS, XI_STARTED, XI_TURN_J, XI_TURNING,
    XI_UPDATES, XK_EXTERNAL, XK_RELOCK, XS_BAD_TIME, XS_NO_TEMP, XW_F0, XW_F1, XW_F2, XW_IGX, XW_IPHI, XW_IRZ, XW_IT, XW_ITP, XW_OK, XW_T,
)
from gyrodrift.kernels.numeric import matvec

__all__ = ["G_MPS2", "acc_scale", "specific_force", "euler_rates", "roll_pitch", "window_step",
           "edge_window", "refusal", "measurement", "residual_ok", "close", "run"]

#: Standard gravity, m/s² (1 g).
G_MPS2 = 9.80665


# ------------------------------------------------------------ accelerometer


@jit(inline=True)
def acc_scale(ax, ay, az):
    """g per input unit of a raw accelerometer row (any unit): 1/G_MPS2 when its norm is
    above 3 (m/s²), 1 when above 0.05 (g), NaN when it cannot tell (empty or about 0)."""
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    if not (math.isfinite(norm) and norm > 0.05):
        return math.nan
    return 1.0 / G_MPS2 if norm > 3.0 else 1.0


@jit(inline=True)
def specific_force(ax, ay, az, scale):
    """The specific force (g, FRD) of a raw row and whether it is usable: a norm within
    0.5–1.5 g, not along body x alone (the roll angle needs ``f_y² + f_z² > 0``). An
    unusable row gives the level ``(0, 0, −1)``. Returns (f_x, f_y, f_z, usable)."""
    f0 = ax * scale
    f1 = ay * scale
    f2 = az * scale
    norm = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    if math.isfinite(norm) and 0.5 < norm < 1.5 and f1 * f1 + f2 * f2 > 0.0:
        return f0, f1, f2, True
    return 0.0, 0.0, -1.0, False


@jit(inline=True)
def euler_rates(f0, f1, f2, p, q, r):
    """Roll and pitch rates (deg/s) of the Euler kinematics with the attitude of the specific
    force ``f`` (g) and the body rates ``p, q, r`` (deg/s):
    ``φ' = p + tanθ (q sinφ + r cosφ)``, ``θ' = q cosφ − r sinφ``, with
    ``sinφ = −f_y/√(f_y² + f_z²)``, ``cosφ = −f_z/√(f_y² + f_z²)``,
    ``tanθ = f_x/√(f_y² + f_z²)``. Returns (φ', θ', tanθ sinφ, cosφ)."""
    yz = math.sqrt(f1 * f1 + f2 * f2)
    sphi = -f1 / yz
    cphi = -f2 / yz
    tth = f0 / yz
    return p + tth * (q * sphi + r * cphi), q * cphi - r * sphi, tth * sphi, cphi


@jit(inline=True)
def roll_pitch(f0, f1, f2):
    """Roll ``atan2(−f_y, −f_z)`` and pitch ``asin(f_x/|f|)`` (deg) of a specific force
    (any unit; pitch NaN for a zero vector)."""
    norm = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    pitch = math.nan
    if norm > 0.0:
        pitch = math.degrees(math.asin(min(1.0, max(-1.0, f0 / norm))))
    elif math.isnan(norm):
        pitch = norm
    return math.degrees(math.atan2(-f1, -f2)), pitch


# ------------------------------------------------------------- row windows


@jit
def window_step(ring, xf, xi, turn_win, turn_rate, keep_s):
    """The turning gate at the ring's newest row (``xi[XI_TURNING]`` set when a window mean of
    the compensated x, y or z rate over the last ``turn_win`` s of the interval, spanning at
    least half of it, is above ``turn_rate``), then the rows older than ``keep_s`` dropped (the
    newest kept)."""
    cap = ring.shape[0]
    head = xi[XI_HEAD]
    n = xi[XI_N]
    j = xi[XI_TURN_J]
    new = (head + n - 1) % cap
    t_new = ring[new, XW_T]
    lo = t_new - turn_win
    while ring[(head + j) % cap, XW_T] < lo:
        j += 1
    old = (head + j) % cap
    span = t_new - ring[old, XW_T]
    if span >= 0.5 * turn_win:
        dT = ring[new, XW_IT] - ring[old, XW_IT]
        dTp = ring[new, XW_ITP] - ring[old, XW_ITP]
        for axis in range(2):
            p = XF_PARAMS + 3 * axis
            d = (ring[new, XW_IGX + axis] - ring[old, XW_IGX + axis] - xf[p] * dT - xf[p + 1] * dTp
                 - xf[p + 2] * span)
            if abs(d / span) > turn_rate:
                xi[XI_TURNING] = 1
        if abs((ring[new, XW_IRZ] - ring[old, XW_IRZ]) / span) > turn_rate:
            xi[XI_TURNING] = 1
    oldest = t_new - keep_s
    while n > 1 and ring[head, XW_T] < oldest:  # older than the turning window too: before j
        head = (head + 1) % cap
        n -= 1
        j -= 1
    xi[XI_HEAD] = head
    xi[XI_N] = n
    xi[XI_TURN_J] = j


@jit
def edge_window(ring, head, n, edge_s, e):
    """Means over the usable rows of the last ``edge_s`` s of the ring (its ``n`` rows from
    ``head``, the newest the interval's boundary) into ``e`` (layout XE_*); False when the
    window is unusable: fewer than 3 rows, fewer than 3 or 80 % usable accelerometer rows,
    or spanning less than half of ``edge_s``."""
    cap = ring.shape[0]
    t_end = ring[(head + n - 1) % cap, XW_T]
    lo = t_end - edge_s
    m = 0
    while m < n and ring[(head + n - 1 - m) % cap, XW_T] > lo:
        m += 1
    first = head + n - m
    n_ok = 0
    for k in range(first, first + m):
        if ring[k % cap, XW_OK] > 0.0:
            n_ok += 1
    if m < 3 or n_ok < max(3.0, 0.8 * m) or t_end - ring[first % cap, XW_T] < 0.5 * edge_s:
        return False
    sums = np.zeros(XE_IK2 + 1)
    roll = 0.0
    pitch = 0.0
    fm = np.zeros(3)
    for k in range(first, first + m):
        r = k % cap
        if ring[r, XW_OK] > 0.0:
            sums[XE_T] += ring[r, XW_T]
            for c in range(XE_IPHI, XE_IK2 + 1):  # XE_IPHI..XE_IK2 are XW_IPHI..XW_IK2
                sums[c] += ring[r, c]
            rr, pp = roll_pitch(ring[r, XW_F0], ring[r, XW_F1], ring[r, XW_F2])
            roll += rr
            pitch += pp
            for c in range(3):
                fm[c] += ring[r, XW_F0 + c]
    for c in range(XE_IK2 + 1):
        e[c] = sums[c] / n_ok
    e[XE_ROLL] = roll / n_ok
    e[XE_PITCH] = pitch / n_ok
    for c in range(3):
        fm[c] /= n_ok
    norm = math.sqrt(fm[0] * fm[0] + fm[1] * fm[1] + fm[2] * fm[2])
    e[XE_NORM] = norm
    e[XE_TILT] = math.degrees(math.acos(max(-1.0, min(1.0, -fm[2] / norm))))
    spread = 0.0
    for c in range(3):
        ss = 0.0
        for k in range(first, first + m):
            r = k % cap
            if ring[r, XW_OK] > 0.0:
                d = ring[r, XW_F0 + c] - fm[c]
                ss += d * d
        spread = max(spread, math.sqrt(ss / n_ok))
    e[XE_SPREAD] = spread
    e[XE_N] = n_ok
    return True


# ------------------------------------------------------- interval decision


@jit(inline=True)
def refusal(bad, start_ok, end_ok, start, end, turning, xc):
    """The first gate that refuses an interval (XG_* code), or XG_NONE: ``gap`` (a gap or
    held cell), ``accel`` (an edge unusable, its specific force off 1 g or unsteady),
    ``tilt`` (an edge tilted beyond the limit), ``turning`` (a turning row). The residual
    gate comes after the measurement (:func:`residual_ok`)."""
    if bad:
        return XG_GAP
    if not (start_ok and end_ok):
        return XG_ACCEL
    for e in (start, end):
        if abs(e[XE_NORM] - 1.0) > xc[XC_NORM_TOL] or e[XE_SPREAD] > xc[XC_SPREAD]:
            return XG_ACCEL
    if max(start[XE_TILT], end[XE_TILT]) > xc[XC_MAX_TILT]:
        return XG_TILT
    if turning:
        return XG_TURNING
    return XG_NONE


@jit
def measurement(start, end, gyro_noise, acc_noise):
    """The drift measurements of x and y between two edges (the analogue of eqs. 4 and 6:
    ``docs/heading_and_axes.md``, "Measurement"), their row of H and variances.

    Returns (m_x, m_y (deg/s), h_T (degC), h_T' (degC/s), r_x, r_y ((deg/s)²), Δt (s)).
    """
    dt = end[XE_T] - start[XE_T]
    M_phi = (end[XE_IPHI] - start[XE_IPHI] - (end[XE_ROLL] - start[XE_ROLL])) / dt
    M_th = (end[XE_ITH] - start[XE_ITH] - (end[XE_PITCH] - start[XE_PITCH])) / dt
    k1 = (end[XE_IK1] - start[XE_IK1]) / dt
    k2 = (end[XE_IK2] - start[XE_IK2]) / dt
    m_y = M_th / k2
    m_x = M_phi - k1 * m_y
    h_T = (end[XE_IT] - start[XE_IT]) / dt
    h_Tp = (end[XE_ITP] - start[XE_ITP]) / dt
    var_edge = (math.degrees(max(acc_noise, start[XE_SPREAD])) ** 2 / start[XE_N]
                + math.degrees(max(acc_noise, end[XE_SPREAD])) ** 2 / end[XE_N])
    r_angle = gyro_noise**2 / dt + var_edge / dt**2
    r_y = r_angle / k2**2
    r_x = r_angle + k1**2 * r_y
    return m_x, m_y, h_T, h_Tp, r_x, r_y, dt


@jit
def residual_ok(m, h, r, dt, params, cov, rates, held, relock, residual_deg, residual_k):
    """The residual gate of one axis with lock-out recovery: accepted when the
    disagreement ``(m − h·x)Δt`` (deg) is within ``max(residual_deg, residual_k
    sqrt(h P hᵀ + r) Δt)``, or when it is the ``relock``-th refusal in a row that agrees
    with those before (:func:`gyrodrift.kernels.aiding.steady_disagreement`; ``rates``,
    ``held``). Returns (accepted, refusals now held)."""
    resid = (m - (h[0] * params[0] + h[1] * params[1] + h[2] * params[2])) * dt
    Ph = matvec(cov, h)
    s = h[0] * Ph[0] + h[1] * Ph[1] + h[2] * Ph[2] + r
    limit = max(residual_deg, residual_k * math.sqrt(max(s, 0.0)) * dt)
    if abs(resid) <= limit:
        return True, 0
    accept, held = steady_disagreement(resid / dt, rates, held, relock)
    if accept:
        held = 0
    return accept, held


@jit(inline=True)
def _hold(axis, xf, xi, xk, ef, ei):
    """A refused interval for one axis: the filter's hold, or the caller's (PENDING_HOLD)."""
    if xk[XK_EXTERNAL + axis] == 1:
        xi[XI_PENDING + axis] = PENDING_HOLD
        return
    kalman.hold(ef, ei, 1.0)
    kalman.put_state(ef, ei, xf, XF_PARAMS + 3 * axis, XF_COV + 9 * axis)


@jit(inline=True)
def _update(axis, m, h, r, xf, xi, xk, ef, ei):
    """An accepted measurement ``m = h x + v``, ``v ~ N(0, r)``, for one axis: the filter's
    update, or the caller's (PENDING_UPDATE, the measurement in ``xf[XF_MEAS..]``)."""
    xi[XI_UPDATES + axis] += 1
    if xk[XK_EXTERNAL + axis] == 1:
        q = XF_MEAS + 4 * axis
        xf[q] = m
        xf[q + 1] = h[0]
        xf[q + 2] = h[1]
        xf[q + 3] = r
        xi[XI_PENDING + axis] = PENDING_UPDATE
        return
    y = np.empty(1)
    y[0] = m
    H = np.empty((1, 3))
    H[0, :] = h
    R = np.empty((1, 1))
    R[0, 0] = r
    kalman.update(ef, ei, y, H, R)
    kalman.put_state(ef, ei, xf, XF_PARAMS + 3 * axis, XF_COV + 9 * axis)


@jit(inline=True)
def close(ring, xf, xi, xc, xk, ef_x, ei_x, ef_y, ei_y):
    """Decide the interval that ends at the ring's newest row: its end edge (the next
    interval's start edge), the gates, and per axis the update or hold. Sets
    ``xi[XI_GATED]`` and counts refusals by reason (not for the first interval, which has
    no start edge) and updates per axis."""
    end = np.empty(N_XE)
    end_ok = edge_window(ring, xi[XI_HEAD], xi[XI_N], xc[XC_EDGE_S], end)
    start = xf[XF_EDGE:XF_EDGE + N_XE].copy()
    start_ok = xi[XI_EDGE_OK] == 1
    xf[XF_EDGE:XF_EDGE + N_XE] = end
    xi[XI_EDGE_OK] = 1 if end_ok else 0
    first = xi[XI_DECIDED] == 0
    xi[XI_DECIDED] = 1
    reason = refusal(xi[XI_BAD] == 1, start_ok, end_ok, start, end, xi[XI_TURNING] == 1, xc)
    if reason != XG_NONE:
        if not first:
            xi[XI_REASONS + reason] += 1
        _hold(0, xf, xi, xk, ef_x, ei_x)
        _hold(1, xf, xi, xk, ef_y, ei_y)
        xi[XI_GATED] = 1
        xi[XI_REFUSALS] = 0
        xi[XI_REFUSALS + 1] = 0
        return
    m_x, m_y, h_T, h_Tp, r_x, r_y, dt = measurement(start, end, xc[XC_GYRO_NOISE], xc[XC_ACC_NOISE])
    h = np.empty(3)
    h[0] = h_T
    h[1] = h_Tp
    h[2] = 1.0
    xf[XF_T_MEAS] = ring[(xi[XI_HEAD] + xi[XI_N] - 1) % ring.shape[0], XW_T]
    relock = xk[XK_RELOCK]
    size = max(relock, 1)
    refused = False
    for axis in range(2):
        m = m_x if axis == 0 else m_y
        r = r_x if axis == 0 else r_y
        ef = ef_x if axis == 0 else ef_y
        ei = ei_x if axis == 0 else ei_y
        params = xf[XF_PARAMS + 3 * axis:XF_PARAMS + 3 * axis + 3]
        cov = xf[XF_COV + 9 * axis:XF_COV + 9 * axis + 9].reshape((3, 3))
        rates = xf[XF_RELOCK + size * axis:XF_RELOCK + size * (axis + 1)]
        ok, held = residual_ok(m, h, r, dt, params, cov, rates, xi[XI_REFUSALS + axis], relock, xc[XC_RESID_DEG],
                               xc[XC_RESID_K])
        xi[XI_REFUSALS + axis] = held
        if ok:
            _update(axis, m, h, r, xf, xi, xk, ef, ei)
        else:
            _hold(axis, xf, xi, xk, ef, ei)
            refused = True
    if refused:
        xi[XI_REASONS + XG_RESIDUAL] += 1
    xi[XI_GATED] = 1 if refused else 0


# ------------------------------------------------------------------ rows


@jit
def _check(t, temp, xf, xi):
    """0, or XS_BAD_TIME when a time is not finite or does not increase (also from the last
    chunk), XS_NO_TEMP when the log's first row has no temperature."""
    prev = xf[XF_TLAST]
    for i in range(t.size):
        if not (math.isfinite(t[i]) and t[i] > prev):
            return XS_BAD_TIME
        prev = t[i]
    if xi[XI_STARTED] == 0 and not math.isfinite(temp[0]):
        return XS_NO_TEMP
    return 0


@jit(inline=True)
def _held(value, xf, slot):
    """``value``, or the last one held in ``xf[slot]`` when it is not finite; stored as
    the last. Returns (value, whether it was held)."""
    if math.isfinite(value):
        xf[slot] = value
        return value, False
    return xf[slot], True


@jit
def run(t, gx, gy, temp, temp_rate, acc, rate_z, i0, xf, xi, xc, xk, ring, ef_x, ei_x, ef_y, ei_y, out, gated):
    """Compensate rows ``i0..`` of a chunk; returns the next row to do (``t.size`` when
    done), or an XS_* status below 0 (then no row was taken).

    Parameters
    ----------
    t, gx, gy, temp, temp_rate, rate_z : (n,) float arrays
        Time (s, strictly increasing), raw gyro_x and gyro_y (deg/s), temperature (degC),
        T' (degC/s), compensated rate_z (deg/s); NaN gyro, temperature or T' holds the
        last value (the first three refuse the interval), NaN rate_z is 0.
    acc : (n, 3) float array
        Raw FRD specific force (g or m/s²).
    out : (4, n) float array
        Receives rate_x, rate_y, bias_x, bias_y (deg/s).
    gated : (n,) int8 array
        Receives ``tilt_gated``.

    Returns early, before row ``i``, when the ring is full (the caller grows it and calls
    again from ``i``), and after an interval end with a PENDING_* action for a Python
    estimator; the results are those of one call.
    """
    n = t.size
    if i0 == 0 and n > 0:
        status = _check(t, temp, xf, xi)
        if status < 0:
            return status
    interval = xc[XC_INTERVAL]
    max_gap = xc[XC_MAX_GAP]
    turn_win = xc[XC_TURN_WIN]
    turn_rate = xc[XC_TURN_RATE]
    keep_s = max(turn_win, xc[XC_EDGE_S])
    cap = ring.shape[0]
    I = xf[XF_I:XF_I + N_XU]
    U = xf[XF_U:XF_U + N_XU]
    u = np.empty(N_XU)
    for i in range(i0, n):
        if xi[XI_N] == cap:
            return i
        ti = t[i]
        first = xi[XI_STARTED] == 0
        if first:
            xf[XF_T0] = ti
            xf[XF_K] = 0.0
            xi[XI_STARTED] = 1
        g_x, bad = _held(gx[i], xf, XF_GX)
        g_y, held = _held(gy[i], xf, XF_GY)
        bad = bad or held
        T, held = _held(temp[i], xf, XF_TEMP)
        bad = bad or held
        Tp, held = _held(temp_rate[i], xf, XF_TP)
        dt = 0.0 if first else ti - xf[XF_TLAST]
        p = g_x if math.isfinite(g_x) else 0.0  # before the first value: 0, and the interval is refused
        q = g_y if math.isfinite(g_y) else 0.0
        bad = bad or dt > max_gap or not math.isfinite(g_x) or not math.isfinite(g_y)
        r = rate_z[i] if math.isfinite(rate_z[i]) else 0.0
        scale = xf[XF_SCALE]
        if math.isnan(scale):
            scale = acc_scale(acc[i, 0], acc[i, 1], acc[i, 2])
            xf[XF_SCALE] = scale
        f0, f1, f2, ok = specific_force(acc[i, 0], acc[i, 1], acc[i, 2], scale)
        phi_dot, theta_dot, k1, cphi = euler_rates(f0, f1, f2, p, q, r)
        u[0] = phi_dot
        u[1] = theta_dot
        u[2] = T
        u[3] = Tp
        u[4] = k1
        u[5] = cphi
        u[6] = p
        u[7] = q
        u[8] = r
        for k in range(N_XU):  # trapezoid rule
            I[k] = 0.5 * (u[k] + (u[k] if first else U[k])) * dt + I[k]
            U[k] = u[k]
        xf[XF_TLAST] = ti
        row = (xi[XI_HEAD] + xi[XI_N]) % cap
        ring[row, XW_T] = ti
        ring[row, XW_IPHI:XW_IRZ + 1] = I
        ring[row, XW_F0] = f0
        ring[row, XW_F1] = f1
        ring[row, XW_F2] = f2
        ring[row, XW_OK] = 1.0 if ok else 0.0
        xi[XI_N] += 1
        b_x = bias(xf[XF_PARAMS], xf[XF_PARAMS + 1], xf[XF_PARAMS + 2], T, Tp)
        b_y = bias(xf[XF_PARAMS + 3], xf[XF_PARAMS + 4], xf[XF_PARAMS + 5], T, Tp)
        out[0, i] = g_x - b_x
        out[1, i] = g_y - b_y
        out[2, i] = b_x
        out[3, i] = b_y
        if bad:
            xi[XI_BAD] = 1
        window_step(ring, xf, xi, turn_win, turn_rate, keep_s)
        k = math.floor((ti - xf[XF_T0]) / interval)
        closes = k > xf[XF_K]
        xf[XF_K] = k
        if closes:  # the boundary row keeps the old parameters, shows the decision and opens the next interval
            close(ring, xf, xi, xc, xk, ef_x, ei_x, ef_y, ei_y)
            xi[XI_HEAD] = row
            xi[XI_N] = 1
            xi[XI_TURN_J] = 0
            xi[XI_BAD] = 0
            xi[XI_TURNING] = 0
        gated[i] = xi[XI_GATED]
        if closes and (xi[XI_PENDING] != 0 or xi[XI_PENDING + 1] != 0):
            return i + 1
    return n

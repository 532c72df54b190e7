"""Gravity direction from the gyro, aided by the accelerometer: the tilt of the raw compass.

A Kalman filter whose state is the down unit vector (body FRD), the three gyro offsets and the
platform's forward speed: the down vector is propagated with the body rates, its covariance
grown by the gyro's noise, its scale and cross-axis errors (with the angle turned) and the
offsets' uncertainty; the accelerometer's down measures it, less the centripetal part of a body
moving forward while it turns about the vertical, and is taken when its innovation is believable
against the covariance. Eq. (1)-(6), the constants and the reasons: ``docs/heading_and_axes.md``
(gyro-aided tilt). With the tilt the filter also gives the heading rate of a tilted body
(:func:`propagate`; ``docs/heading_and_axes.md``, "The heading rate of a tilted body").
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift._columns import read_only_floats
from gyrodrift.kernels import jit

__all__ = [
    "MAX_RATE_DPS", "RELOCK_S", "TURN_MIN_DPS", "TURN_AXIS_DEG", "MAX_GAP_S", "MAX_BIAS_DPS",
    "MIN_COS2_PITCH", "LEARNED_S", "ACC_NOISE0_DEG", "NOISE_TAU_S", "MOTION_SD_DEG", "MOTION_TAU_S", "ARW_DEG",
    "ROTATION_SD", "BIAS_SD0_DPS", "BIAS_RW_DPS", "SPEED_SD0_MPS", "SPEED_RW_MPS", "TILT_SD0_DEG", "GATE_NIS",
    "LEAN_SIGMAS",
    "new_state", "propagate", "tilt_sd_deg", "gravity_down", "GravityFilter", "RawTilt", "accel_down",
    "TILT_SOURCES",
]

#: Largest gyro rate (norm of the three axes) at which a refused accelerometer counts towards
#: RELOCK_S, deg/s.
MAX_RATE_DPS = 10.0
#: Refusals of the accelerometer that outlast its acceptances by this long, s, mean the tilt is
#: lost: it starts again from the accelerometer.
RELOCK_S = 20.0
#: A body turning at least this fast (deg/s, bias removed) about its tilt's vertical, within
#: TURN_AXIS_DEG, is in a turn: its refusals do not count towards RELOCK_S.
TURN_MIN_DPS = 1.0
TURN_AXIS_DEG = 10.0
#: A time step longer than this restarts the tilt from the accelerometer, s.
MAX_GAP_S = 1.0
#: The learned gyro offsets are kept within ± this per axis, deg/s.
MAX_BIAS_DPS = 5.0

#: Floor of cos² of the pitch in the heading rate's denominator: beyond 60° of pitch the
#: heading (an Euler angle) is near its singularity, and the rate is taken as at 60°.
MIN_COS2_PITCH = 0.25

#: Time with the accelerometer taken after which the x/y offsets count as learned, s: before
#: it, the heading rate of a tilted body takes the tilt in by the share of this time passed
#: (:func:`_heading_rate`).
LEARNED_S = 16.0

#: The accelerometer's white noise before it is measured, deg (one axis across gravity), and the
#: time constant of its measurement, s.
ACC_NOISE0_DEG = 0.5
NOISE_TAU_S = 2.0
#: The platform's acceleration the model does not name, as a tilt, deg, and its correlation
#: time, s: the accelerometer tells as much as one independent sample every 2·MOTION_TAU_S.
MOTION_SD_DEG = 0.5
MOTION_TAU_S = 1.0
#: The gyro's angle random walk, deg/√s, and its error with the angle turned (scale factor,
#: cross-axis sensitivity and misalignment), sd per √rad turned.
ARW_DEG = 0.05
ROTATION_SD = 0.01
#: The x/y/z offsets: sd at the start, deg/s, and their random walk, deg/s/√s.
BIAS_SD0_DPS = 1.0
BIAS_RW_DPS = 0.01
#: The forward speed whose turns make the centripetal acceleration: sd at the start, m/s
#: (mean 0), and its random walk, m/s/√s.
SPEED_SD0_MPS = 20.0
SPEED_RW_MPS = 0.5
#: The tilt's sd, deg, when it starts from the accelerometer (with the noise measured so far).
TILT_SD0_DEG = 2.0
#: The accelerometer is taken when its normalised innovation squared is at most this
#: (chi-squared with 2 degrees of freedom at 99.73 %: three sigma).
GATE_NIS = 11.83
#: The centripetal part (eq. 3) is predicted only where the rate about down is beyond this many
#: standard deviations of the offsets' own uncertainty about down: a rate an unlearned offset
#: could make is no turn (on a straight, a z offset times the speed would lean the prediction).
LEAN_SIGMAS = 3.0

_GRAVITY_MPS2 = 9.80665

# State array layout.
_D = 0  # 0..2: down unit vector, body FRD
_B = 3  # 3..5: gyro offsets, rad/s
_T = 6  # previous row's time, s
_STARTED = 7  # 1 once the first accelerometer row was taken
_G = 8  # 1 g in the log's accelerometer unit
_LOST = 9  # refused time less accepted time, at least 0, s
_W = 10  # 10..12: the last finite gyro rate, deg/s (NaN cells hold it)
_ACCEPTED = 13  # time with the accelerometer taken, s
_NOISE = 14  # the accelerometer's white noise, per axis across gravity, rad² (measured)
_M = 15  # 15..17: the last accelerometer down, carried with the gyro (NaN: none yet)
_V = 18  # forward speed, m/s
_NX = 7  # the filter's states: down (3), offsets (3), forward speed
_P = 19  # 19..67: their covariance, 7 x 7 row-major (down dimensionless, offsets rad/s, speed m/s)
_N_STATE = _P + _NX * _NX


def new_state() -> np.ndarray:
    """A fresh filter state (nothing seen yet)."""
    s = np.zeros(_N_STATE)
    s[_D:_D + 3] = math.nan
    s[_T] = math.nan
    s[_M:_M + 3] = math.nan
    return s


def tilt_sd_deg(state: np.ndarray) -> float:
    """The tilt's standard deviation in ``state``, deg, per axis across gravity (NaN before
    the filter started)."""
    if not state[_STARTED]:
        return math.nan
    p = state[_P:_P + _NX * _NX].reshape(_NX, _NX)
    return math.degrees(math.sqrt(max(float(np.trace(p[:3, :3])) / 2.0, 0.0)))


@jit
def _about_the_vertical(w0, w1, w2, d0, d1, d2):
    """Whether the body turns (at least ``TURN_MIN_DPS``, bias removed; rad/s in) about the axis
    its tilt ``d`` calls vertical, within ``TURN_AXIS_DEG``: a turn, in which the accelerometer
    reads the turn's centripetal part, not a wrong tilt (a steady turn of a body that keeps
    its tilt is about the vertical)."""
    wn = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if wn < math.radians(TURN_MIN_DPS):
        return False
    return abs(w0 * d0 + w1 * d1 + w2 * d2) >= wn * math.cos(math.radians(TURN_AXIS_DEG))


@jit
def _heading_rate(i, gz, state, out, rate_out):
    """Row ``i``'s heading rate into ``rate_out[i]``: the rate of the heading (the Euler yaw
    of a ZYX body), deg/s, from the row's z rate ``gz``, the held pitch-axis rate less the y
    offset the filter learned, and the row's down vector ``d = (−sin θ, sin φ cos θ, cos φ cos θ)``:

        ψ̇ = (q sin φ + r cos φ) / cos θ = (q d₁ + r d₂) / (d₁² + d₂²)

    (cos² θ floored at :data:`MIN_COS2_PITCH`). While the offsets are learned it is blended from
    ``gz`` with the weight ``w`` = accepted time / :data:`LEARNED_S` (at most 1), so that the
    drift the model follows changes smoothly as the tilt becomes known; or, where larger, the
    weight of least expected square error, ``1 − var / Δ²`` (``Δ`` = ψ̇ − gz, ``var`` the Euler
    rate's variance from the tilt's and the y offset's covariance): where the filter's own
    uncertainty says the Euler rate is far the better (a body shaken before the time is up).
    ``gz`` where the tilt is not known; NaN where ``gz`` is."""
    d1, d2 = out[i, 1], out[i, 2]
    w = min(state[_ACCEPTED] / LEARNED_S, 1.0)
    if state[_ACCEPTED] == 0.0 or not (d1 == d1 and d2 == d2):
        rate_out[i] = gz
        return
    q = state[_W + 1] - math.degrees(state[_B + 1])
    s2 = d1 * d1 + d2 * d2
    floored = s2 < MIN_COS2_PITCH
    s2 = max(s2, MIN_COS2_PITCH)
    euler = (q * d1 + gz * d2) / s2
    diff = euler - gz
    if w < 1.0 and diff != 0.0:  # the Euler rate's variance, (deg/s)², by its gradient in d₁, d₂ and b_y
        g1 = q / s2 - (0.0 if floored else 2.0 * d1 * euler / s2)
        g2 = gz / s2 - (0.0 if floored else 2.0 * d2 * euler / s2)
        gb = -math.degrees(1.0) * d1 / s2
        p = state[_P:_P + _NX * _NX].reshape((_NX, _NX))
        var = (g1 * g1 * p[1, 1] + 2.0 * g1 * g2 * p[1, 2] + g2 * g2 * p[2, 2]
               + 2.0 * gb * (g1 * p[1, 4] + g2 * p[2, 4]) + gb * gb * p[4, 4])
        w = max(w, 1.0 - max(var, 0.0) / (diff * diff))
    rate_out[i] = gz + w * diff


@jit
def _start(state, m0, m1, m2, all_states):
    """The tilt (re)started at the accelerometer's down ``m``, its covariance across ``m``;
    with ``all_states`` the offsets' and the speed's covariance too, and the speed at 0."""
    state[_D], state[_D + 1], state[_D + 2] = m0, m1, m2
    p = state[_P:_P + _NX * _NX].reshape((_NX, _NX))
    m = (m0, m1, m2)
    var = math.radians(TILT_SD0_DEG) ** 2 + state[_NOISE]
    for r in range(_NX):
        for c in range(_NX):
            if r < 3 and c < 3:
                p[r, c] = var * ((1.0 if r == c else 0.0) - m[r] * m[c])
            elif r < 3 or c < 3:
                p[r, c] = 0.0
            elif all_states:
                p[r, c] = 0.0 if r != c else (math.radians(BIAS_SD0_DPS) ** 2 if r < 6 else SPEED_SD0_MPS ** 2)
    if all_states:
        state[_V] = 0.0


@jit
def _inverse3(a, r, out):
    """``out`` = the inverse of ``a[:3, :3] + r·I`` (``a`` symmetric)."""
    a00, a01, a02 = a[0, 0] + r, a[0, 1], a[0, 2]
    a11, a12, a22 = a[1, 1] + r, a[1, 2], a[2, 2] + r
    det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) + a02 * (a01 * a12 - a11 * a02)
    out[0, 0] = (a11 * a22 - a12 * a12) / det
    out[0, 1] = out[1, 0] = (a02 * a12 - a01 * a22) / det
    out[0, 2] = out[2, 0] = (a01 * a12 - a02 * a11) / det
    out[1, 1] = (a00 * a22 - a02 * a02) / det
    out[1, 2] = out[2, 1] = (a02 * a01 - a00 * a12) / det
    out[2, 2] = (a00 * a11 - a01 * a01) / det


@jit
def _rotation(rot, r0, r1, r2):
    """``rot`` = the rotation matrix of the rotation vector ``r`` (rad; Rodrigues' formula)."""
    ang = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    if ang < 1e-12:
        rot[0, 0], rot[0, 1], rot[0, 2] = 1.0, -r2, r1
        rot[1, 0], rot[1, 1], rot[1, 2] = r2, 1.0, -r0
        rot[2, 0], rot[2, 1], rot[2, 2] = -r1, r0, 1.0
        return
    k0, k1, k2 = r0 / ang, r1 / ang, r2 / ang
    c, s = math.cos(ang), math.sin(ang)
    v = 1.0 - c
    rot[0, 0], rot[0, 1], rot[0, 2] = c + k0 * k0 * v, -k2 * s + k0 * k1 * v, k1 * s + k0 * k2 * v
    rot[1, 0], rot[1, 1], rot[1, 2] = k2 * s + k1 * k0 * v, c + k1 * k1 * v, -k0 * s + k1 * k2 * v
    rot[2, 0], rot[2, 1], rot[2, 2] = -k1 * s + k2 * k0 * v, k0 * s + k2 * k1 * v, c + k2 * k2 * v


@jit
def _predict(state, p, rot, top, w0, w1, w2, dt):
    """Eq. (1)-(2): ``d`` turned by the body rates ``w`` (rad/s, offsets removed) over ``dt``,
    the covariance ``p`` by ``F = [[R, G, 0], [0, I, 0], [0, 0, 1]]``, ``G = −dt·[d]×``, and
    the process noise; the carried accelerometer down turned with ``d``. Only the down rows
    and columns change: ``top`` = [R G] P[:6] (3 × 7), then ``P_dd = top[:, :6] [R G]ᵀ``.
    ``rot`` receives ``R``."""
    _rotation(rot, -w0 * dt, -w1 * dt, -w2 * dt)
    d0, d1, d2 = state[_D], state[_D + 1], state[_D + 2]
    g0, g1, g2 = (0.0, dt * d2, -dt * d1), (-dt * d2, 0.0, dt * d0), (dt * d1, -dt * d0, 0.0)
    for r in range(3):
        gr = g0 if r == 0 else (g1 if r == 1 else g2)
        for c in range(_NX):
            top[r, c] = (rot[r, 0] * p[0, c] + rot[r, 1] * p[1, c] + rot[r, 2] * p[2, c]
                         + gr[0] * p[3, c] + gr[1] * p[4, c] + gr[2] * p[5, c])
    for r in range(3):
        for c in range(3):
            gc = g0 if c == 0 else (g1 if c == 1 else g2)
            p[r, c] = (top[r, 0] * rot[c, 0] + top[r, 1] * rot[c, 1] + top[r, 2] * rot[c, 2]
                       + top[r, 3] * gc[0] + top[r, 4] * gc[1] + top[r, 5] * gc[2])
        for c in range(3, _NX):
            p[r, c] = top[r, c]
            p[c, r] = top[r, c]
    for k in (_D, _M):
        v0, v1, v2 = state[k], state[k + 1], state[k + 2]
        for r in range(3):
            state[k + r] = rot[r, 0] * v0 + rot[r, 1] * v1 + rot[r, 2] * v2
    n = math.sqrt(state[_D] ** 2 + state[_D + 1] ** 2 + state[_D + 2] ** 2)
    for r in range(3):
        state[_D + r] /= n
    qd = math.radians(ARW_DEG) ** 2 * dt + ROTATION_SD * ROTATION_SD * math.sqrt(w0 * w0 + w1 * w1 + w2 * w2) * dt
    for r in range(3):
        for c in range(3):
            p[r, c] += qd * ((1.0 if r == c else 0.0) - state[_D + r] * state[_D + c])
        p[r + 3, r + 3] += math.radians(BIAS_RW_DPS) ** 2 * dt
    p[6, 6] += SPEED_RW_MPS ** 2 * dt


@jit
def _project(p, h, ph, s):
    """``ph`` = P Hᵀ (7 × 3) and ``s`` = H P Hᵀ (3 × 3) of the measurement matrix
    ``H = [I, 0, h]`` (eq. 4; ``h`` the speed's column)."""
    for r in range(_NX):
        for c in range(3):
            ph[r, c] = p[r, c] + p[r, 6] * h[c]
    for r in range(3):
        for c in range(3):
            s[r, c] = ph[r, c] + h[r] * ph[6, c]


@jit
def _update(state, p, y, s, s_inv, ph, gain, r_var):
    """Eq. (4): the state and covariance ``p`` updated with the innovation ``y``, given
    ``ph`` = P Hᵀ and ``s`` = H P Hᵀ (:func:`_project`) and the noise ``r_var·I``; ``p`` kept
    symmetric (the mean of its two triangles)."""
    _inverse3(s, r_var, s_inv)
    for r in range(_NX):
        for c in range(3):
            gain[r, c] = ph[r, 0] * s_inv[0, c] + ph[r, 1] * s_inv[1, c] + ph[r, 2] * s_inv[2, c]
    max_b = math.radians(MAX_BIAS_DPS)
    for r in range(_NX):
        dx = gain[r, 0] * y[0] + gain[r, 1] * y[1] + gain[r, 2] * y[2]
        if r < 3:
            state[_D + r] += dx
        elif r < 6:
            state[_B + r - 3] = min(max(state[_B + r - 3] + dx, -max_b), max_b)
        else:
            state[_V] += dx
    for r in range(_NX):
        for c in range(r, _NX):
            upper = p[r, c] - (gain[r, 0] * ph[c, 0] + gain[r, 1] * ph[c, 1] + gain[r, 2] * ph[c, 2])
            lower = p[c, r] - (gain[c, 0] * ph[r, 0] + gain[c, 1] * ph[r, 1] + gain[c, 2] * ph[r, 2])
            p[r, c] = p[c, r] = 0.5 * (upper + lower)


@jit
def _renormalise(state, p):
    """``d`` back on the unit sphere and its covariance kept across it: ``J P J'`` with
    ``J = I − d d'`` on the down rows and columns."""
    n = math.sqrt(state[_D] ** 2 + state[_D + 1] ** 2 + state[_D + 2] ** 2)
    d0, d1, d2 = state[_D] / n, state[_D + 1] / n, state[_D + 2] / n
    state[_D], state[_D + 1], state[_D + 2] = d0, d1, d2
    for c in range(_NX):
        s = d0 * p[0, c] + d1 * p[1, c] + d2 * p[2, c]
        p[0, c] -= d0 * s
        p[1, c] -= d1 * s
        p[2, c] -= d2 * s
    for r in range(_NX):
        s = p[r, 0] * d0 + p[r, 1] * d1 + p[r, 2] * d2
        p[r, 0] -= s * d0
        p[r, 1] -= s * d1
        p[r, 2] -= s * d2


@jit
def propagate(t, gx, gy, gz, acc, state, out, rate_out):
    """Run the filter over rows; write each row's down unit vector (body FRD) to ``out`` (n, 3)
    and its heading rate (deg/s) to ``rate_out`` (n,).

    ``t`` (s, increasing, also across calls); raw gyro rates ``gx, gy, gz`` (deg/s, FRD; NaN
    holds the previous value); specific force ``acc`` (n, 3; g or m/s², FRD; NaN: not used);
    ``state`` from :func:`new_state`, updated in place. ``out`` is NaN before the first
    finite accelerometer row. The heading rate (:func:`_heading_rate`) takes the row's
    ``gz`` (NaN stays NaN: the engine holds it), the held ``gy`` less the learned y offset and
    the row's down vector, blended in from ``gz`` as the offsets are learned (:data:`LEARNED_S`),
    or sooner where the filter's covariance says the Euler rate is far the better.
    """
    rot = np.empty((3, 3))
    top = np.empty((3, _NX))
    ph = np.empty((_NX, 3))
    gain = np.empty((_NX, 3))
    s_inv = np.empty((3, 3))
    h = np.empty(3)
    s = np.empty((3, 3))
    y = np.empty(3)
    p = state[_P:_P + _NX * _NX].reshape((_NX, _NX))
    motion_var = math.radians(MOTION_SD_DEG) ** 2
    for i in range(t.size):
        if math.isfinite(gx[i]):
            state[_W] = gx[i]
        if math.isfinite(gy[i]):
            state[_W + 1] = gy[i]
        if math.isfinite(gz[i]):
            state[_W + 2] = gz[i]
        f0, f1, f2 = acc[i, 0], acc[i, 1], acc[i, 2]
        fn = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
        have_acc = math.isfinite(fn) and fn > 0.0
        dt = t[i] - state[_T]
        if state[_STARTED] == 0.0 or not dt <= MAX_GAP_S:
            if have_acc:
                first = state[_STARTED] == 0.0
                if first:
                    state[_G] = _GRAVITY_MPS2 if fn > 3.0 else 1.0
                    state[_NOISE] = math.radians(ACC_NOISE0_DEG) ** 2
                _start(state, -f0 / fn, -f1 / fn, -f2 / fn, first)
                state[_M], state[_M + 1], state[_M + 2] = -f0 / fn, -f1 / fn, -f2 / fn
                state[_STARTED] = 1.0
                state[_LOST] = 0.0
            state[_T] = t[i]
            for k in range(3):
                out[i, k] = state[_D + k]
            _heading_rate(i, gz[i], state, out, rate_out)
            continue
        state[_T] = t[i]
        w0 = math.radians(state[_W]) - state[_B]
        w1 = math.radians(state[_W + 1]) - state[_B + 1]
        w2 = math.radians(state[_W + 2]) - state[_B + 2]
        _predict(state, p, rot, top, w0, w1, w2, dt)
        if have_acc:
            m0, m1, m2 = -f0 / fn, -f1 / fn, -f2 / fn
            if state[_M] == state[_M]:  # eq. (6): the accelerometer's noise from its change the gyro does not explain
                change = ((m0 - state[_M]) ** 2 + (m1 - state[_M + 1]) ** 2 + (m2 - state[_M + 2]) ** 2) / 4.0
                state[_NOISE] += dt / (dt + NOISE_TAU_S) * (change - state[_NOISE])
            state[_M], state[_M + 1], state[_M + 2] = m0, m1, m2
            d0, d1, d2 = state[_D], state[_D + 1], state[_D + 2]
            quiet = math.sqrt(state[_W] ** 2 + state[_W + 1] ** 2 + state[_W + 2] ** 2) <= MAX_RATE_DPS
            # eq. (3): m = d − (r_d V / g)(d × e_x), r_d = (ω − b)·d the rate about down, made a
            # unit vector; H its derivative in d and V to first order (the lean's own change with
            # d is second order; its change with b is left to the offsets' own measurement); no
            # lean where r_d is within LEAN_SIGMAS of what the offsets' uncertainty could make
            dv = (d0, d1, d2)
            rate_d = w0 * d0 + w1 * d1 + w2 * d2
            var_bd = 0.0  # the offsets' variance about down: a rate within LEAN_SIGMAS of it is no turn
            for r in range(3):
                for c in range(3):
                    var_bd += dv[r] * p[3 + r, 3 + c] * dv[c]
            rd_g = 0.0 if rate_d * rate_d <= LEAN_SIGMAS * LEAN_SIGMAS * var_bd else rate_d / _GRAVITY_MPS2
            u = (0.0, d2, -d1)  # d × e_x
            lean = rd_g * state[_V]
            scale = 1.0 / math.sqrt(1.0 + lean * lean * (d1 * d1 + d2 * d2))
            for r in range(3):
                h[r] = -rd_g * u[r]
                y[r] = (m0, m1, m2)[r] - (dv[r] - lean * u[r]) * scale
            # the norm's departure from what eq. (3) names (1 g, and the turn's lean): an
            # acceleration at least that large, of unknown direction, as a tilt of as many
            # radians (eq. 4's noise, not a gate)
            excess = fn / state[_G] - math.sqrt(1.0 + lean * lean)
            accel_var = motion_var + excess * excess
            _project(p, h, ph, s)  # eq. (5): the gate, on one sample's own spread
            _inverse3(s, state[_NOISE] + accel_var, s_inv)
            nis = 0.0
            for r in range(3):
                for c in range(3):
                    nis += y[r] * s_inv[r, c] * y[c]
            within = nis <= GATE_NIS
            if within:
                state[_LOST] = max(state[_LOST] - dt, 0.0)
            elif quiet and not _about_the_vertical(w0, w1, w2, d0, d1, d2):
                state[_LOST] += dt
            if state[_LOST] >= RELOCK_S:  # the tilt is lost: it starts again from the accelerometer
                state[_LOST] = 0.0
                _start(state, m0, m1, m2, True)
            elif within:
                state[_ACCEPTED] += dt
                # eq. (4): the motion's share of the noise as one sample every 2·MOTION_TAU_S
                r_var = state[_NOISE] + accel_var * max(1.0, 2.0 * MOTION_TAU_S / max(dt, 1e-3))
                _update(state, p, y, s, s_inv, ph, gain, r_var)
        _renormalise(state, p)
        for k in range(3):
            out[i, k] = state[_D + k]
        _heading_rate(i, gz[i], state, out, rate_out)


class GravityFilter:
    """The gravity filter, resumable: chunks or rows in time order."""

    def __init__(self):
        self.state = new_state()

    @property
    def accepted_s(self) -> float:
        """How long the accelerometer has been accepted so far, s (:data:`LEARNED_S`)."""
        return float(self.state[_ACCEPTED])

    @property
    def tilt_sd_deg(self) -> float:
        """The tilt's standard deviation now, deg per axis across gravity (:func:`tilt_sd_deg`)."""
        return tilt_sd_deg(self.state)

    @property
    def speed_mps(self) -> float:
        """The forward speed whose turns make the accelerometer lean, learned so far, m/s (eq. 3)."""
        return float(self.state[_V])

    def feed(self, t, gyro_x_dps, gyro_y_dps, gyro_z_dps, acc) -> np.ndarray:
        """Down unit vectors (n, 3), body FRD, of these rows (see :func:`propagate`)."""
        return self.run(t, gyro_x_dps, gyro_y_dps, gyro_z_dps, acc)[0]

    def run(self, t, gyro_x_dps, gyro_y_dps, gyro_z_dps, acc) -> tuple[np.ndarray, np.ndarray]:
        """Down unit vectors (n, 3), body FRD, and heading rates (n,), deg/s, of these rows
        (see :func:`propagate`)."""
        t = read_only_floats(t)
        acc = read_only_floats(np.asarray(acc, dtype=float).reshape(-1, 3))
        out = np.empty((t.size, 3))
        rate = np.empty(t.size)
        propagate(t, read_only_floats(gyro_x_dps), read_only_floats(gyro_y_dps), read_only_floats(gyro_z_dps), acc,
                  self.state, out, rate)
        return out, rate


def gravity_down(t, gyro_x_dps, gyro_y_dps, gyro_z_dps, acc) -> np.ndarray:
    """Down unit vectors (n, 3) of a whole log (a fresh :class:`GravityFilter`)."""
    return GravityFilter().feed(t, gyro_x_dps, gyro_y_dps, gyro_z_dps, acc)


def accel_down(acc) -> np.ndarray:
    """The accelerometer's down unit vectors (n, 3), ``-f/|f|``: the tilt without the gyro."""
    acc = np.asarray(acc, dtype=float).reshape(-1, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        return -acc / np.linalg.norm(acc, axis=1)[:, None]


#: Names of the tilt sources (``CompensatorConfig.tilt``).
TILT_SOURCES = ("gyro", "accel")


class RawTilt:
    """The tilt of a raw compass (``mag_x..z`` + ``acc_x..z``) for one log: which one, and its note.

    ``tilt`` ``"gyro"``: the gyro-aided gravity of :class:`GravityFilter` when the log has
    ``gyro_x`` and ``gyro_y`` (``gyro_xy``; then ``uses_gyro``); ``"accel"``: the
    accelerometer alone. ``source`` names the log in the note.
    """

    def __init__(self, tilt: str, gyro_xy: bool, source: str = "log"):
        self.gyro_xy = bool(gyro_xy)
        self.uses_gyro = tilt == "gyro" and self.gyro_xy
        self.source = source

    def note(self) -> str:
        """One line for ``attrs["notes"]``: which tilt the raw compass was compensated with."""
        if self.uses_gyro:
            return (f"{self.source}: compass tilt from the gyro-aided gravity (gyro_x, gyro_y, gyro_z "
                    "corrected by the accelerometer where it is believable; gyrodrift.attitude)")
        why = "tilt = 'accel'" if self.gyro_xy else "no gyro_x, gyro_y"
        return (f"{self.source}: compass tilt from the accelerometer alone ({why}): braking and cornering "
                "tilt the heading")

"""Gravity direction from the gyro, aided by the accelerometer: the tilt of the raw compass.

The down vector is propagated with the body rates and corrected towards the accelerometer
only when it is believable: a complementary filter with an integral term (Mahony, Hamel and
Pflimlin, IEEE TAC 2008) reduced to the gravity vector. Eq. (1)-(4), the gates and their
constants: ``docs/heading_and_axes.md`` (gyro-aided tilt). With the tilt the filter also gives
the heading rate of a tilted body (:func:`propagate`; ``docs/heading_and_axes.md``, "The heading
rate of a tilted body").
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift._columns import read_only_floats
from gyrodrift.kernels import jit

__all__ = [
    "TAU_S", "K_I", "NORM_TOL", "MAX_RATE_DPS", "ANGLE_GATE_DEG", "RELOCK_S", "TURN_MIN_DPS", "TURN_AXIS_DEG",
    "STARTUP_S", "MAX_GAP_S", "MAX_BIAS_DPS", "MIN_COS2_PITCH", "LEARNED_S", "new_state", "propagate", "gravity_down",
    "GravityFilter", "RawTilt", "accel_down",
    "TILT_SOURCES",
]

#: Time constant of the accelerometer correction, s (k_P = 1/TAU_S, eq. 2).
TAU_S = 2.0
#: After the first row, the angle gate is open this long, s (while the bias is learned).
STARTUP_S = 20.0
#: Integral gain of eq. (4), 1/s²: k_P²/4 (critically damped).
K_I = 0.25 / TAU_S**2
#: Tolerance of the specific force's norm about 1 g (fraction of g).
NORM_TOL = 0.05
#: Largest gyro rate (norm of the three axes) at which the accelerometer is used when it
#: disagrees with the tilt (the start-up phase and the relock), deg/s.
MAX_RATE_DPS = 10.0
#: Largest angle between the accelerometer's down and the propagated one that is accepted, deg.
ANGLE_GATE_DEG = 2.0
#: Disagreements beyond ANGLE_GATE_DEG, with the other gates passed, that outlast the agreements
#: by this long, s, mean the tilt is lost: it starts again from the accelerometer.
RELOCK_S = 20.0
#: A body turning at least this fast (deg/s, bias removed) about its tilt's vertical, within
#: TURN_AXIS_DEG, is in a turn: its disagreement does not count towards RELOCK_S.
TURN_MIN_DPS = 1.0
TURN_AXIS_DEG = 10.0
#: A time step longer than this restarts the filter from the accelerometer, s.
MAX_GAP_S = 1.0
#: The learned gyro bias is kept within ± this per axis, deg/s.
MAX_BIAS_DPS = 5.0

#: Floor of cos² of the pitch in the heading rate's denominator: beyond 60° of pitch the
#: heading (an Euler angle) is near its singularity, and the rate is taken as at 60°.
MIN_COS2_PITCH = 0.25

#: Time with the accelerometer accepted after which the bias across gravity counts as learned
#: (the integral term's settling time, 4/ω_n = 8·TAU_S), s: before it, the tilt of a body
#: whose x/y gyros have an unknown offset is not good enough for the heading rate, which
#: takes it in by the share of this time passed (:func:`_heading_rate`).
LEARNED_S = 8.0 * TAU_S

# State array layout.
_D = 0  # 0..2: down unit vector, body FRD
_B = 3  # 3..5: gyro bias, rad/s
_T = 6  # previous row's time, s
_STARTED = 7  # 1 once the first accelerometer row was taken
_G = 8  # 1 g in the log's accelerometer unit
_LOST = 9  # disagreeing time less agreeing time, at least 0, s
_W = 10  # 10..12: the last finite gyro rate, deg/s (NaN cells hold it)
_T0 = 13  # time of the first row taken, s
_ACCEPTED = 14  # time with the accelerometer accepted, s
_RELOCKED = 15  # time of the last restart from a lost tilt, s (NaN: none)
_N_STATE = 16


def new_state() -> np.ndarray:
    """A fresh filter state (nothing seen yet)."""
    s = np.zeros(_N_STATE)
    s[_D:_D + 3] = math.nan
    s[_T] = math.nan
    s[_RELOCKED] = math.nan
    return s


@jit
def _rotate(v0, v1, v2, r0, r1, r2):
    """``v`` rotated by the rotation vector ``r`` (rad; Rodrigues' formula)."""
    ang = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    if ang < 1e-12:
        return v0 + (r1 * v2 - r2 * v1), v1 + (r2 * v0 - r0 * v2), v2 + (r0 * v1 - r1 * v0)
    k0, k1, k2 = r0 / ang, r1 / ang, r2 / ang
    c, s = math.cos(ang), math.sin(ang)
    kv = k0 * v0 + k1 * v1 + k2 * v2
    x0 = v0 * c + (k1 * v2 - k2 * v1) * s + k0 * kv * (1.0 - c)
    x1 = v1 * c + (k2 * v0 - k0 * v2) * s + k1 * kv * (1.0 - c)
    x2 = v2 * c + (k0 * v1 - k1 * v0) * s + k2 * kv * (1.0 - c)
    return x0, x1, x2


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
    part of the bias across gravity the filter learned, and the row's down vector
    ``d = (−sin θ, sin φ cos θ, cos φ cos θ)``:

        ψ̇ = (q sin φ + r cos φ) / cos θ = (q d₁ + r d₂) / (d₁² + d₂²)

    (cos² θ floored at :data:`MIN_COS2_PITCH`). While the bias is learned it is blended from
    ``gz`` with the weight ``w`` = accepted time / :data:`LEARNED_S` (at most 1), so that the
    drift the model follows changes smoothly as the tilt becomes known. ``gz`` where the tilt
    is not known; NaN where ``gz`` is."""
    d1, d2 = out[i, 1], out[i, 2]
    w = min(state[_ACCEPTED] / LEARNED_S, 1.0)
    if w == 0.0 or not (d1 == d1 and d2 == d2):
        rate_out[i] = gz
        return
    q = state[_W + 1] - math.degrees(state[_B + 1])
    rate_out[i] = gz + w * ((q * d1 + gz * d2) / max(d1 * d1 + d2 * d2, MIN_COS2_PITCH) - gz)


@jit
def propagate(t, gx, gy, gz, acc, state, out, rate_out):
    """Run the filter over rows; write each row's down unit vector (body FRD) to ``out`` (n, 3)
    and its heading rate (deg/s) to ``rate_out`` (n,).

    ``t`` (s, increasing, also across calls); raw gyro rates ``gx, gy, gz`` (deg/s, FRD; NaN
    holds the previous value); specific force ``acc`` (n, 3; g or m/s², FRD; NaN: not used);
    ``state`` from :func:`new_state`, updated in place. ``out`` is NaN before the first
    finite accelerometer row. The heading rate (:func:`_heading_rate`) takes the row's
    ``gz`` (NaN stays NaN: the engine holds it), the held ``gy`` less the learned y bias and
    the row's down vector, blended in from ``gz`` as the bias is learned (:data:`LEARNED_S`).
    """
    kp = 1.0 / TAU_S
    cos_gate = math.cos(math.radians(ANGLE_GATE_DEG))
    max_b = math.radians(MAX_BIAS_DPS)
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
        restart = state[_STARTED] == 0.0 or not dt <= MAX_GAP_S
        if restart:
            if have_acc:
                if state[_STARTED] == 0.0:
                    state[_G] = 9.80665 if fn > 3.0 else 1.0
                    state[_T0] = t[i]
                state[_D], state[_D + 1], state[_D + 2] = -f0 / fn, -f1 / fn, -f2 / fn
                state[_STARTED] = 1.0
                state[_LOST] = 0.0
            state[_T] = t[i]
            for k in range(3):
                out[i, k] = state[_D + k]
            _heading_rate(i, gz[i], state, out, rate_out)
            continue
        state[_T] = t[i]
        d0, d1, d2 = state[_D], state[_D + 1], state[_D + 2]
        w0 = math.radians(state[_W]) - state[_B]
        w1 = math.radians(state[_W + 1]) - state[_B + 1]
        w2 = math.radians(state[_W + 2]) - state[_B + 2]
        if have_acc:
            m0, m1, m2 = -f0 / fn, -f1 / fn, -f2 / fn
            norm_ok = abs(fn / state[_G] - 1.0) <= NORM_TOL
            quiet = norm_ok and math.sqrt(state[_W] ** 2 + state[_W + 1] ** 2 + state[_W + 2] ** 2) <= MAX_RATE_DPS
            within = d0 * m0 + d1 * m1 + d2 * m2 >= cos_gate
            turning = _about_the_vertical(w0, w1, w2, d0, d1, d2)
            agree = within or t[i] - state[_T0] < STARTUP_S or (not turning and t[i] - state[_RELOCKED] < STARTUP_S)
            use = (quiet and agree) or (norm_ok and within)  # or turning fast, yet about 1 g and within: no centripetal part
            if within:
                state[_LOST] = max(state[_LOST] - dt, 0.0)
            elif quiet and not agree and not turning:
                state[_LOST] += dt
                if state[_LOST] >= RELOCK_S:  # the tilt is lost: it starts again from the accelerometer
                    d0, d1, d2 = m0, m1, m2
                    w0, w1, w2 = 0.0, 0.0, 0.0
                    state[_LOST] = 0.0
                    state[_RELOCKED] = t[i]  # and the bias is learned again, as at the start
            if use:
                state[_ACCEPTED] += dt
                e0, e1, e2 = d1 * m2 - d2 * m1, d2 * m0 - d0 * m2, d0 * m1 - d1 * m0  # eq. (1)
                w0, w1, w2 = w0 - kp * e0, w1 - kp * e1, w2 - kp * e2  # eq. (2)
                state[_B] = min(max(state[_B] + K_I * e0 * dt, -max_b), max_b)  # eq. (4)
                state[_B + 1] = min(max(state[_B + 1] + K_I * e1 * dt, -max_b), max_b)
                state[_B + 2] = min(max(state[_B + 2] + K_I * e2 * dt, -max_b), max_b)
        d0, d1, d2 = _rotate(d0, d1, d2, -w0 * dt, -w1 * dt, -w2 * dt)  # eq. (3)
        norm = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        state[_D], state[_D + 1], state[_D + 2] = d0 / norm, d1 / norm, d2 / norm
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
                    "corrected by the accelerometer near 1 g; gyrodrift.attitude)")
        why = "tilt = 'accel'" if self.gyro_xy else "no gyro_x, gyro_y"
        return (f"{self.source}: compass tilt from the accelerometer alone ({why}): braking and cornering "
                "tilt the heading")

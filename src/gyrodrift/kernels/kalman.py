"""The paper's drift filters over [a, b, c] (eq. 10 with a fixed fading factor s; s = 1 the plain
Kalman filter), on the estimator arrays of :mod:`gyrodrift.kernels.layout` (``docs/engine.md``,
"The Kalman filters").
"""

from __future__ import annotations

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels.layout import EF_FADING, EF_MAX_VAR, EF_P, EF_Q, EF_Z, EI_ACTIVE, EI_N_ACTIVE
from gyrodrift.kernels.numeric import cap_covariance, correct

__all__ = ["views", "update", "hold", "params", "cov", "put_state"]


@jit(inline=True)
def views(ef, ei):
    """The estimator arrays as (z, P, Q, max_var, active): views."""
    z = ef[EF_Z:EF_Z + 3]
    P = ef[EF_P:EF_P + 9].reshape((3, 3))
    Q = ef[EF_Q:EF_Q + 9].reshape((3, 3))
    max_var = ef[EF_MAX_VAR:EF_MAX_VAR + 3]
    return z, P, Q, max_var, ei[EI_ACTIVE:EI_ACTIVE + ei[EI_N_ACTIVE]]


@jit
def _sub(P, active):
    n = active.size
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = P[active[i], active[j]]
    return out


@jit
def _put(P, active, Pa):
    n = active.size
    for i in range(n):
        for j in range(n):
            P[active[i], active[j]] = Pa[i, j]


@jit
def update(ef, ei, y, H, R):
    """One accepted observation ``y = H x + v``, ``v ~ N(0, R)`` (rows ``[T, T', 1]``):
    ``P⁻ = cap(s P + Q)`` (eq. 10), the Joseph-form correction, the cap again; the estimator
    arrays in place (active states only)."""
    x, P, Q, max_var, active = views(ef, ei)
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
    P_prior = cap_covariance(ef[EF_FADING] * Pa + Qa, mv)
    xa, P_post = correct(xa, P_prior, y, Ha, R)
    _put(P, active, cap_covariance(P_post, mv))
    for j in range(na):
        x[active[j]] = xa[j]


@jit
def hold(ef, ei, intervals):
    """``intervals`` refused intervals (1, or more when a time gap skipped some): ``P ←
    cap(P + intervals Q)`` on the active states (no fading)."""
    x, P, Q, max_var, active = views(ef, ei)
    Pa = _sub(P, active)
    Qa = _sub(Q, active)
    _put(P, active, cap_covariance(1.0 * Pa + intervals * Qa, max_var[active]))


@jit
def params(ef, ei):
    """The parameters in force, [a (deg/s/degC), b (deg/degC), c (deg/s)]."""
    return ef[EF_Z:EF_Z + 3].copy()


@jit
def cov(ef, ei):
    """Covariance (3x3) of [a, b, c]."""
    return ef[EF_P:EF_P + 9].reshape((3, 3)).copy()


@jit(inline=True)
def put_state(ef, ei, out, p0, c0):
    """The parameters in force into ``out[p0:p0 + 3]`` and their covariance (row-major) into ``out[c0:c0 + 9]``."""
    p = params(ef, ei)
    C = cov(ef, ei)
    for r in range(3):
        out[p0 + r] = p[r]
        for c in range(3):
            out[c0 + 3 * r + c] = C[r, c]

"""The drift filters over the parameters [a, b, c] of eq. (2), on the estimator arrays.

States are modelled as constant between updates (Φ = Γ = I, Section 3.2). The state of
an estimator is two arrays, ``ef`` (floats) and ``ei`` (integers), laid out in
:mod:`gyrodrift.kernels.layout`; :func:`update` and :func:`hold` dispatch on its mode.

Fixed fading (``stkf``, ``stkf-s1``, ``kf``)
--------------------------------------------
At every accepted interval ``P⁻ = cap(s P + Q)`` (eq. 10, s the fading factor; s = 1 is
the plain Kalman filter), then the Joseph-form correction; over a refused interval
``P ← cap(P + Q)``: no fading, since fading discounts old measurements and there are
none. Only the ``active`` states take part (``kf``: c alone).

Bounded covariance: a direction the measurements do not see (T' ≡ 0 leaves b
unobservable; a flat temperature confounds a with c) would grow as ``s**N`` under
fading; P is capped at ``diag(max_var)`` (by default the prior) in the whitened
eigenbasis (:func:`gyrodrift.kernels.numeric.cap_covariance`).

``adaptive``
------------
The same model and filter with a memory that adapts (see
:mod:`gyrodrift.estimators.adaptive` for the settings):

* temperature centred on ``T_ref`` (set by the first measurement; with ``recentre``
  moved to each new measurement's temperature): states ``[a, b, c']`` with
  ``c' = c + a T_ref``, rows ``[T − T_ref, T', 1]``;
* the fading factor λ of ``P⁻ = λ P + Q`` from the innovations: the mean normalised
  innovation squared of the last ``w`` updates against β (``normalised``), or Zhou's
  recursive innovation covariance ``V``; capped at λ_max;
* the slope's random walk in temperature: ``slope_q² |ΔT|`` added to Q[a, a];
* a twin without that random walk (``twin``): through refused intervals the drift is
  extrapolated with the twin's a and b from the drift last tracked (the outage anchor).
"""

from __future__ import annotations

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels.layout import (
    AF_ANCHOR, AF_LAMBDA, AF_LAST_H_T, AF_LAST_H_TP, AF_LAST_T, AF_TREF, AI_ANCHOR_SET, AI_LAST_H_SET,
    AI_LAST_T_SET, AI_NIS_N, AI_TREF_SET, AI_V_N, EF_AF, EF_MAX_VAR, EF_P, EF_Q, EF_SET, EF_V, EF_Z, EI_ACTIVE,
    EI_AI, EI_DEPTH, EI_HOLD_DRIFT, EI_MODE, EI_N_ACTIVE, EI_NIS_W, EI_NORMALISED, EI_RECENTRE, EI_TWIN, ES_FADING,
    ES_LAMBDA_MAX, ES_RHO, ES_SLOPE_Q, ES_SOFTENING, MAIN, MODE_ADAPTIVE, N_AF, N_AI, TWIN,
)
from gyrodrift.kernels.numeric import cap_covariance, correct, matmul, matmul_t, matvec, solve

__all__ = ["views", "update", "hold", "params", "cov"]


@jit(inline=True)
def views(ef, ei):
    """The estimator arrays as (z, P, Q, max_var, af, V, nis, ai): views, rows MAIN and TWIN."""
    d = ei[EI_DEPTH]
    w = ei[EI_NIS_W]
    z = ef[EF_Z:EF_Z + 6].reshape((2, 3))
    P = ef[EF_P:EF_P + 18].reshape((2, 3, 3))
    Q = ef[EF_Q:EF_Q + 18].reshape((2, 3, 3))
    max_var = ef[EF_MAX_VAR:EF_MAX_VAR + 6].reshape((2, 3))
    af = ef[EF_AF:EF_AF + 2 * N_AF].reshape((2, N_AF))
    V = ef[EF_V:EF_V + 2 * d * d].reshape((2, d, d))
    nis = ef[EF_V + 2 * d * d:EF_V + 2 * d * d + 2 * w].reshape((2, w))
    ai = ei[EI_AI:EI_AI + 2 * N_AI].reshape((2, N_AI))
    return z, P, Q, max_var, af, V, nis, ai


# ------------------------------------------------------------- fixed fading


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
def _fixed_update(x, P, Q, max_var, active, y, H, R, fading):
    """One accepted update with a fixed fading factor: ``P⁻ = cap(s P + Q)``, then the
    Joseph-form correction, then the cap again; x, P in place (active states only)."""
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


@jit
def _fixed_hold(P, Q, max_var, active, intervals):
    """``intervals`` refused intervals: ``P ← cap(P + intervals Q)`` on the active states."""
    Pa = _sub(P, active)
    Qa = _sub(Q, active)
    _put(P, active, cap_covariance(1.0 * Pa + intervals * Qa, max_var[active]))


# ----------------------------------------------------------------- adaptive


@jit(inline=True)
def _own_params(z, af):
    """The filter's absolute [a, b, c]: c = c' − a T_ref."""
    out = np.empty(3)
    out[0] = z[0]
    out[1] = z[1]
    out[2] = z[2] - z[0] * af[AF_TREF]
    return out


@jit
def _recentre(z, P, af, temp_c):
    """Move T_ref to ``temp_c``: ``c' ← c' + a (temp_c − T_ref)``, P alike (same drift model)."""
    J = np.eye(3)
    J[2, 0] = temp_c - af[AF_TREF]
    z[:] = matvec(J, z)
    P[:, :] = matmul_t(matmul(J, P), J)
    af[AF_TREF] = temp_c


@jit(inline=True)
def _column_mean(H, c):
    """Mean of column ``c`` of H."""
    total = 0.0
    for r in range(H.shape[0]):
        total += H[r, c]
    return total / H.shape[0]


@jit
def _centre(z, af, ai, H):
    """H with T centred on T_ref; the first observation sets T_ref (and c' from the prior)."""
    m = H.shape[0]
    if ai[AI_TREF_SET] == 0:
        af[AF_TREF] = _column_mean(H, 0)
        ai[AI_TREF_SET] = 1
        z[2] = z[2] + z[0] * af[AF_TREF]  # z is still the prior [a, b, c] here
    Hc = H.copy()
    for r in range(m):
        Hc[r, 0] -= af[AF_TREF]
    return Hc


@jit
def _adaptive_update(z, P, V, nis, af, ai, Q, max_var, slope_q, y, H, R, softening, lambda_max, rho, normalised,
                     recentre):
    """One accepted observation of one ``adaptive`` filter (module notes), state in place."""
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
    if recentre and ai[AI_TREF_SET] == 1:
        _recentre(z, P, af, temp_c)
    Hc = _centre(z, af, ai, H)
    gamma = y - matvec(Hc, z)
    M = matmul_t(matmul(Hc, P), Hc)
    trM = np.trace(M)
    if normalised:
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
        excess = total / n - softening
        lam = 1.0 + excess * (np.trace(S) / trM) if trM > 0 else 1.0
    else:
        if ai[AI_V_N] != m:
            for i in range(m):
                for j in range(m):
                    V[i, j] = gamma[i] * gamma[j]
            ai[AI_V_N] = m
        else:
            for i in range(m):
                for j in range(m):
                    V[i, j] = (rho * V[i, j] + gamma[i] * gamma[j]) / (1.0 + rho)
        N = V[:m, :m] - matmul_t(matmul(Hc, Qk), Hc) - softening * R
        lam = np.trace(N) / trM if trM > 0 else 1.0
    if not lam > 1.0:  # min(max(1, λ), λ_max); NaN gives 1
        lam = 1.0
    if lambda_max < lam:
        lam = lambda_max
    af[AF_LAMBDA] = lam
    P_prior = cap_covariance(lam * P + Qk, max_var)
    z_post, P_post = correct(z, P_prior, y, Hc, R)
    z[:] = z_post
    P[:, :] = cap_covariance(P_post, max_var)


# ---------------------------------------------------------------- dispatch


@jit
def update(ef, ei, y, H, R):
    """One accepted observation ``y = H x + v``, ``v ~ N(0, R)`` (rows ``[T, T', 1]``); the
    estimator arrays are updated in place."""
    z, P, Q, max_var, af, V, nis, ai = views(ef, ei)
    if ei[EI_MODE] != MODE_ADAPTIVE:
        active = ei[EI_ACTIVE:EI_ACTIVE + ei[EI_N_ACTIVE]]
        _fixed_update(z[MAIN], P[MAIN], Q[MAIN], max_var[MAIN], active, y, H, R, ef[EF_SET + ES_FADING])
        return
    softening = ef[EF_SET + ES_SOFTENING]
    lambda_max = ef[EF_SET + ES_LAMBDA_MAX]
    rho = ef[EF_SET + ES_RHO]
    normalised = ei[EI_NORMALISED] == 1
    recentre = ei[EI_RECENTRE] == 1
    if ei[EI_TWIN] == 1:
        _adaptive_update(z[TWIN], P[TWIN], V[TWIN], nis[TWIN], af[TWIN], ai[TWIN], Q[TWIN], max_var[TWIN], 0.0,
                         y, H, R, softening, lambda_max, rho, normalised, recentre)
    _adaptive_update(z[MAIN], P[MAIN], V[MAIN], nis[MAIN], af[MAIN], ai[MAIN], Q[MAIN], max_var[MAIN],
                     ef[EF_SET + ES_SLOPE_Q], y, H, R, softening, lambda_max, rho, normalised, recentre)


@jit
def hold(ef, ei, intervals):
    """``intervals`` refused intervals (1, or more when a time gap skipped some): ``P ←
    cap(P + intervals Q)`` (no fading; the random walk of the states grows with the time
    elapsed, up to the cap); ``adaptive`` with a twin also
    sets, at the first refusal after an update, the outage anchor: the twin's a and b
    from the drift last tracked at the last measurement's (T, T') (eq. 5 through the
    outage), or a = b = 0, the drift held, with ``EI_HOLD_DRIFT``."""
    z, P, Q, max_var, af, V, nis, ai = views(ef, ei)
    if ei[EI_MODE] != MODE_ADAPTIVE:
        _fixed_hold(P[MAIN], Q[MAIN], max_var[MAIN], ei[EI_ACTIVE:EI_ACTIVE + ei[EI_N_ACTIVE]], intervals)
        return
    P[MAIN] = cap_covariance(1.0 * P[MAIN] + intervals * Q[MAIN], max_var[MAIN])
    if ei[EI_TWIN] == 1:
        P[TWIN] = cap_covariance(1.0 * P[TWIN] + intervals * Q[TWIN], max_var[TWIN])
        if ai[MAIN, AI_ANCHOR_SET] == 0 and ai[MAIN, AI_LAST_H_SET] == 1:
            T0 = af[MAIN, AF_LAST_H_T]
            Tp0 = af[MAIN, AF_LAST_H_TP]
            tw = _own_params(z[TWIN], af[TWIN])
            a = tw[0] if ei[EI_HOLD_DRIFT] == 0 else 0.0
            b = tw[1] if ei[EI_HOLD_DRIFT] == 0 else 0.0
            h = np.empty(3)
            h[0] = T0
            h[1] = Tp0
            h[2] = 1.0
            drift0 = np.dot(_own_params(z[MAIN], af[MAIN]), h)
            af[MAIN, AF_ANCHOR] = a
            af[MAIN, AF_ANCHOR + 1] = b
            af[MAIN, AF_ANCHOR + 2] = drift0 - a * T0 - b * Tp0
            ai[MAIN, AI_ANCHOR_SET] = 1


@jit
def params(ef, ei):
    """The parameters in force, absolute [a (deg/s/degC), b (deg/degC), c (deg/s)]: ``adaptive``
    gives the outage anchor while one is set."""
    z, P, Q, max_var, af, V, nis, ai = views(ef, ei)
    if ei[EI_MODE] != MODE_ADAPTIVE:
        return z[MAIN].copy()
    if ai[MAIN, AI_ANCHOR_SET] == 1:
        return af[MAIN, AF_ANCHOR:AF_ANCHOR + 3].copy()
    return _own_params(z[MAIN], af[MAIN])


@jit
def cov(ef, ei):
    """Covariance (3x3) of the absolute [a, b, c]: ``adaptive`` transforms its centred
    states by ``J = [[1, 0, 0], [0, 1, 0], [−T_ref, 0, 1]]``."""
    z, P, Q, max_var, af, V, nis, ai = views(ef, ei)
    if ei[EI_MODE] != MODE_ADAPTIVE:
        return P[MAIN].copy()
    J = np.eye(3)
    J[2, 0] = -af[MAIN, AF_TREF]
    return matmul_t(matmul(J, P[MAIN]), J)

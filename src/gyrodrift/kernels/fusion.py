"""The fused heading (:mod:`gyrodrift.fusion`): :func:`step`, one row on scalars, for the row loop
(:mod:`gyrodrift.kernels.loop`) and :func:`fuse_rows` (a whole log).
"""

from __future__ import annotations

import math

from gyrodrift.kernels import jit
from gyrodrift.kernels.numeric import wrap180, wrap360

__all__ = ["step", "fuse_rows"]


@jit(inline=True)
def step(psi, P, t_prev, r_prev, started, t0, isd, sd_prev, rej_t, nu0, cons_t, t, rate, compass, allow, bias_sd,
         R, N2, tau, gate, relock, consistent, held):
    """One row of the fused-heading filter on scalars (``docs/heading_and_axes.md``, "Fused heading").

    State in: ``psi, P, t_prev, r_prev, started, t0, isd, sd_prev, rej_t, nu0, cons_t``
    (``rej_t``: time of the first compass sample of the current run of refused ones, NaN if
    none; ``cons_t`` the time since which its innovations stayed within 2 σ_c of ``nu0``);
    settings ``R = σ_c², N2 = N², tau = τ_b, gate, relock, consistent`` (s); ``held``: the step
    from the previous row is a time gap, across which the heading holds. Returns the new state
    then (ψ in [0, 360), σ_ψ, σ of the gyro-alone heading), NaN before the first compass sample.
    """
    if started == 0.0:
        if math.isnan(compass):
            return (psi, P, t_prev, r_prev, started, t0, isd, sd_prev, rej_t, nu0, cons_t,
                    math.nan, math.nan, math.nan)
        psi = wrap360(compass)
        sr = math.sqrt(R)
        return psi, R, t, rate, 1.0, t, 0.0, bias_sd, math.nan, 0.0, t, psi, sr, sr
    dt = t - t_prev
    if not held:  # held: across a time gap the heading holds (its variance grows all the same)
        psi = psi + 0.5 * (rate + r_prev) * dt
    P = P + (N2 + tau * bias_sd * bias_sd) * dt
    isd = isd + 0.5 * (bias_sd + sd_prev) * dt
    if allow and not math.isnan(compass):
        nu = wrap180(compass - psi)
        S = P + R
        if nu * nu / S <= gate:
            k = P / S
            psi = psi + k * nu
            P = P - k * P
            rej_t = math.nan
        else:
            if math.isnan(rej_t):  # the first refused sample of a run
                rej_t = t
                cons_t = t
                nu0 = nu
            elif abs(wrap180(nu - nu0)) > 2.0 * math.sqrt(R):  # the refusals disagree: count again
                cons_t = t
                nu0 = nu
            if t - rej_t >= relock or t - cons_t >= consistent:  # trust the compass again
                psi = compass
                P = R
                rej_t = math.nan
    psi = wrap360(psi)
    gyro_var = R + N2 * (t - t0) + isd * isd
    return psi, P, t, rate, started, t0, isd, bias_sd, rej_t, nu0, cons_t, psi, math.sqrt(max(P, 0.0)), math.sqrt(gyro_var)


@jit
def fuse_rows(st, t, rate, compass, allow, bias_sd, cfg, max_gap_s, out_h, out_sd, out_gyro_sd):
    """:func:`step` over arrays: state ``st`` (11 values, the order of :func:`step`'s first
    eleven arguments; updated), settings ``cfg`` = [R, N², τ, gate, relock, consistent]; the heading holds
    across a time step longer than ``max_gap_s``; outputs written in place."""
    psi, P_, t_prev, r_prev, started, t0, isd, sd_prev, rej_t = st[0], st[1], st[2], st[3], st[4], st[5], st[6], st[7], st[8]
    nu0, cons_t = st[9], st[10]
    R, N2, tau, gate, relock, consistent = cfg[0], cfg[1], cfg[2], cfg[3], cfg[4], cfg[5]
    for i in range(t.size):
        psi, P_, t_prev, r_prev, started, t0, isd, sd_prev, rej_t, nu0, cons_t, h, sd, gsd = step(
            psi, P_, t_prev, r_prev, started, t0, isd, sd_prev, rej_t, nu0, cons_t, t[i], rate[i], compass[i],
            allow[i], bias_sd[i], R, N2, tau, gate, relock, consistent, started == 1.0 and t[i] - t_prev > max_gap_s,
        )
        out_h[i] = h
        out_sd[i] = sd
        out_gyro_sd[i] = gsd
    st[0], st[1], st[2], st[3], st[4], st[5], st[6], st[7], st[8] = (
        psi, P_, t_prev, r_prev, started, t0, isd, sd_prev, rej_t)
    st[9], st[10] = nu0, cons_t

"""Row function of the fused heading (:mod:`gyrodrift.fusion`), compiled when numba is installed.

Without numba the same functions run as plain Python; either way streaming (one row at
a time) and batch (:func:`fuse_rows`) execute the same operations in the same order.
"""

from __future__ import annotations

import math

try:
    from numba import njit

    _jit = njit(cache=True, nogil=True)
except ImportError:  # pragma: no cover - exercised only without numba
    def _jit(f):
        return f

# state layout
PSI, P, TPREV, RPREV, STARTED, T0, ISD, SDPREV = range(8)
N_STATE = 8


@_jit
def wrap180(x):
    return x - 360.0 * math.floor((x + 180.0) / 360.0)


@_jit
def fuse_row(st, t, rate, compass, allow, bias_sd, cfg):
    """One row of the fused-heading filter (see :mod:`gyrodrift.fusion`); updates ``st``.

    ``cfg`` = [σ_c², N², τ_b, nis_gate]. Returns (ψ in [0, 360), σ_ψ, σ of the
    gyro-alone heading), NaN before the first compass sample.
    """
    R = cfg[0]
    N2 = cfg[1]
    tau = cfg[2]
    if st[STARTED] == 0.0:
        if math.isnan(compass):
            return math.nan, math.nan, math.nan
        st[PSI] = compass - 360.0 * math.floor(compass / 360.0)
        st[P] = R
        st[STARTED] = 1.0
        st[TPREV] = t
        st[RPREV] = rate
        st[T0] = t
        st[ISD] = 0.0
        st[SDPREV] = bias_sd
        return st[PSI], math.sqrt(R), math.sqrt(R)
    dt = t - st[TPREV]
    st[PSI] = st[PSI] + 0.5 * (rate + st[RPREV]) * dt
    st[P] = st[P] + (N2 + tau * bias_sd * bias_sd) * dt
    st[ISD] = st[ISD] + 0.5 * (bias_sd + st[SDPREV]) * dt
    st[TPREV] = t
    st[RPREV] = rate
    st[SDPREV] = bias_sd
    if allow and not math.isnan(compass):
        nu = wrap180(compass - st[PSI])
        S = st[P] + R
        if nu * nu / S <= cfg[3]:
            k = st[P] / S
            st[PSI] = st[PSI] + k * nu
            st[P] = st[P] - k * st[P]
    st[PSI] = st[PSI] - 360.0 * math.floor(st[PSI] / 360.0)
    gyro_var = R + N2 * (t - st[T0]) + st[ISD] * st[ISD]
    return st[PSI], math.sqrt(max(st[P], 0.0)), math.sqrt(gyro_var)


@_jit
def fuse_rows(st, t, rate, compass, allow, bias_sd, cfg, out_h, out_sd, out_gyro_sd):
    """:func:`fuse_row` over arrays (outputs written in place)."""
    for i in range(t.size):
        h, sd, gsd = fuse_row(st, t[i], rate[i], compass[i], allow[i], bias_sd[i], cfg)
        out_h[i] = h
        out_sd[i] = sd
        out_gyro_sd[i] = gsd

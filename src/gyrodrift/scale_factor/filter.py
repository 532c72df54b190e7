"""The scale-factor Kalman filter over the accepted rotations, and the one-off calibration it is compared with.

:func:`sf_correct` is the step for one rotation (also the tracker's); ``docs/scale_factor.md``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from gyrodrift.kernels.numeric import cap_covariance, correct
from gyrodrift.scale_factor.config import ScaleFactorConfig

__all__ = ["sf_filter", "sf_correct", "fixed_scale_factor"]


def sf_filter(turns: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig()):
    """Run the SF STKF (eq. 10 with Φ = I) over the accepted rotations of a turn table, in order.

    Returns
    -------
    params : (K + 1, 2) ndarray
        ``[s0, s1]`` before the first and after each of the K accepted rotations.
    cov : (K + 1, 2, 2) ndarray
        The matching covariances (capped at ``P0``).
    """
    x = np.array(config.x0, dtype=float)
    P = np.diag(np.square(config.p0_sd))
    xs, Ps = [x], [P]
    for _, m in turns[turns["accepted"]].iterrows():
        x, P = sf_correct(x, P, float(m["sf_meas"]), float(m["temp_dev_c"]), float(m["r"]), config)
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


def sf_correct(x: np.ndarray, P: np.ndarray, sf_meas: float, temp_dev_c: float, r: float,
               config: ScaleFactorConfig):
    """One accepted rotation: ``P- = s*P + Q`` capped at ``P0``, then the Joseph-form correction of
    eq. (10) with ``H = [1, T - T_ref]`` (Sec. 3.2), capped again; returns the new ``x``, ``P``.

    ``x = [s0, s1]`` (unitless, 1/degC), ``sf_meas`` the measurement y, ``temp_dev_c`` its mean
    ``T - T_ref`` (degC), ``r`` its variance.
    """
    Q = np.diag(np.square(config.q_sd))
    cap = np.square(np.array(config.p0_sd))
    H = np.array([[1.0, float(temp_dev_c)]])
    P_prior = cap_covariance(float(config.fading) * P + Q, cap)
    x, P_post = correct(np.asarray(x, dtype=float), P_prior, np.array([float(sf_meas)]), H, np.array([[float(r)]]))
    return x, cap_covariance(P_post, cap)


def fixed_scale_factor(turns: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig()) -> float:
    """One-off calibration: inverse-variance mean SF of the first ``fixed_turns`` accepted rotations (1.0: none)."""
    first = turns[turns["accepted"]].head(config.fixed_turns)
    if first.empty:
        return 1.0
    w = 1.0 / first["r"].to_numpy(float)
    return float(np.sum(w * first["sf_meas"].to_numpy(float)) / np.sum(w))

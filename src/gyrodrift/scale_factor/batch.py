"""A whole compensated log at once: :func:`estimate_scale_factor` and the SF-compensated heading."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.integrate import cumulative_trapezoid

from gyrodrift.conventions import wrap_180, wrap_360
from gyrodrift.errors import LogFormatError
from gyrodrift.scale_factor.config import ScaleFactorConfig
from gyrodrift.scale_factor.filter import fixed_scale_factor, sf_filter
from gyrodrift.scale_factor.turns import compensated_columns, turn_measurements

__all__ = ["integrate_heading", "heading_anchor", "heading_error", "estimate_scale_factor"]


def integrate_heading(t_s, rate_dps, anchor_row: int, anchor_heading_deg: float) -> np.ndarray:
    """Heading (deg, [0, 360)) integrated from ``rate_dps`` by the trapezoid rule.

    Equal to ``anchor_heading_deg`` at ``anchor_row``, as the compensator anchors its
    heading on the first compass sample.
    """
    angle = cumulative_trapezoid(np.asarray(rate_dps, dtype=float), np.asarray(t_s, dtype=float), initial=0.0)
    return wrap_360(anchor_heading_deg + (angle - angle[anchor_row]))


def heading_anchor(out: pd.DataFrame) -> tuple[int, float]:
    """Row and value (deg) of the first ``compass_heading`` of a compensate() table, where the
    compensator anchors its heading (:class:`LogFormatError` when there is none)."""
    rows = np.flatnonzero(out["compass_heading"].notna().to_numpy())
    if rows.size == 0:
        raise LogFormatError("scale-factor estimate: no compass heading to anchor the heading")
    return int(rows[0]), float(out["compass_heading"].iloc[rows[0]])


def heading_error(heading_deg, ref_heading_deg) -> np.ndarray:
    """Heading minus reference, wrapped to [-180, 180), deg."""
    return wrap_180(np.asarray(heading_deg, dtype=float) - np.asarray(ref_heading_deg, dtype=float))


def estimate_scale_factor(
    out: pd.DataFrame, config: ScaleFactorConfig = ScaleFactorConfig(), *, causal: bool = False
) -> pd.DataFrame:
    """Adaptive and fixed scale factor, and the SF-compensated rate and heading, per row.

    Parameters
    ----------
    out : DataFrame
        Output of :func:`gyrodrift.compensator.compensate` (``t, rate_z, temp,
        compass_heading``, optionally ``gate_reason``).
    config : ScaleFactorConfig
    causal : bool
        False: the paper reproduction, which looks ahead; True: each row from the rows up to
        it, as :class:`ScaleFactorTracker` (``docs/scale_factor.md``, causal and non-causal).

    Returns
    -------
    DataFrame
        ``t, sf, sf_sd, sf_s0, sf_s1, sf_fixed, rate_sf, rate_sf_fixed, heading_sf,
        heading_sf_fixed, sf_update`` on ``out``'s index (``docs/scale_factor.md``, the
        estimate's columns); ``attrs``: ``turns``, ``sf_fixed``, ``final_params``, ``final_cov``.
    """
    turns = turn_measurements(out, config, causal=causal)
    params, covs = sf_filter(turns, config)
    sf_fixed = fixed_scale_factor(turns, config)

    t, rate, temp, compass, _ = compensated_columns(out)
    dev = temp - config.t_ref_c
    update_rows = turns.loc[turns["accepted"], "row_update"].to_numpy(int)
    if causal:
        k = np.searchsorted(update_rows, np.arange(t.size), "right")  # updates at or before each row
    else:
        k = np.searchsorted(update_rows, np.arange(t.size), "left")  # updates strictly before each row
        if update_rows.size:  # initialisation: rows up to the first update use its result
            k = np.maximum(k, 1)
    s0, s1 = params[k, 0], params[k, 1]
    sf = s0 + s1 * dev
    P = covs[k]
    sf_var = P[:, 0, 0] + 2.0 * dev * P[:, 0, 1] + dev**2 * P[:, 1, 1]
    update = np.zeros(t.size, dtype=int)
    update[update_rows] = 1

    rate_sf = rate / sf
    rate_fixed = rate / sf_fixed
    if causal:
        heading_sf, heading_fixed = _causal_heading(t, rate_sf, compass), _causal_heading(t, rate_fixed, compass)
    else:
        anchor, anchor_deg = heading_anchor(out)
        heading_sf = integrate_heading(t, rate_sf, anchor, anchor_deg)
        heading_fixed = integrate_heading(t, rate_fixed, anchor, anchor_deg)
    table = pd.DataFrame(
        {
            "t": t,
            "sf": sf,
            "sf_sd": np.sqrt(np.maximum(sf_var, 0.0)),
            "sf_s0": s0,
            "sf_s1": s1,
            "sf_fixed": np.full(t.size, sf_fixed),
            "rate_sf": rate_sf,
            "rate_sf_fixed": rate_fixed,
            "heading_sf": heading_sf,
            "heading_sf_fixed": heading_fixed,
            "sf_update": update,
        },
        index=out.index,
    )
    table.attrs = {"turns": turns, "sf_fixed": sf_fixed, "final_params": params[-1], "final_cov": covs[-1]}
    return table


def _causal_heading(t_s: np.ndarray, rate_dps: np.ndarray, compass_deg: np.ndarray) -> np.ndarray:
    """:func:`integrate_heading` from the first compass heading, NaN before it (and everywhere without one)."""
    rows = np.flatnonzero(np.isfinite(compass_deg))
    if rows.size == 0:
        return np.full(t_s.size, np.nan)
    heading = integrate_heading(t_s, rate_dps, int(rows[0]), float(compass_deg[rows[0]]))
    heading[: rows[0]] = np.nan
    return heading

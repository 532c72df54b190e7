"""A whole compensated log at once: :func:`estimate_scale_factor` (the default and the
causal pass) and the SF-compensated heading.
"""

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
    """Row and value of the first compass heading, where the compensator anchors its heading.

    Parameters
    ----------
    out : DataFrame
        A compensate() table with ``compass_heading``.

    Returns
    -------
    row : int
    heading_deg : float

    Raises
    ------
    LogFormatError
        No compass heading at all.
    """
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
        Output of :func:`gyrodrift.compensator.compensate` (columns ``t, rate_z,
        temp, compass_heading``, optionally ``gate_reason``).
    config : ScaleFactorConfig
    causal : bool
        False (default, the paper reproduction): the pass of the package notes, which
        looks ahead (centred rotation test, update decided with ``guard_s`` + half a
        window of look-ahead) and initialises the rows up to the first update with its
        result. True: every row depends on that row and the rows before it only, as
        :class:`ScaleFactorTracker` computes it row by row (same numbers): an update
        applies from the first row at which it could be decided, the prior applies until
        the first update, ``heading_sf`` is NaN before the first compass heading
        and rotations longer than ``max_turn_s`` are dropped. See "Causal and
        non-causal" in the package notes.

    Returns
    -------
    DataFrame
        Same index as ``out``: ``t`` (s); ``sf`` (adaptive SF in force,
        ``s0 + s1*(T - T_ref)`` with the parameters of the last update before the
        row, or of the first update for the rows up to it; causal: of the last update
        at or before the row, or the prior; unitless); ``sf_sd``
        (its standard deviation); ``sf_s0``, ``sf_s1`` (parameters, unitless and
        1/degC); ``sf_fixed`` (the one-off calibration, the same in both passes: a
        calibration done before the run);
        ``rate_sf = rate_z / sf`` and ``rate_sf_fixed`` (deg/s); ``heading_sf`` and
        ``heading_sf_fixed`` (deg, integrated from the first compass heading like
        the compensator's ``heading``, which is the heading without SF
        compensation); ``sf_update`` (1 on the row whose measurement updated the
        filter; the new SF applies from the next row, causal: from that row). ``attrs``
        holds ``turns`` (:func:`turn_measurements`), ``sf_fixed``, ``final_params`` and
        ``final_cov``.

    Raises
    ------
    LogFormatError
        A column is missing, the table is empty, time is not finite or does not
        increase, ``rate_z`` is not finite, the first temperature is empty; default pass:
        no compass heading at all.
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
    """:func:`integrate_heading` from the first compass heading, NaN before it (and
    everywhere without one): a causal pass cannot anchor rows before their heading is known."""
    rows = np.flatnonzero(np.isfinite(compass_deg))
    if rows.size == 0:
        return np.full(t_s.size, np.nan)
    heading = integrate_heading(t_s, rate_dps, int(rows[0]), float(compass_deg[rows[0]]))
    heading[: rows[0]] = np.nan
    return heading

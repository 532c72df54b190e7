"""When compass aiding is refused, and why (the ``gated`` / ``gate_reason`` columns).

Aiding is judged per update interval (10 s by default). An interval is refused for
the first of these reasons seen in it (causal: a row shows what was known at that row):

==============  ================================================================
reason          meaning
==============  ================================================================
``init``        initialising from the first seconds of the log
``gap``         a sample time gap longer than ``max_gap_s``, or a row whose gyro or
                temperature was empty (held from the previous row)
``no_compass``  no compass sample within ``compass_max_age_s`` at an end of the
                interval
``field``       raw magnetometer only: field strength or dip differs from the
                values seen at initialisation (magnetic interference)
``turning``     the 1-s mean compensated rate exceeded ``turn_rate_dps``; the
                paper updates only during straight motion (Section 4.2)
``interference`` the compass and the compensated gyro disagree on the heading
                change since the start of the interval by more than
                ``interference_deg`` at some compass sample; the gyro does not feel
                magnetic fields (Section 4.1). Also shown on the rows after a
                refusal for interference until an interval is accepted again,
                and (``adaptive``) on the rows after a still interval whose
                compass moved: the zero-rate update was held (``zaru_hold``)
                while the compass heading was not flat.
==============  ================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from gyrodrift.errors import ConfigError

__all__ = [
    "GateConfig",
    "INIT",
    "GAP",
    "NO_COMPASS",
    "FIELD",
    "TURNING",
    "INTERFERENCE",
    "REASONS",
    "row_condition",
    "row_conditions",
    "field_anomaly",
]

INIT = "init"
GAP = "gap"
NO_COMPASS = "no_compass"
FIELD = "field"
TURNING = "turning"
INTERFERENCE = "interference"
#: Every value of ``gate_reason`` ("" = accepted), in a fixed order (the categories of
#: the output column).
REASONS = ("", INIT, GAP, NO_COMPASS, FIELD, TURNING, INTERFERENCE)


@dataclass(frozen=True, kw_only=True)
class GateConfig:
    """Thresholds of the aiding gates.

    Attributes
    ----------
    turn_rate_dps : float
        Turning when the 1-s mean compensated rate exceeds this, deg/s.
    turn_window_s : float
        Averaging window of the turning test, s.
    interference_deg : float
        Largest accepted disagreement between compass and gyro heading change
        over one update interval, deg.
    field_norm_tol : float
        Largest accepted relative change of field strength (raw mag only).
    dip_tol_deg : float
        Largest accepted change of dip angle, deg (raw mag only).
    compass_max_age_s : float
        A compass sample older than this at an interval end counts as missing, s.
    max_gap_s : float
        A time step longer than this refuses the interval, s.
    still_std_dps : float
        Initialisation: a sub-window is motionless when the gyro standard deviation
        is below this, deg/s ...
    still_heading_deg : float
        ... and the compass heading changes by less than this, deg.
    relock_intervals : int
        Lock-out recovery (0 = off, as in the paper; default 3): after this many
        consecutive intervals
        refused for ``interference`` whose compass-minus-gyro rates agree (same sign,
        spread below half their mean), the disagreement is taken for a drift change the
        filter has not followed, not for a magnetic disturbance, and the next such
        interval is accepted.
    """

    turn_rate_dps: float = 2.0
    turn_window_s: float = 1.0
    interference_deg: float = 3.0
    field_norm_tol: float = 0.1
    dip_tol_deg: float = 5.0
    compass_max_age_s: float = 2.0
    max_gap_s: float = 1.0
    still_std_dps: float = 1.0
    still_heading_deg: float = 2.0
    relock_intervals: int = 3

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "relock_intervals":
                if not (isinstance(v, int) and v >= 0):
                    raise ConfigError(f"gate setting relock_intervals must be a whole number >= 0, got {v!r}")
            elif not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"gate setting {f.name} must be a positive number, got {v!r}")


def field_anomaly(norm, dip_deg, ref_norm: float, ref_dip_deg: float, config: GateConfig):
    """True where field strength or dip departs from the reference (interference)."""
    norm = np.asarray(norm, dtype=float)
    dip_deg = np.asarray(dip_deg, dtype=float)
    with np.errstate(invalid="ignore"):
        bad = (np.abs(norm / ref_norm - 1.0) > config.field_norm_tol) | (
            np.abs(dip_deg - ref_dip_deg) > config.dip_tol_deg
        )
    return bad & np.isfinite(norm)


def row_condition(gap: bool, field: bool, residual_deg: float, mean_rate_dps: float, config: GateConfig) -> str:
    """:func:`row_conditions` for one row (the streaming path), same priorities."""
    if gap:
        return GAP
    if field:
        return FIELD
    if abs(mean_rate_dps) > config.turn_rate_dps:
        return TURNING
    if abs(residual_deg) > config.interference_deg:  # False for NaN (no compass sample)
        return INTERFERENCE
    return ""


def row_conditions(gap, field, residual_deg, mean_rate_dps, config: GateConfig) -> np.ndarray:
    """Per-row refusal code ('' for none), priority gap > field > turning > interference.

    Parameters
    ----------
    gap, field : (N,) bool array_like
        Gap or held sample; magnetic field anomaly.
    residual_deg : (N,) array_like
        Compass minus compensated-gyro heading change since the interval start, deg
        (NaN on rows without a compass sample).
    mean_rate_dps : (N,) array_like
        1-s mean compensated rate, deg/s.
    """
    gap = np.asarray(gap, dtype=bool)
    out = np.full(gap.shape, "", dtype=object)
    with np.errstate(invalid="ignore"):
        out[np.abs(np.asarray(residual_deg, dtype=float)) > config.interference_deg] = INTERFERENCE
    turning = np.abs(np.asarray(mean_rate_dps, dtype=float)) > config.turn_rate_dps
    out[turning] = TURNING
    out[np.asarray(field, dtype=bool)] = FIELD
    out[gap] = GAP
    return out

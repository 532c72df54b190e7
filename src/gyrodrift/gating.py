"""When compass aiding is refused, and why (the ``gated`` / ``gate_reason`` columns).

This module holds the names of the reasons and the thresholds of the paper's gates
(:class:`GateConfig`).

The default estimator (``adaptive``) has no gates: its model weighs hypotheses about the
compass and the platform by how well each explains the data
(:mod:`gyrodrift.kernels.evidence`), and a row's reason says what the model believes at
that row (:mod:`gyrodrift.kernels.evloop`): ``gap`` (a time step far longer than the
log's own spacing, or an empty gyro or temperature cell), ``no_compass`` (no compass
sample for ``compass_max_age_s``), ``turning`` (the compensated rate, averaged over about
``turn_window_s``, above ``turn_rate_dps``: the compass then errs more), ``interference``
or ``field`` (a disturbed compass is likelier than a clean one; ``field`` when the field
strength and dip say so), or none. ``init`` marks the streaming compensator's provisional
rows while its init window fills.

The paper's filters (``stkf``, ``kf``, ...) judge aiding per update interval (10 s by
default, :func:`gyrodrift.kernels.aiding.row_condition` and
:func:`gyrodrift.kernels.aiding.close`). An interval is refused for the first of these
reasons seen in it (causal: a row shows what was known at that row):

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
                refusal for interference until an interval is accepted again.
==============  ================================================================
"""

from __future__ import annotations

from dataclasses import dataclass

from gyrodrift.kernels.layout import REASON_NAMES
from gyrodrift.settings import check, setting

__all__ = [
    "GateConfig",
    "INIT",
    "GAP",
    "NO_COMPASS",
    "FIELD",
    "TURNING",
    "INTERFERENCE",
    "REASONS",
]

#: Every value of ``gate_reason`` ("" = accepted), in a fixed order (the categories of
#: the output column; the kernels' codes index it).
REASONS = REASON_NAMES
_, INIT, GAP, NO_COMPASS, FIELD, TURNING, INTERFERENCE = REASONS


@dataclass(frozen=True, kw_only=True)
class GateConfig:
    """Thresholds of the aiding gates.

    Attributes
    ----------
    turn_rate_dps : float
        Turning when the 1-s mean compensated rate exceeds this, deg/s (every estimator).
    turn_window_s : float
        Averaging window of the turning test, s (every estimator).
    interference_deg : float
        Largest accepted disagreement between compass and gyro heading change
        over one update interval, deg.
    field_norm_tol : float
        Largest accepted relative change of field strength (raw mag only).
    dip_tol_deg : float
        Largest accepted change of dip angle, deg (raw mag only).
    compass_max_age_s : float
        A compass sample older than this at an interval end counts as missing, s (every
        estimator: ``no_compass``).
    max_gap_s : float
        A time step longer than this refuses the interval, s (the paper's filters; the
        default estimator judges a gap against the log's own spacing).
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

    turn_rate_dps: float = setting(2.0, "deg/s", gt=0.0, flag="--turn-rate-dps", help="turning threshold")
    turn_window_s: float = setting(1.0, "s", gt=0.0)
    interference_deg: float = setting(3.0, "deg", gt=0.0, flag="--interference-deg",
                                      help="largest compass-vs-gyro disagreement per interval")
    field_norm_tol: float = setting(0.1, gt=0.0)
    dip_tol_deg: float = setting(5.0, "deg", gt=0.0)
    compass_max_age_s: float = setting(2.0, "s", gt=0.0)
    max_gap_s: float = setting(1.0, "s", gt=0.0)
    still_std_dps: float = setting(1.0, "deg/s", gt=0.0)
    still_heading_deg: float = setting(2.0, "deg", gt=0.0)
    relock_intervals: int = setting(3, ge=0)

    def __post_init__(self):
        check(self)

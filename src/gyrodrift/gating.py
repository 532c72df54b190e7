"""When compass aiding is refused, and why (the ``gated`` / ``gate_reason`` columns).

The names of the reasons and the thresholds of the paper's gates (:class:`GateConfig`).
What each reason means for the default estimator and for the paper's filters:
docs/conventions.md, section "Gate reasons".
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
    """Thresholds of the aiding gates (docs/conventions.md, section "Gate reasons").

    Attributes
    ----------
    turn_rate_dps, turn_window_s : float
        Turning when the compensated rate, averaged over the window (s), exceeds this, deg/s.
        The default estimator averages only as long as the gyro's noise needs, at most over
        about the window (``gyrodrift.kernels.evloop.turn_weight``).
    interference_deg : float
        Largest accepted compass-vs-gyro heading change disagreement per interval, deg.
    field_norm_tol, dip_tol_deg : float
        Largest accepted relative change of field strength and change of dip, deg (raw mag).
    compass_max_age_s : float
        An older compass sample at an interval end counts as missing, s.
    max_gap_s : float
        A longer time step refuses the interval, s (the paper's filters).
    still_std_dps, still_heading_deg : float
        Initialisation: a sub-window is motionless below this gyro standard deviation, deg/s,
        and this compass heading change, deg.
    relock_intervals : int
        Lock-out recovery after this many agreeing ``interference`` refusals (0 = off).
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

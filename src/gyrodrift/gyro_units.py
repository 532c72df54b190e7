"""Is the gyro in the unit it was read in? A check of the heading-axis rate against the compass.

:class:`GyroUnitCheck` compares the compass's turns with the integrated gyro's over 10-s
windows and gives a note when they differ by a factor near 57.3 in windows that agree, or
when rates read as rad/s exceed any MEMS range: docs/conventions.md, section "The
gyro-unit check". Fed chunk by chunk, a log read in chunks gets the note a whole log gets.
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit

__all__ = ["WINDOW_S", "MIN_TURN_DEG", "MIN_WINDOWS", "AGREE_FACTOR", "RATIO_LIMIT", "MAX_RATE_DPS", "GyroUnitCheck"]

#: Length of the windows whose compass and gyro turns are compared, s.
WINDOW_S = 10.0
#: A window counts when the compass turned at least this much in it, deg.
MIN_TURN_DEG = 10.0
#: Windows needed before the ratio is judged.
MIN_WINDOWS = 3
#: Windows agree when their ratio is within this factor of the median of the majority sign.
AGREE_FACTOR = 2.0
#: Median compass/gyro turn ratio beyond which (or below whose inverse) the unit is suspect.
RATIO_LIMIT = 15.0
#: |rate| above this after a rad/s conversion is beyond any MEMS gyro's range, deg/s.
MAX_RATE_DPS = 2000.0


#: The check's state between chunks (:func:`_turns`): rows taken, the last row's time, held gyro
#: (deg/s) and gyro integral (deg), the unwrapped compass of the last sample (deg, NaN before
#: one), the open window's start (time, unwrapped compass, integral; NaN time before one) and
#: the largest finite |gyro| (deg/s).
S_ROWS, S_T, S_G, S_INTEGRAL, S_HEADING, S_START_T, S_START_H, S_START_I, S_MAX_RATE = range(9)
N_STATE = 9


@jit
def _turns(t, g, heading, state):
    """Rows into the check's windows; returns the compass/gyro turn ratios of the windows
    closed (``state`` in place, :data:`S_ROWS` ...).

    The gyro is integrated by the trapezoid, an empty cell holding the value before it (as
    the compensator does); the compass is unwrapped from sample to sample. A window closes
    at the first compass sample at least ``WINDOW_S`` after its start and later than it
    (times coarser than the window still move on); it counts when the compass turned at
    least ``MIN_TURN_DEG`` and the gyro turned at all.
    """
    ratios = np.empty(t.size)
    n = 0
    t_prev, g_prev, integral = state[S_T], state[S_G], state[S_INTEGRAL]
    last_h, start_t, start_h, start_i = state[S_HEADING], state[S_START_T], state[S_START_H], state[S_START_I]
    big = state[S_MAX_RATE]
    for i in range(t.size):
        gi = g[i]
        if math.isfinite(gi):
            big = max(big, abs(gi))
        else:
            gi = g_prev
        integral += 0.5 * (gi + g_prev) * (t[i] - t_prev)
        t_prev, g_prev = t[i], gi
        h = heading[i]
        if not math.isfinite(h):
            continue
        last_h = h if math.isnan(last_h) else last_h + ((h - last_h + 180.0) % 360.0 - 180.0)
        if math.isnan(start_t):
            start_t, start_h, start_i = t[i], last_h, integral
        elif t[i] >= start_t + WINDOW_S and t[i] > start_t:
            d_compass, d_gyro = last_h - start_h, integral - start_i
            if abs(d_compass) >= MIN_TURN_DEG and d_gyro != 0.0:
                ratios[n] = d_compass / d_gyro
                n += 1
            start_t, start_h, start_i = t[i], last_h, integral
    state[S_ROWS] += t.size
    state[S_T], state[S_G], state[S_INTEGRAL] = t_prev, g_prev, integral
    state[S_HEADING], state[S_START_T], state[S_START_H], state[S_START_I] = last_h, start_t, start_h, start_i
    state[S_MAX_RATE] = big
    return ratios[:n]


def _read_only(x: np.ndarray) -> np.ndarray:
    """A read-only view of ``x`` (one compiled signature, whatever the caller's arrays)."""
    view = x.view()
    view.flags.writeable = False
    return view


class GyroUnitCheck:
    """Compass turn against integrated gyro turn, fed chunk by chunk (see the module notes).

    ``source`` starts the note; ``gyro_unit`` is the unit the gyro columns were read in (None
    when the format states it).
    """

    def __init__(self, source: str, gyro_unit: str | None = None) -> None:
        self.source = source
        self.gyro_unit = gyro_unit
        self._state = np.zeros(N_STATE)
        self._state[S_HEADING] = math.nan
        self._state[S_START_T] = math.nan
        self._ratios: list[float] = []

    def add(self, t_s, gyro_dps, heading_deg) -> None:
        """Account for rows in order: time (s), raw heading-axis rate (deg/s, as read) and
        compass heading (deg, NaN where there is no sample)."""
        t = np.ascontiguousarray(t_s, dtype=np.float64)
        if t.size == 0:
            return
        g = np.ascontiguousarray(gyro_dps, dtype=np.float64)
        h = np.ascontiguousarray(heading_deg, dtype=np.float64)
        if self._state[S_ROWS] == 0.0:  # the first row: no step before it
            first = g[0] if math.isfinite(g[0]) else 0.0
            self._state[S_T], self._state[S_G] = t[0], first
        self._ratios.extend(_turns(_read_only(t), _read_only(g), _read_only(h), self._state).tolist())

    @property
    def ratio(self) -> float:
        """Median compass turn / gyro turn over the windows that turned and agree (module
        notes; NaN: too few, or they do not agree)."""
        ratios = np.asarray(self._ratios, dtype=float)
        if ratios.size < MIN_WINDOWS:
            return math.nan
        sign = 1.0 if np.sum(ratios > 0) >= np.sum(ratios < 0) else -1.0
        same = np.abs(ratios[np.sign(ratios) == sign])
        middle = np.median(same)
        agree = same[(same >= middle / AGREE_FACTOR) & (same <= middle * AGREE_FACTOR)]
        if agree.size < MIN_WINDOWS or 3 * agree.size < 2 * ratios.size:
            return math.nan
        return float(sign * np.median(agree))

    def note(self) -> str | None:
        """The note when the gyro unit looks wrong (None when it does not)."""
        ratio, rad = abs(self.ratio), str(self.gyro_unit).lower() == "rad/s"  # abs: a sign error aside
        head = f"{self.source}: gyro_z"
        if ratio >= RATIO_LIMIT:
            fix = "check the gyro unit" if rad else "if it is in rad/s, pass --gyro-unit rad/s (gyro_unit='rad/s' in Python)"
            return (f"{head} turns {ratio:.3g} times less than the compass over {len(self._ratios)} turning "
                    f"{WINDOW_S:g}-s windows (57.3 would mean rad/s read as deg/s); {fix}")
        if ratio <= 1.0 / RATIO_LIMIT:
            fix = "if it is in deg/s, drop --gyro-unit rad/s" if rad else "check the gyro unit"
            return (f"{head} turns {1.0 / ratio:.3g} times more than the compass over {len(self._ratios)} turning "
                    f"{WINDOW_S:g}-s windows (57.3 would mean deg/s converted as rad/s); {fix}")
        if rad and math.isnan(ratio) and self._state[S_MAX_RATE] > MAX_RATE_DPS:
            return (f"{head} reaches {self._state[S_MAX_RATE]:.4g} deg/s after the rad/s conversion, beyond any MEMS "
                    f"gyro's range ({MAX_RATE_DPS:g} deg/s); if it is in deg/s, drop --gyro-unit rad/s")
        return None

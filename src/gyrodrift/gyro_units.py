"""Is the gyro in the unit it was read in? A check of the heading-axis rate against the compass.

:class:`GyroUnitCheck` compares the compass's turns with the integrated gyro's over 10-s
windows and gives a note when they differ by a factor near 57.3 in windows that agree, or
when rates read as rad/s exceed any MEMS range: docs/conventions.md, section "The
gyro-unit check". Fed chunk by chunk, a log read in chunks gets the note a whole log gets.
"""

from __future__ import annotations

import math

import numpy as np

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


class GyroUnitCheck:
    """Compass turn against integrated gyro turn, fed chunk by chunk (see the module notes).

    ``source`` starts the note; ``gyro_unit`` is the unit the gyro columns were read in (None
    when the format states it).
    """

    def __init__(self, source: str, gyro_unit: str | None = None) -> None:
        self.source = source
        self.gyro_unit = gyro_unit
        self._last = None  # (t, gyro, integral) of the last row
        self._start = None  # (t, unwrapped compass, integral) at the start of the open window
        self._last_heading = math.nan  # unwrapped compass of the last compass sample
        self._ratios: list[float] = []
        self._max_rate_dps = 0.0

    def add(self, t_s, gyro_dps, heading_deg) -> None:
        """Account for rows in order: time (s), raw heading-axis rate (deg/s, as read) and
        compass heading (deg, NaN where there is no sample)."""
        t = np.asarray(t_s, dtype=np.float64)
        if t.size == 0:
            return
        g = np.asarray(gyro_dps, dtype=np.float64)
        ok = np.isfinite(g)
        if ok.any():
            self._max_rate_dps = max(self._max_rate_dps, float(np.max(np.abs(g[ok]))))
        t_prev, g_prev, i_prev = self._last if self._last is not None else (t[0], g[0] if ok[0] else 0.0, 0.0)
        # an empty gyro cell holds the value before it, as in the compensator
        held = np.where(ok, np.arange(g.size), -1)
        np.maximum.accumulate(held, out=held)
        g = np.where(held >= 0, g[np.maximum(held, 0)], g_prev)
        steps = 0.5 * (g + np.r_[g_prev, g[:-1]]) * np.diff(np.r_[t_prev, t])
        integral = i_prev + np.cumsum(steps)
        self._last = (float(t[-1]), float(g[-1]), float(integral[-1]))
        h = np.asarray(heading_deg, dtype=np.float64)
        rows = np.flatnonzero(np.isfinite(h))
        if rows.size == 0:
            return
        turns = np.diff(np.r_[self._last_heading if math.isfinite(self._last_heading) else h[rows[0]], h[rows]])
        unwrapped = (self._last_heading if math.isfinite(self._last_heading) else h[rows[0]]) + np.cumsum(
            (turns + 180.0) % 360.0 - 180.0
        )
        self._last_heading = float(unwrapped[-1])
        tc, ic = t[rows], integral[rows]
        if self._start is None:
            self._start = (float(tc[0]), float(unwrapped[0]), float(ic[0]))
        while True:
            # a later sample even where the window's length is below the times' resolution
            j = max(int(np.searchsorted(tc, self._start[0] + WINDOW_S, "left")),
                    int(np.searchsorted(tc, self._start[0], "right")))
            if j >= tc.size:
                return
            d_compass, d_gyro = unwrapped[j] - self._start[1], ic[j] - self._start[2]
            if abs(d_compass) >= MIN_TURN_DEG and d_gyro != 0.0:
                self._ratios.append(float(d_compass / d_gyro))
            self._start = (float(tc[j]), float(unwrapped[j]), float(ic[j]))

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
        if rad and math.isnan(ratio) and self._max_rate_dps > MAX_RATE_DPS:
            return (f"{head} reaches {self._max_rate_dps:.4g} deg/s after the rad/s conversion, beyond any MEMS "
                    f"gyro's range ({MAX_RATE_DPS:g} deg/s); if it is in deg/s, drop --gyro-unit rad/s")
        return None

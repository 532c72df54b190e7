"""The causal scale-factor estimate row by row: :class:`ScaleFactorTracker`, its rows :class:`ScaleFactorRow`."""

from __future__ import annotations

import bisect
import math
from collections import deque
from typing import NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.kernels.numeric import wrap180, wrap360
from gyrodrift.scale_factor.config import ScaleFactorConfig
from gyrodrift.scale_factor.filter import sf_correct
from gyrodrift.samples import CompensatedSFSample
from gyrodrift.scale_factor.turns import LONG_TURN, measure_turn, read_columns, unmeasured_turn

__all__ = ["ScaleFactorRow", "TRACKER_COLUMNS", "CompensatedSFSample", "ScaleFactorTracker"]

# smallest positive float: the floor of the rotation test's window length (as in moving_mask)
_TINY = float(np.finfo(float).tiny)


class ScaleFactorRow(NamedTuple):
    """One row of :class:`ScaleFactorTracker`: the columns of the causal :func:`estimate_scale_factor`."""

    sf: float
    sf_sd: float
    sf_s0: float
    sf_s1: float
    rate_sf: float
    heading_sf: float
    sf_update: int


#: Columns of :class:`ScaleFactorTracker` output, in order.
TRACKER_COLUMNS = ScaleFactorRow._fields


class ScaleFactorTracker:
    """The causal SF estimate (Sec. 4.3) fed compensated rows in time order.

    :meth:`push` takes one row, :meth:`push_arrays` and :meth:`push_frame` chunks of any
    size; every row comes back at once with the SF in force, bit for bit
    ``estimate_scale_factor(out, config, causal=True)`` however the rows are chunked, in
    bounded memory (``docs/scale_factor.md``, causal and non-causal). ``source`` names the
    rows in error messages.
    """

    _TRIM_ROWS = 64

    def __init__(self, config: ScaleFactorConfig | None = None, *, source: str = "scale-factor stream"):
        cfg = ScaleFactorConfig() if config is None else config
        if not isinstance(cfg, ScaleFactorConfig):
            raise ConfigError(f"ScaleFactorTracker needs a ScaleFactorConfig, got {type(cfg).__name__}")
        self.config = cfg
        self.source = source
        self._half = 0.5 * cfg.turn_window_s
        self._x = np.array(cfg.x0, dtype=float)
        self._P = np.diag(np.square(cfg.p0_sd))
        self._floats()
        # rows kept (parallel lists; element 0 is absolute row self._base)
        self._base = 0
        self._n = 0
        self._t: list[float] = []
        self._rate: list[float] = []
        self._temp: list[float] = []
        self._psi_g: list[float] = []
        self._psi_c: list[float] = []
        self._gate: list[str] = []
        self._moving: list[bool] = []
        self._t_first = math.nan
        # the centred rotation test: next row to decide, interpolation rows of its window
        self._next = 0
        self._p_lo = 0
        self._p_hi = 0
        self._run_start = -1  # first row of the rotation in progress, -1: none
        self._run_dropped = False
        self._pending: deque[tuple[int, int, float]] = deque()  # (first, last row, a1 + guard_s)
        # compass unwrapped against the gyro (np.unwrap, continued)
        self._c_count = 0
        self._c_prev = math.nan
        self._c_corr = 0.0
        # SF-compensated heading
        self._angle = 0.0
        self._rate_sf_prev = math.nan
        self._anchor_angle = math.nan
        self._anchor_deg = math.nan
        #: Number of accepted rotations (filter updates) so far.
        self.n_updates = 0
        #: Decided rotations by reason ('' = accepted), counts.
        self.reasons: dict[str, int] = {}
        #: The turn-table row (:func:`turn_measurements`) of the last decided rotation, or None.
        self.last_turn: dict | None = None

    # -- state
    def _floats(self) -> None:
        self._s0, self._s1 = float(self._x[0]), float(self._x[1])
        self._P00, self._P01, self._P11 = float(self._P[0, 0]), float(self._P[0, 1]), float(self._P[1, 1])

    @property
    def params(self) -> np.ndarray:
        """``[s0 (unitless), s1 (1/degC)]`` now in force."""
        return self._x.copy()

    @property
    def cov(self) -> np.ndarray:
        """Covariance of :attr:`params`."""
        return self._P.copy()

    @property
    def buffered_rows(self) -> int:
        """Number of rows kept for the rotations still to be decided."""
        return len(self._t)

    @property
    def buffer_bound_s(self) -> float:
        """Longest time span the kept rows can cover, s (plus up to 64 rows of trimming slack)."""
        c = self.config
        return c.max_turn_s + 4.0 * c.guard_s + 2.0 * c.still_s + c.turn_window_s

    # -- input
    def push(self, t_s, rate_z_dps, temp_c, compass_heading_deg=math.nan, gate_reason: str = "") -> ScaleFactorRow:
        """Add one compensated row; return its SF columns.

        ``t_s`` (s, finite, increasing), ``rate_z_dps`` (deg/s, finite), ``temp_c`` (degC; NaN
        holds the previous value, the first row needs one), ``compass_heading_deg`` (NaN: no
        sample) and the drift compensator's ``gate_reason``. A bad row is a
        :class:`LogFormatError` and leaves the state alone.
        """
        cfg = self.config
        t, rate, temp = float(t_s), float(rate_z_dps), float(temp_c)
        compass = math.nan if compass_heading_deg is None else float(compass_heading_deg)
        n = self._n
        if not math.isfinite(t):
            raise LogFormatError(f"{self.source}: row {n}: time must be a finite number of seconds, got {t_s!r}")
        if n:
            t_prev = self._t[-1]
            if not t > t_prev:
                raise LogFormatError(f"{self.source}: row {n}: time must increase: got t={t!r} after t={t_prev!r}")
        if not math.isfinite(rate):
            raise LogFormatError(f"{self.source}: row {n}: rate_z must be a finite number of deg/s, got {rate_z_dps!r}")
        if not math.isfinite(temp):
            if not n:
                raise LogFormatError(f"{self.source}: row 0: the first row needs a finite temperature, got {temp_c!r}")
            temp = self._temp[-1]

        # gyro heading: scipy's cumulative_trapezoid, continued (the same operations)
        if n == 0:
            psi = 0.0
            self._t_first = t
        else:
            inc = (t - t_prev) * (rate + self._rate[-1]) / 2.0
            psi = inc if n == 1 else self._psi_g[-1] + inc
        # compass unwrapped against the gyro: numpy's unwrap, continued
        psi_c = math.nan
        has_compass = math.isfinite(compass)
        if has_compass:
            d = wrap180(compass - psi)  # as wrap_180 of the batch pass: the argument is never -0.0
            if self._c_count == 0:
                up = d
            else:
                dd = d - self._c_prev
                ddmod = (dd + 180.0) % 360.0 - 180.0
                if ddmod == -180.0 and dd > 0.0:
                    ddmod = 180.0
                corr = 0.0 if abs(dd) < 180.0 else ddmod - dd
                self._c_corr = corr if self._c_count == 1 else self._c_corr + corr
                up = d + self._c_corr
            self._c_prev = d
            self._c_count += 1
            psi_c = psi + up
        self._t.append(t)
        self._rate.append(rate)
        self._temp.append(temp)
        self._psi_g.append(psi)
        self._psi_c.append(psi_c)
        self._gate.append(gate_reason if isinstance(gate_reason, str) else str(gate_reason))
        self._moving.append(False)
        self._n = n + 1

        self._decide_rotation_test(t)
        update = 0
        while self._pending:
            first, last, lim = self._pending[0]
            nxt = self._next - self._base
            if nxt >= len(self._t) or not self._t[nxt] > lim:
                break
            self._pending.popleft()
            update |= self._decide_turn(first, last, t)
        self._trim()

        # the row's SF and SF-compensated heading (estimate_scale_factor's operations)
        dev = temp - cfg.t_ref_c
        sf = self._s0 + self._s1 * dev
        var = self._P00 + 2.0 * dev * self._P01 + dev * dev * self._P11
        rate_sf = rate / sf
        if n:
            inc = (t - t_prev) * (rate_sf + self._rate_sf_prev) / 2.0
            self._angle = inc if n == 1 else self._angle + inc
        self._rate_sf_prev = rate_sf
        if has_compass and self._anchor_deg != self._anchor_deg:  # first compass heading
            self._anchor_deg, self._anchor_angle = compass, self._angle
        # the scalar form of the batch pass's wrap_360 (integrate_heading): the same bits
        heading = wrap360(self._anchor_deg + (self._angle - self._anchor_angle))
        return ScaleFactorRow(
            sf, math.sqrt(var) if var > 0.0 else 0.0, self._s0, self._s1, rate_sf, heading, update
        )

    def push_arrays(self, t_s, rate_z_dps, temp_c, compass_heading_deg=None, gate_reason=None) -> dict:
        """Add a chunk of rows (arrays of one length, see :meth:`push`); return the :data:`TRACKER_COLUMNS` arrays."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        n = t.size
        rate = np.atleast_1d(np.asarray(rate_z_dps, dtype=float))
        temp = np.atleast_1d(np.asarray(temp_c, dtype=float))
        compass = (np.full(n, np.nan) if compass_heading_deg is None
                   else np.atleast_1d(np.asarray(compass_heading_deg, dtype=float)))
        gates = [""] * n if gate_reason is None else [str(g) for g in np.atleast_1d(np.asarray(gate_reason))]
        sizes = {rate.size, temp.size, compass.size, len(gates)}
        if sizes != {n}:
            raise LogFormatError(f"{self.source}: the chunk's columns differ in length ({n}, {sorted(sizes)})")
        rows = [self.push(*r) for r in zip(t.tolist(), rate.tolist(), temp.tolist(), compass.tolist(), gates)]
        cols = list(zip(*rows)) if rows else [()] * len(TRACKER_COLUMNS)
        return {
            name: np.array(col, dtype=int if name == "sf_update" else float)
            for name, col in zip(TRACKER_COLUMNS, cols)
        }

    def push_frame(self, out: pd.DataFrame) -> pd.DataFrame:
        """Add a chunk of a compensate() table; return the :data:`TRACKER_COLUMNS` on its index."""
        return pd.DataFrame(self.push_arrays(*read_columns(out)), index=out.index)

    # -- steps
    def _interp(self, x: float, p: int) -> tuple[float, int]:
        """``np.interp(x, t, psi_g)`` on the kept rows (the same operations), and the row
        ``p`` with ``t[p] <= x < t[p + 1]`` found by walking forward from ``p``."""
        t, fp, b = self._t, self._psi_g, self._base
        last = len(t) - 1
        j = p - b
        while j < last and t[j + 1] <= x:
            j += 1
        if j == last or t[j] == x:
            return fp[j], j + b
        slope = (fp[j + 1] - fp[j]) / (t[j + 1] - t[j])
        return slope * (x - t[j]) + fp[j], j + b

    def _decide_rotation_test(self, t_now: float) -> None:
        """The centred rotation test (:func:`moving_mask`) of every row whose window has
        ended by ``t_now``; rotations started, ended, or dropped as too long."""
        cfg, half, b = self.config, self._half, self._base
        t = self._t
        while self._next < self._n:
            i = self._next
            ti = t[i - b]
            hi = ti + half
            if hi > t_now:
                break
            lo = ti - half
            if lo < self._t_first:
                lo = self._t_first
            a_hi, self._p_hi = self._interp(hi, self._p_hi)
            a_lo, self._p_lo = self._interp(lo, self._p_lo)
            span = hi - lo
            if span < _TINY:
                span = _TINY
            moving = abs((a_hi - a_lo) / span) > cfg.turn_rate_dps
            self._moving[i - b] = moving
            if moving:
                if self._run_start < 0:
                    self._run_start, self._run_dropped = i, False
                elif not self._run_dropped and ti - t[self._run_start - b] > cfg.max_turn_s:
                    self._run_dropped = True
                    self._count(unmeasured_turn(t[self._run_start - b], ti, LONG_TURN))
            elif self._run_start >= 0:
                if not self._run_dropped:
                    te = t[i - 1 - b]
                    self._pending.append((self._run_start, i - 1, te + cfg.guard_s + cfg.still_s + cfg.guard_s))
                self._run_start = -1
            self._next = i + 1

    def _decide_turn(self, first: int, last: int, t_now: float) -> int:
        """Measure the rotation on rows first..last (shared with the batch pass) and update
        the filter if it is accepted; return 1 if it was."""
        b = self._base
        psi_c = np.array(self._psi_c)
        row = measure_turn(
            np.array(self._t), np.array(self._rate), np.array(self._temp), np.array(self._psi_g), psi_c,
            np.isfinite(psi_c), np.array(self._moving), np.array(self._gate), first - b, last - b, self.config,
            log_start_s=self._t_first, log_end_s=t_now,
        )
        row["row_update"], row["t_update"] = self._n - 1, t_now
        self._count(row)
        if not row["accepted"]:
            return 0
        self._x, self._P = sf_correct(self._x, self._P, row["sf_meas"], row["temp_dev_c"], row["r"], self.config)
        self._floats()
        self.n_updates += 1
        return 1

    def _count(self, row: dict) -> None:
        self.reasons[row["reason"]] = self.reasons.get(row["reason"], 0) + 1
        self.last_turn = row

    def _trim(self) -> None:
        """Forget the rows no rotation still to be decided can need."""
        cfg, b, t = self.config, self._base, self._t
        nxt = min(self._next, self._n - 1) - b
        t_next = t[nxt]
        cut = min(t_next - self._half, t_next - cfg.guard_s - cfg.still_s - cfg.guard_s)
        starts = [self._pending[0][0]] if self._pending else []
        if self._run_start >= 0 and not self._run_dropped:
            starts.append(self._run_start)
        for s in starts:
            cut = min(cut, t[s - b] - cfg.guard_s - cfg.still_s - cfg.guard_s)
        keep = bisect.bisect_right(t, cut) - 1  # the last row at or before the cut
        keep = min(keep, self._p_lo - b, self._p_hi - b)
        if keep >= self._TRIM_ROWS:
            for col in (self._t, self._rate, self._temp, self._psi_g, self._psi_c, self._gate, self._moving):
                del col[:keep]
            self._base = b + keep

"""The engine: one log compensated chunk by chunk, with the same numbers whatever the chunks.

:class:`ChunkEngine` runs the paper's filters for every entry point, its estimator updated in
the row loop (``stkf``, ``stkf-s1``, ``kf``) or in Python at interval ends (any other drift of
eq. 2); the default estimator runs in the subclass
:class:`~gyrodrift.compensator.model_engine.ModelEngine`. Design: ``docs/engine.md`` ("The engine").
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift._columns import read_only_floats
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.estimators import Observation
from gyrodrift.estimators.base import LinearDrift
from gyrodrift.estimators.kalman import compiled_arrays
from gyrodrift.kernels import aiding, drift, loop, numeric
from gyrodrift.kernels import layout as L
from gyrodrift.model import CLOCK_UNIT_S, ElapsedClock
from gyrodrift.compensator.memory import Columns, OutputBuffers, join, new_columns

__all__ = ["ChunkEngine", "settings_arrays", "compiled_arrays", "output_columns", "compiled", "FLOAT_COLUMNS",
           "CODE_COLUMNS", "read_only"]

#: Rows of the accepted-measurement buffer to start with (it grows).
_ACC_ROWS = 64


def read_only(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a``: the kernels take their inputs read-only, one compiled
    version whether the caller's arrays are writable or not (pandas gives read-only ones)."""
    view = a.view()
    view.flags.writeable = False
    return view


_NO_FIELD = read_only(np.empty(0))


def compiled(dispatcher, args):
    """The compiled overload numba's ``dispatcher`` runs for the types of ``args`` (compiled or
    loaded on an earlier call), to call without the dispatcher typing every argument again (a
    one-row call of the streaming path); the dispatcher itself when there is none yet (or with
    ``NUMBA_DISABLE_JIT``)."""
    overloads = getattr(dispatcher, "overloads", None)
    if overloads is None:
        return dispatcher
    from numba import typeof

    found = overloads.get(tuple(typeof(a) for a in args))
    return dispatcher if found is None else found.entry_point


def settings_arrays(config, estimator) -> tuple[np.ndarray, np.ndarray]:
    """The kernels' float and integer settings (``cfg``, ``icfg``) for a configuration and
    estimator."""
    gate, fusion = config.gate, config.fusion_settings
    cfg = np.zeros(L.N_CFG)
    cfg[L.C_INTERVAL] = config.update_interval_s
    cfg[L.C_COMPASS_SD] = config.compass_sigma_deg
    cfg[L.C_GYRO_NOISE] = config.gyro_noise_dps_rthz
    cfg[L.C_TURN_RATE] = gate.turn_rate_dps
    cfg[L.C_TURN_WIN] = gate.turn_window_s
    cfg[L.C_INTERF] = gate.interference_deg
    cfg[L.C_MAX_AGE] = gate.compass_max_age_s
    cfg[L.C_PRIOR_A] = config.kalman.p0_sd[0]
    cfg[L.C_PRIOR_B] = config.kalman.p0_sd[1]
    cfg[L.C_MAX_GAP] = gate.max_gap_s
    cfg[L.C_TP_BIN_S] = config.temp_rate.bin_s
    cfg[L.C_FIELD_NORM_TOL] = gate.field_norm_tol
    cfg[L.C_DIP_TOL] = gate.dip_tol_deg
    cfg[L.C_STILL_STD] = gate.still_std_dps
    cfg[L.C_STILL_HEADING] = gate.still_heading_deg
    vector = fusion.vector(config.gyro_noise_dps_rthz)
    cfg[L.C_FUSION_R:L.C_FUSION_RELOCK + 1] = vector[:5]
    cfg[L.C_FUSION_CONSISTENT] = vector[5]
    icfg = np.zeros(L.N_KCFG, dtype=np.int64)
    icfg[L.K_RELOCK] = gate.relock_intervals
    icfg[L.K_DEPTH] = config.stack_depth
    icfg[L.K_TP_WINDOW_BINS] = config.temp_rate.window_bins
    icfg[L.K_TP_SHORT_BINS] = config.temp_rate.short_bins
    icfg[L.K_FUSE_INTERFERENCE] = int(bool(fusion.magnetic_gates))
    arrays = compiled_arrays(estimator)
    icfg[L.K_MODE] = L.MODE_EXTERNAL if arrays is None else int(arrays[1][L.EI_MODE])
    return cfg, icfg


class ChunkEngine:
    """Resumable compensation of one log, chunk by chunk.

    Parameters
    ----------
    config : CompensatorConfig
    estimator : DriftEstimator
        A fresh estimator whose drift is eq. (2) (:class:`~gyrodrift.estimators.base.LinearDrift`);
        it is updated in place and holds the final state at the end.
    source : str
        Name used in error messages.
    clock : bool, default False
        The drift model's ``T`` is the elapsed time (:class:`gyrodrift.model.ElapsedClock`;
        see :func:`gyrodrift.compensator.uses_clock`), not the ``T`` given, and T' is 0.

    Notes
    -----
    :meth:`feed` returns the output columns of the rows that became available (none
    until the initialisation window is complete, then all of its rows at once);
    :meth:`flush` gives the rows of a log that ended before the window did;
    :meth:`finish` returns the accepted measurements. :attr:`notes` says what could not be
    learned.
    Rows are numbered from 0 across chunks in error messages.
    """

    def __init__(self, config, estimator, source: str = "arrays", *, clock: bool = False):
        owner = next((k for k in type(estimator).__mro__ if "drift" in k.__dict__), None)
        if owner is not LinearDrift:
            raise ConfigError(f"estimator {estimator.name!r}: its drift is not a*T + b*T' + c (eq. 2), which the "
                              "engine compensates with; run it as a baseline of gyrodrift.evaluate.compare")
        self._start_state(config, estimator, source, clock)
        arrays = compiled_arrays(estimator)
        if arrays is None:
            arrays = (np.zeros(L.N_EF), np.zeros(L.N_EI, dtype=np.int64))
        self._ef, self._ei = arrays
        self._set, self._iset = settings_arrays(config, estimator)
        self._external = self._iset[L.K_MODE] == L.MODE_EXTERNAL
        self._lb = np.zeros((64, 2))
        self._stack = np.zeros((config.stack_depth, L.N_MEAS))
        self._refused = np.zeros(max(config.gate.relock_intervals, 1))
        self._acc = np.zeros((_ACC_ROWS, L.N_MEAS))
        self._accepted: list[np.ndarray] = []

    def _start_state(self, config, estimator, source: str, clock: bool) -> None:
        """The state of every engine before its first row (the row loop's own arrays aside)."""
        self.cfg = config
        self.est = estimator
        self.source = source
        self._fs = np.zeros(L.N_FSTATE)
        self._fs[L.F_FIELD_NORM] = self._fs[L.F_FIELD_DIP] = math.nan
        self._ist = np.zeros(L.N_ISTATE, dtype=np.int64)
        self._ist[L.I_INIT_END] = -1
        self._ist[L.I_ANCHOR_ROW] = -1
        self._bins = np.zeros((config.temp_rate.window_bins + 3, 3))
        self._t0: float | None = None
        self._held: list[tuple] | None = []  # prepared chunks of the init window, until it is complete
        self._window: _WindowRows | None = None  # rows of the init window taken one by one (window_row)
        self._row: _RowMemory | None = None
        #: the provisional rows' previous time and rate, heading integral, anchor and its time
        self._prov = (math.nan, 0.0, 0.0, math.nan, math.nan)
        self._prov_model: tuple | None = None  # a, b, c, covariance (9) and unobservable code
        #: What could not be learned or was done instead (one-line sentences, for the user).
        self.notes: list[str] = []
        self._clock = ElapsedClock(config.gate.max_gap_s) if clock else None
        if clock:
            why = "asked for" if config.temperature == "clock" else "the log has no temperature, or it never changes"
            self.notes.append(f"{source}: the drift model's T is the elapsed time, not the temperature ({why}): "
                              f"c is the drift at the start and a its change per {CLOCK_UNIT_S:g} s, deg/s")

    @property
    def regressor(self) -> str:
        """What the drift model's ``T`` is: ``"temperature"`` or ``"clock"`` (the elapsed time)."""
        return "temperature" if self._clock is None else "clock"

    # ---------------------------------------------------------------- state
    @property
    def initialised(self) -> bool:
        """True once the init window is complete (rows come out as they go in)."""
        return self._held is None

    @property
    def rows_in(self) -> int:
        """Rows taken so far."""
        return int(self._ist[L.I_ROWS])

    @property
    def t_start(self) -> float:
        """End of the init window, s (NaN before the first row)."""
        return math.nan if self._t0 is None else float(self._fs[L.F_TSTART])

    # ----------------------------------------------------------------- feed
    def feed(self, t, g, T, heading, norm=None, dip=None, tilt_diff=None,
             buffers: OutputBuffers | None = None) -> dict | None:
        """Add a chunk of rows; return the output columns of the rows that became available.

        Parameters
        ----------
        t, g, T, heading : (n,) array_like
            Time (s, strictly increasing across chunks), raw heading-axis rate (deg/s),
            temperature (degC), compass heading (deg; NaN = no sample). An empty or
            infinite gyro or temperature cell holds the previous value (``gap``).
        norm, dip : (n,) array_like, optional
            Field strength and dip of the raw magnetometer (field-anomaly gate).
        tilt_diff : (n,) array_like, optional
            Difference of each compass sample's headings tilted by the accelerometer and by the
            gyro-aided gravity, deg (NaN: none known): the default estimator's model widens the
            compass by it (``docs/model.md``, "The compass's tilt").
        buffers : OutputBuffers, optional
            Memory for the output, used when all the rows of this chunk come out of this
            call (a whole log); the returned columns are then views of it.

        Returns
        -------
        dict or None
            Columns ``t, bias_z, rate_z, heading, a, b, c, bias_sd, heading_fused,
            heading_fused_sd, heading_sd, temp_rate, compass_heading`` (float) and
            ``updated, reason, unobs`` (int8 codes), or None while the init window fills.
        """
        n = len(t)
        if n == 0:
            return None
        self._hold_window_rows()
        if self.cfg.declination_deg:  # magnetic to true north (CompensatorConfig.declination_deg)
            heading = np.asarray(heading, dtype=float) + self.cfg.declination_deg
        if self._clock is not None:
            T = self._clock(t)
        t, g, T, heading = (read_only_floats(a) for a in (t, g, T, heading))
        norm = _NO_FIELD if norm is None else read_only_floats(norm)
        dip = _NO_FIELD if dip is None else read_only_floats(dip)
        tilt_diff = _NO_FIELD if tilt_diff is None else read_only_floats(tilt_diff)
        if self._t0 is None:
            self._first_row(float(t[0]), g[0], T[0])
        whole = self._held is None or (not self._held and float(t[-1]) >= self._fs[L.F_TSTART])
        helper = None
        if whole and buffers is not None:
            cols = buffers.take(n)
        else:
            cols, helper = new_columns(n)
        try:
            rows_before = self.rows_in
            bad, fix = loop.prepare(t, g, T, heading, self._fs, self._ist, self._set, self._iset, self._bins,
                                    cols.g_held, cols.T_held, cols.h_wrapped, cols.column(L.O_TEMP_RATE),
                                    cols.code(L.OC_GAP).view(np.bool_))
            if bad >= 0:
                raise _bad_time(self.source, rows_before + bad)
            if self._clock is not None:
                cols.column(L.O_TEMP_RATE)[:] = 0.0
            inputs = (t, read_only(cols.g_held) if fix & 1 else g, read_only(cols.T_held) if fix & 2 else T,
                      read_only(cols.h_wrapped) if fix & 4 else heading, norm, dip, tilt_diff)
            if self._held is not None:
                self._held.append((inputs, cols))
                if not t[-1] - self._fs[L.F_TSTART] >= 0:
                    return None
                return self._close_window()
            return self._run(inputs, cols)
        finally:
            join(helper)

    def window_row(self, t: float, g: float, T: float, heading: float, norm: float = math.nan,
                   dip: float = math.nan, tilt_diff: float = math.nan) -> dict | None:
        """One row while the init window fills, on floats (the streaming path): checked and
        prepared as :meth:`feed` prepares a chunk (the same kernel, the same bits) and held
        with the window's other rows. Returns what :meth:`feed` returns: None until the row
        completes the window, then the output columns of every row of the window.
        :meth:`provisional` gives the row's provisional outputs meanwhile."""
        w = self._window
        if w is None:
            if self._held is None:
                raise GyroDriftError(f"{self.source}: the init window is complete: feed rows with feed_row()")
            w = self._window = _WindowRows()
        if self._clock is not None:
            T = float(self._clock((t,))[0])
        heading += self.cfg.declination_deg  # magnetic to true north, as in feed
        if self._t0 is None:
            self._first_row(t, g, T)
        r = self._row or self._new_row()
        fix = self._prepare_row(r, t, g, T, heading, norm, dip, tilt_diff)
        cols = r.cols
        if fix:  # a held gyro or temperature cell, or a compass heading wrapped
            g = float(cols.g_held[0]) if fix & 1 else g
            T = float(cols.T_held[0]) if fix & 2 else T
            heading = float(cols.h_wrapped[0]) if fix & 4 else heading
        w.rows.append((t, g, T, heading, norm, dip, tilt_diff, float(r.Tp[0]), bool(r.gap[0])))
        if not t - self._fs[L.F_TSTART] >= 0:
            return None
        self._hold_window_rows()
        return self._close_window()

    def _first_row(self, t: float, g: float, T: float) -> None:
        """The log's first row, which needs gyro and temperature values; the init window ends
        ``init_s`` after it."""
        if not (math.isfinite(g) and math.isfinite(T)):
            raise LogFormatError(f"{self.source}: the first sample needs gyro_z and temp values")
        if self.cfg.init_s > 0 and not t + self.cfg.init_s > t:  # a window float64 cannot tell from t
            raise LogFormatError(f"{self.source}: row 0: time {t:g} s is too far from 0 for the {self.cfg.init_s:g}-s "
                                 "init window to be told from it; give times in seconds (from the log's start, or "
                                 "the Unix epoch)")
        self._t0 = t
        self._fs[L.F_TSTART] = t + self.cfg.init_s

    def _hold_window_rows(self) -> None:
        """The rows taken by :meth:`window_row` since the last chunk, held as one prepared chunk."""
        if self._window is not None:
            self._held.append(self._window.chunk())
            self._window = None

    def _close_window(self) -> dict:
        """The init window complete: its held chunks joined, the initialisation, its rows compensated."""
        inputs, cols = _joined(self._held) if len(self._held) > 1 else self._held[0]
        self._held = None
        self._initialise(inputs, cols.column(L.O_TEMP_RATE))
        return self._run(inputs, cols)

    def _window_end(self, t, holds: str) -> int:
        """The init window's last row: the first at or after ``t_start``, or the last row of a log
        that ends before (a short log: the window is what there is; a note says it is
        compensated from ``holds`` and the prior)."""
        if t.size < 2:  # no time span: the init window's measurements would divide by zero
            raise LogFormatError(f"{self.source}: the log has a single sample; give at least two samples")
        e = min(int(np.searchsorted(t, self._fs[L.F_TSTART], "left")), t.size - 1)
        if t[e] < self._fs[L.F_TSTART]:
            self.notes.append(f"{self.source}: the log is {t[e] - t[0]:.1f} s long, shorter than the "
                              f"{self.cfg.init_s:g}-s init window: compensated from {holds} and the prior")
        return e

    def _initialise(self, inputs, Tp) -> None:
        """The init window's measurements, the estimator's first update and the field reference."""
        t, g, T, heading, norm, dip, _ = inputs
        cfg = self.cfg
        e = self._window_end(t, "its still parts")
        span = min(float(cfg.init_s), float(t[e] - t[0]))
        found, anchor = aiding.init_measurements(t, g, T, Tp, heading, e, cfg.stack_depth, max(span, 1e-9),
                                                 self._set, self._ist, self._stack, self._acc, cfg.stack_depth)
        if anchor < 0:
            self.notes.append(f"{self.source}: no compass sample in the first {span:.1f} s: the heading starts "
                              "at 0 deg at the first sample (relative)")
        if norm.size:
            self._fs[L.F_FIELD_NORM], self._fs[L.F_FIELD_DIP] = aiding.field_reference(norm, dip, e + 1)
        if found:
            y, H, R = aiding.stacked(self._stack, int(self._ist[L.I_STACK_N]))
            self.est.update(Observation(t=float(t[e]), y=y, H=H, R=R, n_new=int(found)))
        self._in_force()
        self._ist[L.I_INIT_END] = e
        self._ist[L.I_INIT_UPDATED] = int(found > 0)
        self._ist[L.I_ANCHOR_ROW] = anchor

    def _in_force(self) -> None:
        """The estimator's parameters, covariance and unobservable code into the state."""
        if not self._external:
            aiding.in_force(self._fs, self._ist, self._set, self._ef, self._ei)
            return
        C = np.ascontiguousarray(self.est.cov, dtype=float).reshape(3, 3)
        self._fs[L.F_PA:L.F_PC + 1] = self.est.params
        self._fs[L.F_COV:L.F_COV + 9] = C.ravel()
        self._ist[L.I_UNOBS] = aiding.unobservable_code(C, self._set[L.C_PRIOR_A], self._set[L.C_PRIOR_B])

    def _run(self, inputs, cols: Columns) -> dict:
        t, g, T, heading, norm, dip, _ = inputs  # the paper's filters take no compass tilt error
        Tp = read_only(cols.column(L.O_TEMP_RATE))
        gap = read_only(cols.code(L.OC_GAP).view(np.bool_))
        i = 0
        while i < t.size:
            i = loop.run_chunk(t, g, T, Tp, heading, gap, norm, dip, i, self._fs, self._ist, self._set, self._iset,
                               self._lb, self._stack, self._refused, self._acc, self._ef, self._ei,
                               cols.out, cols.codes, cols.n)
            self._after_stop()
        return output_columns(t, heading, cols)

    def _after_stop(self) -> None:
        """What the row loop stopped for: the external estimator's update, or a full buffer."""
        ist = self._ist
        pending = ist[L.I_PENDING]
        if pending != L.PENDING_NONE:
            ist[L.I_PENDING] = L.PENDING_NONE
            if pending == L.PENDING_UPDATE:
                n = int(ist[L.I_STACK_N])
                y, H, R = aiding.stacked(self._stack, n)
                self.est.update(Observation(t=float(self._acc[ist[L.I_N_ACC] - 1, 0]), y=y, H=H, R=R, n_new=1))
            else:
                self.est.hold()
            self._in_force()
        if ist[L.I_LB_N] >= self._lb.shape[0]:  # grow the turning ring, oldest first
            head, n = int(ist[L.I_LB_HEAD]), int(ist[L.I_LB_N])
            order = (head + np.arange(n)) % self._lb.shape[0]
            lb = np.zeros((2 * self._lb.shape[0], 2))
            lb[:n] = self._lb[order]
            self._lb = lb
            ist[L.I_LB_HEAD] = 0
        if ist[L.I_N_ACC] >= self._acc.shape[0]:
            self._flush_accepted()

    def _flush_accepted(self) -> None:
        n = int(self._ist[L.I_N_ACC])
        self._accepted.append(self._acc[:n].copy())
        self._ist[L.I_N_ACC] = 0
        if self._acc.shape[0] < 4096:
            self._acc = np.zeros((2 * self._acc.shape[0], L.N_MEAS))

    def feed_row(self, t: float, g: float, T: float, heading: float, norm: float = math.nan,
                 dip: float = math.nan, tilt_diff: float = math.nan) -> tuple[list, list, float]:
        """One row after initialisation, on floats (the streaming path; the same kernels as
        :meth:`feed`). Returns the N_OUT float outputs and the N_CODES codes of the row, as
        lists in the order of :mod:`gyrodrift.kernels.layout`, and the compass heading used."""
        r = self._row or self._new_row()
        if self._clock is not None:
            T = float(self._clock((t,))[0])
        heading += self.cfg.declination_deg  # magnetic to true north, as in feed
        fix = self._prepare_row(r, t, g, T, heading, norm, dip, tilt_diff)
        self._run_row(r, fix)
        cols = r.cols
        return cols.out.tolist(), cols.codes.tolist(), float(cols.h_wrapped[0]) if fix & 4 else heading

    def _new_row(self) -> _RowMemory:
        self._row = _RowMemory()
        return self._row

    def _prepare_row(self, r: _RowMemory, t: float, g: float, T: float, heading: float, norm: float,
                     dip: float, tilt_diff: float) -> int:
        """One row into the row memory, checked and prepared (:func:`gyrodrift.kernels.loop.prepare`,
        T' 0 with the clock); returns prepare's ``fix`` bits. The arrays are passed as they are,
        writable: numba's dispatcher types a writable array in C and a read-only one in Python
        (about 0.2 µs more per argument); the kernel writes none of its inputs."""
        r.t[0], r.g[0], r.T[0], r.heading[0] = t, g, T, heading
        r.norm[0], r.dip[0], r.tilt_diff[0] = norm, dip, tilt_diff
        cols = r.cols
        args = (r.t, r.g, r.T, r.heading, self._fs, self._ist, self._set, self._iset, self._bins, cols.g_held,
                cols.T_held, cols.h_wrapped, r.Tp, r.gap)
        if r.prepare is None:  # the first row: through the dispatcher, then its compiled function
            bad, fix = loop.prepare(*args)
            r.prepare = compiled(loop.prepare, args)
        else:
            bad, fix = r.prepare(*args)
        if bad >= 0:  # nothing was taken: the rows so far are those before this one
            raise _bad_time(self.source, self.rows_in + bad)
        if self._clock is not None:
            r.Tp[0] = 0.0
        return fix

    def _run_row(self, r: _RowMemory, fix: int) -> None:
        """The prepared row of :meth:`feed_row` through the row loop (its read-only views: the
        paper's loop is compiled for those)."""
        g = r.ro_g_held if fix & 1 else r.ro_g
        T = r.ro_T_held if fix & 2 else r.ro_T
        heading = r.ro_h_wrapped if fix & 4 else r.ro_heading
        done = 0
        while done < 1:  # 0: a ring was full before the row (grown by _after_stop)
            done = loop.run_chunk(r.ro_t, g, T, r.ro_Tp, heading, r.ro_gap, r.ro_norm, r.ro_dip, 0, self._fs,
                                  self._ist, self._set, self._iset, self._lb, self._stack, self._refused,
                                  self._acc, self._ef, self._ei, r.cols.out, r.cols.codes, 1)
            self._after_stop()

    # --------------------------------------------------------------- finish
    def provisional(self) -> tuple:
        """The provisional row of the last :meth:`window_row`, compensated causally with the drift
        model in force before any measurement (``docs/engine.md``, "Provisional rows").

        Returns ``(t, out, codes, compass_heading)`` on Python floats and ints, as :meth:`feed_row`
        gives them (the order of :mod:`gyrodrift.kernels.layout`)."""
        w = self._window
        ti, gi, Ti, hi, _, _, _, Tpi, _ = w.rows[-1]
        if self._prov_model is None:  # nothing updates the estimator before the window ends
            C = np.asarray(self.est.cov, dtype=float).reshape(9)
            unobs = aiding.unobservable_code(C.reshape(3, 3), self._set[L.C_PRIOR_A], self._set[L.C_PRIOR_B])
            codes = [0] * L.N_CODES
            codes[L.OC_REASON], codes[L.OC_UNOBS] = L.R_INIT, int(unobs)
            self._prov_model = (*(float(v) for v in self.est.params), tuple(C.tolist()), codes)
        a, b, c, C, codes = self._prov_model
        t_prev, rate_prev, integral, anchor, t_anchor = self._prov
        bias = drift.bias(a, b, c, Ti, Tpi)
        rate = gi - bias
        if not math.isnan(t_prev) and ti - t_prev <= self.cfg.gate.max_gap_s:
            integral += 0.5 * (rate + rate_prev) * (ti - t_prev)
        if math.isnan(anchor) and not math.isnan(hi):
            anchor, t_anchor = hi - integral, ti
        self._prov = (ti, rate, integral, anchor, t_anchor)
        sd = drift.bias_sd(*C, Ti, Tpi)
        out = [math.nan] * L.N_OUT
        out[L.O_BIAS], out[L.O_RATE], out[L.O_BIAS_SD], out[L.O_TEMP_RATE] = bias, rate, sd, Tpi
        out[L.O_A], out[L.O_B], out[L.O_C] = a, b, c
        out[L.O_HEADING] = numeric.wrap360((0.0 if math.isnan(anchor) else anchor) + integral)
        since = ti - (self._t0 if math.isnan(t_anchor) else t_anchor)
        out[L.O_HEADING_SD] = math.hypot(self.cfg.compass_sigma_deg if not math.isnan(anchor) else 0.0, sd * since)
        if not math.isnan(anchor):  # the fused heading, as the filter's: none before the first compass sample
            out[L.O_FUSED], out[L.O_FUSED_SD] = out[L.O_HEADING], out[L.O_HEADING_SD]
        return ti, out, codes, hi

    def flush(self) -> dict | None:
        """The rows held back while the init window fills (a log shorter than the window),
        compensated from what they give (the window ends at the last row): output columns
        as :meth:`feed` returns them, or None when no row is held. Rows fed afterwards
        come out as they go in."""
        if self._held is None:
            return None
        self._hold_window_rows()
        if not self._held:
            return None
        return self._close_window()

    def finish(self) -> np.ndarray:
        """End of the log: return the accepted measurements, an (M, 5) array of (time s,
        m deg/s, mean T degC, mean T' degC/s, r (deg/s)²). Rows still held must have been
        taken with :meth:`flush` first."""
        if self._t0 is None:
            raise LogFormatError(f"{self.source}: the log has no samples")
        if self._held or self._window is not None:
            raise GyroDriftError(f"{self.source}: rows are still held: call flush() before finish()")
        return self.accepted()

    def accepted(self) -> np.ndarray:
        """The accepted measurements so far (see :meth:`finish`)."""
        self._flush_accepted()
        return np.concatenate(self._accepted) if self._accepted else np.zeros((0, L.N_MEAS))


#: Names of the engine's float output columns and of its codes, in the order of :mod:`gyrodrift.kernels.layout`.
FLOAT_COLUMNS = ("bias_z", "rate_z", "heading", "a", "b", "c", "bias_sd", "heading_fused", "heading_fused_sd",
                 "heading_sd", "temp_rate")
CODE_COLUMNS = ("updated", "reason", "unobs")


def output_columns(t: np.ndarray, heading: np.ndarray, cols: Columns) -> dict:
    """The output columns of :meth:`ChunkEngine.feed` (views of ``cols``) for rows at times
    ``t`` whose compass heading was ``heading``."""
    return {"t": t, **{name: cols.column(k) for k, name in enumerate(FLOAT_COLUMNS)}, "compass_heading": heading,
            **{name: cols.code(k) for k, name in enumerate(CODE_COLUMNS)}}


def _bad_time(source: str, row: int) -> LogFormatError:
    """The error of a row whose time :func:`gyrodrift.kernels.loop.prepare` refuses."""
    return LogFormatError(f"{source}: row {row}: time must be finite and strictly increasing, by at most "
                          f"{loop.MAX_STEP_S:.0e} s a step")


def _joined(held: list[tuple]) -> tuple[tuple, Columns]:
    """The prepared chunks of the init window as one: inputs (with T') and fresh columns."""
    n = sum(cols.n for _, cols in held)
    joined, helper = new_columns(n)
    join(helper)
    inputs = tuple(read_only(np.concatenate([part[0][k] for part in held])) if held[0][0][k].size else held[0][0][k]
                   for k in range(7))
    joined.column(L.O_TEMP_RATE)[:] = np.concatenate([cols.column(L.O_TEMP_RATE) for _, cols in held])
    joined.code(L.OC_GAP)[:] = np.concatenate([cols.code(L.OC_GAP) for _, cols in held])
    return inputs, joined


class _RowMemory:
    """One-row inputs and outputs, reused by :meth:`ChunkEngine.feed_row`."""

    def __init__(self):
        self.t, self.g, self.T, self.heading, self.norm, self.dip, self.tilt_diff = (np.zeros(1) for _ in range(7))
        self.cols = Columns(np.zeros(L.N_OUT), np.zeros(L.N_CODES, dtype=np.int8), np.zeros(1), np.zeros(1),
                            np.zeros(1), 1)
        self.Tp = self.cols.column(L.O_TEMP_RATE)
        self.gap = self.cols.code(L.OC_GAP).view(np.bool_)
        #: the compiled kernels of these arrays and the engine's (:func:`compiled`), once called
        self.prepare = self.run = None
        # the read-only views the kernels take (they see what is written to the arrays above)
        for name in ("t", "g", "T", "heading", "norm", "dip", "tilt_diff", "Tp", "gap"):
            setattr(self, "ro_" + name, read_only(getattr(self, name)))
        for name in ("g_held", "T_held", "h_wrapped"):
            setattr(self, "ro_" + name, read_only(getattr(self.cols, name)))


class _WindowRows:
    """The rows of the init window taken one by one (:meth:`ChunkEngine.window_row`), as
    :func:`gyrodrift.kernels.loop.prepare` left them: the inputs the row loop takes (held
    cells filled, the compass wrapped), T' and the gap flag, one tuple a row."""

    def __init__(self):
        self.rows: list[tuple] = []  # (t, g, T, heading, norm, dip, tilts' difference, T', gap)

    def chunk(self) -> tuple[tuple, Columns]:
        """The rows as one prepared chunk, as :meth:`ChunkEngine.feed` holds one: inputs and columns."""
        t, g, T, heading, norm, dip, tilt_diff, Tp, gap = zip(*self.rows)
        cols, helper = new_columns(len(t))
        join(helper)
        cols.column(L.O_TEMP_RATE)[:] = Tp
        cols.code(L.OC_GAP)[:] = gap
        inputs = tuple(read_only(np.array(v, dtype=float)) for v in (t, g, T, heading, norm, dip, tilt_diff))
        return inputs, cols

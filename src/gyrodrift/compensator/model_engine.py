"""The engine of the default estimator's model: :class:`ModelEngine`, and :func:`make_engine`.

A :class:`~gyrodrift.compensator.engine.ChunkEngine` whose rows run through the model's row
loop (:func:`gyrodrift.kernels.evloop.run`); how it differs: ``docs/engine.md`` ("The model's
engine").
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.compensator.engine import ChunkEngine, read_only, compiled, output_columns, settings_arrays
from gyrodrift.estimators.adaptive import AdaptiveModel
from gyrodrift.kernels import evidence as ev
from gyrodrift.kernels import evloop
from gyrodrift.kernels import layout as L

__all__ = ["ModelEngine", "make_engine"]


def make_engine(config, estimator, source: str = "arrays", *, clock: bool = False, record: bool = True) -> ChunkEngine:
    """The engine that runs ``estimator``: :class:`ModelEngine` for the model (``record``: keep
    the epoch history for the smoother), else the paper's interval engine (:class:`ChunkEngine`)."""
    if isinstance(estimator, AdaptiveModel):
        return ModelEngine(config, estimator, source, clock=clock, record=record)
    return ChunkEngine(config, estimator, source, clock=clock)


class ModelEngine(ChunkEngine):
    """Resumable compensation of one log by the model (the interface of :class:`ChunkEngine`)."""

    def __init__(self, config, estimator, source: str = "arrays", *, clock: bool = False, record: bool = True):
        self._start_state(config, estimator, source, clock)
        self._set, self._iset = settings_arrays(config, None)
        self._set[L.C_MAX_GAP] = math.inf  # time gaps are the model's, relative to the log's spacing
        self._external = False
        self._mc = None
        self._init_last = None  # last row of the init window, until its rows are settled
        self._rf = np.zeros(evloop.RF_N)
        self._clocked = False  # the sample clock's note is said
        self._hist = np.zeros((256, evloop.N_HIST)) if record else np.zeros((0, 0))
        self._rc = np.zeros(evloop.RC_N)
        gate = config.gate
        self._rc[evloop.RC_TURN_RATE] = gate.turn_rate_dps
        self._rc[evloop.RC_TURN_WIN] = gate.turn_window_s
        self._rc[evloop.RC_MAX_AGE] = gate.compass_max_age_s
        self._rc[evloop.RC_PRIOR_A] = config.kalman.p0_sd[0]
        self._rc[evloop.RC_PRIOR_B] = config.kalman.p0_sd[1]

    def _initialise(self, inputs, Tp) -> None:
        t, g, T, heading, norm, dip, _ = inputs
        e = self._window_end(t, "what it holds")
        if not np.isfinite(heading[: e + 1]).any():
            self.notes.append(f"{self.source}: no compass sample in the first {t[e] - t[0]:.1f} s: the heading "
                              "starts at 0 deg at the first sample (relative)")
        self._mc = self.est.start(float(T[0]), self.cfg.compass_sigma_deg, self.cfg.gyro_noise_dps_rthz,
                                  self._clock is not None)
        self._init_last = e
        self._rf[evloop.RF_FIRST_ROW] = -1.0
        self._rf[evloop.RF_INIT_RAW] = 1.0
        self._rf[evloop.RF_UNOBS] = evloop.unobservable(self.est.mf, self._rc)

    def _loop(self, t, g, T, Tp, heading, held, norm, dip, tilt_diff, cols, i=0) -> None:
        """Rows ``i..`` of the arrays through the model's row loop (growing the epoch history)."""
        while i < t.size:
            i = evloop.run(t, g, T, Tp, heading, held, norm, dip, tilt_diff, i, self.est.mf, self._mc, self._rf,
                           self._rc, cols.out, cols.codes, cols.n, self._hist)
            if i < t.size:  # the epoch history is full: twice the room
                hist = np.zeros((2 * self._hist.shape[0], evloop.N_HIST))
                hist[:self._hist.shape[0]] = self._hist
                self._hist = hist
        self._clock_note()

    def _clock_note(self) -> None:
        """Say once that the rows are timed by the sample clock (``docs/model.md``, "A sample
        clock for rows stamped on arrival"), with the steps that showed it."""
        if self._clocked or self._rf[evloop.RF_CLOCKED] == 0.0:
            return
        self._clocked = True
        mf = self.est.mf
        typical, mean = math.exp(mf[ev.MF_H_L] / mf[ev.MF_H_N]), mf[ev.MF_H_S] / mf[ev.MF_H_N]
        self.notes.append(f"{self.source}: its rows look stamped as they arrived, in clusters (typical step "
                          f"{1e3 * typical:.3g} ms, mean {1e3 * mean:.3g} ms): the model times them by a sample clock "
                          "at the mean step, and the output's t keeps the stamps")

    def epochs(self) -> np.ndarray:
        """The epoch history so far (rows of :data:`gyrodrift.kernels.evloop.N_HIST` columns;
        empty when not recorded)."""
        n = int(self._rf[evloop.RF_HIST_N])
        return self._hist[:n].copy() if self._hist.shape[1] else np.zeros((0, evloop.N_HIST))

    @property
    def temp_ref_c(self) -> float:
        """The model's reference temperature T_ref (degC; the clock's units when T is the clock)."""
        return float(self.est.mf[ev.MF_TREF])

    def _run(self, inputs, cols) -> dict:
        t, g, T, heading, norm, dip, tilt_diff = inputs
        Tp = read_only(cols.column(L.O_TEMP_RATE))
        held = read_only(cols.code(L.OC_GAP).view(np.bool_))
        start = 0
        if self._init_last is not None:  # the init window's rows first, then settled; the rest after
            last = self._init_last
            # T' over the init window is the window's own slope: the trailing estimate at its
            # last row (the rows are reported after it), not the start-up of the estimate
            cols.column(L.O_TEMP_RATE)[:last] = Tp[last]
            self._loop(t[:last + 1], g[:last + 1], T[:last + 1], Tp[:last + 1], heading[:last + 1], held[:last + 1],
                       *(v[:last + 1] if v.size else v for v in (norm, dip, tilt_diff)), cols)
            n_init = last if t[last] >= self._fs[L.F_TSTART] else last + 1  # the rows before the window's end
            evloop.settle(t, g, T, Tp, heading, last, n_init, self.est.mf[ev.MF_TREF], self._rf, cols.out, cols.codes,
                          cols.n)
            self._init_last = None
            start = last + 1
        self._loop(t, g, T, Tp, heading, held, norm, dip, tilt_diff, cols, start)
        return output_columns(t, heading, cols)

    def _run_row(self, r, fix: int) -> None:
        # the row memory's arrays as they are, writable (see ChunkEngine._prepare_row); the
        # history-growing loop only when the epoch history was full before the row
        cols = r.cols
        g = cols.g_held if fix & 1 else r.g
        T = cols.T_held if fix & 2 else r.T
        h = cols.h_wrapped if fix & 4 else r.heading
        args = (r.t, g, T, r.Tp, h, r.gap, r.norm, r.dip, r.tilt_diff, 0, self.est.mf, self._mc, self._rf, self._rc,
                cols.out, cols.codes, 1, self._hist)
        if r.run is None:  # the first row: through the dispatcher, then its compiled function
            done = evloop.run(*args)
            r.run = compiled(evloop.run, args)
        else:
            done = r.run(*args)
        if done < 1:
            self._loop(r.t, g, T, r.Tp, h, r.gap, r.norm, r.dip, r.tilt_diff, cols)
        elif not self._clocked and self._rf[evloop.RF_CLOCKED] > 0.0:
            self._clock_note()

    def accepted(self) -> np.ndarray:
        """The model takes no interval measurements: an empty (0, 5) array."""
        return np.zeros((0, L.N_MEAS))


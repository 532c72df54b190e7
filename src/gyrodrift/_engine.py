"""The fast batch engine: compiled per-sample loop, fed in chunks of any size.

:func:`gyrodrift.compensate.compensate_arrays` runs the reference engine (numpy per
update interval, the same arithmetic as the streaming :class:`~gyrodrift.compensate.Compensator`)
or this one. This one runs the whole log, filter updates included, in one compiled
loop (numba), for the Kalman-family estimators (``stkf``, ``stkf-s1``, ``kf``, and
``adaptive`` with every setting of :class:`~gyrodrift.estimators.AdaptiveConfig`) with
the paper's ``endpoints`` measurement (:func:`supports`):

* :mod:`gyrodrift._kernels`: the row loop (``Compensator._step``), the interval decision
  (``_Aiding.begin``/``close``) and the fixed-fading filter of eq. (10);
* :mod:`gyrodrift._adaptive_kernels`: what ``adaptive`` adds, one function per function
  of the reference (the compass window, edge means, ZARU, ``AdaptiveKalman.update`` and
  ``hold`` with the twin filter and the outage anchor);
* :mod:`gyrodrift._common_kernels`: angle wrapping, the Kalman correction and the cap,
  numpy's pairwise summation.

It is resumable: :class:`ChunkEngine` takes the log in chunks and returns the rows of
each, with the same numbers whatever the chunk sizes (the basis of the constant-memory
file path). Its numbers agree with the reference engine to rounding (the T' bin means
and the integrals are summed in a different order); the tests hold both to that, with
the same decisions (tests/test_engine.py, tests/test_engine_adaptive.py).

numba is an optional dependency (``pip install 'gyrodrift[fast]'``); without it the
reference engine runs. The kernels are compiled on first use (about a minute) and
cached in ``__pycache__``. numba's cache checks only the file that defines a function:
after editing :mod:`gyrodrift._adaptive_kernels`, :mod:`gyrodrift._common_kernels` or
:mod:`gyrodrift._fusion_kernels` alone, delete ``src/gyrodrift/__pycache__/_kernels.*.nb*``
(or touch ``_kernels.py``), else the row loop keeps the old code of those it calls.
"""

from __future__ import annotations

import importlib.util
import math
import sys
import threading

import numpy as np

from gyrodrift import gating
from gyrodrift.conventions import wrap_360
from gyrodrift.errors import GyroDriftError, LogFormatError

__all__ = ["available", "supports", "unsupported", "ChunkEngine", "OutputBuffers"]

# The kernel's reason codes index gating.REASONS; its unobservable codes (1 for a + 2
# for b) index compensate.UNOBSERVABLE.


def available() -> bool:
    """True when numba is installed (the fast engine can run)."""
    return importlib.util.find_spec("numba") is not None


def supports(config, estimator) -> bool:
    """True when the fast engine implements this configuration and estimator.

    Implemented: the ``endpoints`` measurement (eqs. 4–6; not ``slope``) with an
    estimator whose ``update``, ``hold`` and ``engine_state`` are defined in one class
    (a subclass overriding those runs on the reference engine) and whose drift is the
    linear one of eq. (2) (:class:`~gyrodrift.estimators.base.LinearDrift`): the Kalman
    family ``stkf``, ``stkf-s1``, ``kf`` and ``adaptive`` with any
    :class:`~gyrodrift.estimators.AdaptiveConfig` (every fix of issue 6 on or off:
    edge averaging, ZARU and its hold, recentring, slope random walk, normalised or
    Zhou fading test, outage memory, one or stacked measurements), except the quadratic
    temperature term.
    """
    return unsupported(config, estimator) is None


def unsupported(config, estimator) -> tuple[str, str] | None:
    """What of this configuration the fast engine does not implement, and the change that
    would let it run (for messages); None when it implements all of it (:func:`supports`)."""
    if config.measurement != "endpoints":
        return f"the {config.measurement!r} measurement", "use the endpoints measurement"
    if getattr(getattr(estimator, "settings", None), "quadratic", False):
        # AdaptiveConfig.quadratic: a fourth state, in the reference engine only
        return "the quadratic term", "turn the quadratic term off"
    from gyrodrift.estimators.base import LinearDrift

    owners = {name: next((c for c in type(estimator).__mro__ if name in c.__dict__), None)
              for name in ("update", "hold", "engine_state", "drift")}
    if (
        owners["engine_state"] is not None
        and owners["update"] is owners["engine_state"] is owners["hold"]
        and owners["drift"] is LinearDrift
    ):
        return None
    return f"estimator {estimator.name!r}", "use --estimator adaptive, stkf or kf"


class ChunkEngine:
    """Resumable fast compensation of one log, chunk by chunk.

    Parameters
    ----------
    config : CompensatorConfig
    estimator : DriftEstimator
        A fresh estimator supported by the engine (see :func:`supports`); it is
        updated in place and holds the final state after :meth:`finish`.
    source : str
        Name used in error messages.

    Notes
    -----
    :meth:`feed` returns a dict of output columns for the rows that became available
    (none until the initialisation window is complete, then all of its rows at once);
    :meth:`finish` checks the log was long enough and returns the accepted
    measurements. Rows are numbered from 0 across chunks in error messages.
    """

    def __init__(self, config, estimator, source: str = "arrays"):
        from gyrodrift import _kernels as K

        self.K = K
        self.cfg = config
        self.est = estimator
        self.source = source
        self.rows_in = 0
        self._t0: float | None = None
        self._t_last = math.nan
        self._g_last = math.nan
        self._T_last = math.nan
        self._t_start = math.nan
        self._buf: list[tuple] | None = []
        self._field_ref = None
        # T' tracker
        tr = config.temp_rate
        self._tf = np.zeros(4)
        self._ti = np.zeros(5, dtype=np.int64)
        self._bins = np.zeros((tr.window_bins + 3, 3))
        # main kernel
        self._fs = np.zeros(K.N_FSTATE)
        self._ist = np.zeros(K.N_ISTATE, dtype=np.int64)
        self._acc = np.zeros((64, 5))
        self._accepted: list[np.ndarray] = []
        self._aid = None
        from gyrodrift.fusion import FusionState

        self._fusion = FusionState(config.fusion_settings, config.gyro_noise_dps_rthz)

    # ------------------------------------------------------------------ input
    def _prepare(self, t, g, T, heading, norm, dip, gap, Tp):
        K = self.K
        t = np.ascontiguousarray(t, dtype=float)
        g = np.ascontiguousarray(g, dtype=float)
        T = np.ascontiguousarray(T, dtype=float)
        heading = np.ascontiguousarray(heading, dtype=float)
        n = t.size
        first = self._t0 is None
        if first:
            if not (np.isfinite(g[0]) and np.isfinite(T[0])):
                raise LogFormatError(f"{self.source}: the first sample needs gyro_z and temp values")
            self._t0 = float(t[0])
            self._t_start = float(t[0]) + self.cfg.init_s
        bad, fix = K.prepare_kernel(t, g, T, heading, self._t_last, first, float(self.cfg.gate.max_gap_s), gap)
        if bad >= 0:
            raise LogFormatError(
                f"{self.source}: row {self.rows_in + bad}: time must be finite and strictly increasing"
            )
        g_out, T_out, h_out = g, T, heading
        if fix & 1:  # empty or infinite cells hold the previous value (and refuse the interval)
            g_out = np.empty(n)
            K.hold_kernel(g, self._g_last, gap, g_out)
        if fix & 2:
            T_out = np.empty(n)
            K.hold_kernel(T, self._T_last, gap, T_out)
        if fix & 4:
            h_out = np.empty(n)
            K.wrap_kernel(heading, h_out)
        tr = self.cfg.temp_rate
        K.temp_rate_kernel(t, T_out, tr.window_bins, float(tr.bin_s), self._tf, self._ti, self._bins, Tp)
        self._t_last, self._g_last, self._T_last = float(t[-1]), float(g_out[-1]), float(T_out[-1])
        self.rows_in += n
        return t, g_out, T_out, Tp, h_out, gap, norm, dip

    # ------------------------------------------------------------------- feed
    def feed(self, t, g, T, heading, norm, dip, buffers: OutputBuffers | None = None) -> dict | None:
        """Add a chunk of rows (arrays of equal length; ``heading`` NaN = no compass sample,
        ``norm``/``dip`` of the raw field, NaN when absent); return the finished rows.

        ``buffers``: memory for the output columns (:class:`OutputBuffers`), used when all
        the rows of this chunk come out of this call, as in a whole-log call; the returned
        columns are then views of it."""
        if len(t) == 0:
            return None
        n = len(t)
        # the output columns now when this chunk's rows come out of this call (all of them)
        t_start = self._t_start if self._t0 is not None else float(t[0]) + self.cfg.init_s
        whole = self._buf is None or (not self._buf and float(t[-1]) - t_start >= 0)
        if whole and buffers is not None:
            out, gap, Tp = buffers.take(n)
            helper = None  # pages touched when the buffers were made
        else:
            gap = _small_pages(np.empty(n, dtype=np.bool_))
            Tp = _small_pages(np.empty(n))
            out = _alloc(n) if whole else None
            helper = _populate_in_background([gap, Tp] + ([out[k] for k in _ROW_COLUMNS] if whole else []), n)
        try:
            cols = self._prepare(t, g, T, heading, norm, dip, gap, Tp)
            if self._buf is not None:
                self._buf.append(cols)
                if not cols[0][-1] - self._t_start >= 0:
                    return None
                if len(self._buf) > 1:
                    cols, out = tuple(_concat(c) for c in zip(*self._buf)), None
                else:
                    cols = self._buf[0]
                self._buf = None
                return self._initialise(*cols, out=out)
            return self._run(*cols, i0=0, out=out)
        finally:
            _join(helper)

    def _initialise(self, t, g, T, Tp, heading, gap, norm, dip, *, out: dict | None = None) -> dict:
        C = importlib.import_module("gyrodrift.compensate")  # the module; the package exports a function of that name
        K, cfg = self.K, self.cfg
        e = int(np.searchsorted(t, self._t_start, "left"))  # first row with t >= t_start (t increases)
        sl = slice(0, e + 1)
        aid = C._Aiding(cfg, self.est)
        _, _, I_raw0, I_T0, I_Tp0, _, _, _ = C._rows(None, t[sl], g[sl], T[sl], Tp[sl], C._zero_drift)
        anchor_row, updated = C._initialise(aid, t[sl], g[sl], heading[sl], I_raw0, I_T0, I_Tp0, float(t[e]), self.source)
        self._field_ref = None if norm is None else C._field_reference(norm[sl], dip[sl])
        bias, rate, I_raw, I_T, I_Tp, I_bias, I_rate, carry = C._rows(None, t[sl], g[sl], T[sl], Tp[sl], self.est.drift)
        self._accepted_init = [(tt, m) for tt, m in aid.accepted]
        if out is None:
            out = _alloc(t.size)
        out["bias_z"][sl] = bias
        out["rate_z"][sl] = rate
        anchor = float(heading[anchor_row] - I_rate[anchor_row])
        out["heading"][sl] = wrap_360(anchor + I_rate)
        out["a"][sl], out["b"][sl], out["c"][sl] = self.est.params
        out["update"][e] = int(updated)
        out["reason"][:e] = K.R_INIT
        out["unobs"][sl] = C.UNOBSERVABLE.index(aid.unobservable)
        out["bias_sd"][sl] = C._bias_sd(aid.cov, T[sl], Tp[sl])
        # the fused heading of the init rows (the kernel continues from this state)
        allowed = C.fusion_allowed(out["reason"][sl], cfg.fusion_settings)
        out["heading_fused"][sl], out["heading_fused_sd"][sl], out["heading_sd"][sl] = self._fusion.rows(
            t[sl], rate, heading[sl], allowed, out["bias_sd"][sl]
        )
        # kernel state from the reference objects
        fs, ist = self._fs, self._ist
        for j, v in enumerate((carry.t, carry.g, carry.T, carry.Tp, carry.bias, carry.rate,
                               carry.I_raw, carry.I_T, carry.I_Tp, carry.I_bias, carry.I_rate)):
            fs[j] = v
        fs[K.F_K] = float(C._interval_index(t[e], self._t_start, cfg.update_interval_s))
        fs[K.F_TSTART] = self._t_start
        fs[K.F_ANCHOR] = anchor
        compass = np.flatnonzero(np.isfinite(heading[sl]))
        if compass.size:
            i = int(compass[-1])
            fs[K.F_S1:K.F_S1 + 6] = (t[i], heading[i], I_raw[i], I_T[i], I_Tp[i], I_bias[i])
            ist[K.I_S1_OK] = 1
        ist[K.I_STACK_N] = len(aid.stack)
        self._stack = np.zeros((cfg.stack_depth, 5))
        for j, m in enumerate(aid.stack):
            self._stack[j] = (m.m, m.h[0], m.h[1], m.h[2], m.r)
        self._refused = np.zeros(max(cfg.gate.relock_intervals, 1))
        lo = int(np.searchsorted(t[sl], t[e] - cfg.gate.turn_window_s, "left"))
        n_lb = e + 1 - lo
        self._lb = np.zeros((max(64, 2 * n_lb), 2))
        self._lb[:n_lb, 0] = t[lo : e + 1]
        self._lb[:n_lb, 1] = I_rate[lo:]
        ist[K.I_LB_HEAD], ist[K.I_LB_N] = 0, n_lb
        # estimator: the linear filter x, P, or the adaptive state (x, P unused)
        st = self.est.engine_state()
        self._x = np.array(st["x"], dtype=float)
        self._P = np.array(st["P"], dtype=float)
        self._Q = np.array(st["Q"], dtype=float)
        self._max_var = np.array(st["max_var"], dtype=float)
        self._active = np.array(st["active"], dtype=np.int64)
        adaptive = st["mode"] == "adaptive"
        AK = importlib.import_module("gyrodrift._adaptive_kernels")
        self._ak = AK.new_state(aid.depth, st["innovation_window"] if adaptive else 1)
        if adaptive:
            AK.load(self._ak, self.est, aid)
        # the compass window of _Aiding.add (empty: the init rows are not added)
        self._win = np.zeros((AK.N_WIN, 256 if aid.collects else 1))
        self._cfg = np.zeros(K.N_CFG)
        self._cfg[K.C_INTERVAL] = cfg.update_interval_s
        self._cfg[K.C_COMPASS_SD] = cfg.compass_sigma_deg
        self._cfg[K.C_GYRO_NOISE] = cfg.gyro_noise_dps_rthz
        self._cfg[K.C_TURN_RATE] = cfg.gate.turn_rate_dps
        self._cfg[K.C_TURN_WIN] = cfg.gate.turn_window_s
        self._cfg[K.C_INTERF] = cfg.gate.interference_deg
        self._cfg[K.C_MAX_AGE] = cfg.gate.compass_max_age_s
        self._cfg[K.C_FADING] = st["fading"]
        self._cfg[K.C_PRIOR_A] = cfg.kalman.p0_sd[0]
        self._cfg[K.C_PRIOR_B] = cfg.kalman.p0_sd[1]
        self._kcfg = np.zeros(K.N_KCFG, dtype=np.int64)
        self._kcfg[K.K_RELOCK] = cfg.gate.relock_intervals
        self._kcfg[K.K_MODE] = K.MODE_ADAPTIVE if adaptive else K.MODE_FIXED
        self._kcfg[K.K_DEPTH] = aid.depth
        K._begin(float(t[e]), fs, ist, self._cfg, self._win, self._ak)
        self._Cabs = K.in_force(self._x, self._P, fs, self._kcfg[K.K_MODE], self._ak)
        ist[K.I_UNOBS] = K._unobservable_code(self._Cabs, self._cfg[K.C_PRIOR_A], self._cfg[K.C_PRIOR_B])
        self._aid = aid
        return self._run(t, g, T, Tp, heading, gap, norm, dip, i0=e + 1, out=out)

    def _run(self, t, g, T, Tp, heading, gap, norm, dip, *, i0: int, out: dict | None) -> dict:
        if out is None:
            out = _alloc(t.size)
        if self._field_ref is not None:
            field = gating.field_anomaly(norm, dip, *self._field_ref, self.cfg.gate)
        else:
            field = np.zeros(t.size, dtype=bool)
        self._loop(t, g, T, Tp, heading, gap, field, i0, out)
        out["t"] = t
        out["temp_rate"] = Tp
        out["compass_heading"] = heading
        return out

    def _loop(self, t, g, T, Tp, heading, gap, field, i0, out) -> None:
        K = self.K
        i = i0
        while True:
            i = K.compensate_kernel(
                t, g, T, Tp, heading, gap, field, i,
                self._fs, self._ist, self._cfg, self._kcfg, self._x, self._P, self._Q, self._max_var,
                self._active, self._stack, self._refused, self._lb, self._win, self._ak, self._Cabs,
                out["bias_z"], out["rate_z"], out["heading"], out["a"], out["b"], out["c"], out["update"], out["reason"],
                out["bias_sd"], out["unobs"], self._acc,
                self._fusion.st, self._fusion.cfg, bool(self.cfg.fusion_settings.magnetic_gates),
                out["heading_fused"], out["heading_fused_sd"], out["heading_sd"],
            )
            if i >= t.size:
                break
            if self._ist[K.I_LB_N] >= self._lb.shape[0]:  # grow the ring, oldest first
                head, n = int(self._ist[K.I_LB_HEAD]), int(self._ist[K.I_LB_N])
                order = (head + np.arange(n)) % self._lb.shape[0]
                lb = np.zeros((2 * self._lb.shape[0], 2))
                lb[:n] = self._lb[order]
                self._lb = lb
                self._ist[K.I_LB_HEAD] = 0
            if 2 * self._ist[K.I_WIN_N] >= self._win.shape[1]:  # the compass window: keep it at most half full
                head, n = int(self._ist[K.I_WIN_HEAD]), int(self._ist[K.I_WIN_N])
                win = np.zeros((self._win.shape[0], 2 * self._win.shape[1]))
                win[:, :n] = self._win[:, head:head + n]
                self._win = win
                self._ist[K.I_WIN_HEAD] = 0
            if self._ist[K.I_N_ACC] >= self._acc.shape[0]:
                self._flush_accepted()

    def _flush_accepted(self) -> None:
        n = int(self._ist[self.K.I_N_ACC])
        self._accepted.append(self._acc[:n].copy())
        self._ist[self.K.I_N_ACC] = 0
        if self._acc.shape[0] < 4096:
            self._acc = np.zeros((2 * self._acc.shape[0], 5))

    # ----------------------------------------------------------------- finish
    def finish(self):
        """End of the log: check its length, write the final state back to the estimator.

        Returns
        -------
        list of (float, _Meas)-like tuples
            The accepted measurements (time s, m, mean T, mean T', r) as an (M, 5) array.
        """
        cfg = self.cfg
        need = cfg.init_s + cfg.update_interval_s
        if self._t0 is None:
            raise LogFormatError(f"{self.source}: the log has no samples")
        span = self._t_last - self._t0
        if self._buf is not None or span < need:
            raise GyroDriftError(
                f"{self.source}: the log is {span:.1f} s long; initialisation needs at least "
                f"{need:g} s (--init-s {cfg.init_s:g} plus one {cfg.update_interval_s:g}-s update interval)"
            )
        self._flush_accepted()
        K = self.K
        if self._kcfg[K.K_MODE] == K.MODE_ADAPTIVE:
            self.est.set_engine_state(importlib.import_module("gyrodrift._adaptive_kernels").export(self._ak))
        else:
            self.est.set_engine_state({"x": self._x, "P": self._P})
        init = np.array([(tt, m.m, m.h[0], m.h[1], m.r) for tt, m in self._accepted_init]).reshape(-1, 5)
        return np.concatenate([init] + self._accepted)


def _concat(parts):
    return None if parts[0] is None else np.concatenate(parts)


#: Output columns the kernel writes row by row; the int8 codes among them start at 0.
_ROW_COLUMNS = ("bias_z", "rate_z", "heading", "a", "b", "c", "update", "reason", "bias_sd", "unobs",
                "heading_fused", "heading_fused_sd", "heading_sd")
_CODE_COLUMNS = ("update", "reason", "unobs")


def _alloc(n: int) -> dict:
    """The output columns of :data:`_ROW_COLUMNS` for ``n`` rows (the codes zeroed), on 4-KB pages."""
    return {k: _small_pages(np.zeros(n, dtype=np.int8) if k in _CODE_COLUMNS else np.empty(n)) for k in _ROW_COLUMNS}


class OutputBuffers:
    """Memory for the output columns of a whole-log call, kept from call to call.

    :func:`gyrodrift.compensate.compensate_arrays` writes about 90 bytes of output per
    row (13 columns, T', the gap flags). New memory costs a page fault per 4 KB on its
    first write, which on a virtual machine can take longer than the compensation itself
    (``benchmarks/README.md``). Code that compensates many logs of similar length in one
    process (a Monte Carlo, a parameter sweep, a service) can make one ``OutputBuffers``
    and pass it to every call as ``buffers=``: the pages are faulted in once, here.

    The table a call returns *views* this memory: the next call with the same buffers
    overwrites it. Copy what must outlive that call (``out.copy()``).

    Parameters
    ----------
    rows : int
        Largest number of rows of a call that will use these buffers.

    Examples
    --------
    >>> buffers = OutputBuffers(1_000)
    >>> buffers.rows
    1000
    """

    def __init__(self, rows: int):
        rows = int(rows)
        if rows < 1:
            raise GyroDriftError(f"OutputBuffers needs at least one row, not {rows}")
        self.rows = rows
        self._columns = _alloc(rows)
        self._gap = np.empty(rows, dtype=np.bool_)
        self._temp_rate = np.empty(rows)
        self.gated = np.empty(rows, dtype=np.bool_)
        for a in (*self._columns.values(), self._gap, self._temp_rate, self.gated):
            a.fill(0)  # fault every page in now, not in the calls

    def take(self, n: int) -> tuple[dict, np.ndarray, np.ndarray]:
        """Views of the first ``n`` rows: the output columns of :data:`_ROW_COLUMNS` (the
        codes zeroed, as :func:`_alloc` gives them), the gap flags and T'."""
        if n > self.rows:
            raise GyroDriftError(
                f"the log has {n} rows but the OutputBuffers were made for {self.rows}: "
                f"make them with OutputBuffers({n}) or more, or leave buffers out"
            )
        out = {k: v[:n] for k, v in self._columns.items()}
        for k in _CODE_COLUMNS:
            out[k].fill(0)
        return out, self._gap[:n], self._temp_rate[:n]


# ------------------------------------------------------------ fresh memory
#
# A 10M-row log has about 1 GB of fresh output (13 columns, T', the gap flags). Its pages
# are faulted in (and zeroed by the OS) on the first write, on the critical path: with
# transparent huge pages that is cheap on memory the process just freed (0.07 s per GB)
# but on a VM whose host takes free memory back (Firecracker, free page reporting) it
# costs about 2 s per GB, and the first large call of a process runs on such memory.
# 4-KB pages more often come from memory that is still backed (faulting 0.88 GB of them
# took 0.29-0.52 s, once 2.7 s); a helper thread faults them in ahead of the compiled
# loop (MADV_POPULATE_WRITE, which leaves the contents alone), off the critical path when
# a second core is free. 10M rows of make_log, adaptive, first call in a fresh process:
# 1.5-2.6 s -> 0.4-1.2 s (huge pages against 4-KB pages; see benchmarks/README.md).

#: ``madvise`` advice (Linux): fault pages in writable, keeping the contents (5.14); no huge pages.
_MADV_POPULATE_WRITE = 23
_MADV_NOHUGEPAGE = 15
#: Arrays smaller than this are left as numpy allocates them (malloc reuses such blocks).
_SMALL_PAGES_MIN_BYTES = 8 << 20
#: Below this many bytes in all the columns no helper thread is started.
_POPULATE_MIN_BYTES = 32 << 20
#: Rows populated at a time, in row order across the columns (ahead of the loop).
_POPULATE_ROWS = 1 << 19
_PAGE = 4096
_madvise = None


def _load_madvise():
    """libc's ``madvise`` through ctypes, or False where there is none (not Linux)."""
    global _madvise
    if _madvise is None:
        _madvise = False
        if sys.platform.startswith("linux"):
            try:
                import ctypes

                fn = ctypes.CDLL(None, use_errno=True).madvise
                fn.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int)
                fn.restype = ctypes.c_int
                _madvise = fn
            except (OSError, AttributeError):
                pass
    return _madvise


def _span(a, lo: int, hi: int) -> tuple[int, int]:
    """Address (rounded down to its page: the same mapping) and length of elements ``lo:hi``."""
    start = a.ctypes.data + lo * a.itemsize
    start -= start % _PAGE
    return start, a.ctypes.data + hi * a.itemsize - start


def _small_pages(a: np.ndarray) -> np.ndarray:
    """``a`` (fresh, not yet written) on 4-KB pages when it is large (see above); returns it."""
    if a.nbytes >= _SMALL_PAGES_MIN_BYTES and _load_madvise():
        _madvise(*_span(a, 0, a.size), _MADV_NOHUGEPAGE)  # a failure only leaves huge pages
    return a


def _populate_in_background(columns, n: int):
    """Fault in the ``n`` rows of the fresh 1-d ``columns`` in a helper thread, in the order the
    kernels write them: the gap flags and T' (the first two, written by the checks and the T'
    kernel in turn), then the output columns in row order; returns the thread (for
    :func:`_join`), or None when they are small or the system cannot (the kernels then fault
    the pages in themselves)."""
    if sum(c.nbytes for c in columns) < _POPULATE_MIN_BYTES or not _load_madvise():
        return None

    def populate(columns=columns):  # holds the columns until done
        for group in (columns[:2], columns[2:]):
            for lo in range(0, n, _POPULATE_ROWS):
                hi = min(lo + _POPULATE_ROWS, n)
                for c in group:
                    if _madvise(*_span(c, lo, hi), _MADV_POPULATE_WRITE) != 0:
                        return  # not supported (Linux < 5.14): the kernels fault the pages in themselves

    helper = threading.Thread(target=populate, name="gyrodrift-pages", daemon=True)
    helper.start()
    return helper


def _join(helper) -> None:
    if helper is not None:
        helper.join()

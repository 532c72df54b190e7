"""The engine (gyrodrift.compensator.ChunkEngine over gyrodrift.kernels): one implementation
run three ways, and run without the compiler.

* Fed in chunks of any size, one row at a time (the streaming Compensator) or all at once,
  a log gives the same bits: it is the same code.
* The same source with numba's JIT off (plain Python) gives the same numbers: the compiled
  code does what the source says.
* A Python estimator updated by the engine at interval ends (MODE_EXTERNAL) sees exactly the
  observations the compiled filters see: wrapping a compiled filter in Python changes no bit.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import textwrap
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.compass import compass_columns
from gyrodrift.compensator import (ChunkEngine, Compensator, CompensatorConfig, build_estimator, compensate,
                                   compensate_arrays, output_frame)
from gyrodrift.compensator import memory
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.estimators import AdaptiveConfig, make_estimator
from gyrodrift.estimators.base import LinearDrift
from gyrodrift.gating import GateConfig
from gyrodrift.compensator.model_engine import make_engine
from gyrodrift.evaluate.montecarlo import draw_case, simulate_case
from test_compensate import complex_log

ESTIMATORS = ("adaptive", "stkf", "stkf-s1", "kf", "lsm")
#: Settings of the model that change its paths: drift jumps, short and long epochs, a
#: time gap at a few typical steps, no still spells.
VARIANTS = {
    "default": AdaptiveConfig(),
    "jumps": AdaptiveConfig(drift_jump_dps=0.3),
    "short-epoch": AdaptiveConfig(epoch_s=0.25),
    "long-epoch": AdaptiveConfig(epoch_s=5.0),
    "eager-gap": AdaptiveConfig(gap_factor=2.0),
    "rarely-still": AdaptiveConfig(p_still0=0.01, moving_s=1e6, still_s=1.0),
    "motion-memory": AdaptiveConfig(motion_memory_s=120.0),
}


@functools.lru_cache(maxsize=None)
def family_log(family: str, scale: float) -> pd.DataFrame:
    log, _ = simulate_case(draw_case(family, 0, duration_scale=scale), calibration=False)
    return log


def feed_in_chunks(log: pd.DataFrame, cfg: CompensatorConfig, sizes, estimator=None):
    """The output table, the accepted measurements and the estimator of a log fed in chunks."""
    t = log["t"].to_numpy(float)
    raw = "mag_x" in log.columns
    heading, norm, dip = compass_columns(
        t.size, log["heading"].to_numpy(float) if "heading" in log.columns else None,
        log[["mag_x", "mag_y", "mag_z"]].to_numpy(float) if raw else None,
        log[["acc_x", "acc_y", "acc_z"]].to_numpy(float) if raw else None)
    est = estimator or build_estimator(cfg)
    eng = make_engine(cfg, est, "chunks")
    parts, start = [], 0
    for size in sizes:
        sl = slice(start, start + size)
        part = eng.feed(t[sl], log["gyro_z"].to_numpy(float)[sl], log["temp"].to_numpy(float)[sl], heading[sl],
                        norm[sl] if raw else None, dip[sl] if raw else None)
        if part is not None:
            parts.append(output_frame(part))
        start += size
        if start >= t.size:
            break
    return pd.concat(parts, ignore_index=True), eng.finish(), est


def engine_columns(out: pd.DataFrame) -> pd.DataFrame:
    """The engine's columns of a :func:`compensate` table (not the input columns after them)."""
    return out[list(out.columns[: list(out.columns).index("heading_sd") + 1])]


def streamed(log: pd.DataFrame, cfg: CompensatorConfig, estimator=None) -> pd.DataFrame:
    comp = Compensator(cfg, estimator=estimator, provisional=False)
    raw = "mag_x" in log.columns
    rows = []
    for r in log.itertuples(index=False):
        kw = {"mag": (r.mag_x, r.mag_y, r.mag_z), "acc": (r.acc_x, r.acc_y, r.acc_z)} if raw else {}
        rows += comp.push(r.t, r.gyro_z, r.temp, heading_deg=np.nan if raw else r.heading, **kw)
    return pd.DataFrame([asdict(s) for s in rows])


def assert_identical(batch: pd.DataFrame, other: pd.DataFrame) -> None:
    """Every column of ``other`` equal to ``batch``'s, bit for bit (codes as text)."""
    assert len(batch) == len(other)
    for col in other.columns:
        if col not in batch.columns:
            continue
        a, b = batch[col], other[col]
        if a.dtype.kind in "fiu" and b.dtype.kind in "fiu":
            assert np.array_equal(a.to_numpy(float), b.to_numpy(float), equal_nan=True), col
        else:
            assert list(a.astype(str)) == list(b.astype(str)), col


# ---------------------------------------------------------------- three ways


@pytest.mark.parametrize("estimator", ESTIMATORS)
@pytest.mark.parametrize("raw_mag", [False, True])
def test_chunks_rows_and_whole_log_give_the_same_bits(estimator, raw_mag):
    """Turns, interference, a compass outage, empty cells, a time gap, a field anomaly; a 5-s
    turn window that makes the ring grow; chunk ends inside the init window and at single rows."""
    log = complex_log(raw_mag)
    cfg = CompensatorConfig(estimator=estimator, gate=GateConfig(turn_window_s=5.0))
    whole = compensate(log, cfg)
    reasons = set(whole["gate_reason"].astype(str))
    assert {"init", "turning", "no_compass", "gap", "interference"} <= reasons
    assert ("field" in reasons) == raw_mag
    rng = np.random.default_rng(3)
    sizes = [1, 1, 7, 250, 1] + list(rng.integers(1, 3000, size=200)) + [len(log)]
    parts, m_parts, est_parts = feed_in_chunks(log, cfg, sizes)
    assert_identical(engine_columns(whole), parts)
    assert np.array_equal(whole.attrs["measurements"].to_numpy(), m_parts)
    assert np.array_equal(whole.attrs["final_params"], est_parts.params)
    assert np.array_equal(whole.attrs["final_cov"], est_parts.cov)
    if estimator in ("adaptive", "lsm") and not raw_mag:
        assert_identical(engine_columns(whole), streamed(log, cfg))


def test_rows_stamped_in_clusters_give_the_same_bits_three_ways():
    """A log stamped in clusters (the model times its rows by its sample clock, whose state is
    carried across chunks and rows): chunks, rows one by one and the whole log agree bit for bit."""
    from test_adaptive import _arriving_in_clusters
    from conftest import synthetic_log

    log = _arriving_in_clusters(synthetic_log(duration_s=120.0, fs_hz=100.0, compass_hz=10.0, gyro_noise_dps=0.05,
                                              heading_deg=lambda t: 100.0 + 60.0 * np.sin(t / 10.0)), 7, 0.0015)
    cfg = CompensatorConfig()
    whole = compensate(log, cfg)
    assert any("sample clock" in n for n in whole.attrs["notes"])
    sizes = [1, 3, 29, 500] + list(np.random.default_rng(5).integers(1, 900, size=60)) + [len(log)]
    parts, _, _ = feed_in_chunks(log, cfg, sizes)
    assert_identical(engine_columns(whole), parts)
    assert_identical(engine_columns(whole), streamed(log, cfg))


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_every_adaptive_setting_in_chunks(variant):
    """Settings that change the model's paths on a soak log (sway, ramps, dropouts): chunks = whole."""
    log = family_log("soak", 0.05)
    cfg = CompensatorConfig(adaptive=VARIANTS[variant])
    whole, m_whole, est_whole = feed_in_chunks(log, cfg, [len(log)])
    assert whole["updated"].sum() > 10
    rng = np.random.default_rng(7)
    sizes = [1, 1, 7, 250, 1, 3] + list(rng.integers(1, 40, size=150)) + list(rng.integers(1, 3000, size=40)) + [len(log)]
    parts, m_parts, est_parts = feed_in_chunks(log, cfg, sizes)
    pd.testing.assert_frame_equal(whole, parts, check_exact=True)
    assert np.array_equal(m_whole, m_parts)
    assert np.array_equal(est_whole.params, est_parts.params)
    assert np.array_equal(est_whole.cov, est_parts.cov)


# ------------------------------------------------------- the Python estimator path


class InPython(LinearDrift):
    """A Python estimator (no kernel arrays) that forwards to a compiled filter."""

    causal = True

    def __init__(self, inner):
        self.inner = inner
        self.name = inner.name
        self.settings = getattr(inner, "settings", None)
        self.observations = []

    @property
    def params(self):
        return self.inner.params

    @property
    def cov(self):
        return self.inner.cov

    def update(self, obs):
        self.observations.append(obs)
        return self.inner.update(obs)

    def hold(self):
        return self.inner.hold()


@pytest.mark.parametrize("estimator", ["stkf", "kf"])
def test_a_python_estimator_sees_what_the_compiled_filter_sees(estimator):
    log = complex_log(False)
    cfg = CompensatorConfig(estimator=estimator)
    compiled = compensate(log, cfg)
    wrapped = InPython(build_estimator(cfg))
    python = compensate(log, cfg, estimator=wrapped)
    assert_identical(engine_columns(compiled), engine_columns(python))
    meas = compiled.attrs["measurements"]
    assert len(wrapped.observations) == int(compiled["updated"].sum())
    # every new measurement is the first row of its observation (eq. 3: the newest first)
    news = np.concatenate([o.y[: o.n_new][::-1] for o in wrapped.observations])
    assert np.array_equal(news, meas["m"].to_numpy())


def test_an_estimator_whose_drift_is_not_eq2_is_refused():
    class Curved(LinearDrift):
        name = "curved"
        causal = True
        params = np.zeros(3)
        cov = np.zeros((3, 3))

        def drift(self, temp_c, temp_rate_cps):
            return 0.001 * temp_c**2

        def update(self, obs):
            return self.params

        def hold(self):
            return self.params

    with pytest.raises(ConfigError, match="not a\\*T \\+ b\\*T' \\+ c"):
        compensate(synthetic_log(duration_s=120.0), estimator=Curved())


# ------------------------------------------------------------- the JIT off


_JIT_OFF_SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np
    sys.path.insert(0, {tests!r})
    from test_compensate import complex_log
    from gyrodrift.compensator import CompensatorConfig, compensate
    log = complex_log({raw_mag}).iloc[:{rows}]
    out = compensate(log, CompensatorConfig(estimator={estimator!r}))
    cols = [c for c in out.columns[: list(out.columns).index("heading_sd") + 1] if out[c].dtype.kind in "fiu"]
    np.savez({path!r}, **{{c: out[c].to_numpy(float) for c in cols}},
             codes=out["gate_reason"].cat.codes.to_numpy(), meas=out.attrs["measurements"].to_numpy())
""")


@pytest.mark.parametrize("estimator,raw_mag", [("adaptive", False), ("stkf", True)])
def test_the_source_without_the_compiler_gives_the_same_numbers(tmp_path, estimator, raw_mag):
    """NUMBA_DISABLE_JIT=1 runs the kernels as plain Python; the compiled run agrees with it."""
    rows = 9000  # 450 s at 20 Hz: init, turns, interference and its recovery, empty cells
    path = tmp_path / "nojit.npz"
    script = _JIT_OFF_SCRIPT.format(tests=str(Path(__file__).parent), raw_mag=raw_mag, rows=rows,
                                    estimator=estimator, path=str(path))
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    proc = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    plain = np.load(path)
    out = compensate(complex_log(raw_mag).iloc[:rows], CompensatorConfig(estimator=estimator))
    assert np.array_equal(plain["codes"], out["gate_reason"].cat.codes.to_numpy())
    assert out["updated"].sum() > 10
    for col in plain.files:
        if col in ("codes", "meas"):
            continue
        x, y = out[col].to_numpy(float), plain[col]
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(np.nanmax(np.abs(y)), 1.0), err_msg=col)
    np.testing.assert_allclose(out.attrs["measurements"].to_numpy(), plain["meas"], rtol=1e-12, atol=1e-15)


# ------------------------------------------------------------------ errors


def test_a_time_step_beyond_any_log_is_refused_in_every_path():
    """A step of 7.7e76 s (hypothesis found it: the drift's variance overflowed and bias_sd was
    NaN) is no sample spacing: the batch call refuses a step beyond 1e9 s naming the row, and
    both paths refuse a first time so far from 0 that the init window cannot be told from it;
    a step of 1e9 s, the most there is, is compensated with finite numbers."""
    import gyrodrift
    from gyrodrift import compensate_arrays

    zeros = np.zeros(2)
    with pytest.raises(LogFormatError, match=r"arrays: row 1: time must be finite and strictly increasing, by at most"):
        compensate_arrays(t_s=np.array([0.0, 2e9]), gyro_z_dps=zeros, temp_c=zeros, heading_deg=zeros)
    with pytest.raises(LogFormatError, match=r"arrays: row 0: time -7.74348e\+76 s is too far from 0"):
        compensate_arrays(t_s=np.array([-7.74348371e76, 0.0]), gyro_z_dps=zeros, temp_c=zeros, heading_deg=zeros)
    comp = gyrodrift.Compensator(provisional=False)
    with pytest.raises(LogFormatError, match=r"^stream: row 0: time -7.74348e\+76 s is too far from 0 for the 30-s init"):
        comp.push(-7.74348371e76, 0.0, 0.0, 0.0)  # its 30-s init window would end at once
    out = compensate_arrays(t_s=np.array([-1e9, 0.0]), gyro_z_dps=zeros, temp_c=zeros, heading_deg=zeros)
    assert np.isfinite(out[["rate_z", "bias_z", "heading", "bias_sd"]].to_numpy()).all()


def test_chunked_errors_name_the_row():
    log = synthetic_log(duration_s=120.0)
    t = log["t"].to_numpy(float).copy()
    g, T, h = (log[c].to_numpy(float) for c in ("gyro_z", "temp", "heading"))
    eng = ChunkEngine(CompensatorConfig(), make_estimator("stkf"), "x.csv")
    eng.feed(t[:100], g[:100], T[:100], h[:100])
    with pytest.raises(LogFormatError, match=r"x.csv: row 100: time must be finite and strictly increasing"):
        eng.feed(t[99:200], g[99:200], T[99:200], h[99:200])  # repeats t[99]
    short = ChunkEngine(CompensatorConfig(), make_estimator("stkf"), "y.csv")
    assert short.feed(t[:200], g[:200], T[:200], h[:200]) is None  # the init window is not complete
    with pytest.raises(GyroDriftError, match="y.csv: rows are still held: call flush"):
        short.finish()
    assert len(short.flush()["t"]) == 200 and short.notes and short.finish().shape[1] == 5
    with pytest.raises(LogFormatError, match="z: row 5: time must be finite"):
        bad = t.copy()
        bad[5] = np.nan
        compensate_arrays(bad, g, T, h, source="z")


# ------------------------------------------------------------------ memory


def test_fresh_pages_made_ahead_change_nothing(monkeypatch):
    """Large outputs go on 4-KB pages faulted in by a helper thread while the loop writes them
    (``memory.populate_in_background``): the same bits as without (thresholds lowered so that
    this short log takes that path)."""
    log = complex_log(False)
    for estimator in ("adaptive", "stkf"):
        cfg = CompensatorConfig(estimator=estimator)
        plain = compensate(log, cfg)
        started = []
        populate = memory.populate_in_background

        def watched(columns, n):
            helper = populate(columns, n)
            started.append((len(columns), helper))
            return helper

        with monkeypatch.context() as m:
            m.setattr(memory, "_POPULATE_MIN_BYTES", 0)
            m.setattr(memory, "_SMALL_PAGES_MIN_BYTES", 0)
            m.setattr(memory, "_POPULATE_ROWS", 97)
            m.setattr(memory, "populate_in_background", watched)
            helped = compensate(log, cfg)
        pd.testing.assert_frame_equal(plain, helped, check_exact=True)
        assert [k for k, _ in started] == [12]  # one chunk: gap flags, T', 10 output columns
        if sys.platform.startswith("linux"):
            assert all(h is not None for _, h in started)

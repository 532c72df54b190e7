"""The compiled engine (gyrodrift._engine) against the reference engine, and fed in chunks."""

import sys
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("numba")

from conftest import synthetic_log  # noqa: E402
from gyrodrift import _engine  # noqa: E402
from gyrodrift.compensator import CompensatorConfig, _compass_arrays, _fast_frame, build_estimator, compensate  # noqa: E402
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError  # noqa: E402
from gyrodrift.estimators import AdaptiveConfig, KalmanConfig, make_estimator  # noqa: E402
from gyrodrift.estimators.kalman import KalmanDrift  # noqa: E402
from gyrodrift.gating import GateConfig  # noqa: E402
from test_compensate import complex_log  # noqa: E402

ESTIMATORS = ("stkf", "stkf-s1", "kf", "adaptive")

#: ``adaptive`` with Zhou's recursive fading, a fixed reference temperature, no stationarity
#: updates and stacked measurements (the default settings and every fix of issue 6:
#: test_engine_adaptive.py).
ZHOU_ADAPTIVE = AdaptiveConfig(zaru=False, stacked=True, edge_s=0.0, recentre=False, normalised=False,
                               softening=1.0, slope_q_per_rtc=0.0)


def config(estimator: str, **kw) -> CompensatorConfig:
    """Settings of ``estimator`` (``adaptive``: :data:`ZHOU_ADAPTIVE`)."""
    return CompensatorConfig(estimator=estimator, adaptive=ZHOU_ADAPTIVE, **kw)


def assert_close(fast: pd.DataFrame, ref: pd.DataFrame, atol: float = 1e-8) -> None:
    """Same rows, same decisions (update, gate_reason, unobservable), numbers equal to rounding."""
    assert list(fast.columns) == list(ref.columns)
    assert len(fast) == len(ref)
    for col in fast.columns:
        a, b = fast[col], ref[col]
        if a.dtype.kind == "f":
            x, y = a.to_numpy(), b.to_numpy()
            if col == "heading":  # compare angles across the 0/360 seam
                x, y = np.unwrap(np.radians(x)), np.unwrap(np.radians(y))
            np.testing.assert_allclose(x, y, rtol=1e-9, atol=atol, err_msg=col)
        else:
            assert (a.astype(str).to_numpy() == b.astype(str).to_numpy()).all(), col


@pytest.mark.parametrize("estimator", ESTIMATORS)
@pytest.mark.parametrize("raw_mag", [False, True])
def test_fast_engine_equals_reference(estimator, raw_mag):
    """Turns, an interference window, a compass outage, empty cells, a time gap, field anomaly."""
    log = complex_log(raw_mag)
    cfg = config(estimator)
    fast = compensate(log, cfg, engine="fast")
    ref = compensate(log, cfg, engine="reference")
    assert_close(fast, ref)
    reasons = set(fast["gate_reason"].astype(str))
    assert {"init", "turning", "no_compass", "gap", "interference"} <= reasons
    np.testing.assert_allclose(fast.attrs["final_params"], ref.attrs["final_params"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fast.attrs["final_cov"], ref.attrs["final_cov"], rtol=1e-8, atol=1e-15)
    np.testing.assert_allclose(fast.attrs["measurements"].to_numpy(), ref.attrs["measurements"].to_numpy(),
                               rtol=1e-9, atol=1e-12)


def test_fast_engine_lock_out_recovery_and_paper_gate():
    """The lock-out recovery decisions (and their absence, relock 0) match the reference."""
    from gyrodrift.simulate import simulate

    log = simulate("static", seed=2, fs_hz=10.0, duration_s=1200.0)
    for relock in (0, 3):
        cfg = CompensatorConfig(gate=GateConfig(relock_intervals=relock))
        assert_close(compensate(log, cfg, engine="fast"), compensate(log, cfg, engine="reference"))


def feed_in_chunks(log: pd.DataFrame, cfg: CompensatorConfig, sizes, estimator="stkf"):
    t = log["t"].to_numpy(float)
    heading, norm, dip = _compass_arrays(t.size, log["heading"].to_numpy(float), None, None)
    eng = _engine.ChunkEngine(cfg, build_estimator(cfg), "chunks")
    parts, start = [], 0
    for size in sizes:
        sl = slice(start, start + size)
        part = eng.feed(t[sl], log["gyro_z"].to_numpy(float)[sl], log["temp"].to_numpy(float)[sl],
                        heading[sl], norm[sl], dip[sl])
        if part is not None:
            parts.append(_fast_frame(part))
        start += size
        if start >= t.size:
            break
    measurements = eng.finish()
    return pd.concat(parts, ignore_index=True), measurements, eng.est


@pytest.mark.parametrize("estimator", ESTIMATORS)
def test_chunks_of_any_size_give_identical_results(estimator):
    """Chunk boundaries inside the init window and at single rows, empty cells held across
    chunks, a 5-s turn window that makes the ring grow: bit for bit the same as one chunk."""
    log = complex_log(False)
    cfg = config(estimator, gate=GateConfig(turn_window_s=5.0))
    whole, m_whole, est_whole = feed_in_chunks(log, cfg, [len(log)], estimator)
    rng = np.random.default_rng(3)
    sizes = [1, 1, 7, 250, 1] + list(rng.integers(1, 3000, size=200)) + [len(log)]
    parts, m_parts, est_parts = feed_in_chunks(log, cfg, sizes, estimator)
    pd.testing.assert_frame_equal(whole, parts, check_exact=True)
    assert np.array_equal(m_whole, m_parts)
    assert np.array_equal(est_whole.params, est_parts.params)
    assert np.array_equal(est_whole.cov, est_parts.cov)


def test_chunked_errors_name_the_row():
    log = synthetic_log(duration_s=120.0)
    t = log["t"].to_numpy(float).copy()
    g, T, h = (log[c].to_numpy(float) for c in ("gyro_z", "temp", "heading"))
    eng = _engine.ChunkEngine(CompensatorConfig(), make_estimator("stkf"), "x.csv")
    eng.feed(t[:100], g[:100], T[:100], h[:100], None, None)
    with pytest.raises(LogFormatError, match=r"x.csv: row 100: time must be finite and strictly increasing"):
        eng.feed(t[99:200], g[99:200], T[99:200], h[99:200], None, None)  # repeats t[99]
    short = _engine.ChunkEngine(CompensatorConfig(), make_estimator("stkf"), "y.csv")
    short.feed(t[:200], g[:200], T[:200], h[:200], None, None)
    with pytest.raises(GyroDriftError, match="y.csv: the log is .* long"):
        short.finish()


def test_engine_choice():
    """Subclasses that override update/hold, and the slope measurement, run on the reference engine;
    asking for the fast engine where it cannot run is a clear error."""

    class Watched(KalmanDrift):
        def update(self, obs):
            return super().update(obs)

    cfg = CompensatorConfig()
    assert _engine.supports(cfg, make_estimator("stkf", config=KalmanConfig()))
    assert _engine.supports(cfg, make_estimator("adaptive", config=KalmanConfig(), settings=ZHOU_ADAPTIVE))
    # every adaptive setting is compiled (test_engine_adaptive.py)
    assert _engine.supports(cfg, make_estimator("adaptive", config=KalmanConfig()))
    for fix in ("recentre", "normalised", "zaru"):
        est = make_estimator("adaptive", settings=replace(ZHOU_ADAPTIVE, **{fix: True}))
        assert _engine.supports(cfg, est), fix
    assert not _engine.supports(CompensatorConfig(measurement="slope"), make_estimator("adaptive"))
    assert not _engine.supports(cfg, Watched(KalmanConfig()))
    assert not _engine.supports(CompensatorConfig(measurement="slope"), make_estimator("stkf"))
    assert not _engine.supports(cfg, make_estimator("lsm"))
    log = synthetic_log(duration_s=120.0)
    with pytest.raises(ConfigError, match="fast engine cannot run"):
        compensate(log, CompensatorConfig(measurement="slope"), engine="fast")
    with pytest.raises(ConfigError, match="engine must be"):
        compensate(log, engine="turbo")


def test_fresh_pages_made_ahead_change_nothing(monkeypatch):
    """Large outputs go on 4-KB pages faulted in by a helper thread while the loop writes them
    (``_engine._populate_in_background``): the same bits as without (thresholds lowered so
    that this short log takes that path)."""
    log = complex_log(False)
    for estimator in ("adaptive", "stkf"):
        cfg = config(estimator)
        plain = compensate(log, cfg, engine="fast")
        started = []
        populate = _engine._populate_in_background

        def watched(columns, n):
            helper = populate(columns, n)
            started.append((len(columns), helper))
            return helper

        with monkeypatch.context() as m:
            m.setattr(_engine, "_POPULATE_MIN_BYTES", 0)
            m.setattr(_engine, "_SMALL_PAGES_MIN_BYTES", 0)
            m.setattr(_engine, "_POPULATE_ROWS", 97)
            m.setattr(_engine, "_populate_in_background", watched)
            helped = compensate(log, cfg, engine="fast")
        pd.testing.assert_frame_equal(plain, helped, check_exact=True)
        assert [k for k, _ in started] == [15]  # one chunk: gap flags, T', 13 output columns
        if sys.platform.startswith("linux"):
            assert all(h is not None for _, h in started)
    # fed in chunks: the init rows buffered over several chunks, then one helper a chunk
    cfg = config("adaptive")
    whole, m_whole, _ = feed_in_chunks(log, cfg, [len(log)], "adaptive")
    with monkeypatch.context() as m:
        m.setattr(_engine, "_POPULATE_MIN_BYTES", 0)
        m.setattr(_engine, "_SMALL_PAGES_MIN_BYTES", 0)
        m.setattr(_engine, "_POPULATE_ROWS", 97)
        parts, m_parts, _ = feed_in_chunks(log, cfg, [1, 7, 250, 3000] + [5000] * 20 + [len(log)], "adaptive")
    pd.testing.assert_frame_equal(whole, parts, check_exact=True)
    assert np.array_equal(m_whole, m_parts)

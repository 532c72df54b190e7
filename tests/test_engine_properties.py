"""Property tests of the compiled engine on messy logs (gaps, empty and infinite cells,
saturated gyro, quantised or constant temperature, missing compass, time faults).

The fast engine either refuses a log the reference engine refuses (a GyroDriftError, the
same kind of problem) or gives the same decisions and numbers to rounding; fed in random
chunks it gives the same bits as in one piece.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

from gyrodrift import _engine  # noqa: E402
from gyrodrift.compensator import CompensatorConfig, _compass_arrays, _fast_frame, build_estimator, compensate  # noqa: E402
from gyrodrift.errors import GyroDriftError  # noqa: E402
from gyrodrift.estimators import AdaptiveConfig  # noqa: E402
from gyrodrift.montecarlo import ablation_variants  # noqa: E402
from test_engine import assert_close  # noqa: E402
from test_properties import REPRO, _kind, messy_logs, small_configs  # noqa: E402


#: ``adaptive`` with a stillness window and edges short enough for these logs (ZARU, edge
#: variance from the compass, the compass ring growing).
SHORT_WINDOWS = AdaptiveConfig(zaru_window_s=8.0, edge_s=1.5)


def adaptive_configs():
    """:func:`small_configs` with the ``adaptive`` estimator: the default settings, short
    windows, or a variant of the ablation."""
    variants = st.sampled_from([SHORT_WINDOWS, *ablation_variants().values()])
    return st.builds(lambda cfg, a: replace(cfg, estimator="adaptive", adaptive=a), small_configs(), variants)


@settings(REPRO, max_examples=60)
@given(messy_logs(max_rows=500), small_configs())
def test_fast_engine_agrees_with_the_reference_on_messy_logs(case, cfg):
    check_fast_against_reference(case, cfg)


@settings(REPRO, max_examples=60)
@given(messy_logs(max_rows=500), adaptive_configs())
def test_fast_adaptive_agrees_with_the_reference_on_messy_logs(case, cfg):
    check_fast_against_reference(case, cfg)


def check_fast_against_reference(case, cfg):
    log, _ = case
    try:
        ref = compensate(log, cfg, engine="reference")
    except GyroDriftError as err:
        event(f"refused: {_kind(err)}")
        with pytest.raises(GyroDriftError):
            compensate(log, cfg, engine="fast")
        return
    event("compared")
    fast = compensate(log, cfg, engine="fast")
    assert_close(fast, ref, atol=1e-7)
    assert np.isfinite(fast["rate_z"]).all() and np.isfinite(fast["heading"]).all()


@settings(REPRO, max_examples=40)
@given(messy_logs(allow_time_faults=False, max_rows=500), st.lists(st.integers(1, 120), min_size=1, max_size=12))
def test_chunks_equal_one_piece_on_messy_logs(case, sizes):
    check_chunks(case, sizes, CompensatorConfig(init_s=10.0, update_interval_s=5.0))


@settings(REPRO, max_examples=25)
@given(messy_logs(allow_time_faults=False, max_rows=500), st.lists(st.integers(1, 120), min_size=1, max_size=12))
def test_adaptive_chunks_equal_one_piece_on_messy_logs(case, sizes):
    check_chunks(case, sizes, CompensatorConfig(init_s=10.0, update_interval_s=5.0, estimator="adaptive",
                                                adaptive=SHORT_WINDOWS))


def check_chunks(case, sizes, cfg):
    log, form = case
    t = log["t"].to_numpy(float)
    mag = log[["mag_x", "mag_y", "mag_z"]].to_numpy(float) if form == "mag" else None
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy(float) if form == "mag" else None
    heading, norm, dip = _compass_arrays(t.size, log["heading"].to_numpy(float) if form != "mag" else None, mag, acc)
    g, T = log["gyro_z"].to_numpy(float), log["temp"].to_numpy(float)

    def run(cuts):
        eng = _engine.ChunkEngine(cfg, build_estimator(cfg), "messy")
        parts, start = [], 0
        for size in cuts:
            sl = slice(start, start + size)
            if sl.start >= t.size:
                break
            part = eng.feed(t[sl], g[sl], T[sl], heading[sl], norm[sl], dip[sl])
            if part is not None:
                parts.append(_fast_frame(part))
            start += size
        eng.finish()
        return parts

    try:
        whole = run([t.size])
    except GyroDriftError as err:
        event(f"refused: {_kind(err)}")
        return
    pieces = run(sizes + [t.size])
    a = np.concatenate([p.to_numpy(dtype=object) for p in whole])
    b = np.concatenate([p.to_numpy(dtype=object) for p in pieces])
    assert a.shape == b.shape
    same = (a == b) | ((a != a) & (b != b))  # NaN equals NaN
    assert same.all()

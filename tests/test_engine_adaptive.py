"""The ``adaptive`` estimator on the compiled engine (gyrodrift._adaptive_kernels) against the reference.

Short simulated logs of the Monte Carlo families, every setting of the ablation: the same
decisions (update, gate_reason, unobservable) and the same numbers to rounding; fed in
chunks of any size, the same bits; the estimator ends in the same state.

Tolerance: every float column within 1e-9 of the reference, relative to the value and
to the column's largest magnitude (``rtol=1e-9``, ``atol=1e-9 * max|column|``), i.e.
nine significant digits. The engines are not bit-identical because T' (the bin means
of :func:`gyrodrift.model.temp_rate`) and the reference's ``np.cumsum`` integrals are
summed in another order; measured on these logs the columns agree to 1e-11 of their
scale or better (the filter gains amplify the last bits of T' a little), so the
tolerance leaves a margin of about 100 while a porting error (a wrong term, a missed
branch) shows as a changed decision or a difference of 1e-6 or more.
"""

from __future__ import annotations

import functools
import math
import numpy as np
import pandas as pd
import pytest

pytest.importorskip("numba")

from gyrodrift import _engine  # noqa: E402
from gyrodrift.compensator import CompensatorConfig, _Aiding, build_estimator, compensate, compensate_arrays  # noqa: E402
from gyrodrift.estimators import AdaptiveConfig, KalmanConfig  # noqa: E402
from gyrodrift.estimators.adaptive import AdaptiveKalman  # noqa: E402
from gyrodrift.montecarlo import BEFORE_ISSUE_6, ablation_variants, draw_case, simulate_case  # noqa: E402
from test_compensate import complex_log  # noqa: E402
from test_engine import feed_in_chunks  # noqa: E402

RTOL = 1e-9

#: Short logs of the families (duration scale): each has something for the fixes to do.
FAMILIES = {
    "static": 0.1,  # ZARU while still, interference refusals and lock-out recovery
    "interference-wander": 0.15,  # wandering compass while still: the ZARU hold
    "vehicle": 0.5,  # turns, braking tilt: outages of a few intervals
    "soak": 0.05,  # yaw sway, temperature ramps, compass dropouts: the outage anchor
    "cold-start": 0.2,  # a fast warm-up
}

VARIANTS = ablation_variants()


@functools.lru_cache(maxsize=None)
def family_log(family: str) -> pd.DataFrame:
    log, _ = simulate_case(draw_case(family, 0, duration_scale=FAMILIES[family]), calibration=False)
    return log


def config(settings: AdaptiveConfig, **kw) -> CompensatorConfig:
    return CompensatorConfig(estimator="adaptive", adaptive=settings, **kw)


def arrays(log: pd.DataFrame) -> dict:
    return {"t_s": log["t"].to_numpy(float), "gyro_z_dps": log["gyro_z"].to_numpy(float),
            "temp_c": log["temp"].to_numpy(float), "heading_deg": log["heading"].to_numpy(float)}


def run(log: pd.DataFrame, cfg: CompensatorConfig, engine: str):
    """Output table and the estimator after the run."""
    est = build_estimator(cfg)
    return compensate_arrays(**arrays(log), config=cfg, estimator=est, engine=engine), est


def assert_agree(fast: pd.DataFrame, ref: pd.DataFrame) -> None:
    """Same rows and decisions; every float column within RTOL of the reference and of its scale."""
    assert list(fast.columns) == list(ref.columns)
    assert len(fast) == len(ref)
    for col in fast.columns:
        a, b = fast[col], ref[col]
        if a.dtype.kind != "f":
            assert (a.astype(str).to_numpy() == b.astype(str).to_numpy()).all(), col
            continue
        x, y = a.to_numpy(), b.to_numpy()
        assert np.array_equal(np.isnan(x), np.isnan(y)), col
        if col in ("heading", "heading_fused"):  # angles: compare across the 0/360 seam
            x = y + ((x - y + 180.0) % 360.0 - 180.0)
        scale = float(np.nanmax(np.abs(y), initial=0.0))
        np.testing.assert_allclose(x, y, rtol=RTOL, atol=RTOL * max(scale, 1e-300), err_msg=col)


def assert_same_state(fast: dict, ref: dict, path: str = "state") -> None:
    """Two ``AdaptiveKalman.engine_state()`` dicts (twin included) equal to RTOL."""
    assert fast.keys() == ref.keys(), path
    for key, b in ref.items():
        a = fast[key]
        where = f"{path}.{key}"
        if isinstance(b, dict) or b is None:
            if b is None:
                assert a is None, where
            else:
                assert_same_state(a, b, where)
        elif isinstance(b, (bool, str, int)) and not isinstance(b, float):
            assert a == b, where
        else:
            x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
            assert x.shape == y.shape, where
            scale = float(np.max(np.abs(y), initial=0.0))
            np.testing.assert_allclose(x, y, rtol=RTOL, atol=RTOL * max(scale, 1e-300), err_msg=where)


# ------------------------------------------------------------------------ tests


def test_every_adaptive_setting_runs_compiled():
    """The default, every ablation variant and the estimator before issue 6, with endpoint
    measurements; the slope measurement stays on the reference engine."""
    for settings in [AdaptiveConfig(), BEFORE_ISSUE_6, *VARIANTS.values(),
                     AdaptiveConfig(edge_s=120.0, zaru_window_s=30.0), AdaptiveConfig(innovation_window=1)]:
        assert _engine.supports(config(settings), build_estimator(config(settings))), settings
    slope = config(AdaptiveConfig(), measurement="slope")
    assert not _engine.supports(slope, build_estimator(slope))
    assert _engine.supports(CompensatorConfig(), build_estimator(CompensatorConfig()))  # stkf


@pytest.mark.parametrize("variant", list(VARIANTS))
@pytest.mark.parametrize("family", list(FAMILIES))
def test_fast_engine_equals_reference(family, variant):
    log = family_log(family)
    cfg = config(VARIANTS[variant])
    fast, est_fast = run(log, cfg, "fast")
    ref, est_ref = run(log, cfg, "reference")
    assert_agree(fast, ref)
    assert ref["update"].sum() > 10
    for key in ("final_params", "final_cov"):
        y = ref.attrs[key]
        np.testing.assert_allclose(fast.attrs[key], y, rtol=RTOL, atol=RTOL * np.max(np.abs(y)), err_msg=key)
    m_fast, m_ref = fast.attrs["measurements"], ref.attrs["measurements"]
    assert m_fast.shape == m_ref.shape
    for col in m_ref.columns:
        y = m_ref[col].to_numpy()
        np.testing.assert_allclose(m_fast[col].to_numpy(), y, rtol=RTOL, atol=RTOL * np.max(np.abs(y)), err_msg=col)
    assert_same_state(est_fast.engine_state(), est_ref.engine_state())


#: Settings off the ablation's path: an edge longer than the stillness window, a window of
#: one innovation, stacked Zhou fading with β = 2 over 2 rows, the shared process noise with
#: another ρ and λ_max, no fading, another update interval and prior.
ODD_SETTINGS = {
    "long edge": (AdaptiveConfig(edge_s=120.0, zaru_window_s=30.0, innovation_window=1), {}),
    "stacked zhou": (AdaptiveConfig(stacked=True, normalised=False, softening=2.0), {"stack_depth": 2}),
    "shared noise": (AdaptiveConfig(q_sd=None, rho=0.3, lambda_max=3.0), {"update_interval_s": 7.0, "init_s": 20.0}),
    "plain": (AdaptiveConfig(fading=False, recentre=False, zaru_hold=False), {"kalman": KalmanConfig(x0=(0.01, 0.5, 0.2))}),
}


@pytest.mark.parametrize("name", list(ODD_SETTINGS))
@pytest.mark.parametrize("family", ["static", "soak"])
def test_fast_engine_equals_reference_with_other_settings(family, name):
    settings, kw = ODD_SETTINGS[name]
    cfg = config(settings, **kw)
    fast, est_fast = run(family_log(family), cfg, "fast")
    ref, est_ref = run(family_log(family), cfg, "reference")
    assert_agree(fast, ref)
    assert_same_state(est_fast.engine_state(), est_ref.engine_state())


@pytest.mark.parametrize("raw_mag", [False, True])
@pytest.mark.parametrize("variant", ["all fixes", "without one_measurement", "before issue 6"])
def test_fast_engine_equals_reference_on_a_messy_log(variant, raw_mag):
    """Turns, an interference window, a compass outage, empty cells, a time gap, a field anomaly."""
    log = complex_log(raw_mag)
    cfg = config(VARIANTS[variant])
    est_fast, est_ref = build_estimator(cfg), build_estimator(cfg)
    fast = compensate(log, cfg, estimator=est_fast, engine="fast")
    ref = compensate(log, cfg, estimator=est_ref, engine="reference")
    assert_agree(fast, ref)
    assert {"init", "turning", "no_compass", "gap", "interference"} <= set(ref["gate_reason"].astype(str))
    assert_same_state(est_fast.engine_state(), est_ref.engine_state())


def test_the_families_exercise_every_fix(monkeypatch):
    """The comparisons above are not vacuous: with the default settings the reference takes
    every branch the compiled mirror implements."""
    seen: dict[str, int] = {}

    def count(key):
        seen[key] = seen.get(key, 0) + 1

    zaru, drift, hold, edge_var = (_Aiding._zaru_measurement, _Aiding._drift_not_interference,
                                   AdaptiveKalman.hold, _Aiding._edge_variance)

    def zaru_counted(self, end):
        meas = zaru(self, end)
        if meas is not None:
            count("zaru verified" if meas.r > self.cfg.gyro_noise_dps_rthz**2 / (end.t - self.start.t) else "zaru hold")
        return meas

    def drift_counted(self, rate):
        out = drift(self, rate)
        count("relock" if out else "refused")
        return out

    def hold_counted(self):
        before = self._anchor is None
        out = hold(self)
        if before and self._anchor is not None:
            count("anchor")
        return out

    def edge_var_counted(self, snap, d_ref, k):
        window = [s for s in self.window if snap.t - self.cfg.update_interval_s < s.t <= snap.t]
        count("edge from the compass" if len(window) >= 10 else "edge from compass_sigma")
        return edge_var(self, snap, d_ref, k)

    monkeypatch.setattr(_Aiding, "_zaru_measurement", zaru_counted)
    monkeypatch.setattr(_Aiding, "_drift_not_interference", drift_counted)
    monkeypatch.setattr(AdaptiveKalman, "hold", hold_counted)
    monkeypatch.setattr(_Aiding, "_edge_variance", edge_var_counted)
    reasons = set()
    for family in FAMILIES:
        out = compensate_arrays(**arrays(family_log(family)), config=config(AdaptiveConfig()), engine="reference")
        reasons |= set(out["gate_reason"].astype(str))
    assert {"zaru verified", "zaru hold", "relock", "refused", "anchor", "edge from the compass",
            "edge from compass_sigma"} <= set(seen), seen
    assert {"", "init", "interference", "no_compass", "turning"} <= reasons


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_chunks_of_any_size_give_identical_results(variant):
    """Chunk boundaries inside the init window and at single rows, the compass window ring
    growing (60 s of a 10-Hz compass): bit for bit the same as one chunk, estimator included."""
    log = family_log("soak")
    cfg = config(VARIANTS[variant])
    whole, m_whole, est_whole = feed_in_chunks(log, cfg, [len(log)])
    rng = np.random.default_rng(7)
    sizes = [1, 1, 7, 250, 1, 3] + list(rng.integers(1, 40, size=150)) + list(rng.integers(1, 3000, size=40)) + [len(log)]
    parts, m_parts, est_parts = feed_in_chunks(log, cfg, sizes)
    pd.testing.assert_frame_equal(whole, parts, check_exact=True)
    assert np.array_equal(m_whole, m_parts)
    _assert_identical(est_whole.engine_state(), est_parts.engine_state())


def test_chunks_on_a_messy_log_and_a_tiny_window():
    """Empty cells held across chunks, a time gap, the ring grown from tiny chunks."""
    log = complex_log(False)
    for settings in (AdaptiveConfig(), AdaptiveConfig(edge_s=12.0, zaru_window_s=5.0)):
        cfg = config(settings, update_interval_s=5.0)
        whole, m_whole, est_whole = feed_in_chunks(log, cfg, [len(log)])
        sizes = [1] * 50 + [2, 3, 5, 8, 13] * 40 + [len(log)]
        parts, m_parts, est_parts = feed_in_chunks(log, cfg, sizes)
        pd.testing.assert_frame_equal(whole, parts, check_exact=True)
        assert np.array_equal(m_whole, m_parts)
        _assert_identical(est_whole.engine_state(), est_parts.engine_state())


def _assert_identical(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key, y in b.items():
        x = a[key]
        if isinstance(y, dict):
            _assert_identical(x, y)
        elif y is None:
            assert x is None, key
        else:
            assert np.array_equal(np.asarray(x), np.asarray(y)), key


def test_fast_estimator_continues_like_the_reference():
    """The state written back after ``finish()`` is the whole filter: updating and holding the
    fast run's estimator further gives what the reference's gives."""
    from gyrodrift.estimators.base import Observation

    log = family_log("soak")
    cfg = config(AdaptiveConfig())
    _, est_fast = run(log, cfg, "fast")
    _, est_ref = run(log, cfg, "reference")
    obs = Observation(t=1e6, y=np.array([0.4]), H=np.array([[31.0, 0.001, 1.0]]), R=np.array([[1e-4]]))
    for est in (est_fast, est_ref):
        est.hold()
        est.update(obs)
        est.hold()
        est.hold()
    assert est_ref._anchor is not None and est_ref._twin is not None
    assert_same_state(est_fast.engine_state(), est_ref.engine_state())
    np.testing.assert_allclose(est_fast.params, est_ref.params, rtol=RTOL, atol=RTOL)
    assert math.isclose(est_fast.last_lambda, est_ref.last_lambda, rel_tol=RTOL)


def test_default_estimator_settings_round_trip():
    """``set_engine_state(engine_state())`` leaves an estimator as it was (twin included)."""
    est = build_estimator(config(AdaptiveConfig()))
    run_log = family_log("vehicle")
    compensate_arrays(**arrays(run_log), config=config(AdaptiveConfig()), estimator=est, engine="reference")
    copy = build_estimator(config(AdaptiveConfig()))
    copy.set_engine_state(est.engine_state())
    _assert_identical(copy.engine_state(), est.engine_state())


def test_common_kernels_sum_like_numpy():
    """The mirror's means and standard deviations have numpy's bits (pairwise summation),
    above and below its 8- and 128-number blocks."""
    from gyrodrift._common_kernels import mean, pairwise_sum, std

    rng = np.random.default_rng(11)
    for n in [1, 2, 7, 8, 9, 15, 16, 17, 127, 128, 129, 255, 600, 1001, 4099, 70001]:
        x = rng.standard_normal(n + 3) * 10.0 ** rng.uniform(-3, 3, n + 3)
        assert pairwise_sum(x, 3, n) == np.sum(x[3:]), n
        y = x[:n].copy()
        assert mean(y) == np.mean(y) and std(y) == np.std(y), n

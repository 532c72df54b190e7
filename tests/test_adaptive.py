"""The ``adaptive`` estimator (beyond the paper): its filter and the aiding it adds."""

import numpy as np
import pytest

from conftest import synthetic_log
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import AdaptiveKalman, Observation, make_estimator
from gyrodrift.kernels.aiding import add, gyro_still
from gyrodrift.kernels.kalman import _recentre, views
from gyrodrift.kernels.layout import MAIN, N_WIN, TWIN
from test_compensate import assert_same, complex_log, stream
from test_engine import InPython


def obs(H, y, r=1e-4):
    H = np.atleast_2d(H)
    return Observation(t=0.0, y=np.atleast_1d(y), H=H, R=np.eye(len(H)) * r)


def test_reports_absolute_parameters_of_the_centred_filter():
    est = AdaptiveKalman()
    rng = np.random.default_rng(0)
    truth = np.array([0.02, 3.0, -0.4])
    for _ in range(400):
        H = np.column_stack([40 + 10 * rng.random(3), rng.normal(0, 0.02, 3), np.ones(3)])
        est.update(obs(H, H @ truth))
    assert est.temp_ref_c == pytest.approx(45.0, abs=2.0)
    np.testing.assert_allclose(est.params, truth, rtol=1e-3)
    T, Tp = np.array([30.0, 50.0]), np.array([0.01, -0.01])
    np.testing.assert_allclose(est.drift(T, Tp), truth[0] * T + truth[1] * Tp + truth[2], rtol=1e-6)
    assert np.all(np.linalg.eigvalsh(est.cov) >= 0)


def test_fading_factor_rises_only_when_the_model_stops_explaining_the_data():
    est = make_estimator("adaptive")
    H = np.array([[30.0, 0.0, 1.0]])
    for _ in range(50):
        est.update(obs(H, 0.2, r=1e-3))
    assert est.last_lambda == 1.0  # consistent measurements: long memory
    for _ in range(3):
        est.update(obs(H, 1.2, r=1e-3))  # the drift jumps by 1 deg/s
    assert est.last_lambda > 2.0
    for _ in range(20):
        est.update(obs(H, 1.2, r=1e-3))
    assert est.drift(np.array([30.0]), np.array([0.0]))[0] == pytest.approx(1.2, abs=0.02)


def test_settings_are_validated():
    with pytest.raises(ConfigError, match="lambda_max"):
        AdaptiveKalman(lambda_max=0.5)
    with pytest.raises(ConfigError, match="rho"):
        AdaptiveKalman(rho=1.0)


# ------------------------------------------------------------------ the fixes

from gyrodrift.estimators import AdaptiveConfig  # noqa: E402


def still_log(heading_deg=lambda t: np.full_like(t, 100.0), seed=4):
    """Motionless unit (or a given heading), drift following a quadratic in temperature."""
    return synthetic_log(
        duration_s=1800.0, fs_hz=10.0, compass_hz=10.0, gyro_noise_dps=0.1, compass_noise_deg=0.5, seed=seed,
        drift_dps=lambda t, T: 0.02 * T - 0.3 + 0.001 * (T - 30) ** 2, heading_deg=heading_deg,
    )


def test_default_adaptive_streaming_equals_batch():
    """ZARU and one measurement per interval: the streaming compensator gives the same bits."""
    cfg = CompensatorConfig(estimator="adaptive")
    for log in (complex_log(), still_log()):
        batch = compensate(log, cfg)
        assert_same(batch, stream(log, cfg))


def test_zaru_used_when_still_and_not_fooled_by_a_slow_turn():
    # Without edge averaging, only ZARU measurements have a variance far below a compass difference.
    cfg = CompensatorConfig(estimator="adaptive", adaptive=AdaptiveConfig(edge_s=0.0))
    still = compensate(still_log(), cfg).attrs["measurements"]
    # A ZARU measurement has the gyro's variance N²/Δt (plus a tiny slope term), far below a compass difference.
    compass_r = 2 * cfg.compass_sigma_deg**2 / cfg.update_interval_s**2
    assert (still["r"] < 0.1 * compass_r).mean() > 0.8
    slow = compensate(still_log(heading_deg=lambda t: 100.0 + 0.05 * t), cfg).attrs["measurements"]
    assert (slow["r"][3:] < 0.1 * compass_r).sum() == 0  # after init: a 0.05 deg/s turn: never taken for stillness
    # ... and the drift estimate on the still log beats the compass-only one.
    log = still_log()
    err = {}
    for zaru in (True, False):
        out = compensate(log, CompensatorConfig(estimator="adaptive", adaptive=AdaptiveConfig(zaru=zaru, edge_s=0.0)))
        err[zaru] = float(np.sqrt(np.mean((out["bias_z"] - log["true_bias_z"]).to_numpy()[3000:] ** 2)))
    assert err[True] < 0.75 * err[False]


def test_one_measurement_per_interval_unless_stacked():
    log = still_log()
    seen = {}
    for stacked in (False, True):
        est = InPython(make_estimator("adaptive", settings=AdaptiveConfig(zaru=False, stacked=stacked)))
        compensate(log, CompensatorConfig(estimator="adaptive"), estimator=est)
        seen[stacked] = [len(o.y) for o in est.observations]
    assert seen[False][0] == 3 and set(seen[False][1:]) == {1}  # init sub-windows, then one each
    assert set(seen[True][3:]) == {3}


def test_adaptive_settings_validated_and_ablated():
    with pytest.raises(ConfigError, match="q_sd"):
        AdaptiveConfig(q_sd=(1e-3, -1.0, 1e-3))
    with pytest.raises(ConfigError, match="zaru_window_s"):
        AdaptiveConfig(zaru_window_s=0.0)
    with pytest.raises(ConfigError, match="AdaptiveConfig"):
        CompensatorConfig(adaptive={"zaru": False})
    base = AdaptiveConfig()
    assert base.ablated("zaru").zaru is False and base.ablated("one_measurement").stacked is True
    assert base.ablated("fading").fading is False and base.ablated("process_noise").q_sd is None
    assert base.ablated("recentre").recentre is False and base.ablated("process_noise").slope_q_per_rtc == 0.0
    with pytest.raises(ConfigError, match="unknown fix"):
        base.ablated("magic")
    for fix in AdaptiveConfig.FIXES:  # each switch is a setting the kernels read
        assert base.ablated(fix) != base


def test_recentring_keeps_the_drift_model():
    est = make_estimator("adaptive")
    H = np.array([[30.0, 0.001, 1.0]])
    for T in (30.0, 32.0, 35.0):
        est.update(obs(np.array([[T, 0.001, 1.0]]), 0.02 * T - 0.3, r=1e-4))
    assert est.temp_ref_c == 35.0  # moved to each new measurement's temperature
    before, cov = est.params.copy(), est.cov.copy()
    z, P, Q, max_var, af, V, nis, ai = views(*est.kernel_arrays)
    _recentre(z[MAIN], P[MAIN], af[MAIN], 50.0)
    np.testing.assert_allclose(est.params, before, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(est.cov, cov, rtol=1e-9, atol=1e-15)
    assert est.temp_ref_c == 50.0 and H.shape == (1, 3)


def test_normalised_fading_ignores_one_outlier_but_follows_a_jump():
    est = make_estimator("adaptive")
    H = np.array([[30.0, 0.0, 1.0]])
    for _ in range(50):
        est.update(obs(H, 0.2, r=1e-3))
    est.update(obs(H, 0.29, r=1e-3))  # one 2.8-sigma outlier: the mean NIS of 3 stays below 3.78
    assert est.last_lambda == 1.0
    for _ in range(3):
        est.update(obs(H, 0.2, r=1e-3))
    for _ in range(3):
        est.update(obs(H, 1.2, r=1e-3))  # the drift jumps by 1 deg/s
    assert est.last_lambda > 2.0


def test_zaru_not_fooled_by_a_yaw_wander_the_compass_cannot_see():
    """A ±0.08 deg/s yaw wander of 20-s period moves the heading by only ±0.25 deg."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 60.0 + 1e-9, 0.1)
    g = 0.3 + rng.normal(0.0, 0.1, t.size)
    for wander, expect in ((0.0, True), (0.08, False)):
        rate = g + wander * np.sin(2 * np.pi * t / 20.0)
        trap = 0.5 * (rate[1:] + rate[:-1])  # rates between samples, as from the trapezoid integral
        assert still(t, trap + 0.001 * t[1:], 50.0) is expect  # a slowly moving drift is fine


def test_edge_averaging_lowers_the_compass_noise_and_keeps_telescoping():
    log = still_log(heading_deg=lambda t: 100.0 + 30.0 * np.sin(2 * np.pi * t / 300.0))  # moving: no ZARU
    out = {}
    for edge in (0.0, 2.0):
        cfg = CompensatorConfig(estimator="adaptive", adaptive=AdaptiveConfig(edge_s=edge))
        out[edge] = compensate(log, cfg)
        assert_same(out[edge], stream(log, cfg))
    m0, m2 = (out[e].attrs["measurements"].iloc[3:] for e in (0.0, 2.0))
    assert m2["r"].median() < 0.2 * m0["r"].median()
    truth = np.interp(m2["t"], log["t"], log["true_bias_z"])
    assert float(np.sqrt(np.mean((m2["m"] - truth) ** 2))) < 0.5 * float(np.sqrt(np.mean((m0["m"] - truth) ** 2)))
    late = slice(3000, None)
    err = {e: float(np.sqrt(np.mean((out[e]["bias_z"] - log["true_bias_z"]).to_numpy()[late] ** 2))) for e in out}
    assert err[2.0] < err[0.0]


def test_outage_memory_extrapolates_with_the_long_memory_slope():
    est = make_estimator("adaptive")
    rng = np.random.default_rng(2)
    truth = np.array([0.02, 3.0, -0.4])
    for T in np.linspace(20.0, 40.0, 200):
        H = np.array([[T, 0.002, 1.0]])
        est.update(obs(H, H @ truth + rng.normal(0.0, 0.01), r=1e-4))
    tracked = est.drift(np.array([40.0]), np.array([0.002]))[0]
    est.hold()  # outage: the long-memory a and b, anchored at the drift last tracked
    assert est.drift(np.array([40.0]), np.array([0.002]))[0] == pytest.approx(tracked, abs=1e-12)
    z, P, Q, max_var, af, V, nis, ai = views(*est.kernel_arrays)
    assert est.params[0] == pytest.approx(z[TWIN, 0])  # the twin's slope
    assert abs(est.params[0] - 0.02) < 0.003
    no_twin = make_estimator("adaptive", settings=AdaptiveConfig(outage_memory=False))
    no_twin.update(obs(np.array([[30.0, 0.0, 1.0]]), 0.3))
    no_twin.hold()
    assert no_twin.params[0] == pytest.approx(no_twin.kernel_arrays[0][0])  # its own slope


def test_stillness_holds_through_slowly_wandering_interference():
    """Still unit, compass pulled 8 deg over 10 min after 15 min: ZARU continues (the compass moved)."""
    wander = lambda t: 8.0 * np.clip((t - 900.0) / 600.0, 0.0, 1.0)  # noqa: E731
    log = still_log()
    log["heading"] = np.mod(log["heading"] + wander(log["t"].to_numpy()), 360.0)
    err = {}
    for hold in (True, False):
        cfg = CompensatorConfig(estimator="adaptive", adaptive=AdaptiveConfig(zaru_hold=hold))
        out = compensate(log, cfg)
        if hold:
            assert_same(out, stream(log, cfg))
        late = (log["t"] > 900.0).to_numpy()
        err[hold] = float(np.sqrt(np.mean((out["bias_z"] - log["true_bias_z"]).to_numpy()[late] ** 2)))
    assert err[True] < 0.8 * err[False]


def test_a_still_unit_whose_compass_moved_keeps_the_compass_from_the_fused_heading():
    """ZARU held on a wandering compass (the compass moved, not the unit): the next interval's
    rows are labelled interference and, with magnetic gates, the fused heading follows the gyro."""
    from gyrodrift.fusion import FusionConfig
    from gyrodrift.montecarlo import draw_case, simulate_case

    log, _ = simulate_case(draw_case("interference-wander", 0, duration_scale=0.3), calibration=False)
    cfg = CompensatorConfig(estimator="adaptive", fusion=FusionConfig(magnetic_gates=True, bias_corr_s=30.0,
                                                                      relock_s=float("inf")))
    out = compensate(log, cfg)
    flagged = (out["gate_reason"] == "interference").to_numpy()
    update = out["updated"].to_numpy() == 1
    # an accepted interval followed by one labelled interference from its first row: only
    # a ZARU held on a moving compass does that (after any other acceptance the label clears)
    assert np.sum(update[:-1] & flagged[1:]) > 10
    # on flagged rows the fused heading only integrates the compensated rate
    t, rate, hf = (out[c].to_numpy() for c in ("t", "rate_z", "heading_fused"))
    step = np.diff(hf)
    expected = 0.5 * (rate[1:] + rate[:-1]) * np.diff(t)
    rows = flagged[1:] & np.isfinite(step)
    assert rows.sum() > 100
    np.testing.assert_allclose((step[rows] - expected[rows] + 180.0) % 360.0 - 180.0, 0.0, atol=1e-9)


def still(t, rates, interval_start_s):
    """:func:`gyrodrift.kernels.aiding.gyro_still` of gyro ``rates`` (deg/s) between compass
    samples at times ``t`` (one more than the rates), through the compass window."""
    win = np.zeros((N_WIN, 2 * t.size))
    head = n = 0
    I_raw = np.r_[0.0, np.cumsum(rates * np.diff(t))]
    for ti, Ii in zip(t, I_raw):
        head, n = add(win, head, n, ti, 0.0, Ii, 0.0, 0.0, 0.0, 1e9)
    return bool(gyro_still(win, head, head + n, interval_start_s, 1.0, 3.0))

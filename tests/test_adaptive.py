"""The experimental ``adaptive`` estimator and the ``slope`` measurement (issue: beyond the paper)."""

import numpy as np
import pytest

from conftest import synthetic_log
from gyrodrift.compensate import CompensatorConfig, compensate
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import AdaptiveKalman, Observation, make_estimator
from test_compensate import assert_same, complex_log, stream


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
    with pytest.raises(ConfigError, match="measurement"):
        CompensatorConfig(measurement="median")


def test_slope_measurement_streaming_equals_batch_and_is_less_noisy():
    cfg = CompensatorConfig(measurement="slope", estimator="adaptive")
    log = complex_log()
    assert_same(compensate(log, cfg), stream(log, cfg))
    # Static, constant bias, noisy compass: the slope averages the compass noise.
    noisy = synthetic_log(duration_s=1800.0, gyro_noise_dps=0.05, compass_noise_deg=1.0, seed=8)
    ends = compensate(noisy, CompensatorConfig(stack_depth=1)).attrs["measurements"]
    slope = compensate(noisy, CompensatorConfig(stack_depth=1, measurement="slope")).attrs["measurements"]
    assert slope["m"].std() < 0.5 * ends["m"].std()
    assert slope["m"].mean() == pytest.approx(0.3, abs=0.01)

import numpy as np
import pytest

from gyrodrift.errors import ConfigError
from gyrodrift.estimators import (
    ESTIMATORS,
    DriftEstimator,
    KalmanConfig,
    KalmanDrift,
    Observation,
    PlainKalmanDrift,
    make_estimator,
)
from gyrodrift.kernels.numeric import cap_covariance, correct


def test_one_stkf_step_by_hand():
    """Eq. (10) with diagonal P0 and one measurement row, written out in scalars."""
    s, p, q, r = 1.5, (0.04, 9.0, 4.0), (1e-6, 0.01, 1e-4), 0.02
    x0 = (0.01, 1.0, -0.2)
    h = (30.0, 0.05, 1.0)
    y = 0.5
    cfg = KalmanConfig(fading=s, x0=x0, p0_sd=tuple(np.sqrt(p)), q_sd=tuple(np.sqrt(q)), max_sd=(1e3,) * 3)
    est = KalmanDrift(cfg)
    obs = Observation(t=10.0, y=np.array([y]), H=np.array([h]), R=np.array([[r]]))
    x = est.update(obs)

    pm = [s * p[i] + q[i] for i in range(3)]  # predicted variances (diagonal)
    S = sum(h[i] ** 2 * pm[i] for i in range(3)) + r
    K = [pm[i] * h[i] / S for i in range(3)]
    innov = y - sum(h[i] * x0[i] for i in range(3))
    x_hand = [x0[i] + K[i] * innov for i in range(3)]
    P_hand = [[(1.0 if i == j else 0.0) * pm[i] - K[i] * h[j] * pm[j] for j in range(3)] for i in range(3)]
    np.testing.assert_allclose(x, x_hand, rtol=1e-12)
    np.testing.assert_allclose(est.cov, P_hand, rtol=1e-9, atol=1e-15)


def test_s_equal_one_matches_filterpy():
    filterpy = pytest.importorskip("filterpy.kalman", reason="filterpy is a test extra: pip install -e .[test]")
    rng = np.random.default_rng(7)
    p0 = np.array([0.05, 5.0, 5.0])
    q = np.array([1e-4, 0.05, 1e-3])
    for fading in (1.0, 1.04):
        cfg = KalmanConfig(fading=fading, p0_sd=tuple(p0), q_sd=tuple(q), max_sd=(1e6,) * 3)
        ours = KalmanDrift(cfg)
        ref = filterpy.KalmanFilter(dim_x=3, dim_z=3)
        ref.x = np.zeros(3)
        ref.P = np.diag(p0**2)
        ref.F = np.eye(3)
        ref.Q = np.diag(q**2)
        ref.alpha = np.sqrt(fading)
        for k in range(200):
            H = np.column_stack([25 + 10 * rng.random(3), rng.normal(0, 0.02, 3), np.ones(3)])
            y = H @ np.array([0.02, 3.0, -0.5]) + rng.normal(0, 0.05, 3)
            R = np.diag(rng.uniform(0.001, 0.01, 3))
            ours.update(Observation(t=10.0 * k, y=y, H=H, R=R))
            ref.predict()
            ref.update(y, R=R, H=H)
            np.testing.assert_allclose(ours.params, ref.x.ravel(), rtol=1e-8, atol=1e-12)
            np.testing.assert_allclose(ours.cov, ref.P, rtol=1e-6, atol=1e-14)


def test_stkf_s1_is_stkf_with_unit_fading():
    s1 = make_estimator("stkf-s1", config=KalmanConfig(fading=1.3))
    stkf1 = KalmanDrift(KalmanConfig(fading=1.0))
    assert isinstance(s1, PlainKalmanDrift) and s1.fading == 1.0
    rng = np.random.default_rng(1)
    for k in range(20):
        H = np.column_stack([30 + rng.random(3), rng.normal(0, 0.01, 3), np.ones(3)])
        obs = Observation(t=k, y=rng.normal(0, 0.1, 3), H=H, R=np.eye(3) * 0.01)
        assert np.array_equal(s1.update(obs), stkf1.update(obs))


def test_kf_baseline_is_a_bias_only_filter():
    """The paper's KF: one state (the bias), so a and b stay 0; one step by hand."""
    cfg = KalmanConfig(x0=(0.0, 0.0, 0.1), p0_sd=(0.05, 5.0, 0.5), max_sd=(1.0, 10.0, 10.0))
    kf = make_estimator("kf", config=cfg, bias_q_sd=0.01)
    H = np.array([[30.0, 0.01, 1.0], [29.0, 0.0, 1.0]])
    y, r = np.array([0.4, 0.3]), 0.02
    x = kf.update(Observation(t=10.0, y=y, H=H, R=np.eye(2) * r))
    p = 0.5**2 + 0.01**2
    # Two equal-variance measurements of c: the posterior mean weighs their sum.
    c_hand = (0.1 / p + y.sum() / r) / (1 / p + 2 / r)
    np.testing.assert_allclose(x, [0.0, 0.0, c_hand], rtol=1e-12)
    assert kf.drift(np.array([50.0]), np.array([1.0]))[0] == pytest.approx(c_hand)


def test_covariance_stays_bounded_and_positive_definite():
    """T' = 0 leaves b unobservable; fading 1.1 would grow P as 1.1**N without the cap."""
    est = KalmanDrift(KalmanConfig(fading=1.1))
    cap = np.square(est.config.p0_sd)
    for k in range(5000):
        if k % 3:
            H = np.array([[40.0, 0.0, 1.0]] * 3)  # flat temperature: a vs c, and b, unobservable
            est.update(Observation(t=k, y=np.full(3, 0.2), H=H, R=np.eye(3) * 0.005))
        else:
            est.hold()
        P = est.cov
        assert np.all(np.isfinite(P))
    assert np.allclose(P, P.T)
    assert np.all(np.linalg.eigvalsh(P) > 0)
    W = 1 / np.sqrt(cap)
    assert np.linalg.eigvalsh(P * np.outer(W, W)).max() <= 1 + 1e-9


def test_hold_adds_only_process_noise():
    est = KalmanDrift(KalmanConfig(fading=1.5, max_sd=(1e3,) * 3))
    P0 = est.cov
    est.hold()
    np.testing.assert_allclose(est.cov, P0 + np.diag(np.square(est.config.q_sd)))


def test_cap_covariance_clips_only_directions_above_the_cap():
    rng = np.random.default_rng(3)
    max_var = np.array([0.05, 5.0, 5.0]) ** 2
    V, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    root = np.sqrt(max_var)
    P = np.outer(root, root) * ((V * [4.0, 1e-4, 0.5]) @ V.T)
    capped = cap_covariance(P, max_var)
    expected = np.outer(root, root) * ((V * [1.0, 1e-4, 0.5]) @ V.T)
    np.testing.assert_allclose(capped, expected, rtol=1e-9, atol=1e-15)
    small = root * V[:, 1]  # a well-known direction keeps its variance
    assert small @ np.linalg.solve(P, small) == pytest.approx(small @ np.linalg.solve(capped, small), rel=1e-6)
    below = np.diag(max_var) * 0.5
    assert np.array_equal(cap_covariance(below, max_var), below)


def test_joseph_form_is_symmetric_and_matches_the_textbook_update():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 3))
    P = A @ A.T + np.eye(3)
    H, R, y = rng.normal(size=(2, 3)), np.eye(2) * 0.1, np.ones(2)
    x, Pp = correct(np.zeros(3), P, y, H, R)
    assert np.array_equal(Pp, Pp.T)
    assert np.all(np.linalg.eigvalsh(Pp) > 0)
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    np.testing.assert_allclose(x, K @ y, rtol=1e-12)
    np.testing.assert_allclose(Pp, (np.eye(3) - K @ H) @ P, rtol=1e-10, atol=1e-12)


def test_registry():
    assert {"stkf", "kf", "stkf-s1", "lsm", "mlr-causal", "fixed", "adaptive"} <= set(ESTIMATORS)
    for name in ("stkf", "kf", "stkf-s1", "lsm", "mlr-causal", "fixed", "adaptive"):
        est = make_estimator(name)
        assert isinstance(est, DriftEstimator)
        assert est.name == name
        assert est.params.shape == (3,) and est.cov.shape == (3, 3)
    assert make_estimator("mlr-causal").causal  # the MLR fitted on the past only
    with pytest.raises(ConfigError, match="choose one of: adaptive, fixed, kf, lsm, mlr-causal, stkf, stkf-s1"):
        make_estimator("nope")


@pytest.mark.parametrize(
    "kwargs, match",
    [({"fading": 0.99}, "fading"), ({"p0_sd": (1.0, 0.0, 1.0)}, "p0_sd"), ({"q_sd": (1.0, 2.0)}, "q_sd"),
     ({"q_sd": (1e-4, -0.05, 1e-3)}, r"q_sd = .*: -0.05 must be >= 0")],
)
def test_config_validation(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        KalmanConfig(**kwargs)

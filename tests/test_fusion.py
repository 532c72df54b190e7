"""The fused heading and the heading standard deviations (gyrodrift.fusion)."""

import math

import numpy as np
import pytest

from conftest import synthetic_log
from gyrodrift.compensator import compensate
from gyrodrift.conventions import wrap_180
from gyrodrift.errors import ConfigError
from gyrodrift.fusion import FusionConfig, FusionState, fuse_rows


def rms(x):
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x[np.isfinite(x)] ** 2)))


def test_perfect_sensors_give_the_true_heading():
    t = np.arange(0.0, 60.0, 0.1)
    heading = np.mod(40.0 + 3.0 * t, 360.0)  # a steady 3 deg/s turn, across the 0/360 seam
    compass = np.where(np.arange(t.size) % 5 == 0, heading, np.nan)
    h, sd, gsd = fuse_rows(t, np.full(t.size, 3.0), compass, np.ones(t.size, bool), np.zeros(t.size))
    np.testing.assert_allclose(wrap_180(h - heading), 0.0, atol=1e-9)
    assert (h >= 0).all() and (h < 360).all()


def test_before_the_first_compass_sample_there_is_no_fused_heading():
    t = np.arange(0.0, 10.0, 0.1)
    compass = np.full(t.size, np.nan)
    compass[50:] = 10.0
    h, sd, gsd = fuse_rows(t, np.zeros(t.size), compass, np.ones(t.size, bool), np.full(t.size, 0.01))
    assert np.isnan(h[:50]).all() and np.isnan(sd[:50]).all() and np.isnan(gsd[:50]).all()
    assert np.isfinite(h[50:]).all()


def test_an_outlier_is_refused_and_a_refused_row_is_not_used():
    """A single 40-deg compass spike fails the innovation test; a row marked not allowed
    (magnetic refusal) is ignored whatever it says."""
    t = np.arange(0.0, 100.0, 0.1)
    compass = np.where(np.arange(t.size) % 10 == 0, 100.0, np.nan)
    compass[500] = 140.0
    allow = np.ones(t.size, bool)
    h, sd, _ = fuse_rows(t, np.zeros(t.size), compass, allow, np.full(t.size, 0.001))
    assert abs(h[500] - 100.0) < 1e-6
    compass[600] = 101.0  # a plausible value, but refused by the gates
    allow[600] = False
    h2, _, _ = fuse_rows(t, np.zeros(t.size), compass, allow, np.full(t.size, 0.001))
    assert abs(h2[600] - h2[599]) < 1e-12


def test_standard_deviations_behave():
    """σ of the gyro heading never shrinks; σ of the fused heading shrinks at compass updates
    and grows between them."""
    log = synthetic_log(duration_s=600.0, gyro_noise_dps=0.05, compass_noise_deg=0.5, seed=4)
    out = compensate(log)
    gsd = out["heading_sd"].to_numpy()
    ok = np.isfinite(gsd)
    assert (np.diff(gsd[ok]) >= -1e-12).all()
    fsd = out["heading_fused_sd"].to_numpy()
    has = np.isfinite(out["compass_heading"].to_numpy())
    step = np.diff(fsd)
    assert (step[~has[1:] & np.isfinite(step)] >= 0).all()
    assert (step[has[1:] & np.isfinite(step)] < 0).any()


def test_fused_heading_beats_both_sensors_on_a_turning_noisy_log():
    """A log that starts still then sways, with a noisy compass, a noisy gyro with a drift the
    filter learns, and a 30-deg interference window shorter than ``relock_s``: the fused heading
    is closer to the truth than the compass and than the gyro heading."""
    log = synthetic_log(duration_s=1800.0, gyro_noise_dps=0.2, compass_noise_deg=1.0, seed=8,
                        drift_dps=lambda t, T: 0.02 * T - 0.3,
                        heading_deg=lambda t: 50.0 + 40.0 * np.sin(2 * np.pi * np.maximum(t - 60.0, 0.0) / 300.0))
    window = (log["t"] > 900) & (log["t"] < 940)
    log.loc[window, "heading"] = np.mod(log.loc[window, "heading"] + 30.0, 360.0)
    out = compensate(log)
    truth = log["ref_heading"].to_numpy()
    fused = rms(wrap_180(out["heading_fused"].to_numpy() - truth))
    gyro = rms(wrap_180(out["heading"].to_numpy() - truth))
    compass = rms(wrap_180(out["compass_heading"].to_numpy() - truth))
    assert fused < 0.8 * min(gyro, compass), (fused, gyro, compass)


def test_row_by_row_equals_batch_and_python_equals_compiled():
    rng = np.random.default_rng(0)
    n = 2000
    t = np.cumsum(rng.uniform(0.005, 0.02, n))
    rate = rng.normal(0, 2, n)
    compass = np.where(rng.random(n) < 0.2, rng.uniform(0, 360, n), np.nan)
    allow = rng.random(n) < 0.9
    sd = rng.uniform(0.001, 0.05, n)
    cfg = FusionConfig()
    batch = FusionState(cfg, 0.04).rows(t, rate, compass, allow, sd)
    one = FusionState(cfg, 0.04)
    rows = np.array([one.row(*args) for args in zip(t, rate, compass, allow, sd)])
    for k in range(3):
        assert np.array_equal(rows[:, k], batch[k], equal_nan=True)
    from gyrodrift.kernels.fusion import fuse_rows as compiled

    plain = compiled.py_func  # the same source run as plain Python gives the same bits
    out = np.empty((3, n))
    plain(np.zeros(11), t, rate, compass, allow, sd, cfg.vector(0.04), math.inf, out[0], out[1], out[2])
    for k in range(3):
        assert np.array_equal(out[k], batch[k], equal_nan=True)


def test_settings_are_checked():
    with pytest.raises(ConfigError, match="heading_sigma_deg"):
        FusionConfig(heading_sigma_deg=0.0)
    with pytest.raises(ConfigError, match="nis_gate"):
        FusionConfig(nis_gate=float("nan"))


def test_a_compass_refused_for_relock_s_is_taken_again():
    """A lasting 20-deg step of the compass (a new magnetic environment): refused at first,
    taken again ``relock_s`` after the first refusal, never a lock-out."""
    t = np.arange(0.0, 300.0, 0.1)
    compass = np.where(np.arange(t.size) % 10 == 0, np.where(t < 100.0, 50.0, 70.0), np.nan)
    cfg = FusionConfig(relock_s=30.0)
    h, sd, _ = fuse_rows(t, np.zeros(t.size), compass, np.ones(t.size, bool), np.full(t.size, 0.001), cfg)
    assert abs(h[int(120 / 0.1)] - 50.0) < 0.5  # still refusing 20 s after the step
    assert abs(h[int(131 / 0.1)] - 70.0) < 1e-6  # re-anchored at 130 s
    assert abs(h[-1] - 70.0) < 1e-6


def test_the_paper_filter_gets_the_tolerant_fused_heading_by_default():
    """Without a ``fusion`` setting, ``stkf`` runs the fused heading with (A), ``adaptive`` with (B):
    the batch and the streaming compensator read ``CompensatorConfig.fusion_settings``."""
    from dataclasses import replace

    from gyrodrift.compensator import Compensator, CompensatorConfig
    from test_compensate import complex_log

    log = complex_log(False)  # interference for 2 min, a compass outage, turns
    stkf = CompensatorConfig(estimator="stkf")

    def fused(cfg):
        return compensate(log, cfg)["heading_fused"].to_numpy()

    auto = fused(stkf)
    assert np.array_equal(auto, fused(replace(stkf, fusion=FusionConfig.tolerant())), equal_nan=True)
    assert not np.allclose(auto, fused(replace(stkf, fusion=FusionConfig())), equal_nan=True)  # it matters here
    assert np.array_equal(fused(CompensatorConfig()), fused(CompensatorConfig(fusion=FusionConfig())), equal_nan=True)
    part = log[log["t"] < 360.0]  # the streaming compensator, on the first 6 minutes
    comp = Compensator(stkf, provisional=False)
    rows = [r for t, g, T, h in part[["t", "gyro_z", "temp", "heading"]].itertuples(index=False)
            for r in comp.push(t, g, T, heading_deg=h)]
    want = compensate(part, stkf)["heading_fused"].to_numpy()
    assert np.array_equal(np.array([r.heading_fused for r in rows]), want, equal_nan=True)


def test_a_lasting_compass_offset_is_taken_back_after_consistent_s():
    """Without relock_s, a 20-deg step of the compass that then turns with the gyro is refused
    at first and taken again once its innovations have agreed for consistent_s; a compass that
    keeps wandering is never taken."""
    t = np.arange(0.0, 600.0, 0.1)
    has = np.arange(t.size) % 10 == 0
    cfg = FusionConfig(consistent_s=120.0)
    step = np.where(has, np.where(t < 100.0, 50.0, 70.0), np.nan)
    h, _, _ = fuse_rows(t, np.zeros(t.size), step, np.ones(t.size, bool), np.full(t.size, 0.001), cfg)
    assert abs(h[int(200 / 0.1)] - 50.0) < 1.0  # refused 100 s after the step
    assert abs(h[int(230 / 0.1)] - 70.0) < 1e-6  # taken again 120 s after the first refusal
    wander = np.where(has, np.where(t < 100.0, 50.0, 90.0 + 15.0 * np.sin(2 * np.pi * t / 40.0)), np.nan)
    h, _, _ = fuse_rows(t, np.zeros(t.size), wander, np.ones(t.size, bool), np.full(t.size, 0.001), cfg)
    assert np.abs(h[t > 100.0] - 50.0).max() < 3.0  # still following the gyro

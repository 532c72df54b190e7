"""Tests of gyrodrift.scale_factor: rotation measurements, the SF STKF and the Section 4.3 experiment."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import cumulative_trapezoid

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.conventions import wrap_180, wrap_360
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.evaluate.paper import scale_factor_experiment
from gyrodrift.scale_factor import (
    ScaleFactorConfig,
    estimate_scale_factor,
    fixed_scale_factor,
    sf_filter,
    turn_measurements,
)
from gyrodrift.simulate import CompassModel, DeviceModel, simulate

#: The full 3-h experiment at 10 Hz runs in about a second (50 Hz: about three).
FS_HZ = 10.0


def _smooth(x):
    x = np.clip(x, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * x)


def synthetic_out(
    *,
    turns=((100.0, 360.0),),
    sf=lambda temp: np.full_like(temp, 1.02),
    temp=lambda t: np.full_like(t, 30.0),
    duration_s=300.0,
    fs_hz=20.0,
    compass_hz=10.0,
    peak_dps=45.0,
    ramp_s=1.0,
):
    """A compensate()-like table with exact drift compensation and a perfect compass.

    ``turns``: (start s, angle deg) each, raised-cosine ramps, plateau ``peak_dps``;
    ``rate_z = sf(temp) * true_rate``.
    """
    t = np.arange(0.0, duration_s, 1.0 / fs_hz)
    rate = np.zeros(t.size)
    for t0, angle in turns:
        dur = abs(angle) / peak_dps + ramp_s
        rate += np.sign(angle) * peak_dps * (_smooth((t - t0) / ramp_s) - _smooth((t - (t0 + dur - ramp_s)) / ramp_s))
    temp_c = temp(t)
    heading = 40.0 + cumulative_trapezoid(rate, t, initial=0.0)
    compass = np.full(t.size, np.nan)
    step = int(round(fs_hz / compass_hz))
    compass[::step] = wrap_360(heading[::step])
    return pd.DataFrame(
        {
            "t": t,
            "rate_z": sf(temp_c) * rate,
            "gate_reason": "",
            "compass_heading": compass,
            "temp": temp_c,
            "ref_heading": wrap_360(heading),
        }
    )


@pytest.fixture(scope="module")
def noisy():
    """The default experiment (seed 0), at 10 Hz to keep the suite fast."""
    return scale_factor_experiment(seed=0, fs_hz=FS_HZ)


@pytest.fixture(scope="module")
def noiseless():
    return scale_factor_experiment(
        seed=0, fs_hz=FS_HZ, device=DeviceModel.noiseless(), compass=CompassModel.noiseless()
    )


# ------------------------------------------------------------------ settings


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"fading": 0.9}, "fading"),
        ({"x0": (1.0,)}, "x0"),
        ({"p0_sd": (0.05, 0.0)}, "p0_sd"),
        ({"q_sd": (-1e-4, 0.0)}, "q_sd"),
        ({"turn_rate_dps": 0.0}, "turn_rate_dps"),
        ({"min_turn_deg": float("nan")}, "min_turn_deg"),
        ({"residual_drift_dps": -0.1}, "residual_drift_dps"),
        ({"min_compass_samples": 0}, "min_compass_samples"),
        ({"fixed_turns": 2.5}, "fixed_turns"),
        ({"t_ref_c": True}, "t_ref_c"),
    ],
)
def test_invalid_settings_name_the_field(kwargs, field):
    with pytest.raises(ConfigError, match=field):
        ScaleFactorConfig(**kwargs)


def test_missing_columns():
    with pytest.raises(LogFormatError, match="compass_heading"):
        estimate_scale_factor(synthetic_out().drop(columns="compass_heading"))


# ------------------------------------------------------------------ one rotation


@pytest.mark.parametrize("angle", [360.0, -360.0, 180.0, -270.0, 720.0])
def test_measurement_of_one_rotation_is_exact(angle):
    out = synthetic_out(turns=((100.0, angle),))
    turns = turn_measurements(out)
    assert len(turns) == 1
    turn = turns.iloc[0]
    assert turn["accepted"] and turn["reason"] == ""
    # the compass change is unwrapped against the gyro: a full turn is 360, not 0
    assert turn["angle_compass_deg"] == pytest.approx(angle, abs=1e-9)
    assert turn["sf_meas"] == pytest.approx(1.02, abs=1e-9)
    assert turn["temp_c"] == pytest.approx(30.0)
    assert turn["t_update"] > turn["t_end"]


def test_small_turn_does_not_count():
    out = synthetic_out(turns=((100.0, 45.0),))
    sf = estimate_scale_factor(out)
    turns = sf.attrs["turns"]
    assert list(turns["reason"]) == ["small_turn"]
    assert sf["sf_update"].sum() == 0
    np.testing.assert_array_equal(sf["sf"], 1.0)  # the prior


def test_refused_rotations():
    # too close to the start for a still window before it
    assert turn_measurements(synthetic_out(turns=((3.0, 360.0),)))["reason"].tolist() == ["edge"]
    # compass missing for 3 s during the turn
    out = synthetic_out()
    out.loc[out["t"].between(103.0, 106.0), "compass_heading"] = np.nan
    assert turn_measurements(out)["reason"].tolist() == ["no_compass"]
    # the drift compensator saw magnetic interference in the span
    out = synthetic_out()
    out.loc[out["t"].between(95.0, 97.0), "gate_reason"] = "interference"
    assert turn_measurements(out)["reason"].tolist() == ["interference"]
    # two turns with no still window between them
    assert set(turn_measurements(synthetic_out(turns=((100.0, 360.0), (113.0, -360.0))))["reason"]) == {"not_still"}


# ------------------------------------------------------------------ the filter


def test_filter_recovers_a_linear_sf_model():
    true = (1.01, 8e-4)  # s0 at 25 degC, s1 per degC
    out = synthetic_out(
        turns=[(60.0 + 120.0 * k, 360.0 * (-1) ** k) for k in range(12)],
        sf=lambda temp: true[0] + true[1] * (temp - 25.0),
        temp=lambda t: 22.0 + 30.0 * t / 1500.0,
        duration_s=1500.0,
    )
    sf = estimate_scale_factor(out)
    assert sf["sf_update"].sum() == 12
    # exact measurements; what is left is the pull of the prior (s1 = 0)
    s0, s1 = sf.attrs["final_params"]
    assert s0 == pytest.approx(true[0], abs=3e-5)
    assert s1 == pytest.approx(true[1], abs=3e-6)
    last = sf.iloc[-1]
    assert last["sf"] == pytest.approx(true[0] + true[1] * (out["temp"].iloc[-1] - 25.0), abs=1e-5)
    # the one-off calibration is the first three turns, frozen
    first = sf.attrs["turns"]["sf_meas"].iloc[:3]
    assert first.min() <= sf.attrs["sf_fixed"] <= first.max()
    np.testing.assert_array_equal(sf["sf_fixed"], sf.attrs["sf_fixed"])


def test_no_update_while_still():
    # a static run has no rotation: nothing to measure, the SF stays at its prior
    out = compensate(simulate("static", seed=2, duration_s=1200.0, fs_hz=FS_HZ), CompensatorConfig().without_scale_factor())
    sf = estimate_scale_factor(out)
    assert len(sf.attrs["turns"]) == 0
    assert sf["sf_update"].sum() == 0
    np.testing.assert_array_equal(sf["sf"], 1.0)
    np.testing.assert_array_equal(sf["rate_sf"], out["rate_z"])
    # ... and the heading is the compensator's heading (the SF-uncompensated line)
    assert np.abs(wrap_180(sf["heading_sf"] - out["heading"])).max() < 1e-9


def test_parameters_change_only_after_rotations(noisy):
    sf, turns, out = noisy["sf"], noisy["turns"], noisy["out"]
    s = sf[["sf_s0", "sf_s1"]].to_numpy()
    changed = np.flatnonzero(np.any(s[1:] != s[:-1], axis=1)) + 1
    ups = np.flatnonzero(sf["sf_update"].to_numpy())
    np.testing.assert_array_equal(changed, ups[1:] + 1)  # the first update also covers the rows before it
    # every update closes a rotation, and the unit is still there
    np.testing.assert_array_equal(ups, turns.loc[turns["accepted"], "row_update"])
    assert np.abs(out["rate_z"].to_numpy()[ups]).max() < 2.0


def test_covariance_stays_bounded(noisy):
    cfg = ScaleFactorConfig()
    p0 = np.diag(np.square(cfg.p0_sd))
    inv_sqrt = np.diag(1.0 / np.array(cfg.p0_sd))
    # 500 rotations at one temperature: s1 is unobservable and fading alone would
    # grow its variance as 1.25**500; the cap keeps P <= P0 in every direction
    turns = pd.DataFrame(
        {"sf_meas": 1.02, "temp_dev_c": 5.0, "r": 1e-6, "accepted": np.ones(500, dtype=bool)}
    )
    x, P = sf_filter(turns, cfg)
    assert np.all(np.isfinite(P))
    for Pk in [*P, noisy["sf"].attrs["final_cov"]]:
        lam = np.linalg.eigvalsh(inv_sqrt @ Pk @ inv_sqrt)
        assert lam.min() > 0 and lam.max() <= 1.0 + 1e-9
    assert x[-1, 0] + x[-1, 1] * 5.0 == pytest.approx(1.02, abs=1e-6)
    assert np.linalg.eigvalsh(p0).min() > 0


def test_fixed_calibration_without_rotations_is_nominal():
    empty = pd.DataFrame({"sf_meas": [], "r": [], "accepted": np.array([], dtype=bool)})
    assert fixed_scale_factor(empty) == 1.0


# ------------------------------------------------------------------ the experiment


def test_experiment_tables(noisy):
    log, fig10, fig11 = noisy["log"], noisy["fig10"], noisy["fig11"]
    assert list(fig10.columns) == ["t", "temp", "sf_ideal", "sf_fixed", "sf_adaptive"]
    assert list(fig11.columns) == ["t", "err_none", "err_fixed", "err_adaptive", "err_ideal"]
    assert len(fig10) == len(fig11) == len(log)
    np.testing.assert_array_equal(fig10["sf_ideal"], log["true_sf"])
    assert noisy["summary"]["turns"] == 89  # one every 120 s over 3 h
    assert noisy["summary"]["sf_updates"] >= 85


def test_noiseless_run_converges_to_true_sf(noiseless):
    sf, truth = noiseless["fig10"]["sf_adaptive"].to_numpy(), noiseless["fig10"]["sf_ideal"].to_numpy()
    ups = np.flatnonzero(noiseless["sf"]["sf_update"].to_numpy())
    # Even a noiseless device leaves the drift compensator a start-up bias error while
    # it heats fast (its drift is not eq. 2): up to 0.05 deg/s over the ~17 s of a
    # measurement, 2e-3 of SF on the first turns. After five rotations:
    assert np.abs(sf[ups[5] + 1 :] - truth[ups[5] + 1 :]).max() < 1e-3
    assert abs(sf[-1] - truth[-1]) < 2e-4


def test_default_noise_tracking(noisy):
    # Per rotation the SF measurement has a standard deviation of about 8e-4:
    # compass 0.5 deg averaged over 50 samples per still window (0.1 deg), angle random
    # walk 0.04 deg/√s over ~17 s (0.17 deg) and the drift left by the drift
    # compensator (0.01-0.05 deg/s, 0.2-0.8 deg), over 360 deg. The STKF remembers
    # about five rotations and lags the SF, which rises up to 6e-4 per minute while
    # heating; 1e-3 RMS is 1/30 of the 3 % change (8 seeds gave 4e-4 to 6e-4), and the
    # fixed calibration is more than ten times worse.
    s = noisy["summary"]
    assert s["sf_rms"]["adaptive"] < 1e-3
    assert s["sf_max"]["adaptive"] < 5e-3
    assert s["sf_rms"]["fixed"] > 10 * s["sf_rms"]["adaptive"]
    assert s["sf_rms"]["none"] > s["sf_rms"]["fixed"]


def test_heading_error_ordering(noisy):
    s = noisy["summary"]
    # The part of the heading error due to the SF (heading minus the heading
    # compensated with the true SF): adaptive < fixed < none on every seed tried.
    part = s["sf_heading_rms_deg"]
    assert part["adaptive"] < 0.5 * part["fixed"] and part["fixed"] < part["none"]
    # Whole-run heading error against the reference (Fig. 11) for this seed. It also
    # holds the open-loop drift residual common to all lines (``ideal``, 4-8 deg RMS
    # over 3 h), which adds to or cancels the SF errors by chance: the same ordering
    # held for 5 of 8 seeds tried, so this check is tied to seed 0.
    rms = s["heading_rms_deg"]
    assert rms["adaptive"] < rms["fixed"] < rms["none"]

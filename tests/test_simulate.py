"""Tests of gyrodrift.simulate: determinism, contract columns, truth consistency, error model."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import cumulative_trapezoid

from gyrodrift.compass import field_norm_dip, tilt_compensated_heading
from gyrodrift.conventions import ACC_COLS, MAG_COLS, wrap_180
from gyrodrift.errors import ConfigError
from gyrodrift.simulate import (
    DEFAULT_DURATION_S,
    SCENARIO_SCALE_FACTOR_PPM,
    SCENARIOS,
    CompassModel,
    DeviceModel,
    interference_windows_static,
    simulate,
    static_temperature,
)

BASE_COLS = ["t", "gyro_z", "temp", "heading", "ref_heading", "true_bias_z"]
EXACT_DEVICE = DeviceModel.noiseless(temp_quant_c=0.0)
TRUE_COMPASS = CompassModel.noiseless(deviation_deg=0.0, deviation2_deg=0.0, kinematic_tilt=False)


def _angle_err(a, b):
    return np.abs(wrap_180(np.asarray(a, dtype=float) - np.asarray(b, dtype=float)))


def _true_rate(df):
    """True heading rate of a level run from a noiseless device: gyro minus true drift."""
    return (df["gyro_z"] - df["true_bias_z"]).to_numpy()


# ------------------------------------------------------------------ determinism


@pytest.mark.parametrize("scenario", list(SCENARIOS))
def test_same_seed_gives_identical_frame(scenario):
    a = simulate(scenario, seed=7, duration_s=300.0, raw_mag=True)
    b = simulate(scenario, seed=7, duration_s=300.0, raw_mag=True)
    pd.testing.assert_frame_equal(a, b)
    assert a.attrs == b.attrs


def test_different_seeds_give_different_noise():
    a = simulate("static", seed=1, duration_s=300.0)
    b = simulate("static", seed=2, duration_s=300.0)
    assert not np.allclose(a["gyro_z"], b["gyro_z"])
    assert not np.allclose(a["heading"].dropna(), b["heading"].dropna())
    # the truth that does not depend on noise is shared
    np.testing.assert_array_equal(a["ref_heading"], b["ref_heading"])


def test_attrs_are_plain_json():
    df = simulate("static-outages", seed=3, duration_s=600.0)
    assert df.attrs["scenario"] == "static-outages"
    assert df.attrs["seed"] == 3
    assert df.attrs["device"]["noise_density_dps_rthz"] == 0.04
    # the scenario's interference windows are recorded in the effective compass model
    assert len(df.attrs["compass"]["interference"]) == 3
    json.dumps(df.attrs)


# ------------------------------------------------------------------ columns, units, ranges


def test_columns_units_and_compass_rate():
    df = simulate("static", seed=0, duration_s=600.0)
    assert list(df.columns) == BASE_COLS
    assert len(df) == 600 * 50 + 1
    np.testing.assert_allclose(np.diff(df["t"]), 0.02, rtol=0, atol=1e-12)
    assert 22.5 < df["temp"].min() and df["temp"].max() < 58.5
    assert df["temp"].max() > 57.5  # the scaled profile still reaches the top
    np.testing.assert_allclose(df["temp"] / 0.0625, np.round(df["temp"] / 0.0625), atol=1e-9)
    for col in ("heading", "ref_heading"):
        h = df[col].dropna()
        assert ((h >= 0) & (h < 360)).all()
    # 10 Hz compass on a 50 Hz gyro: every 5th row, NaN elsewhere
    has = df["heading"].notna().to_numpy()
    np.testing.assert_array_equal(np.flatnonzero(has), np.arange(0, len(df), 5))
    assert df["ref_heading"].notna().all() and df["true_bias_z"].notna().all()


def test_first_minute_is_flat_and_still():
    df = simulate("vehicle", seed=0, duration_s=900.0, device=EXACT_DEVICE)
    first = df[df["t"] < 60.0]
    assert first["temp"].nunique() == 1
    np.testing.assert_allclose(_true_rate(first), 0.0, atol=1e-12)


def test_non_integer_compass_ratio():
    df = simulate("static", duration_s=60.0, fs_hz=50.0, compass=CompassModel(rate_hz=15.0))
    n = int(df["heading"].notna().sum())
    assert n == 15 * 60 + 1
    gaps = np.diff(df.loc[df["heading"].notna(), "t"])
    assert gaps.max() <= 0.08 + 1e-9


def test_profiles_scale_with_duration():
    t = np.array([0.25, 0.5, 0.75])
    short, _ = static_temperature(60.0 + t * 1140.0, 1200.0)
    long_, _ = static_temperature(60.0 + t * (DEFAULT_DURATION_S["static"] - 60.0), DEFAULT_DURATION_S["static"])
    np.testing.assert_allclose(short, long_, atol=1e-9)


# ------------------------------------------------------------------ truth consistency


def test_vehicle_ref_heading_is_integral_of_true_rate():
    df = simulate("vehicle", seed=4, duration_s=900.0, device=DeviceModel.noiseless())
    rate = _true_rate(df)
    ref = np.unwrap(np.radians(df["ref_heading"].to_numpy()))
    ref = np.degrees(ref)
    integ = ref[0] + cumulative_trapezoid(rate, df["t"].to_numpy(), initial=0.0)
    np.testing.assert_allclose(integ, ref, rtol=0, atol=1e-6)
    assert np.ptp(integ) > 180.0  # it really turned


def test_vehicle_has_90_degree_turns_and_straight_legs():
    df = simulate("vehicle", seed=5, duration_s=1500.0, device=DeviceModel.noiseless())
    t = df["t"].to_numpy()
    rate = _true_rate(df)
    heading = df["ref_heading"].to_numpy()
    turning = np.abs(rate) > 1.0
    edges = np.flatnonzero(np.diff(turning.astype(np.int8))) + 1
    segments = np.split(np.arange(t.size), edges)
    turns = [s for s in segments if turning[s[0]]]
    legs = [s for s in segments if not turning[s[0]] and s[0] > 0 and s[-1] < t.size - 1]
    assert len(turns) >= 8
    for s in turns:
        dur = t[s[-1]] - t[s[0]]
        assert 4.0 < dur < 8.0
        assert 15.0 < np.abs(rate[s]).max() < 26.0
    for before, after in zip(legs[:-1], legs[1:]):
        change = wrap_180(heading[after[len(after) // 2]] - heading[before[len(before) // 2]])
        assert abs(abs(change) - 90.0) < 4.0
    for s in legs:
        assert t[s[-1]] - t[s[0]] > 25.0
        core = s[150:-150]  # away from the tails of the turns (3 s at 50 Hz)
        assert np.abs(rate[core]).max() <= 0.3 + 1e-9  # yaw wander only
    # a loop of four turns in one direction closes the rectangle
    signs = [np.sign(rate[s].sum()) for s in turns]
    i = next(k for k in range(len(signs) - 3) if len(set(signs[k : k + 4])) == 1)
    loop = rate[turns[i][0] : turns[i + 3][-1] + 1]
    assert abs(abs(np.trapezoid(loop, dx=1.0 / 50)) - 360.0) < 6.0


def test_static_is_motionless_and_drift_changes_with_temperature():
    df = simulate("static", seed=0, duration_s=1800.0, device=DeviceModel.noiseless())
    np.testing.assert_allclose(_true_rate(df), 0.0, atol=1e-12)
    np.testing.assert_allclose(df["ref_heading"], 40.0, atol=1e-12)
    change = df["true_bias_z"].max() - df["true_bias_z"].min()
    assert 0.5 < change < 1.5


def test_drift_is_not_linear_in_temperature_and_rate():
    dev = EXACT_DEVICE
    df = simulate("static", seed=0, duration_s=3600.0, fs_hz=10.0, device=dev)
    t, bias = df["t"].to_numpy(), df["true_bias_z"].to_numpy()
    temp, rate = static_temperature(t, 3600.0)  # true T and exact T'
    np.testing.assert_allclose(df["temp"], temp, atol=1e-12)
    design = np.column_stack([temp, rate, np.ones_like(temp)])
    coef, *_ = np.linalg.lstsq(design, bias, rcond=None)
    resid = bias - design @ coef
    assert np.sqrt(np.mean(resid**2)) > 0.01  # deg/s, far above rounding
    # ... while the documented formula reproduces it exactly
    np.testing.assert_allclose(dev.drift(temp, rate), bias, rtol=0, atol=1e-12)


def test_drift_formula():
    dev = DeviceModel(c0_dps=0.1, c1_dps_per_c=0.02, c2_dps_per_c2=1e-3, c3_dps_per_c3=-1e-5, t_ref_c=20.0,
                      k_rate_dps_per_cps=4.0, hyst_dps=0.05, hyst_rate_cps=0.01)
    x = 10.0
    want = 0.1 + 0.02 * x + 1e-3 * x**2 - 1e-5 * x**3 + 4.0 * 0.01 + 0.05 * math.tanh(1.0)
    assert float(dev.drift(30.0, 0.01)) == pytest.approx(want, rel=1e-12)


# ------------------------------------------------------------------ compass


def test_static_noiseless_compass_reads_true_heading():
    df = simulate("static", seed=0, duration_s=300.0, compass=TRUE_COMPASS)
    rows = df["heading"].notna()
    assert _angle_err(df.loc[rows, "heading"], df.loc[rows, "ref_heading"]).max() < 1e-9
    assert _angle_err(df.loc[rows, "heading"], 40.0).max() < 1e-9


def test_compass_deviation_is_a_function_of_heading():
    comp = CompassModel.noiseless(kinematic_tilt=False)
    df = simulate("vehicle", seed=2, duration_s=600.0, compass=comp)
    rows = df["heading"].notna()
    ref = df.loc[rows, "ref_heading"].to_numpy()
    want = ref + comp.deviation(ref)
    assert _angle_err(df.loc[rows, "heading"], want).max() < 1e-9
    assert np.ptp(comp.deviation(ref)) > 2.0  # matters once the vehicle turns


def test_compass_noise_level():
    comp = CompassModel(deviation_deg=0.0, deviation2_deg=0.0)
    df = simulate("static", seed=9, duration_s=600.0, compass=comp)
    err = wrap_180(df["heading"].dropna() - 40.0)
    assert np.std(err) == pytest.approx(0.5, rel=0.08)


def test_interference_windows_offset_the_compass_only_inside():
    duration = 1800.0
    df = simulate("static-outages", seed=0, duration_s=duration, compass=TRUE_COMPASS, raw_mag=True)
    rows = df["heading"].notna().to_numpy()
    t = df["t"].to_numpy()[rows]
    diff = wrap_180(df["heading"].to_numpy()[rows] - df["ref_heading"].to_numpy()[rows])
    norm, _ = field_norm_dip(*(df[c].to_numpy()[rows] for c in (*MAG_COLS, *ACC_COLS)))
    windows = interference_windows_static(duration)
    inside_any = np.zeros(t.size, dtype=bool)
    for start, dur, off in windows:
        inside_any |= (t >= start) & (t <= start + dur)
        core = (t > start + dur / 4) & (t < start + dur * 3 / 4)
        assert core.any()
        np.testing.assert_allclose(diff[core], off, atol=1e-9)
        assert np.all(np.abs(norm[core] / 50.0 - 1.0) > 0.02)  # field strength changes too
    np.testing.assert_allclose(diff[~inside_any], 0.0, atol=1e-9)
    np.testing.assert_allclose(norm[~inside_any], 50.0, rtol=1e-12)


def test_user_interference_window():
    comp = CompassModel.noiseless(deviation_deg=0.0, deviation2_deg=0.0, interference=[(100.0, 80.0, -25.0)])
    df = simulate("static", duration_s=300.0, compass=comp)
    mid = df["t"].between(130.0, 150.0) & df["heading"].notna()
    np.testing.assert_allclose(wrap_180(df.loc[mid, "heading"] - 40.0), -25.0, atol=1e-9)
    assert df.attrs["compass"]["interference"] == [[100.0, 80.0, -25.0]]


@pytest.mark.parametrize("scenario", ["static", "vehicle"])
def test_raw_mag_reproduces_heading(scenario):
    df = simulate(scenario, seed=1, duration_s=600.0, compass=CompassModel.noiseless(), raw_mag=True)
    assert list(df.columns) == BASE_COLS + list(MAG_COLS) + list(ACC_COLS)
    rows = df["heading"].notna()
    np.testing.assert_array_equal(df[list(MAG_COLS)].notna().all(axis=1), rows)
    assert df[list(ACC_COLS)].notna().all().all()
    got = tilt_compensated_heading(*(df.loc[rows, c] for c in (*MAG_COLS, *ACC_COLS)))
    assert _angle_err(got, df.loc[rows, "heading"]).max() < 1e-9
    norm, dip = field_norm_dip(*(df.loc[rows, c] for c in (*MAG_COLS, *ACC_COLS)))
    if scenario == "static":  # still: gravity only, Earth field of 50 µT dipping 60°
        np.testing.assert_allclose(np.hypot(np.hypot(df["acc_x"], df["acc_y"]), df["acc_z"]), 1.0, atol=1e-12)
        assert (df["acc_z"] < -0.99).all()
        np.testing.assert_allclose(norm, 50.0, rtol=1e-12)
        np.testing.assert_allclose(dip, 60.0, atol=1e-9)


def test_vehicle_kinematic_tilt_disturbs_compass_when_braking_or_turning():
    real_compass = CompassModel.noiseless(deviation_deg=0.0, deviation2_deg=0.0)  # kinematic_tilt=True
    real = simulate("vehicle", seed=1, duration_s=600.0, compass=real_compass, raw_mag=True)
    assert np.abs(real["acc_y"]).max() > 0.1  # cornering, g
    assert np.abs(real["acc_x"]).max() > 0.05  # braking / pulling away, g
    rows = real["heading"].notna()
    assert _angle_err(real.loc[rows, "heading"], real.loc[rows, "ref_heading"]).max() > 5.0
    ideal = simulate("vehicle", seed=1, duration_s=600.0, compass=TRUE_COMPASS, raw_mag=True)
    assert _angle_err(ideal.loc[rows, "heading"], ideal.loc[rows, "ref_heading"]).max() < 1e-9
    np.testing.assert_array_equal(ideal[["acc_x", "acc_y"]], 0.0)


# ------------------------------------------------------------------ device noise


@pytest.mark.parametrize("fs_hz", [50.0, 100.0])
def test_white_noise_level(fs_hz):
    df = simulate("static", seed=11, duration_s=600.0, fs_hz=fs_hz)
    white = df["gyro_z"] - df["true_bias_z"]  # true rate is 0
    assert np.std(white) == pytest.approx(0.04 * math.sqrt(fs_hz), rel=0.05)


def test_stochastic_bias_terms_are_small_and_switchable():
    noisy = simulate("static", seed=3, duration_s=1200.0, device=DeviceModel(temp_quant_c=0.0))
    clean = simulate("static", seed=3, duration_s=1200.0, device=EXACT_DEVICE)
    extra = noisy["true_bias_z"] - clean["true_bias_z"]
    assert 1e-4 < np.std(extra) < 0.01  # bias instability 0.002 deg/s + small RRW
    temp_err = noisy["temp"] - clean["temp"]
    assert np.std(temp_err) == pytest.approx(0.02, rel=0.1)


def test_noiseless_and_scale_noise():
    d = DeviceModel()
    z = DeviceModel.noiseless()
    assert z.noise_density_dps_rthz == z.bias_instability_dps == z.rate_random_walk_dps_rts == z.temp_noise_c == 0
    assert z.temp_quant_c == d.temp_quant_c and z.c1_dps_per_c == d.c1_dps_per_c
    assert d.scale_noise(2.0).noise_density_dps_rthz == pytest.approx(0.08)
    assert d.scale_noise(0.0) == z
    assert CompassModel().scale_noise(0.0) == CompassModel.noiseless()
    df = simulate("static", duration_s=60.0, device=z, compass=CompassModel.noiseless())
    np.testing.assert_allclose(df["gyro_z"], df["true_bias_z"], atol=1e-15)


# ------------------------------------------------------------------ configuration errors


def test_unknown_scenario_lists_valid_names():
    with pytest.raises(ConfigError, match="static-outages") as exc:
        simulate("bogus")
    for name in SCENARIOS:
        assert name in str(exc.value)


@pytest.mark.parametrize(
    ("cls", "kwargs", "field"),
    [
        (DeviceModel, {"noise_density_dps_rthz": -1.0}, "noise_density_dps_rthz"),
        (DeviceModel, {"bias_tau_s": 0.0}, "bias_tau_s"),
        (DeviceModel, {"c1_dps_per_c": float("nan")}, "c1_dps_per_c"),
        (DeviceModel, {"sf_ppm_per_c": float("inf")}, "sf_ppm_per_c"),
        (CompassModel, {"rate_hz": 0.0}, "rate_hz"),
        (CompassModel, {"noise_deg": -0.1}, "noise_deg"),
        (CompassModel, {"interference": [(10.0, 5.0)]}, "interference"),
        (CompassModel, {"interference": [(10.0, 5.0, 90.0)]}, "interference"),
        (CompassModel, {"dip_deg": 95.0}, "dip_deg"),
        (CompassModel, {"hard_iron_ut": (1.0, 2.0)}, "hard_iron_ut"),
        (CompassModel, {"hard_iron_ut": (1.0, float("nan"), 0.0)}, "hard_iron_ut\\[1\\]"),
        (CompassModel, {"soft_iron_gain": (1.0, 0.0, 1.0)}, "soft_iron_gain\\[1\\]"),
    ],
)
def test_invalid_models_name_the_field(cls, kwargs, field):
    with pytest.raises(ConfigError, match=field):
        cls(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"duration_s": -5.0}, "duration_s"),
        ({"fs_hz": 0.0}, "fs_hz"),
        ({"seed": -1}, "seed"),
        ({"fs_hz": 5.0}, "rate_hz"),
        ({"device": "adxrs623"}, "device"),
    ],
)
def test_invalid_arguments(kwargs, field):
    with pytest.raises(ConfigError, match=field):
        simulate("static", **kwargs)


# ------------------------------------------------------------------ defaults unchanged by the scale factor

# Checksums of simulate(scenario, seed=1, duration_s=600) computed with the code
# *before* the scale-factor model was added (math.fsum of the finite values and of
# their squares, per column): a default device must give the same log. (A relative
# 1e-13 rather than exact equality only allows for another platform's libm.)
_BEFORE_SF = {
    "static": {
        "gyro_z": (16915.55539309187, 36738.30850323346),
        "temp": (1187755.5625, 52069508.04296875),
        "heading": (252317.2589386977, 10610436.511039339),
        "ref_heading": (1200040.0, 48001600.0),
        "true_bias_z": (16953.498364364536, 34365.836806717314),
    },
    "vehicle": {
        "gyro_z": (36152.479453350476, 456387.9680353812),
        "temp": (974127.0, 32036017.46875),
        "heading": (706533.6921845063, 145461037.89431223),
        "ref_heading": (3492290.094051018, 722386454.4042417),
        "true_bias_z": (13626.528593895177, 6493.931481796338),
    },
}


@pytest.mark.parametrize("scenario", list(_BEFORE_SF))
def test_default_device_output_unchanged(scenario):
    df = simulate(scenario, seed=1, duration_s=600)
    assert list(df.columns) == BASE_COLS  # no true_sf column
    for col, (total, total_sq) in _BEFORE_SF[scenario].items():
        v = df[col].to_numpy()
        v = v[np.isfinite(v)]
        assert math.fsum(v) == pytest.approx(total, rel=1e-13, abs=1e-9), col
        assert math.fsum(v * v) == pytest.approx(total_sq, rel=1e-13), col


def test_default_scale_factor_is_exactly_one():
    dev = DeviceModel()
    assert dev.sf_ppm is dev.sf_ppm_per_c is dev.sf_ppm_per_c2 is None
    np.testing.assert_array_equal(dev.scale_factor(np.linspace(-40, 120, 50)), 1.0)
    assert not dev.has_scale_factor_error()
    for name in SCENARIOS:
        if name != "scale-factor":
            assert not dev.with_scenario_scale_factor(name).has_scale_factor_error()


# ------------------------------------------------------------------ scale-factor scenario


def test_scale_factor_scenario_columns_and_sf_span():
    df = simulate("scale-factor", seed=0, duration_s=3600.0, fs_hz=10.0)
    assert list(df.columns) == BASE_COLS + ["true_sf"]
    dev = df.attrs["device"]
    want = SCENARIO_SCALE_FACTOR_PPM["scale-factor"]
    assert {k: dev[k] for k in want} == want
    # ADXRS623: about ±3 % sensitivity change over temperature, here over 23-58 degC
    assert 0.028 < df["true_sf"].max() - df["true_sf"].min() < 0.034
    assert np.corrcoef(df["temp"], df["true_sf"])[0, 1] > 0.99  # rises with temperature
    json.dumps(df.attrs)


def test_scale_factor_gyro_is_sf_times_true_rate():
    dev = DeviceModel.noiseless(temp_quant_c=0.0)
    df = simulate("scale-factor", seed=3, duration_s=1800.0, fs_hz=20.0, device=dev, compass=TRUE_COMPASS)
    t = df["t"].to_numpy()
    temp, _ = static_temperature(t, 1800.0)
    want_sf = dev.with_scenario_scale_factor("scale-factor").scale_factor(temp)
    np.testing.assert_allclose(df["true_sf"], want_sf, rtol=0, atol=1e-15)
    measured = (df["gyro_z"] - df["true_bias_z"]).to_numpy()
    true_rate = measured / df["true_sf"].to_numpy()
    ref = np.degrees(np.unwrap(np.radians(df["ref_heading"].to_numpy())))
    # gyro_z - true_bias_z = true_sf * true rate: dividing out SF gives the reference heading ...
    np.testing.assert_allclose(ref[0] + cumulative_trapezoid(true_rate, t, initial=0.0), ref, rtol=0, atol=1e-6)
    # ... while the raw gyro over-reads every turn by SF - 1 (about 1-4 %)
    gyro_heading = ref[0] + cumulative_trapezoid(measured, t, initial=0.0)
    assert np.abs(gyro_heading - ref).max() > 3.0
    # the compass is clean: no interference, reads the true heading
    rows = df["heading"].notna()
    assert _angle_err(df.loc[rows, "heading"], df.loc[rows, "ref_heading"]).max() < 1e-9


def test_scale_factor_rotations():
    df = simulate("scale-factor", seed=5, duration_s=1500.0, device=DeviceModel.noiseless())
    t = df["t"].to_numpy()
    rate = ((df["gyro_z"] - df["true_bias_z"]) / df["true_sf"]).to_numpy()
    turning = np.abs(rate) > 1e-6
    edges = np.flatnonzero(np.diff(turning.astype(np.int8))) + 1
    turns = [s for s in np.split(np.arange(t.size), edges) if turning[s[0]]]
    assert len(turns) == 12  # every 120 s from 120 s
    starts = np.array([t[s[0]] for s in turns])
    np.testing.assert_allclose(np.diff(starts), 120.0, atol=0.05)
    angles = [np.trapezoid(rate[s[0] - 1 : s[-1] + 2], t[s[0] - 1 : s[-1] + 2]) for s in turns]
    np.testing.assert_allclose(angles, [360.0 * (-1) ** k for k in range(12)], atol=1e-6)  # full turns, alternating
    for s in turns:
        assert 30.0 - 1e-9 <= np.abs(rate[s]).max() <= 90.0 + 1e-9
    assert not turning[t < 120.0].any()  # still start: initialisation and first drift updates
    np.testing.assert_allclose(df["ref_heading"].to_numpy()[[0, -1]], 40.0, atol=1e-6)


def test_explicit_scale_factor_overrides_the_scenario():
    no_sf = DeviceModel(sf_ppm=0.0, sf_ppm_per_c=0.0, sf_ppm_per_c2=0.0)
    unit = simulate("scale-factor", seed=0, duration_s=600.0, device=no_sf)
    np.testing.assert_array_equal(unit["true_sf"], 1.0)
    # a scale factor on a static run: the column appears, the still gyro is unchanged
    plain = simulate("static", seed=0, duration_s=300.0)
    scaled = simulate("static", seed=0, duration_s=300.0, device=DeviceModel(sf_ppm=2000.0))
    np.testing.assert_allclose(scaled["true_sf"], 1.002, rtol=0, atol=1e-15)
    pd.testing.assert_frame_equal(scaled[BASE_COLS], plain)
    assert scaled.attrs["device"]["sf_ppm"] == 2000.0 and plain.attrs["device"]["sf_ppm"] == 0.0


# ------------------------------------------------------------------ scenarios beyond the paper (issue 6)

from dataclasses import replace  # noqa: E402

from gyrodrift.simulate import (  # noqa: E402
    SCENARIO_MEMORY,
    cold_start_temperature,
    hysteresis_temperature,
    interference_windows_wander,
    random_compass,
    random_device,
    soak_outages,
    soak_ramps,
    soak_temperature,
)

NEW_SCENARIOS = ("interference-wander", "hysteresis", "cold-start", "soak")


def test_new_scenarios_registered_with_default_durations():
    for name in ("static", "static-outages", "vehicle", "calibration", "scale-factor", *NEW_SCENARIOS):
        assert name in SCENARIOS
    assert DEFAULT_DURATION_S["soak"] == 12 * 3600.0
    assert DEFAULT_DURATION_S["cold-start"] >= 3600.0
    for name in NEW_SCENARIOS:
        df = simulate(name, seed=0, duration_s=120.0, fs_hz=10.0)
        assert list(df.columns) == BASE_COLS
        assert df.attrs["duration_s"] == 120.0 and len(df) == 1201


@pytest.mark.parametrize("scenario", ["interference-wander", "soak"])
def test_new_scenarios_random_parts_follow_the_seed(scenario):
    a = simulate(scenario, seed=1, duration_s=1800.0, fs_hz=10.0, device=EXACT_DEVICE, compass=TRUE_COMPASS)
    b = simulate(scenario, seed=2, duration_s=1800.0, fs_hz=10.0, device=EXACT_DEVICE, compass=TRUE_COMPASS)
    assert not np.allclose(a["heading"].fillna(0.0), b["heading"].fillna(0.0))


def test_cold_start_spans_minus_20_to_plus_60():
    df = simulate("cold-start", seed=0, duration_s=1800.0, fs_hz=10.0)
    assert df["temp"].min() <= -19.9 and df["temp"].max() >= 59.9
    assert (df.loc[df["t"] < 60.0, "temp"] < -19.8).all()  # the cold soak: held at -20 first
    temp, rate = cold_start_temperature(df["t"].to_numpy(), 1800.0)
    assert temp[0] == pytest.approx(-20.0) and temp[-1] == pytest.approx(60.0)
    assert (rate >= -1e-12).all()  # a warm-up: never cools
    assert rate.max() > 3 * rate[df["t"].to_numpy() > 1200.0].max()  # fast at first, levelling off
    np.testing.assert_array_equal(df["ref_heading"], 300.0)  # motionless


def _heating_vs_cooling(df, duration_s, temp_c):
    """Mean true drift within 0.5 degC of ``temp_c`` on the major loop: heating, cooling."""
    t = df["t"].to_numpy()
    temp, rate = hysteresis_temperature(t, duration_s)
    band = (np.abs(temp - temp_c) < 0.5) & (t < 60.0 + 0.60 * (duration_s - 60.0))  # up to 70 and back to 10
    bias = df["true_bias_z"].to_numpy()
    return bias[band & (rate > 0)].mean(), bias[band & (rate < 0)].mean()


def test_hysteresis_drift_differs_between_heating_and_cooling():
    # no T' terms: any heating/cooling difference comes from the temperature history
    dev = DeviceModel.noiseless(temp_quant_c=0.0, k_rate_dps_per_cps=0.0, hyst_dps=0.0)
    dur = DEFAULT_DURATION_S["hysteresis"]
    hyst = simulate("hysteresis", duration_s=dur, fs_hz=10.0, device=dev)
    assert hyst.attrs["device"]["play_dps"] == SCENARIO_MEMORY["hysteresis"]["play_dps"]
    assert hyst["temp"].min() <= 10.0 and hyst["temp"].max() >= 70.0
    heat, cool = _heating_vs_cooling(hyst, dur, 30.0)
    assert heat - cool > 0.1  # deg/s at the same temperature, same |T'|
    plain = simulate("hysteresis", duration_s=dur, fs_hz=10.0, device=replace(dev, lag_tau_s=0.0, play_dps=0.0))
    heat0, cool0 = _heating_vs_cooling(plain, dur, 30.0)
    assert abs(heat0 - cool0) < 0.01  # memory off: the drift is a function of T alone
    # remanence: after the temperature has stopped changing the backlash term stays
    t = hyst["t"].to_numpy()
    temp, rate = hysteresis_temperature(t, dur)
    excess = hyst["true_bias_z"].to_numpy() - dev.drift(temp, rate)
    play = SCENARIO_MEMORY["hysteresis"]["play_dps"]
    top = np.flatnonzero(temp >= 70.0 - 1e-9)[-1]  # end of the 70 degC plateau (after heating)
    bottom = np.flatnonzero((temp <= 10.0 + 1e-9) & (t > 600.0))[-1]  # end of the 10 degC plateau (after cooling)
    assert excess[top] == pytest.approx(play, abs=0.02)
    assert excess[bottom] == pytest.approx(-play, abs=0.02)


def test_memory_defaults_leave_other_scenarios_unchanged():
    dev = DeviceModel()
    assert dev.lag_tau_s is dev.play_dps is dev.play_width_c is None
    for name in SCENARIOS:
        assert dev.with_scenario_memory(name).has_memory() == (name == "hysteresis")
    t = np.arange(100.0)
    temp = 25.0 + 0.1 * t
    np.testing.assert_array_equal(dev.drift_series(t, temp, np.full(100, 0.1)), dev.drift(temp, 0.1))
    # an explicit memory on a paper scenario is honoured
    df = simulate("static", duration_s=600.0, fs_hz=10.0, device=DeviceModel(play_dps=0.1, play_width_c=2.0))
    assert df.attrs["device"]["play_dps"] == 0.1


def test_play_operator_is_rate_independent():
    dev = DeviceModel.noiseless(temp_quant_c=0.0, play_dps=0.2, play_width_c=4.0, k_rate_dps_per_cps=0.0, hyst_dps=0.0)
    up_down = np.r_[np.linspace(20.0, 40.0, 201), np.linspace(40.0, 20.0, 201)]
    for step_s in (0.1, 10.0):  # 100x slower: the same loop
        t = step_s * np.arange(up_down.size)
        excess = dev.drift_series(t, up_down, np.zeros(t.size)) - dev.drift(up_down, 0.0)
        assert excess[200] == pytest.approx(0.2) and excess[-1] == pytest.approx(-0.2)
        assert np.all(np.abs(excess) <= 0.2 + 1e-12)


@pytest.mark.parametrize(("kwargs", "name"), [({"play_width_c": 0.0}, "play_width_c"), ({"lag_tau_s": -1.0}, "lag_tau_s")])
def test_invalid_memory_fields(kwargs, name):
    with pytest.raises(ConfigError, match=name):
        DeviceModel(**kwargs)


def test_soak_outages_lie_in_temperature_ramps():
    dur = 7200.0
    ramps = soak_ramps(dur)
    assert len(ramps) == 4
    dropouts, interference = soak_outages(dur)
    windows = [(s, d) for s, d in dropouts] + [(s, d) for s, d, _ in interference]
    assert len(dropouts) == 2 and len(interference) == 2
    t = np.linspace(0.0, dur, 20001)
    _, rate = soak_temperature(t, dur)
    for start, length in windows:
        assert any(r0 <= start and start + length <= r1 for r0, r1 in ramps)
        inside = (t >= start) & (t < start + length)
        assert np.abs(rate[inside]).min() > 0.3 * np.abs(rate).max()  # the steep middle of a ramp
    df = simulate("soak", seed=4, duration_s=dur, fs_hz=10.0)
    assert df.attrs["compass_dropouts"] == [list(w) for w in dropouts]
    for start, length in dropouts:
        rows = df["t"].between(start, start + length, inclusive="left")
        assert df.loc[rows, "heading"].isna().all()
    assert df["heading"].notna().mean() > 0.9
    assert len(df.attrs["compass"]["interference"]) == 2


def test_soak_default_outages_are_minutes_long_and_sway_is_slow():
    dropouts, interference = soak_outages(DEFAULT_DURATION_S["soak"])
    assert all(300.0 <= d <= 1800.0 for _, d in dropouts) and all(300.0 <= d <= 1800.0 for _, d, _ in interference)
    df = simulate("soak", seed=3, duration_s=7200.0, fs_hz=10.0, device=EXACT_DEVICE, compass=TRUE_COMPASS)
    rate = _true_rate(df)
    assert 0.1 < np.abs(rate).max() < 2.0  # below the 2 deg/s turning gate
    swing = wrap_180(df["ref_heading"] - 70.0)
    assert 10.0 <= np.abs(swing).max() <= 30.0


def test_interference_wander_offset_is_slow_and_in_windows():
    dur = DEFAULT_DURATION_S["interference-wander"]
    df = simulate("interference-wander", seed=5, duration_s=dur, fs_hz=10.0, device=EXACT_DEVICE, compass=TRUE_COMPASS)
    offset = np.asarray(wrap_180(df["heading"] - df["ref_heading"]))
    t = df["t"].to_numpy()
    windows = interference_windows_wander(dur)
    assert len(windows) == 4
    in_any = np.zeros(t.size, dtype=bool)
    for start, length in windows:
        inside = (t >= start) & (t <= start + length)
        in_any |= inside
        core = (t >= start + 120.0) & (t <= start + length - 120.0)
        assert np.abs(offset[core]).max() > 1.0  # degrees, not a rounding error
        assert np.ptp(offset[core]) > 0.5  # it wanders, it is not a constant window
    assert np.abs(offset[~in_any]).max() < 1e-9
    assert np.abs(np.diff(offset) / np.diff(t)).max() < 0.5  # deg/s: slow
    assert np.abs(offset).max() < 20.0


def test_random_device_and_compass():
    devs = [random_device(np.random.default_rng(s)) for s in range(30)]
    assert devs[0] == random_device(np.random.default_rng(0))
    assert len({d.c1_dps_per_c for d in devs}) == 30
    for d in devs:
        assert 0.015 <= d.noise_density_dps_rthz <= 0.08
        assert 0.005 <= abs(d.c1_dps_per_c) <= 0.04
        assert not d.has_memory() and not d.has_scale_factor_error()
    assert {np.sign(d.c1_dps_per_c) for d in devs} == {-1.0, 1.0}
    hyst = random_device(np.random.default_rng(0), scenario="hysteresis")
    assert hyst.has_memory() and 60.0 <= hyst.lag_tau_s <= 300.0 and 3e-4 <= abs(hyst.c2_dps_per_c2) <= 8e-4
    comp = random_compass(np.random.default_rng(1))
    assert comp == random_compass(np.random.default_rng(1))
    assert 0.3 <= comp.noise_deg <= 0.6 and 0.0 <= comp.deviation_deg <= 3.0
    df = simulate("hysteresis", seed=1, duration_s=600.0, fs_hz=10.0, device=hyst, compass=comp)
    assert df.attrs["device"]["lag_tau_s"] == hyst.lag_tau_s  # the drawn memory, not the scenario's


# ------------------------------------------------------------------ cost linear in the run length


@pytest.mark.parametrize("scenario", list(SCENARIOS))
def test_ramps_are_evaluated_near_their_own_time_only(scenario, monkeypatch):
    """The raised-cosine ramps (turns, rotations, speed changes, interference) cost O(n) in total.

    Every sample handed to ``smooth_step``/``smooth_step_slope`` is counted. A scenario
    that evaluated each of its events over the whole run (as many events as minutes)
    would count about ``events × n`` samples, a number that grows with the run length
    per sample; evaluating each event near its own time keeps the count per sample
    the same for a 2-h and an 8-h run.
    """
    from gyrodrift.simulate import motion, scenarios, sensors

    counted = [0]

    def counting(func):
        def wrapper(x):
            counted[0] += np.size(x)
            return func(x)

        return wrapper

    for name in ("smooth_step", "smooth_step_slope"):
        real = getattr(motion, name)
        for module in (motion, scenarios, sensors):
            if hasattr(module, name):
                monkeypatch.setattr(module, name, counting(real))
    per_sample = {}
    for hours in (2.0, 8.0):
        counted[0] = 0
        n = len(simulate(scenario, seed=0, duration_s=hours * 3600.0, fs_hz=1.0, compass=CompassModel(rate_hz=1.0)))
        per_sample[hours] = counted[0] / n
    assert per_sample[8.0] <= 1.5 * per_sample[2.0] + 1.0, per_sample
    assert per_sample[8.0] <= 20.0, per_sample


def test_sum_of_steps_is_bitwise_the_sum_over_the_whole_run():
    """Each step on its own ramp gives exactly the full-length sum, also for unordered, overlapping steps."""
    from gyrodrift.simulate.motion import ramp_slice, smooth_step, smooth_step_slope, sum_of_steps

    rng = np.random.default_rng(3)
    t = np.arange(20001) / 7.0
    for ordered in (True, False):
        t0 = rng.uniform(-50.0, t[-1] + 50.0, size=60)
        t0 = np.sort(t0) if ordered else t0
        steps = list(zip(t0, rng.uniform(0.05, 300.0, size=60), rng.choice([-8.0, 8.0, 0.37, -1e-3], size=60)))
        full = np.zeros(t.size)
        pulse_full, pulse = np.zeros(t.size), np.zeros(t.size)
        for start, dur, delta in steps:
            full += delta * smooth_step((t - start) / dur)
            pulse_full += delta * smooth_step_slope((t - start) / dur) / dur
            ramp = ramp_slice(t, start, start + dur)
            pulse[ramp] += delta * smooth_step_slope((t[ramp] - start) / dur) / dur
        assert np.array_equal(sum_of_steps(t, steps).view(np.uint64), full.view(np.uint64))
        assert np.array_equal(pulse.view(np.uint64), pulse_full.view(np.uint64))


# ------------------------------------------------------------------ adversarial scenarios

ADVERSARIAL = ("vehicle-rawmag", "bursty", "ramp-interference", "sway", "vessel", "no-temp", "short")


def _motion(scenario, duration_s, seed=0, fs_hz=1.0):
    """The scenario's Motion at ``fs_hz`` (no sensor models: fast, exact rates)."""
    t = np.arange(int(duration_s * fs_hz) + 1) / fs_hz
    return t, SCENARIOS[scenario](t, float(duration_s), np.random.default_rng(seed))


def test_adversarial_scenarios_registered_with_default_durations():
    assert set(ADVERSARIAL) <= set(SCENARIOS)
    assert DEFAULT_DURATION_S["sway"] == 12 * 3600.0 and DEFAULT_DURATION_S["short"] == 30.0
    assert DEFAULT_DURATION_S["vehicle-rawmag"] == DEFAULT_DURATION_S["vehicle"]
    for name in ("ramp-interference", "sway", "vessel", "no-temp", "short"):
        a = simulate(name, seed=1, duration_s=600.0, fs_hz=10.0, device=EXACT_DEVICE, compass=TRUE_COMPASS)
        b = simulate(name, seed=2, duration_s=600.0, fs_hz=10.0, device=EXACT_DEVICE, compass=TRUE_COMPASS)
        assert not np.allclose(a["ref_heading"], b["ref_heading"]), name  # the random heading follows the seed


def test_bursty_logs_5_s_records_about_300_s_apart_with_or_without_compass():
    from gyrodrift.simulate import BURSTY_RECORD_S, BURSTY_SPACING_S

    forms = set()
    for seed in range(6):
        df = simulate("bursty", seed=seed, duration_s=3600.0, fs_hz=10.0)
        t = df["t"].to_numpy()
        jumps = np.flatnonzero(np.diff(t) > 1.0)
        starts = t[np.r_[0, jumps + 1]]
        assert starts[0] == 0.0 and 11 <= starts.size <= 13
        spacing = np.diff(starts)
        assert (spacing >= BURSTY_SPACING_S[0] - 0.1).all() and (spacing <= BURSTY_SPACING_S[1] + 0.1).all()
        assert (np.diff(np.split(t, jumps + 1)[0]) < 0.1 + 1e-9).all()
        assert all(len(rec) == BURSTY_RECORD_S * 10 for rec in np.split(t, jumps + 1))  # 50 rows at 10 Hz
        assert len(df.attrs["records"]) == starts.size
        assert df["ref_heading"].nunique() == 1 and df["temp"].iloc[-1] < df["temp"].iloc[0] - 10.0  # still, cooling
        forms.add("heading" if "heading" in df.columns else df.attrs["compass_form"])
        assert not any(c in df.columns for c in MAG_COLS)
    assert forms == {"heading", "none"}


def test_ramp_interference_falls_fast_while_the_compass_wanders():
    from gyrodrift.simulate import ramp_interference_window

    duration = DEFAULT_DURATION_S["ramp-interference"]
    t, m = _motion("ramp-interference", duration)
    assert -0.9 / 60 - 1e-9 <= m.temp_rate_cps.min() <= -0.7 / 60  # about 0.8 degC/min at the fastest
    assert np.ptp(m.temp_c) > 25.0 and (m.heading_rate_dps == 0.0).all()
    start, dur = ramp_interference_window(duration)
    assert dur == pytest.approx(600.0) and m.temp_rate_cps[int(start)] < -0.6 / 60  # inside the fall
    off = np.abs(m.interference_offset_deg)
    inside = (t > start + 30.0) & (t < start + dur - 30.0)
    assert off[(t < start) | (t > start + dur)].max() == 0.0
    assert 5.0 < off[inside].min() and off[inside].max() < 65.0 and np.ptp(m.interference_offset_deg[inside]) > 5.0


def test_sway_is_slow_small_and_has_long_outages():
    from gyrodrift.simulate import SWAY_MAX_RATE_DPS

    for seed in (0, 1):
        duration = DEFAULT_DURATION_S["sway"]
        t, m = _motion("sway", duration, seed=seed)
        assert 0.0 < np.abs(m.heading_rate_dps).max() <= SWAY_MAX_RATE_DPS + 1e-12
        assert 1.0 < np.ptp(cumulative_trapezoid(m.heading_rate_dps, t)) < 15.0  # a few degrees
        assert 3 <= len(m.compass_dropouts) <= 5
        assert all(40 * 60 <= d <= 90 * 60 for _, d in m.compass_dropouts)
        ends = [s + d for s, d in m.compass_dropouts]
        assert all(e <= s for e, (s, _) in zip(ends, m.compass_dropouts[1:])) and ends[-1] <= duration
        assert np.ptp(m.temp_c) > 4.0  # half a day/night cycle
    df = simulate("sway", seed=0, duration_s=7200.0, fs_hz=2.0, compass=CompassModel(rate_hz=1.0))
    for s, d in df.attrs["compass_dropouts"]:
        assert df.loc[(df["t"] >= s) & (df["t"] < s + d), "heading"].isna().all()


def test_vehicle_rawmag_is_the_vehicle_with_raw_columns_and_no_heading():
    raw = simulate("vehicle-rawmag", seed=4, duration_s=600.0, fs_hz=10.0)
    veh = simulate("vehicle", seed=4, duration_s=600.0, fs_hz=10.0, raw_mag=True)
    assert "heading" not in raw.columns and raw.attrs["compass_form"] == "raw"
    assert list(raw.columns) == [c for c in veh.columns if c != "heading"]
    pd.testing.assert_frame_equal(raw, veh.drop(columns="heading"), check_exact=True)
    assert np.abs(raw["acc_x"]).max() > 0.05  # braking and pulling away tilt the accelerometer


def test_vessel_turns_slowly_and_is_never_still():
    t, m = _motion("vessel", DEFAULT_DURATION_S["vessel"], fs_hz=2.0)
    moving = t > 300.0
    assert np.abs(m.heading_rate_dps).max() < 2.0  # below the turning gate
    mean = np.mean(m.heading_rate_dps[moving])
    assert 0.1 < abs(mean) < 0.8
    assert abs(cumulative_trapezoid(m.heading_rate_dps, t)[-1]) > 360.0  # round and round


def test_no_temp_logs_a_constant_temperature_while_the_drift_follows_the_true_one():
    from gyrodrift.simulate import NO_TEMP_CHANNEL_C

    df = simulate("no-temp", seed=3, duration_s=1800.0, fs_hz=10.0, device=EXACT_DEVICE)
    assert (df["temp"] == NO_TEMP_CHANNEL_C).all() and df.attrs["temp_channel_c"] == NO_TEMP_CHANNEL_C
    assert np.ptp(df["true_bias_z"]) > 0.1  # the real temperature moves the drift
    assert np.ptp(df["ref_heading"]) > 10.0  # turned now and then


def test_short_log_rotates_once():
    for seed in (0, 1, 2):
        t, m = _motion("short", 40.0, seed=seed, fs_hz=100.0)  # 40 s: long enough for any rotation to end
        assert 90.0 - 1e-6 <= abs(cumulative_trapezoid(m.heading_rate_dps, t)[-1]) <= 720.0 + 1e-6
        assert (m.heading_rate_dps[t < 3.0] == 0.0).all() and m.heading_rate_dps[-1] == 0.0
    df = simulate("short", seed=2, fs_hz=10.0)
    assert df["t"].iloc[-1] == 30.0 and df["heading"].notna().sum() == 301

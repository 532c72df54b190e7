"""Tests of the online scale factor: ScaleFactorTracker, the causal batch pass it equals, and
the Compensator's SF columns (Sec. 4.3; gyrodrift.scale_factor)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import cumulative_trapezoid

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.conventions import wrap_360
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.scale_factor import (
    TRACKER_COLUMNS,
    ScaleFactorConfig,
    ScaleFactorTracker,
    estimate_scale_factor,
)
from gyrodrift.simulate import simulate

#: Noise settings that make the measurement variance R negligible (noiseless data).
EXACT = dict(compass_sigma_deg=1e-9, gyro_noise_dps_rthz=1e-9, residual_drift_dps=0.0)


def _ramp(x):
    x = np.clip(x, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * x)


def turn_rate(t, turns, peak_dps=45.0, ramp_s=1.0):
    """True rate (deg/s) of raised-cosine turns ``(start s, angle deg)``."""
    rate = np.zeros(t.size)
    for t0, angle in turns:
        dur = abs(angle) / peak_dps + ramp_s
        rate += np.sign(angle) * peak_dps * (_ramp((t - t0) / ramp_s) - _ramp((t - (t0 + dur - ramp_s)) / ramp_s))
    return rate


def table(t, true_rate, sf, temp_c, compass_every=2, compass_rate=None, rng=None, noise_dps=0.0,
          heading0_deg=40.0, compass_noise_deg=0.0):
    """A compensate()-like table: ``rate_z = sf*true_rate (+ noise)``, compass from the true
    heading (or from ``compass_rate``) on every ``compass_every``-th row."""
    heading = heading0_deg + cumulative_trapezoid(true_rate if compass_rate is None else compass_rate, t, initial=0.0)
    if compass_noise_deg:
        heading = heading + compass_noise_deg * rng.standard_normal(t.size)
    compass = np.full(t.size, np.nan)
    compass[::compass_every] = wrap_360(heading[::compass_every])
    rate = sf * true_rate
    if noise_dps:
        rate = rate + noise_dps * rng.standard_normal(t.size)
    return pd.DataFrame({"t": t, "rate_z": rate, "gate_reason": "", "compass_heading": compass, "temp": temp_c})


def stream(out: pd.DataFrame, config: ScaleFactorConfig, chunks=None, rng=None) -> pd.DataFrame:
    """The tracker fed ``out`` row by row (``chunks`` None) or in random chunks of 1..chunks rows
    (:meth:`~ScaleFactorTracker.push_arrays`, and :meth:`~ScaleFactorTracker.push_frame` for
    chunks of more than 100 rows)."""
    tr = ScaleFactorTracker(config)
    cols = [out[c].to_numpy() for c in ("t", "rate_z", "temp", "compass_heading", "gate_reason")]
    if chunks is None:
        rows = [tr.push(*r) for r in zip(*cols)]
        res = pd.DataFrame(rows, columns=list(TRACKER_COLUMNS), index=out.index)
    else:
        parts, i = [], 0
        while i < len(out):
            k = int(rng.integers(1, chunks + 1))
            if chunks > 100:
                parts.append(tr.push_frame(out.iloc[i : i + k]))
            else:
                parts.append(tr.push_arrays(*(c[i : i + k] for c in cols)))
            i += k
        if chunks > 100:
            res = pd.concat(parts)
        else:
            res = pd.DataFrame({n: np.concatenate([p[n] for p in parts]) for n in TRACKER_COLUMNS}, index=out.index)
    res.attrs["tracker"] = tr
    return res


def assert_same_bits(batch: pd.DataFrame, streamed: pd.DataFrame):
    assert len(batch) == len(streamed)
    for col in TRACKER_COLUMNS:
        a, b = batch[col].to_numpy(), streamed[col].to_numpy()
        assert np.array_equal(a, b, equal_nan=True), (col, np.flatnonzero(~((a == b) | (np.isnan(a) & np.isnan(b))))[:5])


def decided_reasons(turns: pd.DataFrame) -> dict:
    """Reasons of the batch turns a tracker fed the same rows has decided (the rest end with the log)."""
    done = turns[(turns["row_update"] >= 0) | (turns["reason"] == "long_turn")]
    return done["reason"].value_counts().to_dict()


# ------------------------------------------------------------------ known answers


def test_constant_sf_is_recovered_exactly_from_noiseless_turns():
    t = np.arange(0.0, 400.0, 0.05)
    turns = ((60.0, 360.0), (180.0, -360.0), (300.0, 720.0))
    true = turn_rate(t, turns)
    out = table(t, true, 1.02, np.full(t.size, 30.0))
    cfg = ScaleFactorConfig(**EXACT)
    res = stream(out, cfg)
    tr = res.attrs["tracker"]
    assert tr.n_updates == 3 and tr.reasons == {"": 3}
    ups = np.flatnonzero(res["sf_update"].to_numpy())
    # the prior until the first update, which applies from the row that decides it: the end of
    # the turn + guard + still window + guard + half the rotation-test window (one 0.05-s row)
    np.testing.assert_array_equal(res["sf"].to_numpy()[: ups[0]], 1.0)
    moving_end = 60.0 + 360.0 / 45.0 + 1.0
    assert t[ups[0]] == pytest.approx(moving_end + 2.0 + 5.0 + 2.0 + 0.5, abs=0.6)
    np.testing.assert_allclose(res["sf"].to_numpy()[ups[0] :], 1.02, rtol=0, atol=1e-12)
    # from there on the SF-compensated rate is the true rate, and turn 2 and 3 are integrated exactly
    np.testing.assert_allclose(res["rate_sf"].to_numpy()[ups[0] :], true[ups[0] :], rtol=0, atol=1e-9)
    h = res["heading_sf"].to_numpy()
    for (t0, angle) in turns[1:]:
        before, after = np.searchsorted(t, t0 - 1.0), np.searchsorted(t, t0 + abs(angle) / 45.0 + 2.0)
        assert ((h[after] - h[before] - angle + 180.0) % 360.0) - 180.0 == pytest.approx(0.0, abs=1e-7)


def test_measurement_is_the_batch_measurement():
    t = np.arange(0.0, 300.0, 0.05)
    out = table(t, turn_rate(t, ((100.0, -270.0),)), 0.97, np.full(t.size, 40.0))
    tr = stream(out, ScaleFactorConfig()).attrs["tracker"]
    batch = estimate_scale_factor(out, ScaleFactorConfig(), causal=True).attrs["turns"].iloc[0]
    assert tr.last_turn["sf_meas"] == batch["sf_meas"] == pytest.approx(0.97, abs=1e-9)
    assert tr.last_turn["angle_compass_deg"] == pytest.approx(-270.0, abs=1e-9)
    assert tr.last_turn["row_update"] == batch["row_update"]


# ------------------------------------------------------------------ streaming = causal batch


def hard_log(seed=3) -> pd.DataFrame:
    """Irregular sampling, noise, a temperature ramp with empty cells, a compass that starts
    180 deg from the gyro heading (so its unwrapping works on every sample), and a rotation
    refused for every reason the causal pass has (with ``max_turn_s=60``)."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(0.05 * (1.0 + 0.3 * rng.uniform(-1.0, 1.0, 30000)))
    t = t[t < 1500.0]
    turns = [
        (3.0, 360.0),  # edge: no still window before it
        (60.0, 360.0), (660.0, 720.0), (1000.0, -360.0), (1120.0, 360.0), (1240.0, -360.0),  # accepted
        (180.0, 360.0), (192.0, -360.0),  # not_still
        (300.0, 360.0),  # no_compass
        (420.0, -360.0),  # interference
        (540.0, 45.0),  # small_turn
        (800.0, 4500.0),  # a 100-s spin: long_turn
        (1360.0, 360.0),  # implausible: the compass sees 0.7 of it
        (1485.0, 360.0),  # runs past the end of the log
    ]
    true = turn_rate(t, turns)
    compass_rate = true * np.where((t > 1355.0) & (t < 1375.0), 0.7, 1.0)
    temp = 22.0 + 30.0 * t / 1500.0
    sf = 1.01 + 8e-4 * (temp - 25.0)
    out = table(t, true, sf, temp, compass_rate=compass_rate, rng=rng, noise_dps=0.02, heading0_deg=180.0,
                compass_noise_deg=0.3)
    out.loc[out["t"].between(303.0, 306.0), "compass_heading"] = np.nan
    out.loc[out["t"].between(415.0, 417.0), "gate_reason"] = "interference"
    out.loc[out["t"].between(700.0, 702.0), "temp"] = np.nan
    return out


HARD = ScaleFactorConfig(max_turn_s=60.0)


@pytest.fixture(scope="module")
def sim_out():
    return compensate(simulate("scale-factor", seed=0, duration_s=3600.0, fs_hz=10.0), CompensatorConfig().without_scale_factor())


@pytest.mark.parametrize("chunks", [None, 3, 400])
def test_tracker_equals_causal_batch_on_every_refusal(chunks):
    out = hard_log()
    batch = estimate_scale_factor(out, HARD, causal=True)
    streamed = stream(out, HARD, chunks=chunks, rng=np.random.default_rng(chunks))
    assert_same_bits(batch, streamed)
    turns = batch.attrs["turns"]
    assert set(turns["reason"]) == {
        "", "edge", "not_still", "no_compass", "interference", "small_turn", "long_turn", "implausible",
    }
    assert batch["sf_update"].sum() == 5
    assert streamed.attrs["tracker"].reasons == decided_reasons(turns)


@pytest.mark.parametrize("chunks", [None, 5])
def test_tracker_unwraps_the_compass_as_the_batch_pass(chunks):
    # The compass is 180 deg from the gyro heading, +-1 deg of noise: the compass-minus-gyro
    # difference wraps on about every other sample, in every still window.
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 800.0, 0.05)
    out = table(t, turn_rate(t, [(60.0 + 120.0 * k, 360.0 * (-1) ** k) for k in range(6)]), 1.0,
                np.full(t.size, 30.0), rng=rng, heading0_deg=220.0, compass_noise_deg=1.0)
    # SF 1: the gyro heading is the true heading minus 220; shift the compass to 180 (+ noise) from it
    out["compass_heading"] = wrap_360(out["compass_heading"] - 40.0)
    batch = estimate_scale_factor(out, ScaleFactorConfig(), causal=True)
    assert_same_bits(batch, stream(out, ScaleFactorConfig(), chunks=chunks, rng=rng))
    turns = batch.attrs["turns"]
    assert turns["accepted"].all() and len(turns) == 6
    np.testing.assert_allclose(turns["sf_meas"], 1.0, atol=1e-3)


@pytest.mark.parametrize("chunks", [None, 50, 5000])
def test_tracker_equals_causal_batch_on_the_simulated_experiment(sim_out, chunks):
    cfg = ScaleFactorConfig()
    batch = estimate_scale_factor(sim_out, cfg, causal=True)
    streamed = stream(sim_out, cfg, chunks=chunks, rng=np.random.default_rng(0))
    assert_same_bits(batch, streamed)
    assert batch["sf_update"].sum() >= 25
    tr = streamed.attrs["tracker"]
    np.testing.assert_array_equal(tr.params, batch.attrs["final_params"])
    np.testing.assert_array_equal(tr.cov, batch.attrs["final_cov"])


def test_causal_and_default_pass_differ_only_as_documented(sim_out):
    cfg = ScaleFactorConfig()
    nc = estimate_scale_factor(sim_out, cfg)
    ca = estimate_scale_factor(sim_out, cfg, causal=True)
    tn, tc = nc.attrs["turns"], ca.attrs["turns"]
    # the same rotations and measurements ...
    acc = tn["accepted"].to_numpy()
    np.testing.assert_array_equal(acc, tc["accepted"])
    np.testing.assert_array_equal(tn["sf_meas"], tc["sf_meas"])
    np.testing.assert_array_equal(nc.attrs["final_params"], ca.attrs["final_params"])
    # ... each applied guard_s + half a window later (one row at 10 Hz: the default pass
    # applies from the row after its update row), and the prior before the first
    t = sim_out["t"].to_numpy()
    delay = t[tc.loc[acc, "row_update"]] - t[tn.loc[acc, "row_update"] + 1]
    np.testing.assert_allclose(delay, cfg.guard_s + 0.5 * cfg.turn_window_s - 0.1, atol=1e-6)
    first = int(tc.loc[acc, "row_update"].iloc[0])
    assert cfg.x0 == (1.0, 0.0)
    np.testing.assert_array_equal(ca["sf"].to_numpy()[:first], 1.0)
    assert np.all(nc["sf"].to_numpy()[:first] != 1.0)  # the default pass initialises them
    # between updates the two SF columns agree
    same = np.ones(t.size, dtype=bool)
    for a, b in zip(tn.loc[acc, "row_update"] + 1, tc.loc[acc, "row_update"]):
        same[a:b] = False
    same[:first] = False
    np.testing.assert_array_equal(nc["sf"].to_numpy()[same], ca["sf"].to_numpy()[same])


@pytest.mark.parametrize("causal", [True, False])
def test_empty_temperature_cells_are_held(causal):
    out = hard_log()
    held = out.copy()
    held["temp"] = held["temp"].ffill()
    a = estimate_scale_factor(out, HARD, causal=causal)
    b = estimate_scale_factor(held, HARD, causal=causal)
    assert out["temp"].isna().any()
    assert_same_bits(a, b)
    assert np.isfinite(a["sf"]).all() and np.isfinite(a.attrs["final_params"]).all()


def test_heading_is_empty_until_the_first_compass_heading():
    t = np.arange(0.0, 200.0, 0.05)
    out = table(t, turn_rate(t, ((100.0, 360.0),)), 1.0, np.full(t.size, 30.0))
    out.loc[out["t"] < 10.0, "compass_heading"] = np.nan
    res = stream(out, ScaleFactorConfig())
    first = int(np.flatnonzero(out["compass_heading"].notna().to_numpy())[0])
    assert np.isnan(res["heading_sf"].to_numpy()[:first]).all()
    assert res["heading_sf"].iloc[first] == out["compass_heading"].iloc[first]
    assert np.isfinite(res["heading_sf"].to_numpy()[first:]).all()
    assert_same_bits(estimate_scale_factor(out, ScaleFactorConfig(), causal=True), res)


# ------------------------------------------------------------------ bounded state


def test_state_stays_bounded_on_a_long_log():
    # 4 h at 20 Hz: a turn every 2 min and a 20-min spin in the middle
    fs = 20.0
    cfg = ScaleFactorConfig(max_turn_s=120.0)
    t = np.arange(0.0, 4 * 3600.0, 1.0 / fs)
    turns = [(60.0 + 120.0 * k, 360.0 * (-1) ** k) for k in range(119)]
    turns = [tu for tu in turns if not 7000.0 < tu[0] < 8300.0] + [(7100.0, 45.0 * 1200.0)]
    out = table(t, turn_rate(t, turns), 1.02, 25.0 + 10.0 * np.sin(t / 3000.0))
    tr = ScaleFactorTracker(cfg)
    most = 0
    rng = np.random.default_rng(5)
    i = 0
    while i < t.size:
        k = int(rng.integers(1, 200))
        cols = out.iloc[i : i + k]
        tr.push_arrays(cols["t"], cols["rate_z"], cols["temp"], cols["compass_heading"], cols["gate_reason"])
        most = max(most, tr.buffered_rows)
        i += k
    bound_rows = fs * tr.buffer_bound_s + 64 + 2
    assert most <= bound_rows
    assert most < t.size / 50  # a few minutes of rows, not the log
    assert tr.reasons.get("long_turn") == 1
    assert tr.n_updates >= 100
    # the kept rows are far fewer than the bound once the spin is over
    assert tr.buffered_rows < fs * 60.0


# ------------------------------------------------------------------ bad input


def test_bad_rows_give_a_gyrodrift_error_and_leave_the_state_alone():
    tr, ref = ScaleFactorTracker(), ScaleFactorTracker()
    for tracker in (tr, ref):
        tracker.push(0.0, 0.0, 30.0, 10.0)
        tracker.push(0.1, 0.0, 30.0, math.nan)
    with pytest.raises(LogFormatError, match="row 2: time must increase: got t=0.05 after t=0.1"):
        tr.push(0.05, 0.0, 30.0)
    with pytest.raises(LogFormatError, match="row 2: time must increase"):
        tr.push(0.1, 0.0, 30.0)
    with pytest.raises(LogFormatError, match="finite number of seconds"):
        tr.push(float("nan"), 0.0, 30.0)
    with pytest.raises(LogFormatError, match="rate_z must be a finite number"):
        tr.push(0.2, float("inf"), 30.0)
    with pytest.raises(LogFormatError, match="differ in length"):
        tr.push_arrays([0.2, 0.3], [0.0], [30.0, 30.0])
    assert tr.push(0.2, 1.0, 31.0, 12.0) == ref.push(0.2, 1.0, 31.0, 12.0)
    with pytest.raises(LogFormatError, match="first row needs a finite temperature"):
        ScaleFactorTracker().push(0.0, 0.0, float("nan"))
    with pytest.raises(ConfigError, match="ScaleFactorConfig"):
        ScaleFactorTracker({"fading": 1.2})
    assert issubclass(LogFormatError, GyroDriftError)


def test_batch_pass_rejects_time_going_back():
    t = np.arange(0.0, 60.0, 0.1)
    out = table(t, np.zeros(t.size), 1.0, np.full(t.size, 30.0))
    out.loc[100, "t"] = out.loc[99, "t"]
    for causal in (False, True):
        with pytest.raises(LogFormatError, match="row 100: time must increase"):
            estimate_scale_factor(out, causal=causal)
    with pytest.raises(LogFormatError, match="no rows"):
        estimate_scale_factor(out.iloc[:0], causal=True)


# ------------------------------------------------------------------ the Compensator


def test_compensator_scale_factor_equals_batch():
    from dataclasses import asdict

    from gyrodrift.compensator import Compensator

    log = simulate("scale-factor", seed=1, duration_s=1500.0, fs_hz=10.0)
    log.loc[log["t"].between(1074.0, 1074.3), "temp"] = np.nan  # held; a gap refusal before a turn
    log.loc[log["t"].between(362.0, 365.0), "heading"] = np.nan  # a turn without compass
    cfg, sf_cfg = CompensatorConfig(), ScaleFactorConfig()
    batch = compensate(log, cfg.without_scale_factor())  # as the Compensator does with a scale factor
    sf = estimate_scale_factor(batch, sf_cfg, causal=True)

    comp = Compensator(cfg, scale_factor=sf_cfg, provisional=False)
    rows = []
    for r in log.itertuples(index=False):
        rows += comp.push(r.t, r.gyro_z, r.temp, heading_deg=r.heading)
    streamed = pd.DataFrame([asdict(s) for s in rows])
    assert len(streamed) == len(batch)
    for col in ("rate_z", "heading", "gate_reason", "compass_heading"):
        np.testing.assert_array_equal(streamed[col], batch[col])
    for col in ("sf", "sf_sd", "rate_sf", "heading_sf"):
        assert np.array_equal(streamed[col].to_numpy(), sf[col].to_numpy(), equal_nan=True), col
    turns = sf.attrs["turns"]
    assert {"", "no_compass", "gap"} <= set(turns["reason"])
    assert comp.scale_factor.n_updates == int(sf["sf_update"].sum()) >= 6
    np.testing.assert_array_equal(comp.scale_factor.params, sf.attrs["final_params"])
    assert streamed["sf"].nunique() > 100  # the SF moves with the temperature after updates


def test_compensator_without_scale_factor_is_unchanged():
    from dataclasses import asdict

    from gyrodrift.compensator import CompensatedSample, CompensatorConfig, Compensator

    comp = Compensator(CompensatorConfig(init_s=3.0, update_interval_s=1.0))
    rows = []
    for i in range(500):
        rows += comp.push(i * 0.01, gyro_z_dps=0.2, temp_c=30.0, heading_deg=90.0)
    assert comp.scale_factor is None
    assert all(type(r) is CompensatedSample for r in rows)
    assert math.isnan(rows[-1].sf) and math.isnan(rows[-1].heading_sf)
    assert "sf" not in asdict(rows[-1])  # the columns of compensate(), as before

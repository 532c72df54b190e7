"""The gyro-aided gravity of the raw compass (gyrodrift.attitude): known answers, and the same
numbers in the batch, chunked and streaming paths."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

import gyrodrift
from gyrodrift.attitude import GravityFilter, RawTilt, gravity_down
from gyrodrift.compass import compass_columns, roll_pitch_deg
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.conventions import wrap_180

H_UT, V_UT = 20.0, 40.0  # horizontal and vertical Earth field (dip 63 deg)


def _level_field(heading_deg):
    """Body field of a level unit at this heading (FRD)."""
    psi = np.radians(heading_deg)
    return np.column_stack([H_UT * np.cos(psi), -H_UT * np.sin(psi), np.full(psi.shape, V_UT)])


def _tilt_error_deg(down, true_down):
    return np.degrees(np.arccos(np.clip(np.sum(down * true_down, axis=1), -1.0, 1.0)))


def test_level_unit_turning_gives_the_exact_heading():
    t = np.arange(0.0, 60.0, 0.05)
    rate = 30.0 * np.sin(2 * np.pi * t / 20.0)  # up to 30 deg/s, both ways
    heading = 40.0 + np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])
    acc = np.tile([0.0, 0.0, -1.0], (t.size, 1))
    down = gravity_down(t, np.zeros_like(t), np.zeros_like(t), rate, acc)
    np.testing.assert_allclose(down, np.tile([0.0, 0.0, 1.0], (t.size, 1)), atol=1e-12)
    got, norm, dip = compass_columns(t.size, None, _level_field(heading), acc, down)
    assert np.max(np.abs(wrap_180(got - heading))) < 1e-9
    np.testing.assert_allclose(norm, math.hypot(H_UT, V_UT), rtol=1e-12)
    np.testing.assert_allclose(dip, math.degrees(math.atan2(V_UT, H_UT)), rtol=1e-12)


def test_static_tilted_unit_converges_to_the_accelerometer_and_learns_the_gyro_bias():
    t = np.arange(0.0, 200.0, 0.1)
    roll, pitch = math.radians(20.0), math.radians(-10.0)
    f = np.array([math.sin(pitch), -math.cos(pitch) * math.sin(roll), -math.cos(pitch) * math.cos(roll)])
    acc = np.tile(f, (t.size, 1)) + 0.002 * np.random.default_rng(1).standard_normal((t.size, 3))
    bias_dps = (0.3, -0.2, 0.1)
    filt = GravityFilter()
    down = filt.feed(t, *(np.full(t.size, b) for b in bias_dps), acc)
    late = t > 100.0
    assert np.max(_tilt_error_deg(down[late], np.tile(-f, (late.sum(), 1)))) < 0.1
    # the bias across gravity is learned (along gravity it does not move the tilt)
    learned = np.degrees(filt.state[3:6])
    across = np.asarray(bias_dps) - np.dot(bias_dps, -f) * (-f)
    np.testing.assert_allclose(learned - np.dot(learned, -f) * (-f), across, atol=0.01)


def test_braking_vehicle_keeps_the_tilt_where_the_accelerometer_alone_is_off():
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 120.0, 0.1)
    brake = np.clip(np.minimum(t - 60.0, 66.0 - t), 0.0, 1.0) * 0.25  # 6 s of braking, 0.25 g, 1-s ramps
    acc = np.column_stack([-brake, np.zeros_like(t), -np.ones_like(t)]) + 0.002 * rng.standard_normal((t.size, 3))
    gx, gy = 0.2 + 0.02 * rng.standard_normal(t.size), -0.15 + 0.02 * rng.standard_normal(t.size)
    gz = 0.5 + 0.02 * rng.standard_normal(t.size)
    down = gravity_down(t, gx, gy, gz, acc)
    level = np.tile([0.0, 0.0, 1.0], (t.size, 1))
    during = brake > 0
    gyro_err = _tilt_error_deg(down[during], level[during])
    acc_only = -acc / np.linalg.norm(acc, axis=1)[:, None]
    acc_err = _tilt_error_deg(acc_only[during], level[during])
    assert gyro_err.max() < 1.0 and acc_err.max() > 5.0
    heading = np.full(t.size, 123.0)
    mag = _level_field(heading)
    h_gyro, _, _ = compass_columns(t.size, None, mag, acc, down)
    h_acc, _, _ = compass_columns(t.size, None, mag, acc)
    assert np.max(np.abs(wrap_180(h_gyro[during] - 123.0))) < 1.0
    assert np.max(np.abs(wrap_180(h_acc[during] - 123.0))) > 5.0


def test_a_time_gap_restarts_from_the_accelerometer_and_nan_cells_hold():
    t = np.array([0.0, 0.1, 0.2, 5.0, 5.1])
    acc = np.array([[0, 0, -1.0], [np.nan] * 3, [0, 0, -1.0], [0, -0.5, -0.866025403784], [0, -0.5, -0.866025403784]])
    gx = np.array([0.0, np.nan, np.nan, 0.0, 0.0])
    down = gravity_down(t, gx, np.zeros(5), np.zeros(5), acc)
    roll, _ = roll_pitch_deg(*(-down).T)
    np.testing.assert_allclose(roll, [0, 0, 0, 30, 30], atol=1e-9)


def test_chunks_and_rows_give_the_numbers_of_one_call():
    rng = np.random.default_rng(3)
    n = 700
    t = np.cumsum(rng.uniform(0.05, 0.15, n))
    g = rng.normal(0.0, 3.0, (n, 3))
    acc = np.column_stack([rng.normal(0, 0.05, n), rng.normal(0, 0.05, n), -1.0 + rng.normal(0, 0.02, n)])
    whole = gravity_down(t, *g.T, acc)
    f = GravityFilter()
    parts = np.concatenate([f.feed(t[a:b], *g[a:b].T, acc[a:b]) for a, b in [(0, 1), (1, 250), (250, 251), (251, n)]])
    assert np.array_equal(parts, whole)


def _turning_log(seconds: float = 240.0) -> pd.DataFrame:
    from gyrodrift.montecarlo import draw_case
    from gyrodrift.simulate import simulate
    from gyrodrift.simulate.device import TriadModel

    case = draw_case("vehicle-rawmag", 1)
    return simulate(case.scenario, seed=case.log_seed, duration_s=seconds, fs_hz=10.0, device=case.device,
                    compass=case.compass, triad=TriadModel())


def test_the_compensator_uses_the_gyro_tilt_with_gyro_x_y_and_says_so():
    log = _turning_log()
    gyro = gyrodrift.compensate(log)
    accel = gyrodrift.compensate(log, CompensatorConfig(tilt="accel"))
    assert any("gyro-aided gravity" in n for n in gyro.attrs["notes"])
    assert any("accelerometer alone (tilt = 'accel')" in n for n in accel.attrs["notes"])
    err = {k: np.abs(wrap_180(o["compass_heading"] - o["ref_heading"])) for k, o in (("g", gyro), ("a", accel))}
    assert np.nanpercentile(err["g"], 99) < np.nanpercentile(err["a"], 99)
    without = gyrodrift.compensate(log.drop(columns=["gyro_x", "gyro_y"]))
    assert np.array_equal(without["compass_heading"], accel["compass_heading"], equal_nan=True)
    assert any("no gyro_x, gyro_y" in n for n in without.attrs["notes"])
    with pytest.raises(gyrodrift.errors.ConfigError, match="tilt must be"):
        CompensatorConfig(tilt="mag")


def test_batch_chunked_and_streaming_give_the_same_compass(tmp_path):
    from gyrodrift.pipeline import compensate_file

    log = _turning_log()
    cols = [c for c in log.columns if not c.startswith("true_bias_")]
    log[cols].to_csv(tmp_path / "in.csv", index=False)
    compensate_file(tmp_path / "in.csv", tmp_path / "whole.csv", stream=False)
    compensate_file(tmp_path / "in.csv", tmp_path / "parts.csv", stream=True, chunk_rows=333)
    whole, parts = pd.read_csv(tmp_path / "whole.csv"), pd.read_csv(tmp_path / "parts.csv")
    for c in ("compass_heading", "heading", "heading_fused", "bias_z", "gate_reason"):
        assert whole[c].equals(parts[c]), c
    batch = gyrodrift.compensate(log)
    comp = gyrodrift.Compensator(provisional=False)
    rows = []
    for r in log.itertuples(index=False):
        rows += comp.push(r.t, r.gyro_z, r.temp, mag=(r.mag_x, r.mag_y, r.mag_z), acc=(r.acc_x, r.acc_y, r.acc_z),
                          gyro_x_dps=r.gyro_x, gyro_y_dps=r.gyro_y)
    rows += comp.flush()
    stream = pd.DataFrame([dataclasses.asdict(r) for r in rows])
    for c in ("compass_heading", "heading", "heading_fused", "bias_z"):
        np.testing.assert_allclose(stream[c].to_numpy(float), batch[c].to_numpy(float), rtol=0, atol=1e-9,
                                   equal_nan=True, err_msg=c)
    assert any("gyro-aided gravity" in n for n in comp.notes)
    assert RawTilt("gyro", True).uses_gyro and not RawTilt("accel", True).uses_gyro

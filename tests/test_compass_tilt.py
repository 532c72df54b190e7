"""The compass's tilt (docs/model.md, "The compass's tilt"): a raw compass sample whose
accelerometer tilt and gyro-aided tilt disagree is widened by their headings' difference;
known answers, a banked turn under a raw compass, and the same numbers in the batch,
chunked and streaming paths."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

import gyrodrift
from gyrodrift.compass import tilt_compensated_heading
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.compensator.intake import tilt_difference
from gyrodrift.conventions import wrap_180

FIELD = (0.2, 0.0, 0.4)  # north, east, down (gauss): 63 deg of dip


def body_field(heading_deg, roll_deg):
    """The field ``FIELD`` in the FRD body frame of a body at these headings and rolls (no pitch)."""
    psi, phi = np.radians(heading_deg), np.radians(roll_deg)
    n, e, d = FIELD
    x = n * np.cos(psi) + e * np.sin(psi)  # the level frame turned with the heading
    y = -n * np.sin(psi) + e * np.cos(psi)
    return np.column_stack([x, y * np.cos(phi) + d * np.sin(phi), -y * np.sin(phi) + d * np.cos(phi)])


def test_the_difference_of_a_banked_sample_by_hand():
    """A body heading north, banked 30 deg right in a coordinated turn: its accelerometer reads
    along body z (1/cos 30 g), so levelled by it the field's down part shows in y: the heading
    reads atan2(-0.4 sin 30, 0.2) = -45 deg. Levelled by the true gravity it reads 0."""
    mag = body_field(0.0, 30.0)[0]
    by_acc = tilt_compensated_heading(*mag, 0.0, 0.0, -1.0 / math.cos(math.radians(30.0)))
    down = (0.0, math.sin(math.radians(30.0)), math.cos(math.radians(30.0)))
    by_gravity = tilt_compensated_heading(*mag, *(-v for v in down))
    assert abs(float(wrap_180(by_gravity))) < 1e-9
    assert abs(float(tilt_difference(by_acc, by_gravity)) + 45.0) < 1e-9
    assert np.isnan(tilt_difference(np.nan, 10.0))
    assert float(tilt_difference(359.0, 1.0)) == -2.0  # within ±180


def raw_banked_turn(fs_hz: float = 20.0, bank_deg: float = 30.0, turn_dps: float = 10.0, seed: int = 0):
    """Level and still for 40 s, a 5-s roll into a bank, a coordinated 60-s turn (600 deg), a
    5-s roll out, level to 180 s; logged with a raw magnetometer (0.005 gauss of noise) and an
    accelerometer that reads along body z in the turn. Gyro offsets 0.3, -0.2, 0.5 deg/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 180.0, 1.0 / fs_hz)
    roll_in = np.clip((t - 40.0) / 5.0, 0.0, 1.0) - np.clip((t - 105.0) / 5.0, 0.0, 1.0)
    roll = bank_deg * roll_in
    roll_rate = bank_deg / 5.0 * (((t >= 40.0) & (t < 45.0)).astype(float) - ((t >= 105.0) & (t < 110.0)).astype(float))
    psi_dot = np.where((t >= 45.0) & (t < 105.0), turn_dps, 0.0)
    heading = 70.0 + np.concatenate([[0.0], np.cumsum(psi_dot[:-1]) / fs_hz])
    phi = np.radians(roll)
    gyro = np.column_stack([roll_rate, psi_dot * np.sin(phi), psi_dot * np.cos(phi)]) + (0.3, -0.2, 0.5)
    gyro = gyro + 0.02 * rng.standard_normal(gyro.shape)
    acc = np.column_stack([np.zeros(t.size), -np.sin(phi), -np.cos(phi)])  # at rest: -gravity
    turning = psi_dot != 0.0
    acc[turning] = np.column_stack([np.zeros(turning.sum()), np.zeros(turning.sum()), -1.0 / np.cos(phi[turning])])
    acc = acc + 0.002 * rng.standard_normal(acc.shape)
    mag = body_field(heading, roll) + 0.005 * rng.standard_normal((t.size, 3))
    log = pd.DataFrame({"t": t, "gyro_z": gyro[:, 2], "temp": 25.0, "gyro_x": gyro[:, 0], "gyro_y": gyro[:, 1],
                        "mag_x": mag[:, 0], "mag_y": mag[:, 1], "mag_z": mag[:, 2],
                        "acc_x": acc[:, 0], "acc_y": acc[:, 1], "acc_z": acc[:, 2]})
    return log, heading, turning


@pytest.mark.parametrize("bank_deg, turn_dps", [(8.0, 2.0), (10.0, 3.0), (30.0, 10.0)])
def test_a_banked_turn_under_a_raw_compass_keeps_the_gyros_heading(bank_deg, turn_dps):
    """Through the turn the accelerometer-tilted compass errs by 10-70 deg, and its tilt
    disagrees with the gyro-aided one by as much: the fused heading follows the gyro there (far
    below the compass's error), says how well it knows it (the truth within 2 sd on most rows),
    and is back on the compass once level. (A shallow bank's error, 10-15 deg, is one the
    compass could have; without the two tilts' difference it was taken in part as heading.)"""
    log, heading, turning = raw_banked_turn(bank_deg=bank_deg, turn_dps=turn_dps)
    out = compensate(log, CompensatorConfig(mag_calibration=False))
    err = wrap_180(out["heading_fused"].to_numpy() - heading)
    compass_err = wrap_180(out["compass_heading"].to_numpy() - heading)
    fused, compass = (float(np.sqrt(np.mean(e[turning] ** 2))) for e in (err, compass_err))
    assert compass > 10.0
    assert fused < 0.1 * compass, (fused, compass)
    inside = np.abs(err[turning]) <= 2.0 * out["heading_fused_sd"].to_numpy()[turning]
    assert inside.mean() > 0.9, inside.mean()
    level = log["t"].to_numpy() > 150.0
    assert float(np.sqrt(np.mean(err[level] ** 2))) < 2.0


def test_batch_chunked_and_streaming_give_the_same_numbers(tmp_path):
    from gyrodrift.pipeline import compensate_file

    log, _, _ = raw_banked_turn(fs_hz=10.0)
    log["temp"] = 25.0 + log["t"] / 60.0  # a temperature that changes: a stream cannot tell a flat one
    log.loc[[300, 1200], ["mag_x", "mag_y", "mag_z"]] = np.nan  # no compass sample
    log.loc[[700], "gyro_y"] = np.nan
    log.to_csv(tmp_path / "in.csv", index=False)
    config = CompensatorConfig(mag_calibration=False)  # a stream does not calibrate the magnetometer
    compensate_file(tmp_path / "in.csv", tmp_path / "whole.csv", config, chunked=False)
    compensate_file(tmp_path / "in.csv", tmp_path / "parts.csv", config, chunked=True, chunk_rows=97)
    whole, parts = pd.read_csv(tmp_path / "whole.csv"), pd.read_csv(tmp_path / "parts.csv")
    for c in ("heading", "heading_fused", "heading_fused_sd", "bias_z", "bias_sd", "gate_reason"):
        assert whole[c].equals(parts[c]), c
    batch = compensate(log, config)
    comp = gyrodrift.Compensator(config, provisional=False)
    rows = []
    for r in log.itertuples(index=False):
        rows += comp.push(float(r.t), float(r.gyro_z), float(r.temp), mag=(r.mag_x, r.mag_y, r.mag_z),
                          acc=(r.acc_x, r.acc_y, r.acc_z), gyro_x_dps=float(r.gyro_x), gyro_y_dps=float(r.gyro_y))
    rows += comp.flush()
    stream = pd.DataFrame([dataclasses.asdict(r) for r in rows])
    for c in ("heading", "heading_fused", "heading_fused_sd", "bias_z", "bias_sd", "compass_heading"):
        assert np.array_equal(stream[c].to_numpy(float), batch[c].to_numpy(float), equal_nan=True), c


def _tilt_inflation(log) -> float:
    """The model's measured inflation K of the tilt's error after a log (``docs/model.md``)."""
    from gyrodrift.estimators import AdaptiveModel
    from gyrodrift.kernels import evidence as ev

    model = AdaptiveModel()
    compensate(log, CompensatorConfig(mag_calibration=False), estimator=model)
    return float(model.mf[ev.MF_TILT_K])


def test_the_tilts_difference_is_measured_as_persistent_or_not():
    """A banked turn's difference lasts the turn: its successive epochs correlate and K rises
    from the prior's 9 to its bound (39). (At a 30-deg bank under a 63-deg dip the level-looking
    accelerometer's heading errs by up to 130 deg and its difference wraps through ±180 twice in
    the turn, which the epochs' means do not follow: K 6 there, the widening no smaller for it.)
    A still, level board whose accelerometer is noisy (0.03 g a sample) has a difference that is
    noise from epoch to epoch: K falls towards 1."""
    from gyrodrift.kernels.evidence import TILT_RHO_MAX

    banked, _, _ = raw_banked_turn(bank_deg=15.0, turn_dps=5.0)
    assert _tilt_inflation(banked) == pytest.approx((1.0 + TILT_RHO_MAX) / (1.0 - TILT_RHO_MAX))
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 1800.0, 0.1)
    mag = body_field(np.full(t.size, 30.0), np.zeros(t.size)) + 0.002 * rng.standard_normal((t.size, 3))
    acc = np.array([0.0, 0.0, -1.0]) + 0.03 * rng.standard_normal((t.size, 3))
    still = pd.DataFrame({"t": t, "gyro_z": 0.2 + 0.05 * rng.standard_normal(t.size), "temp": 25.0,
                          "gyro_x": 0.05 * rng.standard_normal(t.size), "gyro_y": 0.05 * rng.standard_normal(t.size),
                          "mag_x": mag[:, 0], "mag_y": mag[:, 1], "mag_z": mag[:, 2],
                          "acc_x": acc[:, 0], "acc_y": acc[:, 1], "acc_z": acc[:, 2]})
    assert _tilt_inflation(still) < 3.0

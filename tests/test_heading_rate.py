"""The heading rate of a tilted body (gyrodrift.attitude, CompensatorConfig.heading_rate):
known answers from Euler kinematics, the z gyro's columns kept, and the same numbers in
the batch, chunked and streaming paths."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

import gyrodrift
from gyrodrift.attitude import LEARNED_S, GravityFilter
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.conventions import wrap_180

BIAS_DPS = (0.3, -0.2, 0.5)  # x, y, z gyro offsets


def _down(roll_rad, pitch_rad):
    """Down unit vectors (n, 3), body FRD, of a ZYX body at these angles."""
    return np.column_stack([-np.sin(pitch_rad), np.sin(roll_rad) * np.cos(pitch_rad),
                            np.cos(roll_rad) * np.cos(pitch_rad)])


def banked_turn(fs_hz: float = 20.0, bank_deg: float = 30.0, turn_dps: float = 10.0, seed: int = 0) -> pd.DataFrame:
    """Level and still for 40 s (the x/y offsets are learned), a 5-s roll into a bank, a
    coordinated 60-s turn (600 deg: the accelerometer reads along body z, ``1/cos(bank)`` g),
    a 5-s roll out, still to 180 s. Gyro offsets ``BIAS_DPS``, noise 0.02 deg/s; the compass
    (a heading column, 0.3 deg) is out from 40 to 120 s: through the turn only the gyro knows
    the heading. ``true_heading`` and ``true_bias_z`` beside."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 180.0, 1.0 / fs_hz)
    roll_in = np.clip((t - 40.0) / 5.0, 0.0, 1.0) - np.clip((t - 105.0) / 5.0, 0.0, 1.0)
    roll = math.radians(bank_deg) * roll_in
    roll_rate = math.radians(bank_deg) / 5.0 * (((t >= 40.0) & (t < 45.0)).astype(float)
                                                 - ((t >= 105.0) & (t < 110.0)).astype(float))
    psi_dot = np.where((t >= 45.0) & (t < 105.0), turn_dps, 0.0)  # deg/s
    heading = 70.0 + np.concatenate([[0.0], np.cumsum(psi_dot[:-1]) / fs_hz])
    # body rates of ZYX Euler kinematics at zero pitch: p = roll rate, q = psi' sin(roll), r = psi' cos(roll)
    p, q, r = np.degrees(roll_rate), psi_dot * np.sin(roll), psi_dot * np.cos(roll)
    noise = 0.02 * rng.standard_normal((t.size, 3))
    gyro = np.column_stack([p, q, r]) + np.asarray(BIAS_DPS) + noise
    turning = psi_dot != 0.0
    acc = -_down(roll, np.zeros_like(roll))  # the specific force of a body at rest: -gravity
    acc[turning] = np.column_stack([np.zeros(turning.sum()), np.zeros(turning.sum()), -1.0 / np.cos(roll[turning])])
    acc = acc + 0.002 * rng.standard_normal(acc.shape)
    compass = wrap_180(heading + 0.3 * rng.standard_normal(t.size)) % 360.0
    compass[(t >= 40.0) & (t < 120.0)] = np.nan
    return pd.DataFrame({"t": t, "gyro_z": gyro[:, 2], "temp": 25.0, "heading": compass, "gyro_x": gyro[:, 0],
                         "gyro_y": gyro[:, 1], "acc_x": acc[:, 0], "acc_y": acc[:, 1], "acc_z": acc[:, 2],
                         "true_heading": heading, "true_bias_z": BIAS_DPS[2]})


def _turned(out: pd.DataFrame, log: pd.DataFrame, until_s: float = 119.0) -> float:
    """The heading's error (deg) at ``until_s``, at the end of the compass outage."""
    i = int(np.searchsorted(log["t"], until_s))
    return float(wrap_180(out["heading"].iloc[i] - log["true_heading"].iloc[i]))


def test_the_heading_rate_of_a_tilted_body_turning_about_the_vertical():
    """A body tilted (roll 20, pitch -10 deg), still, then turning at 6 deg/s about the vertical:
    once the x/y offsets are learned the heading rate is the turn rate plus a constant drift,
    where gyro_z alone is short of it by the factor cos(roll) cos(pitch) (ZYX Euler kinematics)."""
    t = np.arange(0.0, 120.0, 0.05)
    roll, pitch = math.radians(20.0), math.radians(-10.0)
    psi_dot = np.where(t >= 60.0, 6.0, 0.0)
    d = _down(np.full(t.size, roll), np.full(t.size, pitch))
    body = psi_dot[:, None] * d + np.asarray(BIAS_DPS)  # turning about the vertical: body rate along d
    filt = GravityFilter()
    down, rate = filt.run(t, *body.T, -d)
    assert filt.accepted_s > LEARNED_S  # the accelerometer was accepted long enough: the tilt is used
    late = t >= 61.0
    np.testing.assert_allclose(down[late], d[late], atol=2e-3)
    still = (t > 40.0) & (t < 60.0)
    np.testing.assert_allclose(rate[late] - np.mean(rate[still]), 6.0, atol=0.01)
    np.testing.assert_allclose(body[late, 2] - BIAS_DPS[2], 6.0 * math.cos(roll) * math.cos(pitch), atol=1e-9)
    # before any accelerometer row was accepted the rate is gyro_z
    assert rate[0] == body[0, 2]


def test_a_coordinated_banked_turn_is_integrated_through_a_compass_outage():
    """A 600-deg turn at a 30-deg bank without a compass: gyro_z alone turns 600 cos(30) = 520 deg
    (80 deg short); the heading of a tilted body ends within 4.5 deg. What is left is the drift
    the model learned level, 0.5 deg/s, where the heading rate's is 0.5 cos(30) in the bank
    (60 s x 0.067 deg/s = 4.0 deg at most; docs/heading_and_axes.md)."""
    log = banked_turn()
    auto = compensate(log)
    level = compensate(log, CompensatorConfig(heading_rate="gyro_z"))
    assert abs(_turned(auto, log)) < 4.5
    assert _turned(level, log) == pytest.approx(-600.0 * (1.0 - math.cos(math.radians(30.0))), abs=3.0)
    # rate_z stays the z gyro's: gyro_z - bias_z (and the scale factor's share: 1e-3), bias_z its
    # offset where level
    still = (log["t"] > 150.0).to_numpy()
    assert np.abs(auto["bias_z"][still] - BIAS_DPS[2]).max() < 0.02
    np.testing.assert_allclose(auto["rate_z"], log["gyro_z"] - auto["bias_z"], atol=1e-3)
    assert np.abs(auto["rate_z"] - log["gyro_z"]).max() < 1.0


def test_a_tilted_still_body_holds_its_heading():
    """Still at roll 20, pitch -10 deg with x/y/z offsets (2, -1, 0.5) deg/s: the heading holds,
    and bias_z is the heading rate's drift, the z gyro's 0.5 and 6 % (cos 20 / cos 10 to first
    order in the x/y offsets' residual: docs/heading_and_axes.md)."""
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 400.0, 0.1)
    d = _down(np.full(t.size, math.radians(20.0)), np.full(t.size, math.radians(-10.0)))
    gyro = np.array([2.0, -1.0, 0.5]) + 0.02 * rng.standard_normal((t.size, 3))
    log = pd.DataFrame({"t": t, "gyro_z": gyro[:, 2], "temp": 25.0, "heading": 40.0 + 0.3 * rng.standard_normal(t.size),
                        "gyro_x": gyro[:, 0], "gyro_y": gyro[:, 1], "acc_x": -d[:, 0], "acc_y": -d[:, 1],
                        "acc_z": -d[:, 2]})
    out = compensate(log)
    late = t > 200.0
    assert abs(float(np.median(out["bias_z"][late])) - 0.5) < 0.04
    assert np.abs(wrap_180(out["heading"][late] - 40.0)).max() < 1.0
    np.testing.assert_allclose(out["rate_z"], log["gyro_z"] - out["bias_z"], atol=1e-3)


def test_without_the_inputs_or_when_asked_the_engine_takes_gyro_z():
    """The heading rate needs gyro_x, gyro_y and the accelerometer on the first rows;
    ``heading_rate = "gyro_z"`` keeps the z axis: both give the columns of a log without them."""
    log = banked_turn()
    bare = compensate(log.drop(columns=["gyro_x", "gyro_y"]))
    asked = compensate(log, CompensatorConfig(heading_rate="gyro_z"))
    no_acc = compensate(log.drop(columns=["acc_x", "acc_y", "acc_z"]))
    for c in ("heading", "bias_z", "rate_z", "heading_fused"):
        assert np.array_equal(bare[c], asked[c], equal_nan=True), c
        assert np.array_equal(bare[c], no_acc[c], equal_nan=True), c
    with pytest.raises(gyrodrift.errors.ConfigError, match="heading_rate"):
        CompensatorConfig(heading_rate="euler")


def test_batch_chunked_and_streaming_give_the_same_numbers(tmp_path):
    from gyrodrift.pipeline import compensate_file

    log = banked_turn(fs_hz=10.0)
    log["temp"] = 25.0 + log["t"] / 60.0  # a temperature that changes: a stream cannot tell a flat one
    log.loc[[500, 501, 1300], "gyro_z"] = np.nan  # empty cells: held, with what they added
    log.loc[[700, 1400], "gyro_y"] = np.nan
    log.drop(columns=["true_heading", "true_bias_z"]).to_csv(tmp_path / "in.csv", index=False)
    compensate_file(tmp_path / "in.csv", tmp_path / "whole.csv", chunked=False)
    compensate_file(tmp_path / "in.csv", tmp_path / "parts.csv", chunked=True, chunk_rows=111)
    whole, parts = pd.read_csv(tmp_path / "whole.csv"), pd.read_csv(tmp_path / "parts.csv")
    columns = ("heading", "heading_fused", "bias_z", "rate_z", "bias_sd", "gate_reason", "rate_x", "bias_y")
    for c in columns:
        assert whole[c].equals(parts[c]), c
    batch = compensate(log)
    for provisional in (False, True):
        comp = gyrodrift.Compensator(provisional=provisional)
        rows = []
        for r in log.itertuples(index=False):
            rows += comp.push(float(r.t), float(r.gyro_z), float(r.temp), heading_deg=float(r.heading),
                              acc=(r.acc_x, r.acc_y, r.acc_z), gyro_x_dps=float(r.gyro_x), gyro_y_dps=float(r.gyro_y))
        rows += comp.flush()
        stream = pd.DataFrame([dataclasses.asdict(r) for r in rows])
        assert len(stream) == len(batch)
        after = batch["gate_reason"].astype(str) != "init"  # provisional rows differ inside the init window
        for c in ("heading", "heading_fused", "bias_z", "rate_z", "bias_sd", "rate_x", "bias_y"):
            a, b = stream[c].to_numpy(float), batch[c].to_numpy(float)
            sel = after.to_numpy() if provisional else slice(None)
            assert np.array_equal(a[sel], b[sel], equal_nan=True), c
        if provisional:  # the provisional rows give the z gyro's rate too
            first = stream.iloc[: int(np.argmax(after))]
            np.testing.assert_allclose(first["rate_z"], log["gyro_z"][: len(first)] - first["bias_z"], atol=1e-3)


def test_a_long_slow_coordinated_turn_keeps_its_tilt():
    """A 60-s coordinated turn at 6 deg/s and a 15-deg bank: the accelerometer reads 1.035 g along
    body z (inside the 1-g gate) and disagrees with the tilt by 15 deg for a minute, at a rate the
    relock would take; the body turns about the axis its tilt calls vertical, so it is a turn and
    the tilt holds (within 2 deg to its end)."""
    log = banked_turn(bank_deg=15.0, turn_dps=6.0)
    t = log["t"].to_numpy()
    down = GravityFilter().feed(t, log["gyro_x"], log["gyro_y"], log["gyro_z"],
                                log[["acc_x", "acc_y", "acc_z"]].to_numpy())
    roll = np.degrees(np.arctan2(down[:, 1], down[:, 2]))
    late = (t > 80.0) & (t < 105.0)
    assert np.abs(roll[late] - 15.0).max() < 2.0


def test_the_notes_say_what_the_heading_integrates():
    """A note says the heading integrates the tilted body's rate, or gyro_z alone when the x/y
    offsets were never learned (an accelerometer on the first row only: the filter starts from it
    and never takes another); none with ``"gyro_z"``."""
    log = banked_turn()
    assert any("rate of the tilted body's heading" in n for n in compensate(log).attrs["notes"])
    assert not any("heading integrates" in n for n in
                   compensate(log, CompensatorConfig(heading_rate="gyro_z")).attrs["notes"])
    blind = log.copy()
    blind.loc[blind.index[1:], ["acc_x", "acc_y", "acc_z"]] = np.nan  # never taken after the start
    out = compensate(blind)
    assert any("integrates gyro_z alone: the x/y gyros' offsets were never learned" in n for n in out.attrs["notes"])
    level = compensate(blind, CompensatorConfig(heading_rate="gyro_z"))
    assert np.array_equal(out["heading"], level["heading"], equal_nan=True)


def test_a_board_shaken_before_its_offsets_are_learned_keeps_its_heading():
    """A tilted board shaken in a cone (roll and pitch of 5 deg at 2 Hz, a quarter turn apart)
    from its second second to its sixth, not yawing: its z gyro reads a mean rate of about
    2.7 deg/s (``r = −θ̇ sin φ``), 11 deg over the shaking, while the Euler heading rate of the
    gravity filter's tilt stays near 0. Before 16 s of accelerometer the time rule alone would
    take mostly ``gyro_z``; the filter's own covariance says the Euler rate is far the better
    (its variance small against the difference), so the heading holds within 1 deg."""
    fs = 200.0
    t = np.arange(0.0, 12.0, 1.0 / fs)
    tau = np.clip(t - 2.0, 0.0, 4.0)
    shaking = (t > 2.0) & (t < 6.0)
    w = 2.0 * np.pi * 2.0
    roll = np.radians(5.0) * np.sin(w * tau) * shaking
    pitch = np.radians(5.0) * (np.cos(w * tau) - 1.0) * shaking
    roll_rate = np.radians(5.0) * w * np.cos(w * tau) * shaking
    pitch_rate = -np.radians(5.0) * w * np.sin(w * tau) * shaking
    # ZYX Euler kinematics with no yaw: p = φ̇, q = θ̇ cos φ, r = −θ̇ sin φ
    gyro = np.degrees(np.column_stack([roll_rate, pitch_rate * np.cos(roll), -pitch_rate * np.sin(roll)]))
    gyro += 0.02 * np.random.default_rng(5).standard_normal(gyro.shape)
    acc = -_down(roll, pitch)
    down, rate = GravityFilter().run(t, *gyro.T, acc)
    assert abs(np.sum(gyro[shaking, 2]) / fs) > 8.0  # the z gyro alone walks
    assert abs(np.sum(rate[shaking]) / fs) < 1.0

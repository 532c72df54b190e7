"""What a user expects of the default estimator, as properties over random conditions (hypothesis).

Each property draws a device (drift a*T + c, noise), a temperature course, a motion (still,
sway, or a steady turn, starting after a still minute) and a compass (its noise; a disturbance
of random size and length), compensates a 10-min log at 10 Hz and checks:

* where the compass is clean, ``heading_fused`` is no worse than the compass alone (RMS
  against the truth);
* where the compass is disturbed, ``heading_fused`` is no worse than the gyro-alone heading,
  and no worse than the disturbed compass;
* with no compass at all, a slow steady turn is not learned as drift beyond ``bias_sd`` (the
  drift error stays within 3 sd on 99 % of the rows);
* aiding adds: started from a calibration of the drift that is off by a little (as ``--prior``
  gives), the drift is no worse than the calibration alone (within 0.005 deg/s RMS).

The default run draws a few examples per property; the slow suite draws 200 (``-m slow``);
both are derandomized, yet hypothesis's later draws were seen to differ between a file run
alone and the whole suite. None holds today: each is a strict xfail naming the counterexample hypothesis found, which it
draws first (issue 21's invariants not met; an xpass fails the run, so a fix is noticed), as
is a platform already in a slow steady turn in its first second
(``test_a_turn_from_the_first_second``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from conftest import synthetic_log
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.estimators import AdaptiveConfig
from gyrodrift.conventions import wrap_180

DURATION_S, FS_HZ, STILL_S = 600.0, 10.0, 60.0


def _profile(n: int):
    return settings(max_examples=n, derandomize=True, database=None, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


SHORT, LONG = _profile(4), _profile(200)


UNMET_CLEAN = pytest.mark.xfail(strict=True, reason=(
    "issue 21 invariant not met: a slow sway (5 deg, 160-s period) under a 3-deg compass (seed 4) "
    "gives heading_fused 5.87 deg RMS against the compass's 3.00 (its flat temperature puts T on the "
    "clock); docs/results.md"))
UNMET_DISTURBED = pytest.mark.xfail(strict=True, reason=(
    "issue 21 invariant not met: a +10-deg ramp over 32 s on a 5-deg, 30-s sway "
    "under a 1-deg compass (seed 0) gives heading_fused 2.21 deg RMS through it against the gyro "
    "alone's 1.19 (+1 allowed): the ramp's first degrees are taken as heading (the -10-deg, 33-s "
    "ramp found before, 2.96 against 1.59, now holds); docs/results.md"))
#: The counterexamples hypothesis found, drawn first in every run (so an edit to this file, which
#: changes the derandomized draws, cannot hide them).
CLEAN_CASE = (dict(a=0.0, c=0.0, t0=10.0, rise=0.0, kind="sway", h0=0.0, amp=5.0, period=160.0, rate=0.0,
                   gyro_noise=0.125, compass_noise=3.0, seed=4), (120.0, 20.0, -10.0, "step"))
DISTURBED_CASE = (dict(a=0.0, c=0.0, t0=10.0, rise=0.0, kind="sway", h0=0.0, amp=5.0, period=30.0, rate=0.0,
                       gyro_noise=0.125, compass_noise=1.0, seed=0), (120.0, 32.0, 10.0, "ramp"))
PRIOR_CASE = (dict(a=0.0, c=0.0, t0=10.0, rise=0.0, kind="still", h0=0.0, amp=5.0, period=30.0, rate=0.0,
                   gyro_noise=0.1875, compass_noise=1.0, seed=0), (120.0, 20.0, -10.0, "step"))
UNMET_SLOW_TURN = pytest.mark.xfail(strict=True, reason=(
    "issue 21 invariant not met: without a compass a steady 0.06 deg/s turn is taken for drift, "
    "beyond 3 bias_sd on 97 % of the rows (the still hypothesis explains it; nothing in the gyro "
    "alone tells them apart, and bias_sd does not say so); docs/results.md"))
UNMET_PRIOR = pytest.mark.xfail(strict=True, reason=(
    "issue 21 invariant not met: from an exact calibration (sd 1e-4 deg/s/degC and 1e-3 deg/s), on a "
    "still unit at a constant temperature with a 0.19-deg/s gyro noise, the drift RMS is 0.0059 deg/s "
    "against the calibration's 0: the drift's random walks let it follow the noise; docs/results.md"))


@st.composite
def scenarios(draw):
    """A scenario's parameters (shown as they are when a property fails) and its disturbance."""
    p = dict(a=draw(st.floats(-0.02, 0.02)), c=draw(st.floats(-0.5, 0.5)), t0=draw(st.floats(10.0, 40.0)),
             rise=draw(st.floats(0.0, 20.0)), kind=draw(st.sampled_from(["still", "sway", "turn"])),
             h0=draw(st.floats(0.0, 359.0)), amp=draw(st.floats(5.0, 60.0)), period=draw(st.floats(30.0, 300.0)),
             rate=draw(st.floats(-5.0, 5.0)), gyro_noise=draw(st.floats(0.01, 0.2)),
             compass_noise=draw(st.floats(0.3, 3.0)), seed=draw(st.integers(0, 10_000)))
    window = (draw(st.floats(120.0, 400.0)), draw(st.floats(20.0, 150.0)),
              draw(st.floats(10.0, 60.0)) * draw(st.sampled_from([-1.0, 1.0])), draw(st.sampled_from(["step", "ramp"])))
    return p, window


def scenario_log(p: dict):
    """The 10-min log of a scenario: still for a minute, then still, swaying or turning steadily."""

    def heading(t):
        moving = np.maximum(t - STILL_S, 0.0)
        if p["kind"] == "still":
            return np.full_like(t, p["h0"])
        if p["kind"] == "sway":
            return p["h0"] + p["amp"] * np.sin(2.0 * np.pi * moving / p["period"])
        return p["h0"] + p["rate"] * moving

    return synthetic_log(duration_s=DURATION_S, fs_hz=FS_HZ,
                         temp_c=lambda t: p["t0"] + p["rise"] * (1.0 - np.exp(-t / 200.0)),
                         drift_dps=lambda t, T: p["a"] * T + p["c"], heading_deg=heading,
                         gyro_noise_dps=p["gyro_noise"], compass_noise_deg=p["compass_noise"], seed=p["seed"])


def _rms(err, rows) -> float:
    e = np.asarray(err, dtype=float)[rows]
    e = e[np.isfinite(e)]
    return float(np.sqrt(np.mean(e**2)))


def fused_and_compass_rms(p, config: CompensatorConfig | None = None) -> tuple[float, float]:
    """RMS (deg) against the truth, after 30 s, of ``heading_fused`` and of the compass on a
    scenario (or on ``synthetic_log(**p)``), compensated with ``config`` (default settings);
    also used by ``benchmarks/probe_clean_compass.py`` and ``benchmarks/sweep_slow_turns.py``."""
    log = scenario_log(p) if isinstance(p, dict) and "kind" in p else synthetic_log(**p)
    out = compensate(log, config)
    truth = log["ref_heading"]
    rows = (out["t"] > 30.0).to_numpy() & out["compass_heading"].notna().to_numpy()
    return _rms(wrap_180(out["heading_fused"] - truth), rows), _rms(wrap_180(out["compass_heading"] - truth), rows)


def _clean(p) -> None:
    fused, compass = fused_and_compass_rms(p)
    assert fused <= compass, (fused, compass)


def _disturbed(p, window) -> None:
    log = scenario_log(p)
    start, length, size, shape = window
    t = log["t"].to_numpy()
    inside = (t >= start) & (t < start + length)
    offset = size * (np.ones(t.size) if shape == "step" else (t - start) / length)
    log["heading"] = np.where(inside, np.mod(log["heading"] + offset, 360.0), log["heading"])
    out = compensate(log)
    truth = log["ref_heading"]
    fused = _rms(wrap_180(out["heading_fused"] - truth), inside)
    gyro = _rms(wrap_180(out["heading"] - truth), inside)
    compass = _rms(wrap_180(out["compass_heading"] - truth), inside)
    assert fused <= max(gyro, 1.0) + 1.0 and fused < compass, (fused, gyro, compass)


@UNMET_CLEAN
@given(scenarios())
@example(case=CLEAN_CASE)
@SHORT
def test_fused_heading_no_worse_than_a_clean_compass(case):
    _clean(case[0])


@pytest.mark.slow
@UNMET_CLEAN
@given(scenarios())
@example(case=CLEAN_CASE)
@LONG
def test_fused_heading_no_worse_than_a_clean_compass_200(case):
    _clean(case[0])


@UNMET_DISTURBED
@given(scenarios())
@example(case=DISTURBED_CASE)
@SHORT
def test_fused_heading_no_worse_than_the_gyro_through_a_disturbance(case):
    _disturbed(*case)


@pytest.mark.slow
@UNMET_DISTURBED
@given(scenarios())
@example(case=DISTURBED_CASE)
@LONG
def test_fused_heading_no_worse_than_the_gyro_through_a_disturbance_200(case):
    _disturbed(*case)


def _slow_turn(rate_dps, a, c, seed) -> None:
    log = synthetic_log(duration_s=DURATION_S, fs_hz=FS_HZ, temp_c=lambda t: 25.0 + 5.0 * (1.0 - np.exp(-t / 200.0)),
                        drift_dps=lambda t, T: a * T + c, heading_deg=lambda t: 10.0 + rate_dps * np.maximum(t - STILL_S, 0.0),
                        gyro_noise_dps=0.05, seed=seed)
    log["heading"] = np.nan
    out = compensate(log)
    late = (out["t"] > STILL_S).to_numpy()
    z = (np.abs(out["bias_z"] - out["true_bias_z"]) / out["bias_sd"]).to_numpy()[late]
    assert np.mean(z <= 3.0) >= 0.99, float(np.mean(z <= 3.0))


@UNMET_SLOW_TURN
@given(st.floats(-0.1, 0.1), st.floats(-0.02, 0.02), st.floats(-0.5, 0.5), st.integers(0, 10_000))
@example(0.0625, 0.0, 0.0, 0)
@SHORT
def test_a_slow_turn_without_compass_is_not_learned_as_drift(rate, a, c, seed):
    _slow_turn(rate, a, c, seed)


@pytest.mark.slow
@UNMET_SLOW_TURN
@given(st.floats(-0.1, 0.1), st.floats(-0.02, 0.02), st.floats(-0.5, 0.5), st.integers(0, 10_000))
@example(0.0625, 0.0, 0.0, 0)
@LONG
def test_a_slow_turn_without_compass_is_not_learned_as_drift_200(rate, a, c, seed):
    _slow_turn(rate, a, c, seed)


#: A platform that turns smoothly and slowly for long: the motion's character carried (docs/model.md, "Motion").
STEADY_MOTION = CompensatorConfig(adaptive=AdaptiveConfig(motion_memory_s=120.0))


@pytest.mark.parametrize("rate_dps", [0.06, 0.1, 0.2])
@pytest.mark.parametrize("rise_degc", [0.0, 10.0])
def test_with_the_motion_kept_a_smooth_slow_turn_keeps_the_clean_compass(rate_dps, rise_degc):
    """A smooth steady turn under a clean compass, slow enough that the default takes it for a still
    platform with a drifting compass (docs/results.md, "Where slow turns end and compass ramps
    begin"): with ``motion_memory_s`` the fused heading is no worse than the compass, and far
    better than the default's."""
    case = {"a": 0.01, "c": 0.2, "t0": 20.0, "rise": rise_degc, "kind": "turn", "h0": 40.0, "amp": 10.0,
            "period": 100.0, "rate": rate_dps, "gyro_noise": 0.05, "compass_noise": 1.5, "seed": 3}
    fused, compass = fused_and_compass_rms(case, STEADY_MOTION)
    default, _ = fused_and_compass_rms(case)
    assert fused <= compass, (fused, compass)
    assert fused < 0.5 * default or default <= compass, (fused, default, compass)


def test_with_the_motion_kept_a_still_unit_keeps_the_clean_compass():
    """The same setting on a still unit under a clean compass: the fused heading stays below the compass's error."""
    case = {"a": 0.01, "c": 0.2, "t0": 20.0, "rise": 10.0, "kind": "still", "h0": 40.0, "amp": 10.0,
            "period": 100.0, "rate": 0.0, "gyro_noise": 0.05, "compass_noise": 1.5, "seed": 3}
    fused, compass = fused_and_compass_rms(case, STEADY_MOTION)
    assert fused <= 0.5 * compass, (fused, compass)


@pytest.mark.xfail(strict=True, reason="issue 21 invariant not met: a steady 0.77 deg/s turn from the first "
                   "second is taken for drift, and the compass then for disturbed (heading_fused 90 deg RMS "
                   "against a 0.4-deg compass; a still unit whose compass walks costs the model about what "
                   "a smooth turn does); docs/results.md")
def test_a_turn_from_the_first_second():
    kwargs = dict(duration_s=DURATION_S, fs_hz=FS_HZ, temp_c=lambda t: 20.0 + 10.0 * (1.0 - np.exp(-t / 200.0)),
                  drift_dps=lambda t, T: -0.02 * T + 0.357, heading_deg=lambda t: 100.0 - 0.77 * t,
                  gyro_noise_dps=0.034, compass_noise_deg=0.38, seed=5)
    _clean(kwargs)


def _prior(case, err_a, err_c) -> None:
    """A calibration off by ``err_a`` and ``err_c`` as the prior (its sd the size of its error)."""
    from gyrodrift.estimators import KalmanConfig

    log = scenario_log(case[0])
    truth = log["true_bias_z"].to_numpy()
    # the calibration: the true drift's a and c (from two points of the truth), off by the errors
    T = log["temp"].to_numpy()
    i, j = int(np.argmin(T)), int(np.argmax(T))
    a = (truth[j] - truth[i]) / (T[j] - T[i]) if T[j] - T[i] > 1.0 else 0.0
    c = truth[i] - a * T[i]
    cal = KalmanConfig(x0=(a + err_a, 0.0, c + err_c), p0_sd=(max(abs(err_a), 1e-4), 1e-3, max(abs(err_c), 1e-3)))
    out = compensate(log, CompensatorConfig(kalman=cal))
    prior_alone = (a + err_a) * T + (c + err_c)
    late = (log["t"] > 30.0).to_numpy()
    aided = float(np.sqrt(np.mean((out["bias_z"].to_numpy() - truth)[late] ** 2)))
    alone = float(np.sqrt(np.mean((prior_alone - truth)[late] ** 2)))
    assert aided <= alone + 0.005, (aided, alone)


@UNMET_PRIOR
@given(scenarios(), st.floats(-0.002, 0.002), st.floats(-0.05, 0.05))
@example(case=PRIOR_CASE, err_a=0.0, err_c=0.0)
@SHORT
def test_aiding_adds_to_a_good_calibration(case, err_a, err_c):
    _prior(case, err_a, err_c)


@pytest.mark.slow
@UNMET_PRIOR
@given(scenarios(), st.floats(-0.002, 0.002), st.floats(-0.05, 0.05))
@example(case=PRIOR_CASE, err_a=0.0, err_c=0.0)
@LONG
def test_aiding_adds_to_a_good_calibration_200(case, err_a, err_c):
    _prior(case, err_a, err_c)


AFTER_LANDING_SF_UNMET = pytest.mark.xfail(strict=True, reason=(
    "issue 21 invariant not met: in this flight (its gyro's scale factor in error) the fused heading takes the "
    "12.6-deg throttle offset from a turn on, and after landing comes back to the compass within about 50 s: "
    "2.7 deg RMS over the rest against the compass's 0.53 (docs/results.md, 'The gyro's scale factor')"))


@pytest.mark.parametrize("seed", [1_000_000, pytest.param(1_000_002, marks=AFTER_LANDING_SF_UNMET), 1_000_006])
def test_after_landing_the_fused_heading_returns_to_a_clean_compass(seed):
    """Held-out multicopter runs of the generator: from 10 s after landing (the compass clean
    again) to the end, ``heading_fused`` is within 0.5 deg RMS of the compass alone."""
    from gyrodrift.simulate.generator import generate

    log = generate("multicopter", seed).log
    out = compensate(log)
    t = log["t"].to_numpy()
    offset = log["true_compass_offset"].to_numpy()
    landed = t > t[np.flatnonzero(np.abs(offset) > 0.01)[-1]] + 10.0
    truth = log["ref_heading"].to_numpy()
    fused = float(np.sqrt(np.mean(wrap_180(out["heading_fused"].to_numpy() - truth)[landed] ** 2)))
    alone = float(np.sqrt(np.mean(wrap_180(log["heading"].to_numpy() - truth)[landed & log["heading"].notna().to_numpy()] ** 2)))
    assert fused <= alone + 0.5, (fused, alone)

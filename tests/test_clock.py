"""A temperature that never changes: the drift model's T becomes the elapsed time (the clock).

``CompensatorConfig.temperature`` and :class:`gyrodrift.model.ElapsedClock`.
"""

from dataclasses import asdict, replace

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.compensator import Compensator, CompensatorConfig, compensate, uses_clock
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import AdaptiveConfig
from gyrodrift.fleet import process_one
from gyrodrift.io import read_log
from gyrodrift.model import CLOCK_UNIT_S, ElapsedClock, temperature_is_flat
from gyrodrift.pipeline import compensate_file
from gyrodrift.profile import Profile, profile_from_run, warm_config
from gyrodrift.smooth import smooth_output

#: A warming unit whose temperature is not logged: the drift rises by 0.4 deg/s over the
#: log, fast at first (time constant 900 s), as a warm-up does.
WARMING = dict(duration_s=3600.0, fs_hz=10.0, compass_hz=5.0, temp_c=lambda t: np.zeros_like(t),
               drift_dps=lambda t, T: 0.2 + 0.4 * (1.0 - np.exp(-t / 900.0)))


def warming_log(seed=0, noise=True):
    return synthetic_log(**WARMING, gyro_noise_dps=0.04 if noise else 0.0, compass_noise_deg=0.5 if noise else 0.0,
                         seed=seed)


# ------------------------------------------------------------------ the clock


def test_clock_counts_units_of_elapsed_time_and_stops_across_gaps():
    t = np.array([0.0, 0.5, 1.0, 31.0, 31.5, 331.5])  # a 30-s gap, then a 300-s gap
    clock = ElapsedClock(1.0)
    np.testing.assert_allclose(clock(t), np.array([0.0, 0.5, 1.0, 1.0, 1.5, 1.5]) / CLOCK_UNIT_S)


def test_clock_in_chunks_equals_the_clock_at_once():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.choice([0.01, 0.1, 5.0], size=2000, p=[0.6, 0.39, 0.01]))
    whole = ElapsedClock(1.0)(t)
    clock = ElapsedClock(1.0)
    parts = np.concatenate([clock(t[lo:lo + n]) for lo, n in zip(range(0, 2000, 137), [137] * 15)])
    assert np.array_equal(parts, whole)
    assert np.all(np.diff(whole) >= 0.0)


@pytest.mark.parametrize("temp, flat", [
    ([20.0, 20.0, np.nan, 20.0], True),
    ([np.nan, np.nan], True),
    ([20.0, 20.0625, 20.0], False),
    ([], True),
    ([np.inf, 20.0, np.nan, 20.0], True),
    ([-np.inf, np.inf], True),
    ([20.0, np.inf, 21.0], False),
])
def test_flat_temperature(temp, flat):
    assert temperature_is_flat(temp) is flat


def test_auto_takes_the_clock_only_for_a_flat_temperature_without_warm_start():
    cfg = CompensatorConfig()
    assert uses_clock(cfg, [0.0, 0.0]) and not uses_clock(cfg, [0.0, 0.1])
    assert not uses_clock(cfg)  # streaming: the whole log is not known
    warm = replace(cfg, kalman=replace(cfg.kalman, x0=(0.03, 0.0, -0.8)))
    assert not uses_clock(warm, [45.0, 45.0])
    exact = replace(cfg, kalman=replace(cfg.kalman, p0_sd=(1e-4, 1e-3, 1e-3)))  # a calibration of zero drift
    assert not uses_clock(exact, [45.0, 45.0])
    assert uses_clock(replace(cfg, temperature="clock"), [20.0, 30.0])
    assert not uses_clock(replace(cfg, temperature="measured"), [0.0, 0.0])
    with pytest.raises(ConfigError, match="temperature = .* must be one of"):
        CompensatorConfig(temperature="time")


# ------------------------------------------------------------------ accuracy


def test_noiseless_linear_trend_in_time_is_recovered_exactly():
    """A drift that is a straight line in time, a temperature that never changes: the model
    with the clock is exact, so the drift is recovered (a = slope per clock unit)."""
    slope_dps_per_s = 2e-4
    log = synthetic_log(duration_s=1800.0, fs_hz=10.0, temp_c=lambda t: np.full_like(t, 31.0),
                        drift_dps=lambda t, T: -0.1 + slope_dps_per_s * t)
    frozen = AdaptiveConfig(slope_walk=0.0, rate_walk=0.0, drift_walk=0.0, drift_walk_temp=0.0,
                            drift_rate_dps2=1e-9)  # the model without process noise: exact, as
    out = compensate(log, CompensatorConfig(adaptive=frozen))  # fast as its gyro noise floor allows
    assert out.attrs["drift_regressor"] == "clock"
    late = out["t"] > 900.0
    err = np.abs(out["bias_z"] - out["true_bias_z"])
    assert err[late].max() < 1e-3 and err.iloc[-1] < 4e-4
    assert out["a"].iloc[-1] == pytest.approx(slope_dps_per_s * CLOCK_UNIT_S, rel=0.02)
    assert np.all(out["temp_rate"] == 0.0)
    # with the default process noise the drift rate is shared between a and r: a small lag
    out = compensate(log)
    assert np.abs(out["bias_z"] - out["true_bias_z"])[late].max() < 5e-3


def test_warm_up_without_temperature_the_clock_beats_a_constant_bias():
    """The drift of a warming unit whose temperature is not logged: a bias that follows it by
    its own rate lags it; the clock, a regressor that keeps changing, follows it better
    (heading RMS at least 30 % lower)."""
    errors = {}
    for mode in ("measured", "auto"):
        rms = []
        for seed in range(3):
            out = compensate(warming_log(seed), CompensatorConfig(temperature=mode))
            err = (out["heading"] - out["ref_heading"] + 180.0) % 360.0 - 180.0
            rms.append(float(np.sqrt(np.mean((err - err.iloc[0]) ** 2))))
        errors[mode] = np.mean(rms)
    assert errors["auto"] < 0.7 * errors["measured"], errors


def test_the_note_says_what_t_is():
    out = compensate(warming_log(noise=False))
    assert any("elapsed time" in note and "never changes" in note for note in out.attrs["notes"])
    measured = compensate(synthetic_log(duration_s=300.0))
    assert measured.attrs["drift_regressor"] == "temperature"
    assert not any("elapsed time" in note for note in measured.attrs["notes"])


# ------------------------------------------------------------------ every path the same


def test_file_path_in_chunks_gives_the_batch_numbers(tmp_path):
    log = warming_log(1)
    path = tmp_path / "warm.csv"
    log.to_csv(path, index=False)
    whole = compensate(read_log(path))
    out_path = tmp_path / "out.parquet"
    stats = compensate_file(path, out_path, chunk_rows=5000, chunked=True)
    chunked = pd.read_parquet(out_path)
    assert stats.regressor == "clock"
    for col in ("bias_z", "heading", "a", "c", "bias_sd"):
        np.testing.assert_array_equal(chunked[col].to_numpy(), whole[col].to_numpy(), err_msg=col)


@pytest.mark.parametrize("chunked", [False, True])
def test_the_summary_gives_a_drift_in_time_not_per_degc(tmp_path, chunked):
    """On the clock the model's a and b are per unit of time: the printed summary gives the
    drift at the last row, in deg/s, and no a, b per degC (as the fleet summary does)."""
    path = tmp_path / "warm.csv"
    warming_log(1).to_csv(path, index=False)
    out_path = tmp_path / "out.csv"
    stats = compensate_file(path, out_path, chunk_rows=5000, chunked=chunked)
    line = next(s for s in stats.result_lines() if s.startswith("final drift"))
    assert "deg/s/degC" not in line, line
    last = pd.read_csv(out_path)["bias_z"].iloc[-1]
    assert f"{last:.6g} deg/s" in line, (line, last)
    assert "a = " not in line


def test_file_whose_first_chunk_is_flat_but_not_the_rest_keeps_the_temperature(tmp_path):
    log = warming_log(2)
    log.loc[log.index[-100:], "temp"] = 0.5  # the temperature moves at the end only
    path = tmp_path / "late.csv"
    log.to_csv(path, index=False)
    stats = compensate_file(path, tmp_path / "out.parquet", chunk_rows=5000, chunked=True)
    assert stats.regressor == "temperature"
    assert compensate(read_log(path)).attrs["drift_regressor"] == "temperature"


def test_streaming_with_the_clock_and_no_temperature_equals_the_batch():
    log = warming_log(3).iloc[:6000]
    cfg = CompensatorConfig(temperature="clock")
    whole = compensate(log, cfg)
    comp = Compensator(cfg, provisional=False)
    rows = []
    for r in log.itertuples(index=False):
        rows += comp.push(r.t, r.gyro_z, None, heading_deg=r.heading)
    streamed = pd.DataFrame([asdict(s) for s in rows])
    assert len(streamed) == len(whole)
    for col in ("bias_z", "heading", "heading_fused", "bias_sd"):
        np.testing.assert_array_equal(streamed[col].to_numpy(), whole[col].to_numpy(), err_msg=col)


def test_smoothing_a_clock_run_uses_the_clock():
    out = compensate(warming_log(4))
    smoothed = smooth_output(out)
    err = lambda o: float(np.sqrt(np.mean((o["bias_z"] - o["true_bias_z"]) ** 2)))  # noqa: E731
    assert err(smoothed) < err(out)


# ------------------------------------------------------------------ what does not carry over


def test_no_profile_from_a_clock_run_but_a_warm_start_keeps_the_temperature():
    out = compensate(warming_log(5, noise=False))
    with pytest.raises(ConfigError, match="no profile saved"):
        profile_from_run(out)
    prof = Profile(params=(0.03, 0.0, -0.8), cov=((1e-6, 0, 0), (0, 1.0, 0), (0, 0, 1e-3)), temp_range_c=(20, 50),
                   samples=1, updates=1, estimator="adaptive", created="", software="")
    warm = compensate(warming_log(5, noise=False), warm_config(prof))
    assert warm.attrs["drift_regressor"] == "temperature"


def test_batch_of_a_log_without_temperature_reports_the_final_drift(tmp_path):
    path = tmp_path / "no_temp.csv"
    warming_log(6).drop(columns=["temp"]).to_csv(path, index=False)
    (tmp_path / "out").mkdir()
    row = process_one(path, tmp_path / "out")
    assert row["status"] == "ok", row["error"]
    assert np.isnan(row["a"]) and np.isnan(row["b"])
    assert row["c"] == pytest.approx(0.6, abs=0.02)


def test_stream_command_without_a_temp_column_takes_the_clock(tmp_path):
    from gyrodrift.cli import main

    log = warming_log(7).iloc[:3000]
    src = tmp_path / "in.csv"
    log.drop(columns=["temp", "ref_heading", "true_bias_z"]).to_csv(src, index=False)
    out_path = tmp_path / "out.csv"
    assert main(["stream", str(src), "-o", str(out_path), "--quiet"]) == 0
    streamed = pd.read_csv(out_path)
    batch = compensate(log.assign(temp=0.0))  # a flat column: the clock, as the note says
    late = streamed["t"] > 60.0
    np.testing.assert_allclose(streamed["bias_z"][late], batch["bias_z"][late], atol=1e-9)


def test_temperature_absent_after_the_first_sample_is_refused():
    from gyrodrift.errors import GyroDriftError

    comp = Compensator()
    comp.push(0.0, 0.1, 20.0)
    with pytest.raises(GyroDriftError, match="before the first sample"):
        comp.temperature_absent()


def test_a_warm_started_file_in_chunks_keeps_the_temperature_as_the_batch_does(tmp_path):
    prof = Profile(params=(0.03, 0.0, -0.8), cov=((1e-6, 0, 0), (0, 1.0, 0), (0, 0, 1e-3)), temp_range_c=(20, 50),
                   samples=1, updates=1, estimator="adaptive", created="", software="")
    path = tmp_path / "flat.csv"
    warming_log(8).to_csv(path, index=False)
    cfg = warm_config(prof)
    stats = compensate_file(path, tmp_path / "out.parquet", cfg, chunk_rows=5000, chunked=True)
    assert stats.regressor == compensate(read_log(path), cfg).attrs["drift_regressor"] == "temperature"

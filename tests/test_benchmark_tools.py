"""The diagnosis aids in ``benchmarks/``: run comparison (known ratios) and the hypothesis trace."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import compare_runs  # noqa: E402


def _run(rows):
    return pd.DataFrame([dict(zip(("class", "seed", "heading_rms_deg", "bias_rms_dps", "fused_rms_deg"), r),
                              method="default", split="tuning") for r in rows]).set_index(["class", "seed"])


def test_ratios_are_matched_by_class_and_seed_and_averaged_geometrically():
    before = _run([("a", 1, 1.0, 0.01, 2.0), ("a", 2, 4.0, 0.02, 1.0), ("b", 1, 1.0, 0.01, 1.0), ("b", 9, 1.0, 1.0, 1.0)])
    after = _run([("a", 2, 1.0, 0.02, 4.0), ("a", 1, 4.0, 0.01, 2.0), ("b", 1, 2.0, 0.01, 1.0), ("c", 1, 1.0, 1.0, 1.0)])
    r = compare_runs.ratios(before, after)
    assert sorted(r.index) == [("a", 1), ("a", 2), ("b", 1)]  # only seeds in both runs
    assert r.loc[("a", 1), "heading_rms_deg"] == 4.0 and r.loc[("a", 2), "fused_rms_deg"] == 4.0
    gm = compare_runs.geometric_means(r)
    assert np.isclose(gm.loc["a", "heading_rms_deg"], 1.0)  # 4 and 1/4
    assert np.isclose(gm.loc["a", "fused_rms_deg"], 2.0)  # 1 and 4
    assert np.isclose(gm.loc["b", "heading_rms_deg"], 2.0)
    assert np.isclose(gm.loc["all", "heading_rms_deg"], 2.0 ** (1 / 3))


def test_the_trace_prints_every_hypothesis_of_each_epoch_asked_for():
    out = subprocess.run([sys.executable, str(BENCH / "trace_hypotheses.py"), "no-temp-robot", "0", "--from", "20",
                          "--to", "23"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    epochs = [ln for ln in lines if ln.startswith("t ")]
    assert len(epochs) == 4 and all("truth rate" in ln for ln in epochs)
    modes = [ln.split()[0] for ln in lines if not ln.startswith("t ")]
    assert modes == [str(j) for j in range(6)] * 4
    probs = np.array([float(ln.split()[2]) for ln in lines if not ln.startswith("t ")]).reshape(4, 6)
    assert np.allclose(probs.sum(axis=1), 1.0, atol=2e-3)


def test_the_bursty_probe_draws_time_gaps_inside_turns():
    """``probe_bursty_turns.draw``: every stall is a time gap (20 typical steps or more), most
    fall inside a turn, and the gyro less its drift integrates to the reference heading."""
    import probe_bursty_turns

    log = probe_bursty_turns.draw(np.random.default_rng(0))
    t = log["t"].to_numpy()
    steps = np.diff(t)
    typical = np.median(steps)
    stalls = steps > 1.5 * typical
    assert stalls.sum() > 20 and np.all(steps[stalls] >= 20.0 * typical)
    rate = (log["gyro_z"] - log["true_bias_z"]).to_numpy()
    assert np.mean(np.abs(rate[1:][stalls]) > 10.0) > 0.3  # a third or more of the stalls in a turn
    turned = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * steps)])
    err = (log["ref_heading"].to_numpy() - log["ref_heading"].iloc[0] - turned + 180.0) % 360.0 - 180.0
    assert np.abs(err).max() < 1.0  # the gyro's noise and the stalls' trapezoids only (0.33 deg here)


def test_the_trace_runs_with_the_settings_given():
    """``--set`` reaches the model: a stillness far likelier a priori changes the first epochs' weights."""
    def first_epoch(*extra):
        out = subprocess.run([sys.executable, str(BENCH / "trace_hypotheses.py"), "no-temp-robot", "0", "--from", "0",
                              "--to", "2", "--modes", "0", *extra], capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        return [float(ln.split()[2]) for ln in out.stdout.splitlines() if not ln.startswith("t ")]

    default, set_ = first_epoch(), first_epoch("--set", "p_still0=0.99", "--set", "turn_shares=0.2,0.2,0.2,0.2")
    assert len(default) == len(set_) > 0
    assert set_[0] > default[0]


def test_the_slow_turn_sweep_counts_per_rate_and_temperature():
    """One draw a cell: 14 rows (two temperatures, seven rates); a 0.5 deg/s turn on a flat
    temperature is followed (docs/results.md, "Where slow turns end and compass ramps begin")."""
    out = subprocess.run([sys.executable, str(BENCH / "sweep_slow_turns.py"), "1"], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    rows = [ln.split("|")[1:-1] for ln in out.stdout.splitlines() if ln.startswith("| ") and "of" in ln]
    assert len(rows) == 14
    cells = {(float(r[0]), float(r[1])): r[2].strip() for r in rows}
    assert cells[(0.0, 0.5)] == "0 of 1" and float(rows[6][3]) < 1.0


def test_the_real_logs_table_measures_against_the_autopilots_heading(capsys):
    """``real_logs.py`` on the repository's real telemetry flight: a Markdown row with its rows,
    that it has the x/y gyros and a raw magnetometer, and three RMS cells against its ATTITUDE
    yaw; settings given as ``name=value`` reach the configuration."""
    import real_logs

    assert real_logs._setting("heading_rate=gyro_z") == ("heading_rate", "gyro_z")
    assert real_logs._setting("declination_deg=0") == ("declination_deg", 0.0)
    assert real_logs._rms([float("nan")]) == "–" and real_logs._rms([3.0, -4.0, float("nan")]) == "3.54"
    vtol = real_logs.ROOT / "tests" / "data" / "ardupilot_vtol.tlog"
    assert real_logs.main([], [vtol]) == 0
    row = [line for line in capsys.readouterr().out.splitlines() if "ardupilot_vtol" in line][0]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == "795" and cells[2] == "True, True"
    compass, heading, fused = (float(c) for c in cells[5:8])
    assert fused < heading < compass

"""Tests of gyrodrift.evaluate.montecarlo and the ``gyrodrift montecarlo`` command (tiny runs only)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from gyrodrift.cli import main
from gyrodrift.errors import ConfigError
from gyrodrift.fusion_offset import available as fusion_offset_available
from gyrodrift.evaluate.montecarlo import (
    ADVERSARIAL_FAMILIES,
    COLUMNS,
    DEFAULT_METHODS,
    FAMILIES,
    draw_case,
    markdown,
    run_case,
    run_monte_carlo,
    simulate_case,
    summarise,
)
from gyrodrift.simulate import DEFAULT_DURATION_S, SCENARIOS

TINY = 0.02  # durations x 0.02: 48 s (vehicle) to 864 s (soak)
METRICS = ["heading_rms_deg", "heading_max_deg", "bias_rms_dps"]


def test_families_map_to_scenarios():
    old = ["static", "interference-wander", "vehicle", "hysteresis", "cold-start", "soak"]
    assert list(FAMILIES) == old + list(ADVERSARIAL_FAMILIES)
    assert list(ADVERSARIAL_FAMILIES) == ["bursty", "ramp-interference", "sway", "vehicle-rawmag", "vessel",
                                          "no-temp", "short"]
    for family in FAMILIES.values():
        assert family.scenario in SCENARIOS
        assert family.duration_s == DEFAULT_DURATION_S[family.scenario]
    assert DEFAULT_METHODS[0] == "adaptive"
    assert set(DEFAULT_METHODS) >= {"adaptive", "stkf", "kf", "mlr", "lsm", "poly3", "fusion-offset"}


#: draw_case of the six original families, seed 0: (log_seed, calibration_seed, device c1, compass noise).
_OLD_CASES = {
    "static": (1011153410, 2033498012, -0.031177361511713783, 0.5920455227839132),
    "interference-wander": (806003562, 1639323459, 0.013253363007605667, 0.5999762720473867),
    "vehicle": (3294786, 891576921, 0.015800470779683683, 0.5510067916020799),
    "hysteresis": (2558700555, 1979149884, 0.013137609325928324, 0.4135230029260205),
    "cold-start": (1123712478, 1528351654, 0.02708695415733681, 0.4058017900324672),
    "soak": (2058229281, 3068979129, -0.030198630981765437, 0.5876058777754781),
}


def test_original_families_draw_the_same_cases():
    for family, expected in _OLD_CASES.items():
        case = draw_case(family, 0)
        assert (case.log_seed, case.calibration_seed, case.device.c1_dps_per_c, case.compass.noise_deg) == expected
        assert case.duration_s == DEFAULT_DURATION_S[family]


def test_short_family_draws_its_length_whatever_the_scale():
    lengths = [draw_case("short", s, duration_scale=0.1).duration_s for s in range(8)]
    assert all(20.0 <= x <= 40.0 for x in lengths) and len(set(lengths)) == 8
    assert draw_case("short", 3, duration_scale=5.0) == draw_case("short", 3, duration_scale=0.1)
    log, _ = simulate_case(draw_case("short", 3), calibration=False)
    assert log["t"].iloc[-1] == pytest.approx(lengths[3], abs=0.1)


def test_every_adversarial_family_runs_and_reports_failures_as_rows():
    df = run_monte_carlo(ADVERSARIAL_FAMILIES, [1], ["kf", "fusion-offset"], duration_scale=TINY, workers=1)
    assert list(df["family"]) == [f for f in ADVERSARIAL_FAMILIES for _ in range(2)]
    assert set(df["status"]) <= {"ok", "error"}
    failed = df[df["status"] == "error"]
    assert (failed["error"] != "").all() and not failed["error"].str.contains("\n").any()
    ok = df[df["status"] == "ok"]
    assert np.isfinite(ok[METRICS].to_numpy()).all()
    if fusion_offset_available():
        assert set(ok["family"]) >= {"ramp-interference", "sway", "vehicle-rawmag", "vessel", "no-temp"}


def test_cases_are_seeded_by_family_and_seed():
    a = draw_case("static", 3)
    assert a == draw_case("static", 3)
    assert a.device != draw_case("static", 4).device
    assert a.device != draw_case("cold-start", 3).device  # same seed, other family: another device
    assert a.log_seed != a.calibration_seed
    assert draw_case("hysteresis", 0).device.has_memory()
    assert not any(draw_case(f, 0).device.has_memory() for f in FAMILIES if f != "hysteresis")
    assert draw_case("soak", 1, duration_scale=0.5).duration_s == 0.5 * DEFAULT_DURATION_S["soak"]


def test_calibration_run_is_the_same_device():
    case = draw_case("vehicle", 2, duration_scale=TINY)
    log, cal = simulate_case(case, fs_hz=10.0)
    assert log.attrs["scenario"] == "vehicle" and cal.attrs["scenario"] == "calibration"
    assert log.attrs["device"] == cal.attrs["device"]
    assert log.attrs["seed"] != cal.attrs["seed"]
    assert cal["temp"].min() < -9.0 and cal["temp"].max() > 59.0
    assert simulate_case(case, calibration=False)[1] is None


def test_run_is_finite_and_independent_of_workers():
    kwargs = dict(families=["static", "soak"], seeds=2, methods=["adaptive", "kf"], duration_scale=TINY)
    serial = run_monte_carlo(**kwargs, workers=1)
    assert list(serial.columns) == list(COLUMNS)
    assert list(serial["family"]) == ["static"] * 4 + ["soak"] * 4
    assert list(serial["seed"]) == [0, 0, 1, 1] * 2
    assert list(serial["method"]) == ["adaptive", "kf"] * 4
    assert (serial["status"] == "ok").all() and (serial["error"] == "").all()
    assert np.isfinite(serial[METRICS].to_numpy()).all()
    assert (serial[METRICS].to_numpy() >= 0).all()
    assert serial.attrs["duration_scale"] == TINY
    parallel = run_monte_carlo(**kwargs, workers=2)
    pd.testing.assert_frame_equal(serial, parallel)


def test_poly3_and_oracle_run_on_the_same_log():
    rows = run_case("cold-start", 0, ["poly3", "oracle", "adaptive"], duration_scale=TINY)
    assert [r["status"] for r in rows] == ["ok", "ok", "ok"]
    oracle = rows[1]
    assert oracle["bias_rms_dps"] == 0.0
    assert oracle["heading_rms_deg"] < min(rows[0]["heading_rms_deg"], rows[2]["heading_rms_deg"])


def test_a_failing_method_is_reported_not_raised():
    # "fixed" is a registered estimator that cannot be built from settings alone
    df = run_monte_carlo(["vehicle"], [5], ["kf", "fixed"], duration_scale=TINY, workers=1)
    assert list(df["status"]) == ["ok", "error"]
    assert "cannot be built" in df["error"].iloc[1]
    assert math.isnan(df["heading_rms_deg"].iloc[1])
    summary = summarise(df, reference="kf")
    assert summary.set_index("method").loc["fixed", "failed"] == 1


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"families": ["static", "bogus"]}, "bogus"),
        ({"methods": ["adaptive", "nope"]}, "nope"),
        ({"seeds": 0}, "seeds"),
        ({"seeds": [1, -2]}, "seeds"),
        ({"duration_scale": 0.0}, "duration_scale"),
        ({"workers": 0}, "workers"),
        ({"methods": ["kf", "kf"]}, "repeat"),
    ],
)
def test_invalid_arguments(kwargs, match):
    base = dict(families=["static"], seeds=1, methods=["kf"], duration_scale=TINY, workers=1)
    with pytest.raises(ConfigError, match=match):
        run_monte_carlo(**{**base, **kwargs})


def _fake_runs() -> pd.DataFrame:
    """Two families, three seeds, three methods, with chosen numbers."""
    rows = []
    numbers = {  # (heading_rms_deg, bias_rms_dps) for seeds 0, 1, 2
        ("a", "adaptive"): [(1.0, 0.01), (2.0, 0.02), (3.0, 0.03)],
        ("a", "kf"): [(2.0, 0.02), (1.0, 0.03), (4.0, 0.04)],  # adaptive wins seeds 0 and 2
        ("a", "lsm"): [(0.5, 0.005), (0.5, 0.005), (0.5, 0.005)],  # adaptive never wins
        ("b", "adaptive"): [(1.0, 0.01), (1.0, 0.01), (1.0, 0.01)],
        ("b", "kf"): [(2.0, 0.02), (2.0, 0.02), (2.0, 0.02)],
        ("b", "lsm"): [(2.0, 0.02), (2.0, 0.02), (9.0, 0.09)],
    }
    for (family, method), values in numbers.items():
        for seed, (h, b) in enumerate(values):
            rows.append(
                {"family": family, "seed": seed, "method": method, "scenario": "static", "duration_s": 1.0,
                 "heading_rms_deg": h, "heading_max_deg": 2 * h, "bias_rms_dps": b, "status": "ok", "error": ""}
            )
    df = pd.DataFrame(rows, columns=list(COLUMNS))
    return df.sort_values(["family", "seed"], kind="stable").reset_index(drop=True)


def test_summarise_counts_wins_on_both_metrics():
    s = summarise(_fake_runs()).set_index(["family", "method"])
    assert list(s.index.get_level_values(0).unique()) == ["a", "b", "all"]
    assert s.loc[("a", "kf"), "wins"] == 2 and s.loc[("a", "kf"), "pairs"] == 3
    assert s.loc[("a", "lsm"), "wins"] == 0
    assert s.loc[("b", "kf"), "wins"] == 3 and s.loc[("b", "lsm"), "wins"] == 3
    assert s.loc[("all", "kf"), "wins"] == 5 and s.loc[("all", "kf"), "pairs"] == 6
    assert pd.isna(s.loc[("a", "adaptive"), "wins"])
    assert s.loc[("a", "kf"), "heading_rms_mean_deg"] == pytest.approx(7.0 / 3.0)
    assert s.loc[("a", "kf"), "heading_rms_median_deg"] == 2.0
    assert s.loc[("b", "lsm"), "bias_rms_median_dps"] == 0.02
    assert bool(s.loc[("a", "kf"), "better_mean"]) and not bool(s.loc[("a", "lsm"), "better_mean"])
    assert (s["n"] == s["n"].max()).sum() == 3  # the "all" rows have every case


def test_markdown_reports_tuning_and_held_out_families():
    summary = summarise(_fake_runs())
    text = markdown(summary)
    assert text.splitlines()[0].startswith("| family | method | n |")
    assert "| a | kf | 3 | 0 |" in text and "2/3" in text
    split = markdown(summary, tuned_on="a")
    assert "Settings tuned on `a`" in split and "Held-out families (settings frozen)" in split
    tuned, held = split.split("Held-out families")
    assert "| a | kf |" in tuned and "| b | kf |" not in tuned
    assert "| b | kf |" in held and "| all |" not in held
    with pytest.raises(ConfigError, match="tuned_on"):
        markdown(summary, tuned_on="zzz")


def test_cli_montecarlo_end_to_end(tmp_path, capsys):
    out = tmp_path / "mc.csv"
    rc = main([
        "montecarlo", "--families", "static,vehicle", "--seeds", "2", "--methods", "adaptive", "kf",
        "--duration-scale", str(TINY), "--workers", "1", "-o", str(out), "--markdown", "--tuned-on", "static",
    ])
    assert rc == 0
    text = capsys.readouterr().out
    assert "| static | adaptive | 2 | 0 |" in text and "Held-out families" in text
    assert "0 of 8 runs failed" in text
    runs = pd.read_csv(out, keep_default_na=False)
    assert list(runs.columns) == list(COLUMNS) and len(runs) == 8
    assert (runs["status"] == "ok").all()


def test_cli_montecarlo_plain_table(capsys):
    rc = main(["montecarlo", "--families", "vehicle", "--seeds", "1", "--methods", "kf,adaptive",
               "--duration-scale", str(TINY), "--workers", "1"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "heading_rms_mean_deg" in text and "|" not in text.splitlines()[0]


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--families", "bogus"], "unknown family bogus"),
        (["--methods", "nope"], "unknown method"),
        (["--seeds", "0"], "--seeds"),
        (["--duration-scale", "-1"], "duration_scale"),
    ],
)
def test_cli_montecarlo_errors_are_one_line(argv, match, capsys):
    rc = main(["montecarlo", "--workers", "1", *argv])
    assert rc == 2
    err = capsys.readouterr().err
    assert err.startswith("gyrodrift: error:") and match in err and len(err.strip().splitlines()) == 1

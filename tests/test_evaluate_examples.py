"""Small known answers of the evaluation, the batch helpers and the command line (they were docstring examples)."""

from __future__ import annotations

import pandas as pd

from gyrodrift.evaluate.metrics import error_stats, heading_error_deg, markdown_table, paper_table2


def test_metrics_examples():
    assert float(heading_error_deg(1.0, 359.0)) == 2.0
    assert error_stats([1.0, -1.0, 1.0, -1.0])["rms"] == 1.0
    assert float(paper_table2("dynamic").loc["mean", "Adaptive Algorithm"]) == 0.2743


def test_markdown_table_example():
    df = pd.DataFrame({"KF": [0.5, 0.25]}, index=pd.Index(["mean", "variance"], name="stat"))
    assert markdown_table(df, ".2f").splitlines() == [
        "| stat | KF |", "| :--- | ---: |", "| mean | 0.50 |", "| variance | 0.25 |"]


def test_method_label():
    from gyrodrift.evaluate.compare import DEFAULT_METHOD, method_label

    assert method_label(DEFAULT_METHOD) == "adaptive (default)"
    assert method_label("kf") == "kf"


def test_allan_examples():
    import numpy as np

    from gyrodrift.evaluate.allan import allan_deviation, even_rate, noise_terms

    rate = np.random.default_rng(0).normal(0.0, 0.04 * np.sqrt(100.0), 200_000)  # N = 0.04 deg/√s at 100 Hz
    terms = noise_terms(allan_deviation(rate, 100.0))
    assert (round(terms.arw.value, 3), terms.rate_ramp is None) == (0.04, True)
    r = allan_deviation([892, 809, 823, 798, 671, 644, 883, 903, 677], 1.0, taus=[1, 2], unit="")  # NBS14, SP 1065
    assert [round(float(v), 5) for v in r.adev] == [91.22945, 85.95287]
    rate, fs, resampled = even_rate(np.array([0.0, 0.1, 0.25, 0.3, 0.4]), [1.0, 1.0, 1.0, 1.0, 1.0])
    assert (rate.round(12).tolist(), fs, resampled) == ([1.0, 1.0, 1.0, 1.0], 10.0, True)


def test_scale_factor_experiment_example():
    from gyrodrift.evaluate.paper import scale_factor_experiment

    res = scale_factor_experiment(seed=0, fs_hz=10.0)  # the 3-h experiment at 10 Hz (about a second)
    assert sorted(res) == ["config", "fig10", "fig11", "log", "out", "sf", "summary", "turns"]
    assert res["summary"]["sf_rms"]["adaptive"] < 1e-3 < res["summary"]["sf_rms"]["fixed"]
    part = res["summary"]["sf_heading_rms_deg"]
    assert part["adaptive"] < part["fixed"] < part["none"]


def test_monte_carlo_examples():
    from gyrodrift.evaluate.montecarlo import draw_case, run_monte_carlo

    df = run_monte_carlo(["static"], 1, ["adaptive", "kf"], duration_scale=0.02, workers=1)
    assert (list(df["method"]), list(df["status"])) == (["adaptive", "kf"], ["ok", "ok"])
    assert draw_case("vehicle", 3) == draw_case("vehicle", 3)
    assert draw_case("vehicle", 3).device != draw_case("static", 3).device


def test_plotbase_examples():
    import numpy as np

    from gyrodrift.evaluate.plotbase import minmax_decimate, time_axis

    x = np.arange(100_000.0)
    y = np.zeros_like(x)
    y[54_321] = 5.0
    xd, yd = minmax_decimate(x, y, 1000)
    assert (len(xd) <= 1000, float(yd.max()), float(xd[np.argmax(yd)])) == (True, 5.0, 54321.0)
    assert time_axis([0.0, 1800.0])[1] == "time from start (min)"


def test_fleet_output_names():
    from gyrodrift.fleet import common_root, output_path

    assert common_root(["/data/runs/a/x.csv", "/data/runs/b/x.csv"]).as_posix() == "/data/runs"
    assert output_path("logs/run1.csv.gz", "out").as_posix() == "out/run1_out.parquet"
    assert output_path("runs/b/x.csv", "out", root="runs").as_posix() == "out/b/x_out.parquet"

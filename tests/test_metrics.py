"""Tests of gyrodrift.evaluate.metrics: Table 2 statistics with known answers, the paper's numbers, Markdown."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.evaluate.metrics import (
    PAPER_METHODS,
    PAPER_TABLE2,
    TABLE2_STATS,
    Accuracy,
    accuracy,
    bias_error,
    error_stats,
    heading_error_deg,
    heading_error_stats,
    markdown_table,
    paper_table2,
    raw_heading_deg,
    table2,
)

PAPER = Path(__file__).resolve().parents[2] / "shared" / "paper" / "feng-2015-stkf-gyro-temperature-drift.txt"


def out_table(n: int = 1000, fs: float = 10.0, **cols) -> pd.DataFrame:
    """A hand-made output table: t at fs Hz plus the given columns (scalars broadcast)."""
    t = np.arange(n) / fs
    df = pd.DataFrame({"t": t})
    for name, v in cols.items():
        df[name] = np.broadcast_to(np.asarray(v, dtype=float), t.shape).copy()
    return df


# -------------------------------------------------------------------- bias error


def test_constant_bias_error_gives_that_mean_and_zero_variance():
    drift = 0.3 + 0.01 * np.sin(np.arange(1000) / 50.0)
    out = out_table(bias_z=drift + 2.5e-4, true_bias_z=drift, rate_z=0.7)
    e = bias_error(out)
    np.testing.assert_allclose(e, 2.5e-4, rtol=1e-9)
    s = error_stats(e)
    assert s["mean"] == pytest.approx(2.5e-4, rel=1e-9)
    assert s["variance"] == pytest.approx(0.0, abs=1e-20)
    assert s["max_abs"] == pytest.approx(2.5e-4) and s["n"] == 1000


def test_without_truth_the_error_is_the_compensated_rate():
    rate = np.linspace(-1e-3, 1e-3, 1000)
    out = out_table(bias_z=0.3, rate_z=rate)
    np.testing.assert_array_equal(bias_error(out), rate)


def test_averaging_windows():
    # 100 s at 10 Hz; error = whole second of t, so 10-s windows average to 4.5, 14.5, ...
    out = out_table(1000, 10.0, bias_z=0.0, true_bias_z=0.0)
    out["bias_z"] = np.floor(out["t"].to_numpy() + 1e-9)
    means = bias_error(out, average_s=10.0)
    np.testing.assert_allclose(means, 4.5 + 10.0 * np.arange(10))
    # 1-s windows hold exactly their 10 samples (edges in floating point)
    np.testing.assert_allclose(bias_error(out, average_s=1.0), np.arange(100.0))


def test_averaging_drops_the_partial_last_window_and_nans():
    out = out_table(1050, 10.0, rate_z=1.0)  # 105 s: ten complete 10-s windows + half of one
    out.loc[5, "rate_z"] = np.nan
    out.loc[100:199, "rate_z"] = 3.0
    means = bias_error(out, average_s=10.0)
    np.testing.assert_allclose(means, [1.0, 3.0] + [1.0] * 8)


def test_averaging_needs_one_complete_window():
    out = out_table(50, 10.0, rate_z=0.0)
    with pytest.raises(ConfigError, match="no complete window"):
        bias_error(out, average_s=10.0)
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(ConfigError):
            bias_error(out, average_s=bad)


def test_bias_error_needs_a_rate_or_bias_column():
    with pytest.raises(LogFormatError, match="rate_z"):
        bias_error(out_table(10, heading=1.0))


# ----------------------------------------------------------------- heading error


def test_heading_error_wraps_across_north():
    out = out_table(4, heading=[359.0, 1.0, 0.5, 179.0], ref_heading=[1.0, 359.0, 359.5, -179.0 % 360.0])
    # errors: -2, +2, +1, -2 (179 vs 181)
    s = heading_error_stats(out)
    assert s["mean"] == pytest.approx(-0.25)
    assert s["min"] == pytest.approx(-2.0) and s["max"] == pytest.approx(2.0)
    assert s["max_abs"] == pytest.approx(2.0)
    assert s["rms"] == pytest.approx(math.sqrt((4 + 4 + 1 + 4) / 4))
    assert s["variance"] == pytest.approx(np.var([-2.0, 2.0, 1.0, -2.0], ddof=1))
    assert s["std"] == pytest.approx(math.sqrt(s["variance"]))


def test_heading_error_is_in_minus_180_to_180():
    out = out_table(3, heading=[180.0, 0.0, 90.0], ref_heading=[0.0, 180.0, 270.0])
    s = heading_error_stats(out)
    assert s["min"] == -180.0 and s["max"] == -180.0  # [-180, 180): half a turn is -180


def test_heading_rows_without_reference_are_left_out():
    out = out_table(4, heading=10.0, ref_heading=[9.0, np.nan, 11.0, np.nan])
    s = heading_error_stats(out)
    assert s["n"] == 2 and s["mean"] == pytest.approx(0.0) and s["max_abs"] == pytest.approx(1.0)


def test_heading_stats_need_a_reference():
    with pytest.raises(LogFormatError, match="ref_heading"):
        heading_error_stats(out_table(5, heading=1.0))


def test_error_stats_known_values():
    s = error_stats([1.0, 2.0, 3.0, 4.0, np.nan])
    assert s == pytest.approx(
        {"mean": 2.5, "variance": 5.0 / 3.0, "std": math.sqrt(5.0 / 3.0), "min": 1.0, "max": 4.0,
         "rms": math.sqrt(7.5), "max_abs": 4.0, "n": 4}
    )
    with pytest.raises(LogFormatError):
        error_stats([np.nan])
    assert math.isnan(error_stats([1.0])["variance"])


# ----------------------------------------------------------------------- Table 2


def test_table2_layout_and_method_order():
    runs = {
        "Adaptive Algorithm": out_table(bias_z=0.30, true_bias_z=0.30),
        "MLR": out_table(bias_z=0.32, true_bias_z=0.30),
        "KF": out_table(bias_z=0.29, true_bias_z=0.30),
    }
    df = table2(runs, kind="static")
    assert list(df.columns) == ["Adaptive Algorithm", "MLR", "KF"]
    assert tuple(df.index) == TABLE2_STATS == ("mean", "variance", "std", "rms", "max_abs")
    assert df.index.name == "bias drift error (deg/s)"
    assert df.loc["mean", "MLR"] == pytest.approx(0.02)
    assert df.loc["mean", "KF"] == pytest.approx(-0.01)
    assert df.loc["max_abs", "KF"] == pytest.approx(0.01)
    np.testing.assert_allclose(df.loc["variance"].to_numpy(), 0.0, atol=1e-20)


def test_table2_dynamic_uses_heading_error():
    runs = {"B": out_table(heading=1.0, ref_heading=359.0), "A": out_table(heading=358.0, ref_heading=0.0)}
    df = table2(runs, kind="dynamic")
    assert list(df.columns) == ["B", "A"]
    assert df.index.name == "heading error (deg)"
    assert df.loc["mean"].tolist() == pytest.approx([2.0, -2.0])


def test_table2_static_with_averaging():
    out = out_table(1000, 10.0, rate_z=0.0)
    out["rate_z"] = np.where(np.arange(1000) % 2 == 0, 1.0, -1.0)  # white-ish ±1, zero mean per window
    df = table2({"raw": out}, kind="static", average_s=10.0)
    assert df.loc["variance", "raw"] == pytest.approx(0.0, abs=1e-20)
    assert table2({"raw": out}, kind="static").loc["variance", "raw"] == pytest.approx(1000 / 999)


@pytest.mark.parametrize("kw", [{"kind": "rotating"}, {"kind": "dynamic", "average_s": 10.0}])
def test_table2_bad_arguments(kw):
    with pytest.raises(ConfigError):
        table2({"m": out_table(heading=0.0, ref_heading=0.0, rate_z=0.0)}, **kw)
    with pytest.raises(ConfigError):
        table2({})


def test_table2_on_compensated_logs():
    """Real output tables: static from a compensated synthetic log, both kinds."""
    log = synthetic_log(duration_s=240.0, fs_hz=20.0, gyro_noise_dps=0.05, compass_noise_deg=0.3, seed=2)
    out = compensate(log, CompensatorConfig(init_s=30.0))
    df = table2({"stkf": out}, kind="static")
    acc = accuracy(out)
    assert df.loc["rms", "stkf"] == pytest.approx(acc.bias_rms)
    dyn = table2({"stkf": out}, kind="dynamic")
    assert dyn.loc["rms", "stkf"] == pytest.approx(acc.heading_rms)
    assert dyn.loc["max_abs", "stkf"] == pytest.approx(acc.heading_max)


# ---------------------------------------------------------- the paper's Table 2


def _paper_number(text: str) -> float:
    """'-1.1496×10^{-4}' or '0.002134' as printed in the paper text."""
    text = text.strip().replace("−", "-")
    m = re.fullmatch(r"(-?[\d.]+)\s*(?:×\s*10\^\{(-?\d+)\})?", text)
    assert m, text
    return float(m.group(1)) * (10.0 ** int(m.group(2)) if m.group(2) else 1.0)


def _paper_table2_from_text() -> dict[str, dict[str, tuple[float, float]]]:
    lines = PAPER.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Table 2."))
    rows = [line for line in lines[start + 1 : start + 12] if line.startswith("|")]
    header = [c.strip() for c in rows[0].strip("|").split("|")]
    assert header[2:] == list(PAPER_METHODS)
    body = [[c.strip() for c in r.strip("|").split("|")] for r in rows[2:]]
    assert len(body) == 6
    out = {}
    for kind, (mean_row, var_row) in zip(PAPER_TABLE2, zip(body[::2], body[1::2])):
        assert mean_row[1].startswith("Mean") and var_row[1] == "Variance"
        out[kind] = {
            m: (_paper_number(a), _paper_number(v)) for m, a, v in zip(PAPER_METHODS, mean_row[2:], var_row[2:])
        }
    return out


@pytest.fixture
def paper_text_table2():
    if not PAPER.is_file():
        pytest.skip(f"paper text not found at {PAPER}")
    return _paper_table2_from_text()


def test_paper_table2_matches_the_paper(paper_text_table2):
    # a couple by hand, then every cell
    assert PAPER_TABLE2["static"]["Adaptive Algorithm"].variance == 6.7660e-5
    assert paper_text_table2["static"]["Adaptive Algorithm"][1] == pytest.approx(6.7660e-5, rel=1e-12)
    assert PAPER_TABLE2["dynamic"]["Modified LSM"].mean == -11.5318
    assert paper_text_table2["dynamic"]["Modified LSM"][0] == pytest.approx(-11.5318, rel=1e-12)
    for kind, rows in paper_text_table2.items():
        for method, (mean, var) in rows.items():
            assert PAPER_TABLE2[kind][method] == pytest.approx((mean, var), rel=1e-12), (kind, method)


def test_paper_text_quotes_the_same_static_means(paper_text_table2):
    text = PAPER.read_text(encoding="utf-8")
    assert "improved to $0.002134^\\circ/\\text{s}$ with the compensation by MLR" in text
    assert "$2.1619 \\times 10^{-5}" in text
    assert PAPER_TABLE2["static"]["MLR"].mean == 0.002134
    assert PAPER_TABLE2["static"]["Adaptive Algorithm"].mean == 2.1619e-5


def test_paper_table2_is_read_only_and_in_table2_layout():
    with pytest.raises(TypeError):
        PAPER_TABLE2["static"] = {}
    with pytest.raises(TypeError):
        PAPER_TABLE2["dynamic"]["KF"] = (0.0, 0.0)
    df = paper_table2("static_interference")
    assert list(df.columns) == list(PAPER_METHODS)
    assert list(df.index) == ["mean", "variance"] and df.index.name == "bias drift error (deg/s)"
    assert df.loc["mean", "KF"] == 0.003023
    assert paper_table2("dynamic").index.name == "heading error (deg)"
    with pytest.raises(ConfigError):
        paper_table2("static_without")


# ----------------------------------------------------------------------- Markdown


def test_markdown_table_exact():
    df = pd.DataFrame(
        {"KF": [1.5e-4, 7.5105e-05], "note|x": ["a|b", None]},
        index=pd.Index(["mean", "variance"], name="bias drift error (deg/s)"),
    )
    assert markdown_table(df, ".3g") == (
        "| bias drift error (deg/s) | KF | note\\|x |\n"
        "| :--- | ---: | :--- |\n"
        "| mean | 0.00015 | a\\|b |\n"
        "| variance | 7.51e-05 |  |"
    )


def test_markdown_table_without_index_and_nan():
    df = pd.DataFrame({"a": [1.0, np.nan], "n": [3, 4]})
    assert markdown_table(df, ".1f", index=False) == "| a | n |\n| ---: | ---: |\n| 1.0 | 3 |\n|  | 4 |"


def test_markdown_of_table2_keeps_method_order():
    runs = {"Z": out_table(bias_z=1.0, true_bias_z=1.0), "A": out_table(bias_z=1.0, true_bias_z=1.0)}
    md = markdown_table(table2(runs), ".4g")
    assert md.splitlines()[0] == "| bias drift error (deg/s) | Z | A |"
    assert len(md.splitlines()) == 2 + len(TABLE2_STATS)
    assert markdown_table(paper_table2("dynamic"), ".4f").splitlines()[2] == (
        "| mean | 1.4882 | -1.9085 | -11.5318 | 0.2743 |"
    )


# ------------------------------------------------- existing API (unchanged)


def test_existing_functions_keep_working():
    assert float(heading_error_deg(1.0, 359.0)) == 2.0
    np.testing.assert_allclose(raw_heading_deg([0.0, 1.0, 2.0], [1.0, 1.0, 1.0], 10.0), [10.0, 11.0, 12.0])
    out = out_table(10, heading=5.0, ref_heading=4.0, gyro_z=0.0, bias_z=0.2, true_bias_z=0.1)
    acc = accuracy(out)
    assert isinstance(acc, Accuracy)
    assert acc.heading_rms == pytest.approx(1.0) and acc.bias_rms == pytest.approx(0.1)

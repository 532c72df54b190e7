"""A shortened `gyrodrift paper` run (every scenario 10x shorter): it runs and writes what it claims."""

import json

import pytest

from gyrodrift.cli import main
from gyrodrift.evaluate.metrics import PAPER_METHODS
from gyrodrift.evaluate.paper import OURS_TO_PAPER, PaperSettings, run_paper, same_size, table2_comparison


def test_ours_cover_the_papers_methods():
    assert set(OURS_TO_PAPER.values()) == set(PAPER_METHODS)


def test_same_size_rule():
    assert same_size(1e-4, 1.9e-4) and same_size(-2.0, -1.1)
    assert not same_size(1e-4, -1e-4) and not same_size(1e-4, 2.1e-4) and not same_size(1.0, 0.49)


def test_table2_layout_on_short_runs():
    runs = run_paper(PaperSettings(duration_scale=0.1, methods=("stkf", "kf", "lsm", "mlr", "oracle")))
    assert set(runs) == {"static", "static-outages", "static-interference", "vehicle"}
    # forced outages: the compass really is gone in three windows
    assert (runs["static-outages"].outputs["stkf"]["gate_reason"] == "no_compass").sum() > 0
    tables = table2_comparison(runs)
    for kind, df in tables.items():
        assert list(df.columns[:4]) == ["Adaptive Algorithm", "KF", "Modified LSM", "MLR"]
        assert df.loc[("paper", "mean"), "Adaptive Algorithm"] == {
            "static": 2.1619e-5, "static_interference": 1.7511e-4, "dynamic": 0.2743}[kind]
        assert df.loc[("ours", "mean"), "oracle"] == 0.0 or kind == "dynamic"


@pytest.mark.slow
def test_full_paper_run(tmp_path):
    assert main(["paper", "-o", str(tmp_path)]) == 0
    assert (tmp_path / "fig10_11_scale_factor.png").stat().st_size > 20_000


def test_paper_command_quick(tmp_path, capsys):
    assert main(["paper", "-o", str(tmp_path / "p"), "--quick"]) == 0
    out = tmp_path / "p"
    names = {p.name for p in out.iterdir()}
    assert {"table2.md", "results.json", "fig04_heading_error_static.png", "fig06_allan_static.png",
            "fig09_heading_error_vehicle.png", "fig10_11_scale_factor.png"} <= names
    text = (out / "table2.md").read_text()
    assert "Adaptive Algorithm" in text and "| Fig. 5 |" in text and "reproduced" in text
    data = json.loads((out / "results.json").read_text())
    assert data["table2"]["static"]["paper:mean"]["MLR"] == 0.002134
    assert {c["where"] for c in data["claims"]} >= {"Fig. 4", "Fig. 5", "Fig. 9", "Table 2", "Fig. 10", "Fig. 11"}

"""Fleets of logs: gyrodrift.fleet (find_logs, process_one, process_many, `gyrodrift batch`)."""

import argparse
import sys

import numpy as np
import pandas as pd
import pytest

from gyrodrift import fleet
from gyrodrift.cli.batch import add_batch_parser, batch_command
from gyrodrift.compensator import compensate
from gyrodrift.errors import ConfigError
from gyrodrift.fleet import (
    SUMMARY_COLUMNS,
    find_logs,
    output_path,
    process_many,
    process_one,
)
from gyrodrift.io import read_log, write_table
from gyrodrift.simulate import simulate

GOOD = ("run0.csv", "run1.parquet", "run2.csv.gz")
SHORT = ("short.csv",)  # shorter than the init window: compensated, with a note
BAD = ("corrupt.csv",)
#: Summary columns that must not depend on how the logs were scheduled.
NUMBERS = [c for c in SUMMARY_COLUMNS if c != "seconds"]


def _sim(seed: int, duration_s: float) -> pd.DataFrame:
    log = simulate("static", duration_s=duration_s, fs_hz=10, seed=seed)
    log.attrs = {}
    return log


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    """4 good simulated logs (CSV, Parquet, gzip CSV, one shorter than the init window), a corrupt
    one, and a stray file."""
    d = tmp_path_factory.mktemp("fleet")
    write_table(_sim(0, 300.0), d / "run0.csv")
    write_table(_sim(1, 300.0), d / "run1.parquet")
    _sim(2, 300.0).to_csv(d / "run2.csv.gz", index=False)
    (d / "corrupt.csv").write_bytes(bytes(range(256)) * 16)  # binary garbage
    write_table(_sim(3, 20.0), d / "short.csv")  # shorter than the init window: compensated with a note
    (d / "notes.txt.bak").write_text("not a log\n")
    return d


def _parse(argv):
    p = argparse.ArgumentParser(prog="gyrodrift")
    sub = p.add_subparsers(dest="command")
    add_batch_parser(sub)
    return p.parse_args(argv)


def _by_name(summary: pd.DataFrame) -> dict:
    return {name.split("/")[-1]: row for name, row in zip(summary["file"], summary.to_dict("records"))}


# ------------------------------------------------------------------ finding logs


def test_find_logs_folder_glob_and_single_file(fleet_dir):
    found = find_logs(fleet_dir)
    assert [p.name for p in found] == sorted(GOOD + SHORT + BAD)
    assert [p.name for p in find_logs(str(fleet_dir / "run*"))] == sorted(GOOD)
    assert [p.name for p in find_logs(fleet_dir / "run1.parquet")] == ["run1.parquet"]


def test_find_logs_nothing_found_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="no logs found"):
        find_logs(tmp_path)
    with pytest.raises(ConfigError, match="no logs found"):
        find_logs(str(tmp_path / "*.csv"))
    with pytest.raises(ConfigError, match="no such folder"):
        find_logs(tmp_path / "missing")


def test_output_path_strips_the_log_ending(tmp_path):
    assert output_path("a/run.csv.gz", tmp_path).name == "run_out.parquet"
    assert output_path("a/Run.PQ", tmp_path, "csv").name == "Run_out.csv"
    assert output_path("a/b.c.ulg", tmp_path).name == "b.c_out.parquet"
    with pytest.raises(ConfigError, match="output format"):
        output_path("a.csv", tmp_path, "xlsx")


# ------------------------------------------------------------------ one log


def test_process_one_matches_compensate_exactly(fleet_dir, tmp_path):
    for name in GOOD:
        path = fleet_dir / name
        row = process_one(path, tmp_path)
        assert row["status"] == "ok" and row["error"] == ""
        assert set(row) == set(SUMMARY_COLUMNS)
        expected = compensate(read_log(path), source=str(path))
        written = pd.read_parquet(output_path(path, tmp_path))
        as_written = expected.copy()
        for col in ("gate_reason", "unobservable"):  # categorical in memory, text in the file
            as_written[col] = as_written[col].astype(str)
        pd.testing.assert_frame_equal(written, as_written, check_exact=True)
        a, b, c = expected.attrs["final_params"]
        assert (row["a"], row["b"], row["c"]) == (a, b, c)
        assert row["updates"] == int(expected["updated"].sum())
        assert row["rows"] == len(expected)
        assert row["duration_s"] == pytest.approx(300.0)
        assert row["temp_min_c"] == expected["temp"].min() and row["temp_max_c"] == expected["temp"].max()


def test_process_one_csv_output(fleet_dir, tmp_path):
    row = process_one(fleet_dir / "run0.csv", tmp_path, out_format="csv")
    assert row["status"] == "ok"
    back = read_log(fleet_dir / "run0.csv")
    out = pd.read_csv(tmp_path / "run0_out.csv", keep_default_na=False, na_values=[""])
    np.testing.assert_array_equal(out["t"], back["t"])


def test_process_one_never_raises(fleet_dir, tmp_path, monkeypatch):
    bad = process_one(fleet_dir / "corrupt.csv", tmp_path)
    assert bad["status"] == "error" and "corrupt.csv" in bad["error"] and "binary" in bad["error"]
    assert not list(tmp_path.iterdir())  # nothing written for a failed log

    def boom(*args, **kwargs):
        raise RuntimeError("boom\nwith a second line")

    monkeypatch.setattr(sys.modules["gyrodrift.pipeline"], "compensate_file", boom)
    row = process_one(fleet_dir / "run0.csv", tmp_path)
    assert row["status"] == "error"
    assert row["error"] == "unexpected RuntimeError: boom with a second line"


# ------------------------------------------------------------------ many logs / CLI


def test_batch_processes_good_logs_and_reports_bad_ones(fleet_dir, tmp_path, capsys):
    out_dir = tmp_path / "out"  # created by the command
    code = batch_command(_parse(["batch", str(fleet_dir), "-o", str(out_dir), "--workers", "2"]))
    printed = capsys.readouterr().out
    assert code == 1
    assert "4 ok, 1 failed" in printed.splitlines()
    assert printed.startswith("| file | status | error |")
    summary = pd.read_csv(out_dir / "summary.csv", keep_default_na=False, na_values=[""])
    assert list(summary.columns) == list(SUMMARY_COLUMNS)
    assert [p.split("/")[-1] for p in summary["file"]] == sorted(GOOD + SHORT + BAD)  # input order
    rows = _by_name(summary)
    for name in GOOD:
        assert rows[name]["status"] == "ok"
        assert (out_dir / output_path(name, out_dir).name).is_file()
    for name in BAD:
        err = rows[name]["error"]
        assert rows[name]["status"] == "error" and name in err and "\n" not in err
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(
        ["summary.csv"] + [output_path(n, out_dir).name for n in GOOD + SHORT]
    )
    assert not [p for p in out_dir.iterdir() if p.name.startswith(".")]  # no temporary files left


def test_batch_all_ok_exits_0_and_writes_csv(fleet_dir, tmp_path, capsys):
    code = batch_command(_parse(["batch", str(fleet_dir / "run*.csv"), "-o", str(tmp_path), "--workers", "1",
                                 "--format", "csv"]))
    assert code == 0
    assert "1 ok, 0 failed" in capsys.readouterr().out
    assert (tmp_path / "run0_out.csv").is_file()


def test_batch_usage_errors_exit_2(fleet_dir, tmp_path, capsys):
    assert batch_command(_parse(["batch", str(tmp_path / "*.csv"), "-o", str(tmp_path / "o")])) == 2
    assert "no logs found" in capsys.readouterr().err
    assert batch_command(_parse(["batch", str(fleet_dir), "-o", str(tmp_path),
                                 "--config", str(tmp_path / "missing.toml")])) == 2
    err = capsys.readouterr().err
    assert err.startswith("gyrodrift: error:") and err.count("\n") == 1


def test_batch_help_states_exit_codes(capsys):
    with pytest.raises(SystemExit):
        _parse(["batch", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "1 if some logs failed" in text and "2 for bad usage" in text and "gyrodrift[fleet]" in text


def test_process_many_usage_errors(fleet_dir, tmp_path, monkeypatch):
    logs = find_logs(fleet_dir)
    with pytest.raises(ConfigError, match="workers"):
        process_many(logs, tmp_path, workers=0)
    with pytest.raises(ConfigError, match="output format"):
        process_many(logs, tmp_path, out_format="xlsx")
    with pytest.raises(ConfigError, match="does not exist"):
        process_many(logs, tmp_path / "missing")
    twin = tmp_path / "twin"
    twin.mkdir()
    write_table(_sim(0, 60.0), twin / "a.csv")
    write_table(_sim(0, 60.0), twin / "a.parquet")
    with pytest.raises(ConfigError, match="both be written"):
        process_many(find_logs(twin), tmp_path)
    with pytest.raises(ConfigError, match="overwrite the input"):
        process_many([twin / "a.csv", twin / "a_out.parquet"], twin)
    assert process_many([], tmp_path).columns.tolist() == list(SUMMARY_COLUMNS)
    monkeypatch.setitem(sys.modules, "distributed", None)  # dask not installed
    with pytest.raises(ConfigError, match=r"gyrodrift\[fleet\]"):
        process_many(logs, tmp_path, dask_address="tcp://127.0.0.1:8786")


@pytest.fixture(scope="module")
def serial_summary(fleet_dir, tmp_path_factory):
    return process_many(find_logs(fleet_dir), tmp_path_factory.mktemp("serial"), workers=1)


def test_local_pool_equals_serial(fleet_dir, tmp_path, serial_summary):
    pooled = process_many(find_logs(fleet_dir), tmp_path, workers=2)
    pd.testing.assert_frame_equal(pooled[NUMBERS], serial_summary[NUMBERS], check_exact=True)


@pytest.mark.parametrize("processes", [False, True])
def test_dask_local_cluster_equals_local(fleet_dir, tmp_path, serial_summary, processes):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, processes=processes, dashboard_address=None) as cluster:
        seen = []

        def progress(items, total):
            for item in items:
                seen.append(total)
                yield item

        summary = process_many(
            find_logs(fleet_dir), tmp_path, dask_address=cluster.scheduler_address, progress=progress
        )
    assert seen == [len(summary)] * len(summary)
    pd.testing.assert_frame_equal(summary[NUMBERS], serial_summary[NUMBERS], check_exact=True)
    for name in GOOD:
        a = pd.read_parquet(output_path(name, tmp_path))
        assert len(a) == 3001


def test_module_has_no_hard_dask_import():
    src = fleet.__file__
    text = open(src, encoding="utf-8").read()
    header = text.split("def ", 1)[0]
    assert "import distributed" not in header and "import dask" not in header

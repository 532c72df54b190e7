"""Wide inputs (issue 24, item 7): the pass-through columns are joined to the output at once.

Adding thousands of input columns one at a time copied pandas' column index at every
insertion (quadratic time, a PerformanceWarning each); :func:`gyrodrift._columns.join_input_columns`
joins them in one step, with the names and types the one-at-a-time way gave.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import compensate
from gyrodrift.cli import main
from gyrodrift.compensator import append_input_columns


def wide_log(extra: int, seconds: float = 60.0) -> pd.DataFrame:
    log = synthetic_log(duration_s=seconds, fs_hz=10.0)
    cols = pd.DataFrame(np.random.default_rng(0).normal(size=(len(log), extra)),
                        columns=[f"x{i}" for i in range(extra)])
    return pd.concat([log, cols], axis=1)


def test_join_gives_what_one_at_a_time_gives():
    from gyrodrift._columns import join_input_columns

    log = synthetic_log(duration_s=5.0, fs_hz=10.0)
    log["note"] = ["a", None] * (len(log) // 2)
    log["rate_z"] = 1.0  # a name the output has: in_rate_z
    log["count"] = np.arange(len(log))
    log.index += 100  # joined by position, not by label
    out = pd.DataFrame({"t": log["t"].to_numpy(), "rate_z": 0.5, "gate_reason": pd.Categorical(["init"] * len(log))})
    out.attrs["notes"] = ["kept"]
    expected = append_input_columns(out.copy(), log)
    got = join_input_columns(out, log)
    pd.testing.assert_frame_equal(got, expected)
    assert got.attrs == {"notes": ["kept"]}


def test_no_input_column_is_ever_replaced():
    from gyrodrift._columns import join_input_columns

    out = pd.DataFrame({"t": [0.0], "rate_z": [1.0]})
    log = pd.DataFrame({"in_rate_z": [2.0], "rate_z": [3.0]})
    got = join_input_columns(out, log)
    assert list(got.columns) == ["t", "rate_z", "in_rate_z", "in_in_rate_z"]
    assert got.iloc[0].tolist() == [0.0, 1.0, 2.0, 3.0]


def test_thousands_of_columns_are_joined_without_a_warning(tmp_path, capsys):
    log = wide_log(3000)
    path = tmp_path / "wide.csv"
    log.to_csv(path, index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", pd.errors.PerformanceWarning)
        start = time.perf_counter()
        assert main(["compensate", str(path), "-o", str(tmp_path / "o.csv"), "-q"]) == 0
        streamed = time.perf_counter() - start
        out = compensate(log)
    assert out.shape[1] == 3000 + 21 and streamed < 120  # 17 output columns, 4 of the input besides t, heading
    back = pd.read_csv(tmp_path / "o.csv", usecols=["x0", "x2999"])
    np.testing.assert_allclose(back["x2999"].to_numpy(), log["x2999"].to_numpy())


def test_a_wide_stream_is_joined_without_a_warning(tmp_path, capsys):
    path = tmp_path / "wide.csv"
    wide_log(300, seconds=5.0).to_csv(path, index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", pd.errors.PerformanceWarning)
        assert main(["stream", str(path), "-o", str(tmp_path / "s.csv"), "-q"]) == 0
    assert pd.read_csv(tmp_path / "s.csv").shape == (50, 300 + 21)


@pytest.mark.slow
def test_a_header_of_100k_columns_is_bounded_in_time_and_leaves_no_temporary(tmp_path, capsys):
    names = ["t", "gyro_z", "temp", "heading"] + [f"c{i}" for i in range(100_000)]
    rows = [",".join([f"{i * 0.1:g}", "0.1", "25", "10"] + [""] * 100_000) for i in range(50)]
    path = tmp_path / "wide.csv"
    path.write_text(",".join(names) + "\n" + "\n".join(rows) + "\n")
    start = time.perf_counter()
    assert main(["compensate", str(path), "-o", str(tmp_path / "o.csv"), "-q"]) == 0
    assert time.perf_counter() - start < 120
    assert [p.name for p in tmp_path.iterdir() if "gyrodrift-tmp" in p.name] == []

"""Injection (issue 24, item 4): no formula in an output CSV, no line or escape code from a file name.

Every CSV writer (``compensate`` whole or in chunks, ``stream``, ``batch``) quotes text
cells and column names that start with ``= + - @`` (a spreadsheet would run them);
numbers are never changed. File names and other user text reach the terminal, parameter
files and reports as one line, their control characters shown as escapes.
"""

from __future__ import annotations

import io
import os

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest

from conftest import synthetic_log
from gyrodrift.cli import main
from gyrodrift.io import write_table
from gyrodrift.io.chunked import ChunkWriter
from gyrodrift.simulate import simulate

FORMULAS = ["=HYPERLINK(\"http://x\",\"y\")", "+1+1", "-2+3", "@SUM(A1)", "plain", "a=b"]
HOSTILE_NAME = "=cmd|' /C calc'!A0"


def hostile_log() -> pd.DataFrame:
    log = synthetic_log(duration_s=60.0, fs_hz=10.0)
    log["note"] = [FORMULAS[i % len(FORMULAS)] for i in range(len(log))]
    log[HOSTILE_NAME] = "@x"
    log["-gain"] = 1.5
    return log


def assert_no_formula(text: str) -> None:
    """No CSV field of ``text`` starts with = + @, nor - unless it is a number."""
    frame = pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False)
    for name in frame.columns:
        assert not name.startswith(("=", "+", "-", "@")), name
    for name in frame.columns:
        for cell in frame[name]:
            if cell.startswith(("=", "+", "@")) or (cell.startswith("-") and not _is_number(cell)):
                raise AssertionError(f"formula cell {cell!r} in column {name!r}")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_compensate_quotes_formula_cells_and_names(tmp_path, suffix, capsys):
    log = hostile_log()
    src = tmp_path / f"in{suffix}"
    log.to_csv(src, index=False) if suffix == ".csv" else log.to_parquet(src)
    out = tmp_path / "out.csv"
    assert main(["compensate", str(src), "-o", str(out), "-q"]) == 0
    text = out.read_text()
    assert_no_formula(text)
    back = pd.read_csv(out, keep_default_na=False)
    assert back["note"].tolist()[:6] == ["'" + FORMULAS[0], "'+1+1", "'-2+3", "'@SUM(A1)", "plain", "a=b"]
    assert "'" + HOSTILE_NAME in back.columns and "'-gain" in back.columns
    assert (back["'-gain"] == 1.5).all()  # a number column is never changed
    assert (back["rate_z"] < 0).any() or (back["rate_z"] > 0).any()


def test_stream_and_batch_quote_formula_cells(tmp_path, capsys):
    log = hostile_log()
    src = tmp_path / "logs" / "in.csv"
    src.parent.mkdir()
    log.to_csv(src, index=False)
    assert main(["stream", str(src), "-o", str(tmp_path / "s.csv"), "-q"]) == 0
    assert_no_formula((tmp_path / "s.csv").read_text())
    assert main(["batch", str(src.parent), "-o", str(tmp_path / "b"), "--format", "csv", "--workers", "1"]) == 0
    assert_no_formula((tmp_path / "b" / "in_out.csv").read_text())


def test_chunks_and_the_whole_table_quote_alike(tmp_path):
    df = pd.DataFrame({"t": np.arange(6.0), "=x": FORMULAS, "c": pd.Categorical(["-a", "b"] * 3)})
    write_table(df, tmp_path / "whole.csv")
    with ChunkWriter(tmp_path / "chunks.csv") as w:
        w.write(df.iloc[:3])
        w.write(df.iloc[3:])
    assert (tmp_path / "whole.csv").read_bytes() == (tmp_path / "chunks.csv").read_bytes()
    assert_no_formula((tmp_path / "whole.csv").read_text())


def test_arrow_and_pandas_quoting_agree():
    from gyrodrift.io.formula import formula_safe_frame, formula_safe_table

    df = pd.DataFrame({"=x": FORMULAS, "n": np.linspace(-1, 1, 6)})
    via_arrow = formula_safe_table(pa.Table.from_pandas(df, preserve_index=False)).to_pandas()
    pd.testing.assert_frame_equal(via_arrow, formula_safe_frame(df))
    assert df.columns.tolist() == ["=x", "n"]  # the caller's frame is not changed


def test_printable_escapes_line_ends_and_escape_codes():
    from gyrodrift._text import printable

    assert printable("a\nb\r\x1b[31m\x07\u202e\u2028") == "a\\nb\\r\\x1b[31m\\x07\\u202e\\u2028"
    assert printable("plain name é.csv") == "plain name é.csv"


def test_file_names_reach_the_terminal_as_one_line(tmp_path, capsys):
    name = tmp_path / "evil\n#x\x1b[31m.csv"
    synthetic_log(duration_s=60.0, fs_hz=10.0).to_csv(name, index=False)
    assert main(["compensate", str(name), "-o", str(tmp_path / "o\x1b]0;t\x07.csv")]) == 0
    captured = capsys.readouterr()
    assert "\x1b" not in captured.out + captured.err and "\x07" not in captured.out
    assert captured.out.splitlines()[0].startswith("read ") and "evil\\n#x\\x1b[31m.csv" in captured.out
    assert main(["compensate", str(name), "-o", str(tmp_path / "o.csv"), "--profile", str(tmp_path / "n\x1b.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "\x1b" not in err


def test_a_file_name_cannot_add_a_parameter_line(tmp_path, capsys):
    log = simulate("calibration", seed=0, duration_s=3600.0, fs_hz=10.0)
    log.attrs = {}
    name = tmp_path / "cal\nTC_G0_X0\t5\x1b[31m.csv"
    log.to_csv(name, index=False)
    for out in ("c.params", "c.param"):
        assert main(["calibrate", str(name), "-o", str(tmp_path / out), "-q"]) == 0, capsys.readouterr().err
        lines = (tmp_path / out).read_text().splitlines()
        assert not any(line.startswith("TC_G0_X0\t5") for line in lines)
        assert all(line.startswith("#") for line in lines[:2]) and "\x1b" not in "".join(lines)


def test_the_report_shows_a_hostile_title_as_text(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    src = tmp_path / "in.csv"
    synthetic_log(duration_s=120.0, fs_hz=10.0).to_csv(src, index=False)
    out = tmp_path / "r.html"
    assert main(["report", str(src), "-o", str(out), "--methods", "adaptive", "--title",
                 "t\x1b[31m<script>\nx", "-q"]) == 0
    page = out.read_text()
    assert "\x1b" not in page and "<script>" not in page and "t\\x1b[31m&lt;script&gt;\\nx" in page
    assert os.path.getsize(out) > 0

"""Fuzzing the edges of issue 24: the file system, injection, and streaming against files.

Each test runs ``FUZZ_EXAMPLES`` hypothesis examples (:mod:`test_fuzz`; 60 by default,
``GYRODRIFT_FUZZ_EXAMPLES=2000`` for the long run of ``benchmarks/fuzz_long.py``).
Properties:

* **file system**: ``gyrodrift compensate`` and ``stream`` with any mix of outputs (``-o``,
  ``--save-profile``) and inputs (the log, ``--profile``, ``--config``), through
  symbolic and hard links, onto ``/dev/null``, a folder, a missing folder or an
  over-long name, exits 0 or 2 with one error line; never changes an input, never
  replaces a link or a device, leaves no output behind when it refuses and no
  temporary file ever;
* **injection**: whatever text a log's pass-through columns and column names hold, no
  field of the output CSV (written whole, in chunks, or by ``stream``) starts a
  spreadsheet formula, and each reads back as the text with a leading ``'`` where one
  was needed; user text made printable holds no control character;
* **streaming parity**: a log the file path refuses (``read_log`` and ``compensate``, as
  ``gyrodrift compensate`` runs them), ``stream`` refuses too; a log both take gives as
  many rows either way. The one difference allowed is what a stream
  cannot look ahead for: a ``temp`` column empty in every row (the file reader then
  takes 0 degC, the stream refuses a first sample without a temperature).
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import stat
import tempfile
import unicodedata
from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import event, given
from hypothesis import strategies as st

from conftest import synthetic_log
from gyrodrift import compensate
from gyrodrift._text import printable
from gyrodrift.cli import main
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import GyroDriftError, LogFormatError
from gyrodrift.io import read_log, write_table
from gyrodrift.io.chunked import ChunkWriter
from gyrodrift.io.formula import FORMULA_STARTS
from gyrodrift.stream import stream_rows
from test_fuzz import FUZZ  # the examples per test of every fuzz file (GYRODRIFT_FUZZ_EXAMPLES)

SHORT = CompensatorConfig(init_s=2.0, update_interval_s=2.0)
_LOG = synthetic_log(duration_s=20.0, fs_hz=2.0, compass_hz=2.0)
_CONFIG = "init_s = 2.0\nupdate_interval_s = 2.0\n"
#: The columns of the output of _LOG: an input column of the same name is written as in_NAME.
_OUTPUT_NAMES = frozenset(compensate(_LOG, SHORT).columns)

# --------------------------------------------------------------------------- the file system

#: Where an output may point: (name, how it is made in the folder).
_TARGETS = ["new", "other", "log", "profile", "config", "soft_log", "hard_log", "soft_new", "dangling", "devnull",
            "folder", "missing_folder", "long_name", "deep"]


def _make_target(kind: str, d: Path, suffix: str) -> Path:
    """The path of an output of ``kind`` in folder ``d`` (made as ``kind`` says)."""
    if kind == "new":
        return d / f"new{suffix}"
    if kind == "other":
        (d / f"other{suffix}").write_text("old\n")
        return d / f"other{suffix}"
    if kind in ("log", "profile", "config"):
        return {"log": d / "log.csv", "profile": d / "dev.json", "config": d / "s.toml"}[kind]
    if kind == "soft_log":
        link = d / f"soft_log{suffix}"
        if not link.is_symlink():
            link.symlink_to(d / "log.csv")
        return link
    if kind == "hard_log":
        link = d / f"hard_log{suffix}"
        if not link.exists():
            os.link(d / "log.csv", link)
        return link
    if kind == "soft_new":
        link = d / f"soft_new{suffix}"
        (d / f"target{suffix}").write_text("old\n")
        if not link.is_symlink():
            link.symlink_to(d / f"target{suffix}")
        return link
    if kind == "dangling":
        link = d / f"dangling{suffix}"
        if not link.is_symlink():
            link.symlink_to(d / f"made_by_link{suffix}")
        return link
    if kind == "devnull":
        return Path(os.devnull)
    if kind == "folder":
        (d / "folder").mkdir(exist_ok=True)
        return d / "folder"
    if kind == "missing_folder":
        return d / "missing" / f"x{suffix}"
    if kind == "long_name":
        return d / ("n" * 260 + suffix)
    return d.joinpath(*["d" * 200] * 22) / f"x{suffix}"


def _snapshot(d: Path) -> dict:
    """What must not change: the inputs' bytes and inodes, and the kinds of links and devices."""
    snap = {}
    for name in ("log.csv", "dev.json", "s.toml"):
        st_ = os.stat(d / name)
        snap[name] = ((d / name).read_bytes(), st_.st_ino)
    for p in d.iterdir():
        if p.is_symlink():
            snap[p.name + "@link"] = os.readlink(p)
    snap["devnull"] = os.stat(os.devnull).st_mode
    return snap


@FUZZ
@given(st.sampled_from(["compensate", "stream"]), st.sampled_from([".csv", ".parquet"]), st.sampled_from(_TARGETS),
       st.one_of(st.none(), st.sampled_from(_TARGETS)), st.booleans(), st.booleans())
def test_outputs_never_overwrite_inputs_nor_replace_nodes(command, suffix, output, profile_out, with_profile,
                                                          with_config):
    with tempfile.TemporaryDirectory() as folder:
        d = Path(folder)
        _LOG.to_csv(d / "log.csv", index=False)
        (d / "s.toml").write_text(_CONFIG)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            assert main(["compensate", str(d / "log.csv"), "-o", str(d / "first.csv"), "--save-profile",
                         str(d / "dev.json"), "--config", str(d / "s.toml")]) == 0
        out = _make_target(output, d, suffix)
        argv = [command, str(d / "log.csv"), "-o", str(out), "-q"]
        profile = None
        if profile_out is not None:
            profile = _make_target(profile_out, d, ".json")
            argv += ["--save-profile", str(profile)]
        argv += ["--profile", str(d / "dev.json")] if with_profile else []
        argv += ["--config", str(d / "s.toml")] if with_config else []
        fresh = [p for p in (out, profile) if p is not None and not os.path.lexists(p)]
        before = _snapshot(d)
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            code = main(argv)
        event(f"exit {code}")
        assert code in (0, 2), err.getvalue()
        if code == 2:
            text = err.getvalue()
            assert text.startswith("gyrodrift: error: ") and text.count("\n") == 1 and "Traceback" not in text
            for p in fresh:
                assert not os.path.lexists(p), p
        after = _snapshot(d)
        inputs = ["log.csv", *(["dev.json"] if with_profile else []), *(["s.toml"] if with_config else [])]
        for key in [*inputs, "devnull", *(k for k in before if k.endswith("@link"))]:
            assert after.get(key) == before[key], key  # an input, a link or a device: never changed
        assert not [p for p in d.rglob("*") if "gyrodrift-tmp" in p.name]
        assert stat.S_ISCHR(os.stat(os.devnull).st_mode)


# --------------------------------------------------------------------------- injection

_text = st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=12)
_formula_like = st.builds(lambda a, b: a + b, st.sampled_from(["=", "+", "-", "@", "\t", "\r", ""]), _text)


def _fields(data: bytes) -> list[list[str]]:
    return list(csv.reader(io.StringIO(data.decode("utf-8"), newline="")))


def _check_csv(data: bytes, names: list[str], cells: dict[str, list[str]]) -> None:
    """No field starts a formula, unless it is a number in a number column; text reads back quoted."""
    rows = _fields(data)
    header, body = rows[0], rows[1:]
    for name in header:
        assert not name.startswith(FORMULA_STARTS), name
    for row in body:
        for name, value in zip(header, row):
            if value.startswith(FORMULA_STARTS):
                float(value)  # only a number (a negative one) may start with '-'
    for name in names:
        shown = "'" + name if name.startswith(FORMULA_STARTS) else name
        col = header.index(shown)
        got = [row[col] for row in body]
        want = [("'" + v if v.startswith(FORMULA_STARTS) else v) for v in cells[name]]
        assert got == want, (name, got[:3], want[:3])


@FUZZ
@given(st.lists(st.tuples(_formula_like, st.lists(_formula_like, min_size=1, max_size=1)), min_size=1, max_size=3,
                unique_by=lambda item: item[0]))
def test_csv_fields_never_start_a_formula(columns):
    log = _LOG.copy()
    names, cells = [], {}
    for name, (cell,) in columns:
        if name in log.columns or name in _OUTPUT_NAMES or not name.strip() or name != name.strip() \
                or name.startswith("in_"):
            continue  # a name the output has is written as in_NAME: not this test's concern
        values = [cell if i % 2 else f"{cell}{i}" for i in range(len(log))]
        log[name] = values
        names.append(name)
        cells[name] = values
    out = compensate(log, SHORT, source="fuzz")
    with tempfile.TemporaryDirectory() as folder:
        whole, chunks = Path(folder) / "whole.csv", Path(folder) / "chunks.csv"
        write_table(out, whole)
        with ChunkWriter(chunks) as w:
            w.write(out.iloc[: len(out) // 2])
            w.write(out.iloc[len(out) // 2:])
        assert whole.read_bytes() == chunks.read_bytes()
        _check_csv(whole.read_bytes(), [n for n in names if "\r" not in n and "\n" not in n],
                   {n: v for n, v in cells.items()})
    event("text columns" if names else "no text column")


@FUZZ
@given(_text)
def test_printable_text_holds_no_control_character(text):
    shown = printable(text)
    assert "\n" not in shown and "\r" not in shown and "\x1b" not in shown
    for ch in shown:
        assert unicodedata.category(ch) != "Cc", repr(ch)


# --------------------------------------------------------------------------- streaming parity

#: Time columns of one kind each: (name, times of row i as text).
_TIME_BASES = {
    "seconds 10 Hz": lambda i: repr(i * 0.1),
    "seconds 0.5 Hz": lambda i: repr(i * 2.0),
    "integer ms": lambda i: str(i * 10),
    "integer us": lambda i: str(i * 10_000),
    "epoch ms": lambda i: str(1_700_000_000_000 + i * 100),
    "1 MHz": lambda i: repr(i * 1e-6),
}
_cells = st.one_of(st.just(""), st.floats(-400.0, 400.0).map(repr), st.sampled_from(["1e6", "abc", "inf", "-5e38", "200"]))


@st.composite
def stream_logs(draw) -> tuple[str, str]:
    """A CSV log with one time base and cells of any kind, and the kind of its time base."""
    base = draw(st.sampled_from(sorted(_TIME_BASES)))
    extra = draw(st.lists(st.sampled_from(["heading", "gyro_x", "note", "mag_x"]), max_size=2, unique=True))
    columns = ["t", "gyro_z", "temp", *extra]
    n = draw(st.integers(1, 25))
    dirt = draw(st.sampled_from([0, 0, 20, 5]))  # one cell in this many is of any kind (0: none)
    lines = [",".join(columns)]
    for i in range(n):
        row = [_TIME_BASES[base](i)]
        for col in columns[1:]:
            if dirt and draw(st.integers(0, dirt)) == 0:
                row.append(draw(_cells))
            else:
                row.append({"gyro_z": "0.1", "temp": "25.0", "heading": "90.0", "note": "ok"}.get(col, "1.5"))
        if draw(st.integers(0, 30)) == 0:
            row = row[:-1]  # a ragged row now and then
        lines.append(",".join(row))
    if draw(st.integers(0, 20)) == 0:
        lines[draw(st.integers(1, len(lines) - 1))] = lines[1].split(",")[0] + ",x"  # another
    return "\n".join(lines) + "\n", base


@FUZZ
@given(stream_logs())
def test_the_stream_refuses_what_the_file_reader_refuses(case):
    text, base = case
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.csv"
        path.write_text(text)
        try:  # as gyrodrift compensate reads and compensates it
            file_rows, file_err = len(compensate(read_log(path))), None
        except LogFormatError as err:
            file_rows, file_err = None, err
    out: list[str] = []
    try:
        stream_rows([text], out.append)
        stream_err = None
    except LogFormatError as err:
        stream_err = err
    except GyroDriftError as err:  # anything else is a finding
        raise AssertionError(f"stream: {err}") from err
    event(f"{base}: file {'refused' if file_err else 'read'}, stream {'refused' if stream_err else 'read'}")
    if file_err is not None:
        assert stream_err is not None, f"file refused ({file_err}); the stream took it"
        return
    if stream_err is not None:
        temp = pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False)["temp"]
        assert (temp.str.strip() == "").all() or temp.str.strip().iloc[0] == "", (
            f"the file was read, the stream refused: {stream_err}")
        return
    assert "".join(out).count("\n") == 1 + file_rows
    assert np.isfinite(file_rows)

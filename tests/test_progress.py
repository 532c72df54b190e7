"""Progress bars: on a terminal only, with the total, the rate and the ETA (issue 15)."""

from __future__ import annotations

import io
import sys
import types

import pytest

from conftest import synthetic_log
from gyrodrift._progress import progress_iter
from gyrodrift.cli import main


class Terminal(io.StringIO):
    def isatty(self):
        return True


class FakeTqdm:
    """Stands in for ``tqdm.tqdm``: records how each bar was made and advanced."""

    made: list[dict] = []

    def __init__(self, **kwargs):
        self.kwargs, self.n = kwargs, 0
        FakeTqdm.made.append(self.__dict__)

    def update(self, n=1):
        self.n += n

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


@pytest.fixture
def fake_tqdm(monkeypatch):
    FakeTqdm.made = []
    monkeypatch.setitem(sys.modules, "tqdm", types.SimpleNamespace(tqdm=FakeTqdm))
    return FakeTqdm.made


@pytest.fixture
def log_files(tmp_path):
    log = synthetic_log(duration_s=120.0)
    log.to_csv(tmp_path / "log.csv", index=False)
    log.to_parquet(tmp_path / "log.parquet")
    return tmp_path, len(log)


def test_built_in_bar_shows_the_count_the_rate_and_the_eta(monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)  # the bar drawn by gyrodrift
    stream = Terminal()
    chunks = [[0] * 300, [0] * 300, [0] * 400]
    assert list(progress_iter(chunks, 1000, "compensating", stream=stream, unit="rows", size=len)) == chunks
    text = stream.getvalue()
    assert "\rcompensating [" in text and "1k/1k rows" in text and "rows/s" in text and "ETA " in text
    assert "\n" not in text and text.endswith("\r")  # one line, erased at the end


def test_built_in_bar_without_a_total_shows_the_count_and_the_rate(monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)
    stream = Terminal()
    assert list(progress_iter(range(3), None, "reading", stream=stream, unit="logs")) == [0, 1, 2]
    text = stream.getvalue()
    assert "reading 3 logs" in text and "logs/s" in text and "ETA" not in text


def test_tqdm_bar_is_made_with_the_total_and_unit(fake_tqdm):
    stream = Terminal()
    assert list(progress_iter([[1, 2], [3]], 3, "x", stream=stream, unit="rows", size=len)) == [[1, 2], [3]]
    (bar,) = fake_tqdm
    assert bar["kwargs"]["total"] == 3 and bar["kwargs"]["unit"] == "rows" and bar["n"] == 3
    assert bar["kwargs"]["file"] is stream and bar["kwargs"]["leave"] is False


@pytest.mark.parametrize("ending", ["csv", "parquet"])
def test_compensate_on_a_terminal_shows_a_bar_over_the_rows(log_files, ending, fake_tqdm, monkeypatch):
    folder, rows = log_files
    monkeypatch.setattr(sys, "stderr", Terminal())
    assert main(["compensate", str(folder / f"log.{ending}"), "-o", str(folder / "out.csv"), "-q"]) == 0
    (bar,) = fake_tqdm
    assert bar["kwargs"]["desc"] == "compensating" and bar["kwargs"]["unit"] == "rows"
    assert bar["n"] == rows  # every row read advanced it
    total = bar["kwargs"]["total"]
    if ending == "parquet":
        assert total == rows  # the footer's count
    else:
        assert total == pytest.approx(rows, rel=0.05)  # the CSV's size over its mean line length


def test_compensate_in_memory_on_a_terminal_shows_a_bar_with_a_total(tmp_path, fake_tqdm, monkeypatch):
    from gyrodrift.compensator import batch

    monkeypatch.setattr(batch, "PROGRESS_ROWS", 500)  # the in-memory path's chunks
    synthetic_log(duration_s=120.0).to_csv(tmp_path / "log.csv", index=False)
    monkeypatch.setattr(sys, "stderr", Terminal())
    assert main(["compensate", str(tmp_path / "log.csv"), "-o", str(tmp_path / "o.csv"), "--smooth", "-q"]) == 0
    (bar,) = fake_tqdm
    assert bar["kwargs"]["total"] == bar["n"] > 1


def test_nothing_is_drawn_when_stderr_is_not_a_terminal(log_files, fake_tqdm, capsys):
    folder, _ = log_files
    assert main(["compensate", str(folder / "log.parquet"), "-o", str(folder / "out.csv"), "-q"]) == 0
    assert fake_tqdm == [] and capsys.readouterr().err == ""
    pipe = io.StringIO()
    assert list(progress_iter(range(5), 5, "x", stream=pipe)) == list(range(5))
    assert pipe.getvalue() == ""

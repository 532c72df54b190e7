"""compensate_file: the streaming (chunked) path writes what the in-memory path writes."""

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.io import write_table
from gyrodrift.pipeline import compensate_file
from test_compensate import complex_log


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pipeline")
    log = complex_log(False)  # turns, interference, outage, empty cells, a time gap
    log["note"] = np.where(np.arange(len(log)) % 7 == 0, "seven", "other")  # a pass-through text column
    paths = {}
    for suffix in ("csv", "parquet"):
        paths[suffix] = folder / f"log.{suffix}"
        write_table(log, paths[suffix])
    mag = complex_log(True)
    paths["mag"] = folder / "mag.csv"
    write_table(mag, paths["mag"])
    return paths


@pytest.mark.parametrize("kind", ["csv", "parquet", "mag"])
def test_streamed_file_equals_in_memory_file(logs, tmp_path, kind):
    src = logs[kind]
    before = src.read_bytes()
    suffix = "parquet" if kind == "parquet" else "csv"
    whole, parts = tmp_path / f"whole.{suffix}", tmp_path / f"parts.{suffix}"
    s_whole = compensate_file(src, whole, chunked=False)
    s_parts = compensate_file(src, parts, chunked=True, chunk_rows=1000)  # 18 chunks, init inside the first
    assert src.read_bytes() == before
    if suffix == "csv":
        assert parts.read_bytes() == whole.read_bytes()
    else:
        pd.testing.assert_frame_equal(pd.read_parquet(parts), pd.read_parquet(whole))
    assert s_parts.read_line() == s_whole.read_line()
    assert s_parts.result_lines() == s_whole.result_lines()
    assert np.array_equal(s_parts.final_params, s_whole.final_params)
    assert s_parts.streamed and not s_whole.streamed
    out = pd.read_csv(parts) if suffix == "csv" else pd.read_parquet(parts)
    assert {"heading_fused", "heading_fused_sd", "heading_sd", "gyro_z", "temp"} <= set(out.columns)
    assert len(out) == len(pd.read_csv(src) if suffix == "csv" else pd.read_parquet(src))


def test_truth_columns_give_accuracy_lines(tmp_path):
    log = synthetic_log(duration_s=600.0, gyro_noise_dps=0.05, compass_noise_deg=0.3, seed=2)
    write_table(log, tmp_path / "in.csv")
    stats = compensate_file(tmp_path / "in.csv", tmp_path / "out.csv", chunk_rows=2500)
    lines = "\n".join(stats.result_lines())
    assert "drift error RMS vs true_bias_z" in lines and "heading error vs ref_heading" in lines
    assert stats.rows == len(log) and stats.streamed


def test_a_bad_row_in_a_later_chunk_is_named_and_nothing_is_written(tmp_path):
    log = synthetic_log(duration_s=300.0)
    log.loc[4000, "t"] = log.loc[3999, "t"]  # time stops increasing at row 4000 (line 4002)
    write_table(log, tmp_path / "bad.csv")
    with pytest.raises(LogFormatError, match=r"bad.csv.*line 4002.*strictly increasing"):
        compensate_file(tmp_path / "bad.csv", tmp_path / "out.csv", chunk_rows=1000)
    assert not (tmp_path / "out.csv").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["bad.csv"]


def test_a_log_shorter_than_the_init_window_streams_like_in_memory_with_a_note(tmp_path):
    write_table(synthetic_log(duration_s=20.0), tmp_path / "short.csv")
    streamed = compensate_file(tmp_path / "short.csv", tmp_path / "s.csv", chunk_rows=100)
    whole = compensate_file(tmp_path / "short.csv", tmp_path / "w.csv", chunked=False)
    assert streamed.streamed and (tmp_path / "s.csv").read_bytes() == (tmp_path / "w.csv").read_bytes()
    for stats in (streamed, whole):
        assert any("shorter than the 30-s init window" in n for n in stats.notes)


def test_python_estimators_stream_too(logs, tmp_path):
    """lsm (a Python estimator updated at interval ends) streams, with the in-memory path's output."""
    cfg = CompensatorConfig(estimator="lsm")
    stats = compensate_file(logs["csv"], tmp_path / "o.csv", cfg, chunk_rows=997)
    assert stats.streamed
    compensate_file(logs["csv"], tmp_path / "o2.csv", cfg, chunked=False)
    assert (tmp_path / "o.csv").read_bytes() == (tmp_path / "o2.csv").read_bytes()
    with pytest.raises(ConfigError, match="cannot read this log in chunks"):
        compensate_file(tmp_path / "x.ulg", tmp_path / "o3.csv", cfg, chunked=True)  # a ULog is read whole


def test_scale_factor_columns_run_in_memory(tmp_path):
    from gyrodrift.simulate import simulate

    log = simulate("scale-factor", seed=2, fs_hz=10.0, duration_s=1800.0)
    write_table(log, tmp_path / "sf.csv")
    stats = compensate_file(tmp_path / "sf.csv", tmp_path / "out.csv", scale_factor=True)
    assert not stats.streamed
    out = pd.read_csv(tmp_path / "out.csv")
    cols = list(out.columns)
    assert cols[cols.index("heading_sd") + 1 : cols.index("heading_sd") + 5] == ["sf", "sf_sd", "rate_sf", "heading_sf"]
    late = out["t"] > 900
    err = out.loc[late, "sf"].to_numpy() - log.loc[late.to_numpy(), "true_sf"].to_numpy()
    assert np.sqrt(np.mean(err**2)) < 0.002 and np.abs(err).max() < 0.01  # the SF itself moves by 0.03
    assert any(line.startswith("heading_sf error") for line in stats.result_lines())
    with pytest.raises(ConfigError, match="scale-factor"):
        compensate_file(tmp_path / "sf.csv", tmp_path / "o2.csv", scale_factor=True, chunked=True)


def _late_type_change_log(n: int = 40_000, *, late_text_in_numbers: bool = False) -> pd.DataFrame:
    """A log past the reader's first 1-MiB block, with two pass-through columns whose cells
    change type after it: ``flag`` empty, then text; ``count`` whole numbers, then a fraction
    (and, if asked, then text)."""
    log = synthetic_log(duration_s=n / 10.0, gyro_noise_dps=0.05, compass_noise_deg=0.3, seed=3)
    log = log[["t", "gyro_z", "temp", "heading"]].copy()
    m = len(log)
    flag = np.full(m, "", dtype=object)
    flag[int(0.9 * m):] = "late text"
    count = np.array([str(k % 5) for k in range(m)], dtype=object)
    count[int(0.5 * m)] = "2.5"
    if late_text_in_numbers:
        count[int(0.97 * m)] = "many"
    log["flag"], log["count"] = flag, count
    return log


def test_a_column_that_changes_type_late_is_read_again_with_its_type(tmp_path):
    src = tmp_path / "late.csv"
    _late_type_change_log().to_csv(src, index=False)
    assert src.stat().st_size > 2 * (1 << 20)  # both changes after the first block
    before = src.read_bytes()
    for suffix in ("csv", "parquet"):
        whole, parts = tmp_path / f"whole.{suffix}", tmp_path / f"parts.{suffix}"
        s_whole = compensate_file(src, whole, chunked=False)
        s_parts = compensate_file(src, parts, chunked=True, chunk_rows=5000)
        if suffix == "csv":
            assert parts.read_bytes() == whole.read_bytes()
        else:
            pd.testing.assert_frame_equal(pd.read_parquet(parts), pd.read_parquet(whole), check_dtype=False)
        assert s_parts.streamed and not s_whole.notes
        notes = "\n".join(s_parts.notes)
        assert "'flag' read as text" in notes and "'count' read as numbers" in notes
        assert [line for line in s_parts.result_lines() if line.startswith("note: ")] == [f"note: {n}" for n in s_parts.notes]
    assert src.read_bytes() == before
    assert pd.read_csv(tmp_path / "parts.csv", dtype=str)["flag"].iloc[-1] == "late text"


def test_a_number_column_that_later_holds_text_is_read_as_text(tmp_path):
    src = tmp_path / "late.csv"
    _late_type_change_log(late_text_in_numbers=True).to_csv(src, index=False)
    whole, parts = tmp_path / "whole.csv", tmp_path / "parts.csv"
    compensate_file(src, whole, chunked=False)
    stats = compensate_file(src, parts, chunked=True, chunk_rows=5000)  # read 3 times: 'count' numbers, then text
    assert parts.read_bytes() == whole.read_bytes()
    assert any("'count' read as text" in n and "'many'" in n for n in stats.notes)
    assert not any("'count' read as numbers" in n for n in stats.notes)
    assert "many" in set(pd.read_csv(parts, dtype=str)["count"])


@pytest.mark.parametrize("kind", ["csv", "parquet"])
def test_row_estimate_is_close_to_the_rows(logs, tmp_path, kind):
    from gyrodrift.pipeline import _estimated_rows

    rows = len(pd.read_csv(logs["csv"]))
    assert abs(_estimated_rows(logs[kind]) - rows) <= 0.02 * rows
    odd = tmp_path / "log.dat"  # the format named, not told by the ending
    odd.write_bytes(logs[kind].read_bytes())
    assert abs(_estimated_rows(odd, kind) - rows) <= 0.02 * rows


def test_no_row_estimate_for_a_compressed_csv(logs, tmp_path):
    import gzip

    from gyrodrift.pipeline import _estimated_rows

    packed = tmp_path / "log.csv.gz"
    packed.write_bytes(gzip.compress(logs["csv"].read_bytes()))
    assert _estimated_rows(packed) is None


@pytest.mark.parametrize(
    "options, expected",
    [
        ({"smooth": True}, r"--smooth needs the whole log in memory.*Drop --smooth to stream it"),
        ({"scale_factor": True, "smooth": True}, r"--scale-factor and --smooth need the whole .*Drop --scale-factor and --smooth"),
        ({"chunked": False}, r"kept in memory \(chunked=False\).*Let it run in chunks"),
    ],
)
def test_a_log_that_cannot_fit_in_memory_is_refused_before_reading(logs, tmp_path, monkeypatch, options, expected):
    from gyrodrift import pipeline

    rows = len(pd.read_csv(logs["csv"]))
    available = rows * pipeline.IN_MEMORY_MIN_BYTES_PER_ROW // 2
    monkeypatch.setattr(pipeline, "available_memory_bytes", lambda: available)
    monkeypatch.setattr("gyrodrift.io.read_log", lambda *a, **k: pytest.fail("read before the check"))
    out = tmp_path / "out.csv"
    with pytest.raises(GyroDriftError, match=expected) as info:
        compensate_file(logs["parquet"], out, **options)
    assert f"{rows / 1e6:.1f} million rows" in str(info.value) and "split the log" in str(info.value)
    assert not out.exists()
    monkeypatch.undo()  # this machine's memory: the same run goes through
    compensate_file(logs["parquet"], out, **options)
    assert out.exists()


def test_streaming_needs_no_memory_check(logs, tmp_path, monkeypatch):
    from gyrodrift import pipeline

    monkeypatch.setattr(pipeline, "available_memory_bytes", lambda: 1)
    compensate_file(logs["csv"], tmp_path / "out.csv")  # streams: constant memory, never refused
    assert (tmp_path / "out.csv").exists()

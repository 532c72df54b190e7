"""Real-log hygiene (issue 15, item 5): time units, held compass values, declination,
unit mix-ups, batch folders, option typos."""

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.cli import main
from gyrodrift.errors import LogFormatError
from gyrodrift.io import read_log
from gyrodrift.io.chunked import iter_log_chunks


@pytest.fixture(scope="module")
def log():
    return synthetic_log(duration_s=200.0, gyro_noise_dps=0.05, compass_noise_deg=0.5)


def _write(frame, path):
    frame.to_csv(path, index=False)
    return path


def _with_time(log, t):
    out = log.copy()
    out["t"] = t
    return out


# ----------------------------------------------------------------------------- time unit


@pytest.mark.parametrize(
    "unit, factor, offset_s",
    [("ms", 1e3, 12_345.0), ("us", 1e6, 12_345.0), ("ns", 1e9, 12_345.0), ("ms", 1e3, 1.7e9), ("us", 1e6, 1.7e9)],
)
def test_time_stamps_in_another_unit_are_refused_naming_the_unit(log, tmp_path, capsys, unit, factor, offset_s):
    t = np.round((log["t"] + offset_s) * factor)  # since boot, or since 1970
    path = _write(_with_time(log, t.astype("int64")), tmp_path / "log.csv")
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "column 't'" in err and f"--time-unit {unit}" in err
    assert not (tmp_path / "out.csv").exists()


def test_float_epoch_milliseconds_are_refused(log, tmp_path):
    path = _write(_with_time(log, log["t"] * 1e3 + 1.7e12), tmp_path / "log.csv")
    with pytest.raises(LogFormatError, match="--time-unit ms"):
        read_log(path)


def test_time_unit_converts_to_seconds_whole_and_chunked(log, tmp_path, capsys):
    path = _write(_with_time(log, np.round((log["t"] + 100.0) * 1e3).astype("int64")), tmp_path / "ms.csv")
    whole = read_log(path, time_unit="ms")
    np.testing.assert_allclose(whole["t"], log["t"] + 100.0, rtol=0, atol=1e-9)
    chunks = pd.concat(list(iter_log_chunks(path, time_unit="ms", chunk_rows=1000)))
    pd.testing.assert_frame_equal(chunks, whole, check_exact=True)
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), "--time-unit", "ms"]) == 0
    assert "at 20.0 Hz" in capsys.readouterr().out


def test_a_sample_rate_above_100_khz_is_refused_even_with_a_time_unit(log, tmp_path, capsys):
    path = _write(_with_time(log, np.round(log["t"] * 1e3).astype("int64")), tmp_path / "ms.csv")
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), "--time-unit", "ns"]) == 2
    err = capsys.readouterr().err
    assert "MHz" in err and "--time-unit ms" in err


def test_a_sample_rate_below_1_hz_is_read_with_a_note(log, tmp_path, capsys):
    path = _write(_with_time(log, log["t"] * 50.0), tmp_path / "slow.csv")  # 0.4 Hz, not whole numbers
    notes = read_log(path).attrs["notes"]
    assert any("below 1 Hz" in n and "--time-unit" in n for n in notes)
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv")]) == 0
    out = capsys.readouterr().out
    assert "note:" in out and "below 1 Hz" in out and "at 0.4 Hz" in out


def test_a_bad_time_unit_is_a_usage_error(log, tmp_path, capsys):
    path = _write(log, tmp_path / "log.csv")
    with pytest.raises(SystemExit):
        main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), "--time-unit", "min"])
    assert "invalid choice" in capsys.readouterr().err


# ----------------------------------------------------------------------------- gyro unit


@pytest.fixture(scope="module")
def turning():
    return synthetic_log(
        duration_s=300.0, gyro_noise_dps=0.05, compass_noise_deg=0.5,
        heading_deg=lambda t: 100.0 + 90.0 * np.sin(2 * np.pi * t / 120.0),
    )


def _gyro_in(log, factor):
    out = log.copy()
    out["gyro_z"] = log["gyro_z"] * factor
    out["true_bias_z"] = log["true_bias_z"] * factor
    return out


def test_a_gyro_in_rad_s_read_as_deg_s_gets_a_note(turning, tmp_path, capsys):
    path = _write(_gyro_in(turning, np.pi / 180.0), tmp_path / "rad.csv")
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv")]) == 0
    out = capsys.readouterr().out
    assert "note:" in out and "times less than the compass" in out and "--gyro-unit rad/s" in out
    assert main(["compensate", str(path), "-o", str(tmp_path / "out2.csv"), "--gyro-unit", "rad/s"]) == 0
    assert "gyro_z turns" not in capsys.readouterr().out
    from gyrodrift import compensate

    notes = compensate(read_log(path)).attrs["notes"]  # the in-memory path says it too
    assert any("times less than the compass" in n for n in notes)


def test_a_gyro_in_deg_s_converted_as_rad_s_gets_a_note(turning, tmp_path, capsys):
    path = _write(turning, tmp_path / "deg.csv")
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), "--gyro-unit", "rad/s"]) == 0
    out = capsys.readouterr().out
    assert "times more than the compass" in out and "drop --gyro-unit rad/s" in out
    assert main(["compensate", str(path), "-o", str(tmp_path / "out2.csv")]) == 0
    assert "gyro_z turns" not in capsys.readouterr().out


def test_rates_beyond_a_mems_range_after_rad_s_conversion_get_a_note_without_compass(turning, tmp_path):
    from gyrodrift import compensate

    path = _write(_gyro_in(turning, 10.0).drop(columns=["heading"]), tmp_path / "nocompass.csv")
    notes = compensate(read_log(path, gyro_unit="rad/s")).attrs["notes"]
    assert any("beyond any MEMS gyro's range" in n for n in notes)
    assert not any("MEMS" in n for n in compensate(read_log(path)).attrs["notes"])


# ----------------------------------------------------------------------------- declination


def test_declination_puts_the_headings_in_true_north(log, tmp_path, capsys):
    from gyrodrift import compensate
    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.config import config_from_dict

    turning = log
    magnetic = turning.copy()
    magnetic["heading"] = np.mod(turning["heading"] - 7.0, 360.0)  # east declination 7 deg; ref in true north
    plain = compensate(magnetic)
    true = compensate(magnetic, CompensatorConfig(declination_deg=7.0))
    error = lambda out, col: np.abs((out[col] - turning["ref_heading"] + 180.0) % 360.0 - 180.0).mean()
    for col in ("heading", "heading_fused"):
        assert error(plain, col) > 5.0 and error(true, col) < 1.0
    np.testing.assert_allclose(true["compass_heading"], turning["heading"], atol=1e-9, equal_nan=True)
    # the drift does not depend on it (to the rounding of angles shifted by 7 deg)
    np.testing.assert_allclose(true["bias_z"], plain["bias_z"], rtol=1e-12, atol=1e-12)
    assert config_from_dict({"declination_deg": 7.0}).declination_deg == 7.0
    path = _write(magnetic, tmp_path / "mag.csv")
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), "--declination", "7"]) == 0
    assert "compensated RMS 0." in capsys.readouterr().out
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), "--declination", "200"]) == 2
    assert "declination_deg = 200.0 must be within -180 to 180" in capsys.readouterr().err


# ----------------------------------------------------------------------------- held compass


def test_held_compass_values_are_dropped_so_a_resampled_csv_equals_its_bag(log, tmp_path):
    from gyrodrift import compensate

    sparse = log.copy()  # as a bag gives it: one compass sample per message, NaN elsewhere
    held = sparse.copy()
    held["heading"] = sparse["heading"].ffill()  # as a CSV resampled onto the gyro rows gives it
    a, b = read_log(_write(sparse, tmp_path / "bag.csv")), read_log(_write(held, tmp_path / "held.csv"))
    np.testing.assert_array_equal(a["heading"], b["heading"])
    dropped = int(held["heading"].notna().sum() - sparse["heading"].notna().sum())
    assert any(f"{dropped} compass samples repeated" in n for n in b.attrs["notes"])
    assert not any("repeated" in n for n in a.attrs.get("notes", []))
    np.testing.assert_array_equal(compensate(a)["heading_fused"], compensate(b)["heading_fused"])
    chunks = pd.concat(list(iter_log_chunks(tmp_path / "held.csv", chunk_rows=7)))  # runs across chunks
    pd.testing.assert_frame_equal(chunks, b, check_exact=True)
    with iter_log_chunks(tmp_path / "held.csv", chunk_rows=7) as reader:
        list(reader)
        assert any(f"{dropped} compass samples repeated" in n for n in reader.notes)


def test_held_magnetometer_triples_are_dropped_only_when_all_three_repeat(tmp_path):
    rows = pd.DataFrame({
        "t": np.arange(6) * 0.1, "gyro_z": 0.1, "temp": 25.0,
        "mag_x": [0.2, 0.2, 0.2, 0.3, 0.3, np.nan], "mag_y": [0.0, 0.0, 0.1, 0.1, 0.1, np.nan],
        "mag_z": [0.4] * 5 + [np.nan], "acc_x": 0.0, "acc_y": 0.0, "acc_z": -1.0,
    })
    out = read_log(_write(rows, tmp_path / "mag.csv"))
    assert out["mag_x"].isna().tolist() == [False, True, False, False, True, True]
    assert out["mag_y"].isna().tolist() == out["mag_x"].isna().tolist()
    assert any("2 compass samples repeated" in n for n in out.attrs["notes"])


# ----------------------------------------------------------------------------- batch


def test_batch_mirrors_input_folders_and_takes_the_input_options(log, tmp_path, capsys):
    ms = _with_time(log, np.round((log["t"] + 100.0) * 1e3).astype("int64"))
    for sub in ("a", "b"):
        (tmp_path / "logs" / sub).mkdir(parents=True)
        _write(ms, tmp_path / "logs" / sub / "x.csv")
    out = tmp_path / "out"
    pattern = str(tmp_path / "logs" / "*" / "x.csv")
    assert main(["batch", pattern, "-o", str(out), "--workers", "1", "--format", "csv"]) == 1  # ms read as s
    assert "--time-unit ms" in capsys.readouterr().out
    args = ["batch", pattern, "-o", str(out), "--workers", "1", "--format", "csv", "--time-unit", "ms",
            "--init-s", "20", "--gyro-unit", "deg/s", "--frame", "ned", "--map", "gyro_z=gyro_z"]
    assert main(args) == 0
    a, b = pd.read_csv(out / "a" / "x_out.csv"), pd.read_csv(out / "b" / "x_out.csv")
    np.testing.assert_allclose(a["t"], log["t"] + 100.0, atol=1e-9)
    pd.testing.assert_frame_equal(a, b)
    assert (a["gate_reason"] == "init").sum() == 20 * 20  # 20 s at 20 Hz


# ----------------------------------------------------------------------------- did you mean


@pytest.mark.parametrize(
    "argv, hint",
    [
        (["compensat", "x.csv"], "did you mean 'compensate'?"),
        (["compensate", "x.csv", "-o", "y.csv", "--gyro-units", "rad/s"], "did you mean --gyro-unit?"),
        (["compensate", "x.csv", "-o", "y.csv", "--declinaton=3"], "did you mean --declination?"),
        (["batch", "x", "-o", "y", "--time-units", "ms"], "did you mean --time-unit?"),
        (["compensate", "x.csv", "-o", "y.csv", "--estimator", "stfk"], "did you mean 'stkf'?"),
    ],
)
def test_typos_get_a_did_you_mean(argv, hint, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert hint in capsys.readouterr().err


# ----------------------------------------------------------------------------- units printed, typing marker


def test_b_is_printed_in_deg_per_degc_and_the_package_is_typed(log, tmp_path, capsys):
    from importlib import resources

    path = _write(log, tmp_path / "log.csv")
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv")]) == 0
    assert " deg/degC, c = " in capsys.readouterr().out  # b multiplies T' (degC/s) and gives deg/s
    assert (resources.files("gyrodrift") / "py.typed").is_file()


# ----------------------------------------------------------------------------- the updated column


def test_the_updated_column_does_not_shadow_a_dataframe_method(log, tmp_path):
    import gyrodrift
    from gyrodrift.evaluate.compare import summary_table
    from gyrodrift.conventions import OUTPUT_COLS

    out = gyrodrift.compensate(log)
    assert "updated" in OUTPUT_COLS and "update" not in OUTPUT_COLS
    assert "update" not in out.columns and out["updated"].sum() > 0
    assert out.updated.equals(out["updated"])  # attribute access reaches the column
    comp = gyrodrift.Compensator()
    rows = [row for t, g, temp, h in log[["t", "gyro_z", "temp", "heading"]].itertuples(index=False)
            for row in comp.push(t, g, temp, heading_deg=h)]
    assert sum(row.updated for row in rows) == out["updated"].sum() and not hasattr(rows[0], "update")
    written = tmp_path / "out.csv"
    assert main(["compensate", str(_write(log, tmp_path / "log.csv")), "-o", str(written), "-q"]) == 0
    assert pd.read_csv(written, nrows=1).columns[7] == "updated"
    old = out.rename(columns={"updated": "update"})  # an output table written before the rename
    with pytest.warns(FutureWarning, match="'update' read as 'updated'"):
        old_table = summary_table({"adaptive": old})
    assert old_table.loc["adaptive", "updates"] == summary_table({"adaptive": out}).loc["adaptive", "updates"] > 0

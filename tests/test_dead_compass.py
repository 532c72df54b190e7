"""A dead magnetometer (issue 24, item 3): a raw sample without a field is no compass sample.

A magnetometer that reads (0, 0, 0), 1e-300 or NaN has no direction; before, a field
reference of zero made the field gate divide by zero in every entry point. Here every
entry point runs on such logs, the dead samples are left out (with a note), and a log
whose magnetometer never reads a field is compensated as a log without compass.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import Compensator, compensate
from gyrodrift.cli import main
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.io import read_log

MAG = ["mag_x", "mag_y", "mag_z"]
ACC = ["acc_x", "acc_y", "acc_z"]


def raw_compass_log(dead: str = "none", until_s: float = math.inf, keep_heading: bool = False) -> pd.DataFrame:
    """A level 10-Hz log of 120 s with a raw magnetometer (uT) and accelerometer (g) read
    on every row; ``dead`` ("zero", "tiny", "nan": mag_x NaN, "mixed": 0 and 1e-300 in turn) in the
    rows before ``until_s``. The heading column is kept on request (the compass is then
    given twice)."""
    log = synthetic_log(duration_s=120.0, fs_hz=10.0, compass_hz=10.0, gyro_noise_dps=0.02,
                        heading_deg=lambda t: 100.0 + 20.0 * np.sin(t / 20.0))
    h = np.radians(log["ref_heading"].to_numpy())
    log["mag_x"], log["mag_y"], log["mag_z"] = 20.0 * np.cos(h), -20.0 * np.sin(h), np.full(h.size, 40.0)
    log["acc_x"], log["acc_y"], log["acc_z"] = 0.0, 0.0, -1.0
    rows = log["t"].to_numpy() < until_s
    if dead == "zero":
        log.loc[rows, MAG] = 0.0
    elif dead == "tiny":
        log.loc[rows, MAG] = 1e-300
    elif dead == "nan":  # one component NaN (all three NaN is no sample, as an empty cell)
        log.loc[rows, "mag_x"] = np.nan
    elif dead == "mixed":  # not a held value: each row differs from the one before
        log.loc[rows, MAG] = 0.0
        log.loc[rows & (np.arange(len(log)) % 2 == 1), "mag_x"] = 1e-300
    if not keep_heading:
        log = log.drop(columns=["heading"])
    return log


SHORT = CompensatorConfig(init_s=30.0, update_interval_s=5.0)


def test_usable_field_refuses_zero_tiny_and_nan():
    from gyrodrift.compass import MIN_FIELD, usable_field

    ok = usable_field([[0.0, 0.0, 0.0], [1e-300, 0.0, 0.0], [np.nan, 20.0, 40.0], [np.inf, 0, 0], [20.0, 0.0, 40.0],
                       [MIN_FIELD, 0.0, 0.0]])
    assert ok.tolist() == [False, False, False, False, True, True]


def test_dead_field_counts_samples_not_empty_rows():
    from gyrodrift.compass import DeadField

    dead = DeadField()
    out = dead.mask(np.array([[0.0, 0.0, 0.0], [np.nan] * 3, [20.0, 0.0, 40.0], [np.nan, 1.0, 1.0]]))
    assert (dead.samples, dead.dead) == (3, 2)
    assert np.isnan(out[[0, 1, 3]]).all() and out[2].tolist() == [20.0, 0.0, 40.0]
    assert dead.sample(0.0, 0.0, 0.0) is False and dead.sample(20.0, 0.0, 40.0) is True
    assert dead.sample(math.nan, math.nan, math.nan) is False and (dead.samples, dead.dead) == (5, 3)


@pytest.mark.parametrize("dead", ["zero", "tiny", "mixed", "nan"])
@pytest.mark.parametrize("until_s", [math.inf, 30.0])
def test_compensate_leaves_dead_samples_out(dead, until_s):
    log = raw_compass_log(dead, until_s, keep_heading=True)
    out = compensate(log, SHORT, source="log.csv")
    assert np.isfinite(out[["rate_z", "bias_z", "heading"]].to_numpy()).all()
    notes = " ".join(out.attrs["notes"])
    assert "magnetometer samples read no field" in notes, notes
    assert out.attrs.get("compass") != "none"  # the heading column is a compass


@pytest.mark.parametrize("dead", ["zero", "mixed"])
def test_a_magnetometer_that_never_reads_a_field_is_no_compass(dead):
    log = raw_compass_log(dead)
    out = compensate(log, SHORT, source="log.csv")
    assert out.attrs["compass"] == "none"
    assert any(n.startswith("log.csv: no compass (the magnetometer is dead") for n in out.attrs["notes"])
    without = compensate(log.drop(columns=MAG), SHORT, source="log.csv")
    for col in ("rate_z", "bias_z", "heading", "a", "b", "c"):
        np.testing.assert_array_equal(out[col].to_numpy(), without[col].to_numpy(), err_msg=col)


def test_dead_rows_through_the_init_window_give_no_compass_heading_there():
    out = compensate(raw_compass_log("mixed", 30.0), SHORT, source="log.csv")
    early = out["t"].to_numpy() < 30.0
    assert np.isnan(out["compass_heading"].to_numpy()[early]).all()
    assert np.isfinite(out["compass_heading"].to_numpy()[~early]).any()


@pytest.mark.parametrize("dead", ["zero", "mixed"])
def test_compensator_push_takes_dead_samples(dead):
    log = raw_compass_log(dead, 30.0, keep_heading=True)
    comp = Compensator(SHORT, source="stream")
    rows = []
    for r in log.itertuples(index=False):
        rows += comp.push(r.t, r.gyro_z, r.temp, heading_deg=r.heading, mag=(r.mag_x, r.mag_y, r.mag_z),
                          acc=(r.acc_x, r.acc_y, r.acc_z))
    assert len(rows) == len(log) and all(math.isfinite(r.rate_z) for r in rows)
    assert any("read no field" in n for n in comp.notes) and not comp.compass_dead


def test_compensator_without_any_field_has_no_compass():
    comp = Compensator(SHORT, source="stream")
    for t in np.arange(0.0, 40.0, 0.1):
        comp.push(float(t), 0.1, 25.0, mag=(0.0, 0.0, 1e-300 * (int(t * 10) % 2)), acc=(0.0, 0.0, -1.0))
    assert comp.compass_dead
    assert any(n.startswith("stream: no compass (the magnetometer is dead") for n in comp.notes)


@pytest.fixture
def dead_files(tmp_path):
    """The same dead-magnetometer log (heading column kept) as CSV and Parquet."""
    log = raw_compass_log("zero", keep_heading=True)
    csv, parquet = tmp_path / "dead.csv", tmp_path / "dead.parquet"
    log.to_csv(csv, index=False)
    log.to_parquet(parquet)
    return csv, parquet


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_compensate_command_on_a_dead_magnetometer(dead_files, tmp_path, capsys, fmt):
    path = dead_files[fmt == "parquet"]
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), "--init-s", "30"]) == 0
    assert "read no field" in capsys.readouterr().out
    assert len(read_log(tmp_path / "out.csv")) == 1200


def test_stream_report_and_compare_on_a_dead_magnetometer(dead_files, tmp_path, capsys):
    csv = str(dead_files[0])
    assert main(["stream", csv, "-o", str(tmp_path / "s.csv"), "-q"]) == 0
    assert "read no field" in capsys.readouterr().err
    assert main(["report", csv, "-o", str(tmp_path / "r.html"), "--methods", "adaptive,stkf"]) == 0
    assert main(["compare", csv, "--methods", "adaptive,kf", "--json"]) == 0
    assert "Traceback" not in capsys.readouterr().err


def test_stream_says_no_compass_when_the_field_is_never_read(tmp_path, capsys):
    path = tmp_path / "dead.csv"
    raw_compass_log("mixed").to_csv(path, index=False)
    assert main(["stream", str(path), "-o", str(tmp_path / "s.csv")]) == 0
    err = capsys.readouterr().err
    assert "compass from none" in err and "no compass (the magnetometer is dead" in err


def test_a_dataflash_log_with_a_dead_magnetometer(tmp_path, capsys):
    from dataflash_writer import write_simulated
    from gyrodrift.simulate import TriadModel, simulate

    sim = simulate("vehicle-rawmag", seed=3, duration_s=60.0, fs_hz=50.0, raw_mag=True, triad=TriadModel())
    sim.loc[np.isfinite(sim["mag_x"].to_numpy()), MAG] = 0.0
    path = write_simulated(tmp_path / "dead.bin", sim, instances=1)
    assert main(["compensate", str(path), "-o", str(tmp_path / "o.csv")]) == 0
    out = capsys.readouterr().out
    assert "no compass (the magnetometer is dead" in out
    assert np.isfinite(pd.read_csv(tmp_path / "o.csv")["rate_z"]).all()

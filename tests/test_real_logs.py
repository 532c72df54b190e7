"""Real recorded logs nobody here designed (shared/data, and one excerpt in tests/data):
compensated, never refused.

Each test of shared/data skips with a reason when ``../shared/data`` is not beside the repository.
"""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gyrodrift import compensate
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.conventions import wrap_180
from gyrodrift.io import read_log


def records(log: pd.DataFrame) -> np.ndarray:
    """Record number of every row of a bursty log (a new record after each time gap)."""
    return np.cumsum(np.r_[True, np.diff(log["t"].to_numpy()) > 1.0])


@pytest.mark.parametrize("name", ["contract.csv", "contract_synthcompass.csv"])
def test_bursty_thermal_vacuum_log_learns_from_every_record(shared_data, name):
    """pan_lsm6dsm_tvac: 5-s records every 305 s, still, cooling 24 -> 16 degC. Each record is a
    still run that measures the drift; the bias in force during a record is within the
    record-to-record wander of the bias (record means move by up to 0.016 deg/s between records,
    each known to 0.001) of that record's mean gyro."""
    log = read_log(shared_data / "pan_lsm6dsm_tvac" / name)
    out = compensate(log)
    rec = records(log)
    assert rec[-1] == 25
    assert out["updated"].sum() >= 22  # one per record (the first is the init window)
    by = pd.DataFrame({"rec": rec, "g": log["gyro_z"].to_numpy(), "b": out["bias_z"].to_numpy()}).groupby("rec").mean()
    err = (by["b"] - by["g"]).abs().to_numpy()[3:]
    assert np.median(err) < 0.005 and err.max() < 0.02
    if "synthcompass" in name:  # a still compass: the gyro heading holds within 1 deg of it
        assert np.abs(wrap_180(out["heading"] - out["ref_heading"])).max() < 1.0
        fused = np.asarray(wrap_180(out["heading_fused"] - out["ref_heading"]), dtype=float)
        seen = np.isfinite(fused)  # empty before the first compass epoch
        assert seen.mean() > 0.99 and np.abs(fused[seen]).max() < 1.0
    else:
        assert out.attrs["notes"] and out["compass_heading"].isna().all()
        assert np.abs(wrap_180(out["heading"] - out["heading"].iloc[0])).max() < 1.0  # still: holds


def _two_turns(shared_data, estimator, name="contract.csv"):
    out = compensate(read_log(shared_data / "mpu6050_rotate_z" / name), CompensatorConfig(estimator=estimator))
    assert any("shorter than the 30-s init window" in n for n in out.attrs["notes"])
    return float(np.sum(wrap_180(np.diff(out["heading"]))))


def test_two_turns_in_24_s_by_the_papers_filter(shared_data):
    """mpu6050_rotate_z: a 24-s log (shorter than the 30-s init window), two counter-clockwise
    turns: -720 deg within 15 deg, with a note (the STKF keeps its prior: -733 deg)."""
    assert _two_turns(shared_data, "stkf") == pytest.approx(-720.0, abs=15.0)


#: The start rows :func:`test_two_turns_wherever_the_log_starts` drops: none to 57 (its first 0.5 s).
_STARTS = range(0, 60, 3)


def test_two_turns_in_24_s_with_the_default_settings(shared_data):
    """The issue's file, its raw magnetometer uncalibrated (its field strength scatters by 9 % with
    the heading), calibrated from the log by default (``mag_calibration = "auto"``): it turns
    -720 deg within 15 deg."""
    assert _two_turns(shared_data, "adaptive") == pytest.approx(-720.0, abs=15.0)


def test_its_raw_magnetometer_is_calibrated_from_the_log_with_a_note(shared_data):
    """The same file: the note says the magnetometer was calibrated from the log, and why."""
    raw = compensate(read_log(shared_data / "mpu6050_rotate_z" / "contract.csv"))
    said = [n for n in raw.attrs["notes"] if "calibrated from the log" in n]
    assert len(said) == 1 and "it looked uncalibrated: its field strength scattered by 9." in said[0], raw.attrs["notes"]


def test_without_the_calibration_its_magnetometer_is_said_to_be_uncalibrated(shared_data):
    """With ``mag_calibration = false`` a note says the magnetometer looks uncalibrated and names
    the setting; the same log's heading column gets no such note."""
    log = read_log(shared_data / "mpu6050_rotate_z" / "contract.csv")
    raw = compensate(log, CompensatorConfig(mag_calibration=False))
    said = [n for n in raw.attrs["notes"] if "looks uncalibrated" in n]
    assert len(said) == 1 and "mag_calibration" in said[0], raw.attrs["notes"]
    column = compensate(read_log(shared_data / "mpu6050_rotate_z" / "contract_heading.csv"))
    assert not any("uncalibrated" in n for n in column.attrs["notes"])


@pytest.mark.parametrize("name, reader", [("actigraph_gt9x_cooling/contract.csv", None),
                                          ("px4/sample_px4_events.ulg", "pyulog")])
def test_a_magnetometer_that_does_not_look_uncalibrated_is_left_as_it_is(shared_data, name, reader):
    """Real raw magnetometers that do not look uncalibrated (a still board; a flight that turns
    too little for the fit): the default calibration (``"auto"``) changes nothing and says nothing."""
    if reader:
        pytest.importorskip(reader)
    log = read_log(shared_data / name)
    default = compensate(log)
    off = compensate(log, CompensatorConfig(mag_calibration=False))
    assert not any("calibrated" in n for n in default.attrs["notes"]), default.attrs["notes"]
    np.testing.assert_array_equal(default["heading"].to_numpy(float), off["heading"].to_numpy(float))


def test_two_turns_in_24_s_from_the_heading_column(shared_data):
    """The same log with its compass as a heading column, which follows the gyro through the
    turns within 6.6 deg RMS (the raw magnetometer's heading: 36 deg)."""
    assert _two_turns(shared_data, "adaptive", "contract_heading.csv") == pytest.approx(-720.0, abs=15.0)


@pytest.mark.parametrize("name", ["contract.csv", "contract_heading.csv"])
def test_two_turns_wherever_the_log_starts(shared_data, name):
    """The log started 0, 3, ..., 57 rows later (within its first half second, before the hand
    turns it): the gyro heading turns -720 deg within 15 deg in the median over those starts and
    from at least 90 % of them. Its rows arrive in clusters, about 8 rows 2 ms apart every 50-80
    ms (a 252-ms pause after its first 13): the pauses are no time gaps past the first second (a
    128-ms one at 0.43 s is, where the log's rate is not yet known), and the model times the
    rows by a sample clock at the log's mean step, so where the log starts does not move what it
    learns in its first epochs."""
    log = read_log(shared_data / "mpu6050_rotate_z" / name)
    totals = []
    for start in _STARTS:
        out = compensate(log.iloc[start:].reset_index(drop=True))
        totals.append(float(np.sum(wrap_180(np.diff(out["heading"])))))
        gaps = out["t"].to_numpy()[out["gate_reason"].astype(str).to_numpy() == "gap"]
        assert np.all(gaps < 1.0), gaps  # at most while the first clusters show the log's rate
    totals = np.array(totals)
    assert np.median(totals) == pytest.approx(-720.0, abs=15.0), totals
    assert np.mean(np.abs(totals + 720.0) <= 15.0) >= 0.9, totals


@pytest.mark.parametrize("name, said", [
    ("sample_log_small.ulg", "shorter than the 30-s init window"),
    ("sample_px4_events.ulg", "no usable gyro temperature"),
])
def test_px4_sample_logs_are_compensated_with_a_note(shared_data, name, said):
    pytest.importorskip("pyulog")
    log = read_log(shared_data / "px4" / name)
    out = compensate(log)
    assert len(out) == len(log) and out["rate_z"].notna().all() and out["heading"].notna().all()
    assert any(said in n for n in out.attrs["notes"]), out.attrs["notes"]


def test_px4s_declination_brings_the_simulated_flight_to_its_attitude(shared_data):
    """``sample_px4_events.ulg`` (PX4 SITL): its EKF2_MAG_DECL (3.32 deg) is added to the compass by
    default; the fused heading is then within 0.5 deg RMS of ``vehicle_attitude``'s yaw (3.6 deg in
    magnetic north)."""
    pytest.importorskip("pyulog")
    log = read_log(shared_data / "px4" / "sample_px4_events.ulg")
    assert log.attrs["onboard"].declination[0] == pytest.approx(3.3231, abs=1e-3)

    def rms(out):
        err = np.asarray(wrap_180(out["heading_fused"] - log["ref_heading"]), dtype=float)
        return float(np.sqrt(np.nanmean(err ** 2)))

    assert rms(compensate(log)) < 0.5 < 3.0 < rms(compensate(log, CompensatorConfig(declination_deg=0.0)))


@pytest.mark.xfail(strict=True, reason="issue 21 not met: the heading column's samples repeat (an 8-Hz magnetometer on "
                   "100-Hz rows); with the noise's correlation measured (kappa) the still rows keep the compass, "
                   "but the fused heading keeps the first seconds' compass (86.3 deg) while the compass creeps "
                   "to 88.6 deg: 1.9-2.7 deg from its mean against the 2 asked (docs/results.md, 'A real "
                   "compass whose samples repeat')")
def test_a_still_board_with_a_repeating_compass_keeps_it(shared_data):
    """actigraph_gt9x_cooling, heading column: still and cooling for the first ~68 s, the compass
    within a few degrees (it creeps 1.7 deg). After the init window the still rows are not
    refused as interference, and the fused heading stays within 2 deg of the compass's mean."""
    log = read_log(shared_data / "actigraph_gt9x_cooling" / "contract_heading.csv")
    out = compensate(log)
    t = out["t"].to_numpy()
    still = (t > 35.0) & (t < 65.0)
    assert np.mean(out["gate_reason"].to_numpy()[still] == "interference") < 0.1
    compass = np.nanmean(log["heading"].to_numpy()[still])
    fused = np.asarray(out["heading_fused"], dtype=float)[still]
    assert np.abs(wrap_180(fused - compass)).max() < 2.0


#: 120 s of a still MPU6050 + HMC5883L board (tests/data/README.md), its rows stamped in clusters.
STILL_MPU6050 = Path(__file__).parent / "data" / "mpu6050_still_120s.csv.gz"


def test_a_real_still_board_stamped_in_clusters_has_no_time_gaps():
    """The same rig as ``mpu6050_rotate_z``, unmoved: its rows arrive in clusters (median step
    2 ms, mean 10 ms). After its first second (its first clusters show the spacing) no row is a
    time gap, none is labelled turning or disturbed, the gyro heading holds within 0.5 deg, and
    after the first minute the drift is the still gyro's own mean within 0.01 deg/s."""
    log = read_log(STILL_MPU6050)
    steps = np.diff(log["t"].to_numpy())
    assert np.median(steps) < 0.003 < 0.008 < steps.mean()  # the premise: clusters
    out = compensate(log)
    labels = set(out["gate_reason"].astype(str)[log["t"].to_numpy() > 1.0])
    assert labels <= {"", "init"}, labels
    heading = out["heading"].to_numpy(float)
    assert np.abs(wrap_180(heading - heading[0])).max() < 0.5
    late = log["t"].to_numpy() > 60.0
    own = float(log["gyro_z"].to_numpy()[late].mean())
    assert np.abs(out["bias_z"].to_numpy()[late] - own).max() < 0.01, own

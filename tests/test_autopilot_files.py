"""Parameter files a pilot can load without fear (issue 23, items 1-4).

Synthetic heating runs are written as the autopilots log them (ArduPilot .bin through
tests/dataflash_writer.py, PX4 .ulg through tests/ulog_writer.py): a rotated board, an
onboard correction on while recording, gyros with device ids. The files gyrodrift writes
are then applied as the autopilot would, by this module's own emulation (the formulas in
gyrodrift.onboard's notes, on the raw sensor rates of the simulation, from the file
parsed here), and the drift left is compared with the fit's residual.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dataflash_writer import G_MPS2, write_simulated
from gyrodrift.calcheck import check_log
from gyrodrift.calibrate import calibrate_log
from gyrodrift.cli import main
from gyrodrift.onboard import ardupilot_onboard, px4_onboard
from gyrodrift.paramfiles import write_calibration
from gyrodrift.rotations import ARDUPILOT_ROTATIONS, PX4_ROTATIONS, rotation_matrix
from test_calibrate import ardupilot_poly_dps, parse, px4_offset_dps
from ulog_writer import SENSOR_COMBINED, SENSOR_GYRO, records, write_ulog

#: The body-frame drift, deg/s, as c_0..c_3 about 30 degC, plus a small departure from a cubic.
DRIFT = {"x": (-0.2, -0.012, 1e-4, 2e-6), "y": (0.15, 0.02, -2e-4, 0.0), "z": (0.3, 0.025, 3e-4, -3e-6)}
DEVICE = 2424842


def body_drift(temp: np.ndarray) -> np.ndarray:
    """True drift of the body axes (n, 3), deg/s."""
    cols = [np.polynomial.polynomial.polyval(temp - 30.0, DRIFT[a]) + 0.01 * np.sin(temp / 1.7) for a in "xyz"]
    return np.column_stack(cols)


def heating(fs_hz: float = 2.0, duration_s: float = 1200.0, noise_dps: float = 0.03, seed: int = 1):
    """t (s), temperature 15 -> 45 degC, and the true body rates of a still unit (drift + noise)."""
    t = np.arange(0.0, duration_s, 1.0 / fs_hz)
    temp = 15.0 + 30.0 * t / t[-1]
    rates = body_drift(temp) + np.random.default_rng(seed).normal(0.0, noise_dps, (t.size, 3))
    return t, temp, rates


def frame(t, temp, rates) -> pd.DataFrame:
    """A contract log of a still level unit (FRD: acc_z = -1 g)."""
    n = t.size
    return pd.DataFrame({"t": t, "gyro_x": rates[:, 0], "gyro_y": rates[:, 1], "gyro_z": rates[:, 2], "temp": temp,
                         "acc_x": np.zeros(n), "acc_y": np.zeros(n), "acc_z": -np.ones(n),
                         "mag_x": np.nan, "mag_y": np.nan, "mag_z": np.nan, "ref_heading": np.zeros(n)})


def left_rms(temp, left_dps, about_mean: bool) -> np.ndarray:
    """Per axis, RMS over 0.25-degC bins of the bin mean of ``left_dps`` (n, 3)."""
    b = np.floor((temp - temp.min()) / 0.25).astype(int)
    n = np.bincount(b)
    out = []
    for i in range(3):
        means = np.bincount(b, left_dps[:, i])[n >= 10] / n[n >= 10]
        out.append(np.sqrt(np.mean((means - means.mean() if about_mean else means) ** 2)))
    return np.array(out)


def ardupilot_left(path, temp, raw_body, R, imu=1) -> np.ndarray:
    """ArduPilot with the file at ``path``: sensor = R^T body, minus P(T); back to the body frame."""
    p = parse(path)
    sensor = raw_body @ R  # rows: R^T v
    out = (sensor - ardupilot_poly_dps(p, temp, imu)) @ R.T
    return left_rms(temp, out, about_mean=True)


def px4_left(path, temp, raw_body, R, slot=0) -> np.ndarray:
    """PX4 with the file at ``path``: R (sensor - offset(T))."""
    p = parse(path)
    out = (raw_body @ R - px4_offset_dps(p, temp, slot)) @ R.T
    return left_rms(temp, out, about_mean=False)


def residuals(cal) -> np.ndarray:
    return np.array([cal.axes[a].residual_rms_dps for a in "xyz"])


# --------------------------------------------------------------------------- logs as the autopilots write them


def ardupilot_bin(path, t, temp, logged_body, params) -> str:
    write_simulated(path, frame(t, temp, logged_body), instances=1, mag=False, att_every=0, params=params)
    return str(path)


def px4_ulg(path, t, temp, raw_body, R, params, *, devices=(DEVICE,), combined=None) -> str:
    """``sensor_gyro`` (board frame, rad/s) of each device; ``combined``: body rates (deg/s)
    for ``sensor_combined`` at every row, sensor_gyro then at every 4th."""
    us = (t * 1e6).astype(np.int64) + 1_000_000
    sensor = np.radians(raw_body @ R)
    every = slice(None, None, 4) if combined is not None else slice(None)
    topics = {}
    for k, dev in enumerate(devices):
        topics[("sensor_gyro", k)] = (SENSOR_GYRO, records(
            SENSOR_GYRO, timestamp=us[every], timestamp_sample=us[every], device_id=np.full(us[every].size, dev),
            x=sensor[every, 0] + 0.001 * k, y=sensor[every, 1], z=sensor[every, 2], temperature=temp[every]))
    if combined is not None:
        topics[("sensor_combined", 0)] = (SENSOR_COMBINED, records(
            SENSOR_COMBINED, timestamp=us, gyro_rad=np.radians(combined), gyro_integral_dt=np.full(us.size, 4000),
            accelerometer_timestamp_relative=np.zeros(us.size, dtype=np.int32),
            accelerometer_m_s2=np.tile([0.0, 0.0, -G_MPS2], (us.size, 1))))
    ids = {f"CAL_GYRO{k}_ID": dev for k, dev in enumerate(devices)}
    write_ulog(path, topics, {**ids, **params})
    return str(path)


# --------------------------------------------------------------------------- defect 1: board rotation


def test_ardupilot_board_rolled_180_gets_coefficients_in_its_sensor_frame(tmp_path, capsys):
    t, temp, body = heating()
    R = rotation_matrix("ardupilot", 8)
    log = ardupilot_bin(tmp_path / "roll180.bin", t, temp, body, {"AHRS_ORIENTATION": 8})
    assert main(["calibrate", log, "-o", str(tmp_path / "c.param")]) == 0
    cal = calibrate_log(pd.read_csv(_csv(tmp_path, frame(t, temp, body))), source="same data")[0]
    left = ardupilot_left(tmp_path / "c.param", temp, body, R)
    assert np.all(left <= residuals(cal) + 0.01), (left, residuals(cal))
    p = parse(tmp_path / "c.param")  # board y = -body y: the sign of y and z flips
    assert p["INS_TCAL1_GYR1_Y"][0] * DRIFT["y"][1] < 0 and p["INS_TCAL1_GYR1_X"][0] * DRIFT["x"][1] > 0
    assert "AHRS_ORIENTATION=8 (ROLL_180)" in (tmp_path / "c.param").read_text()


def _csv(tmp_path, df) -> str:
    df.to_csv(tmp_path / "same.csv", index=False)
    return str(tmp_path / "same.csv")


def test_px4_board_rotation_and_device_id_from_the_ulog(tmp_path):
    """Defects 1 and 3: SENS_BOARD_ROT read and undone in the file; TC_G0_ID = the gyro's id."""
    t, temp, body = heating()
    R = rotation_matrix("px4", 10)  # roll 180 yaw 90
    log = px4_ulg(tmp_path / "rot.ulg", t, temp, body, R, {"SENS_BOARD_ROT": 10, "MAV_SYS_ID": 3})
    assert main(["calibrate", log, "-o", str(tmp_path / "c.params"), "-q"]) == 0
    p = parse(tmp_path / "c.params")
    assert p["TC_G0_ID"][0] == DEVICE and p["TC_G0_ID"][2] == "3"  # the log's MAV_SYS_ID
    cal = calibrate_log(pd.read_csv(_csv(tmp_path, frame(t, temp, body))))[0]
    left = px4_left(tmp_path / "c.params", temp, body, R)
    assert np.all(left <= residuals(cal) + 0.01), (left, residuals(cal))
    assert main(["calibrate", log, "-o", str(tmp_path / "s.params"), "-q", "--sysid", "7"]) == 0
    assert parse(tmp_path / "s.params")["TC_G0_ID"][2] == "7"


def test_board_rotation_option_overrides_the_log(tmp_path):
    t, temp, body = heating()
    R = rotation_matrix("ardupilot", 8)
    log = ardupilot_bin(tmp_path / "wrong.bin", t, temp, body, {"AHRS_ORIENTATION": 0})
    assert main(["calibrate", log, "-o", str(tmp_path / "c.param"), "-q", "--board-rotation", "8"]) == 0
    cal = calibrate_log(pd.read_csv(_csv(tmp_path, frame(t, temp, body))))[0]
    assert np.all(ardupilot_left(tmp_path / "c.param", temp, body, R) <= residuals(cal) + 0.01)
    # a table's axes are the sensor's unless told: the option names roll,pitch,yaw then
    table = _csv(tmp_path, frame(t, temp, body))
    assert main(["calibrate", table, "-o", str(tmp_path / "t.param"), "-q", "--board-rotation", "180,0,0"]) == 0
    np.testing.assert_allclose(parse(tmp_path / "t.param")["INS_TCAL1_GYR1_Y"][0],
                               parse(tmp_path / "c.param")["INS_TCAL1_GYR1_Y"][0], rtol=1e-9)


ROTATIONS = [("px4", n) for n in PX4_ROTATIONS] + [("ardupilot", n) for n in ARDUPILOT_ROTATIONS] + \
    [("ardupilot", n) for n in (100, 101, 102)]
CUSTOM = {"AHRS_CUSTOM_ROLL": 10.0, "AHRS_CUSTOM_PIT": -20.0, "AHRS_CUSTOM_YAW": 33.0, "CUST_ROT1_ROLL": 180.0,
          "CUST_ROT1_PITCH": 0.0, "CUST_ROT1_YAW": 225.0, "CUST_ROT2_ROLL": 90.0, "CUST_ROT2_PITCH": 45.0,
          "CUST_ROT2_YAW": 270.0}


@pytest.fixture(scope="module")
def run():
    t, temp, body = heating()
    return t, temp, body, frame(t, temp, body)


@pytest.mark.parametrize("autopilot, number", ROTATIONS)
def test_round_trip_on_every_rotation_leaves_the_fits_residual(run, tmp_path, autopilot, number):
    """Acceptance: the autopilot-side drift left after applying our file is within 0.01
    deg/s of the fit's residual, per axis; --check measures what the emulation does."""
    t, temp, body, log = run
    log = log.copy()
    if autopilot == "ardupilot":
        log.attrs["onboard"] = ardupilot_onboard({"AHRS_ORIENTATION": number, **CUSTOM}, 0)
    else:
        R = rotation_matrix("px4", number)
        log.attrs["onboard"] = px4_onboard({}, 0, DEVICE, R, f"SENS_BOARD_ROT={number}", corrected=False)
    R = log.attrs["onboard"].matrix
    cal, notes = calibrate_log(log, source="run")
    path = tmp_path / ("c.params" if autopilot == "px4" else "c.param")
    write_calibration(cal, path)
    left = (px4_left if autopilot == "px4" else ardupilot_left)(path, temp, body, R)
    assert np.all(np.abs(left - residuals(cal)) <= 0.01), (left, residuals(cal))
    check = check_log(path, log)
    assert check.applied and not notes
    np.testing.assert_allclose([a.left_rms_dps for a in check.axes], residuals(cal), atol=0.01)


# --------------------------------------------------------------------------- defect 2: onboard correction on


OLD_AP = {"INS_TCAL1_ENABLE": 1, "INS_TCAL1_TMIN": 10.0, "INS_TCAL1_TMAX": 50.0, "INS_GYR1_CALTEMP": 25.0,
          **{f"INS_TCAL1_GYR{k}_{a}": v for k, row in enumerate(((300.0, -350.0, 420.0), (3.0, -2.0, 4.0),
                                                                  (0.02, 0.0, -0.03)), start=1)
             for a, v in zip("XYZ", row)}}


def test_ardupilot_correction_on_while_recording_is_added_back(tmp_path, capsys):
    t, temp, body = heating()
    R = rotation_matrix("ardupilot", 8)
    applied = ardupilot_poly_dps({k: (v,) for k, v in OLD_AP.items()}, temp) - \
        ardupilot_poly_dps({k: (v,) for k, v in OLD_AP.items()}, np.full(1, 25.0))
    logged = body - applied @ R.T  # ArduPilot logs R (sensor - P(T) + P(T_cal))
    log = ardupilot_bin(tmp_path / "on.bin", t, temp, logged, {"AHRS_ORIENTATION": 8, **OLD_AP})
    assert main(["calibrate", log, "-o", str(tmp_path / "c.param")]) == 0
    err = capsys.readouterr().err
    assert "INS_TCAL1_* (INS_TCAL1_ENABLE=1) was on" in err and "added back" in err
    cal = calibrate_log(pd.read_csv(_csv(tmp_path, frame(t, temp, body))))[0]
    left = ardupilot_left(tmp_path / "c.param", temp, body, R)  # applied to the raw sensor, as it will be
    assert np.all(left <= residuals(cal) + 0.01), (left, residuals(cal))


def test_px4_correction_on_while_recording_is_added_back(tmp_path, capsys):
    t, temp, body = heating(fs_hz=8.0)
    R = rotation_matrix("px4", 4)
    old = {"TC_G_ENABLE": 1, "TC_G0_ID": DEVICE, "TC_G0_TMIN": 10.0, "TC_G0_TMAX": 50.0, "TC_G0_TREF": 30.0,
           **{f"TC_G0_X{k}_{a}": float(np.radians(c) * 0.8) for k in range(4)
              for a, c in enumerate(np.array([DRIFT[x][k] for x in "xyz"]) @ R)}}
    corrected = body - px4_offset_dps({k: (v,) for k, v in old.items()}, temp) @ R.T
    log = px4_ulg(tmp_path / "tc.ulg", t, temp, body, R, {"SENS_BOARD_ROT": 4, **old}, combined=corrected)
    assert main(["calibrate", log, "-o", str(tmp_path / "c.params"), "--instance", "0"]) == 0
    assert "TC_G0_* (TC_G_ENABLE=1) was on" in capsys.readouterr().err
    cal = calibrate_log(pd.read_csv(_csv(tmp_path, frame(t, temp, body))))[0]
    left = px4_left(tmp_path / "c.params", temp, body, R)
    assert np.all(left <= residuals(cal) + 0.01), (left, residuals(cal))


@pytest.mark.parametrize("case, expected", [
    ("changed", "INS_TCAL1_ENABLE changed during the log"),
    ("missing", "INS_TCAL1_GYR3_Z"),
])
def test_a_correction_that_cannot_be_undone_is_refused_in_one_line(tmp_path, capsys, case, expected):
    t, temp, body = heating()
    params = dict(OLD_AP)
    if case == "missing":
        del params["INS_TCAL1_GYR3_Z"]
    path = ardupilot_bin(tmp_path / "x.bin", t, temp, body, params)
    if case == "changed":  # a second PARM later in the log with another value
        from dataflash_writer import DataFlashWriter, PARM_COLUMNS, PARM_FORMAT

        with open(path, "ab") as fh:
            w = DataFlashWriter(fh)
            w.define("PARM", PARM_FORMAT, PARM_COLUMNS)
            w.write("PARM", 900_000_000, "INS_TCAL1_ENABLE", 0.0)
    assert main(["calibrate", path, "-o", str(tmp_path / "c.param")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expected in err and str(path) in err
    assert not (tmp_path / "c.param").exists()


# --------------------------------------------------------------------------- defect 3: ids and instances


def test_every_gyro_gets_its_slot_and_device_id(tmp_path, capsys):
    t, temp, body = heating()
    R = np.eye(3)
    devices = (2424842, 3670050)
    log = px4_ulg(tmp_path / "two.ulg", t, temp, body, R, {"SENS_BOARD_ROT": 0}, devices=devices)
    assert main(["calibrate", log, "-o", str(tmp_path / "c.params")]) == 0
    out = capsys.readouterr().out
    assert [line[:7] for line in out.splitlines()] == ["gyro 0:", "gyro 1:"] and "wrote" in out
    p = parse(tmp_path / "c.params")
    assert (p["TC_G0_ID"][0], p["TC_G1_ID"][0]) == devices and list(p).count("TC_G_ENABLE") == 1
    # the second gyro reads 0.001 rad/s more on x: its own slot says so
    assert p["TC_G1_X0_0"][0] - p["TC_G0_X0_0"][0] == pytest.approx(0.001, abs=2e-4)
    assert main(["calibrate", "--check", str(tmp_path / "c.params"), log]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 4 and "PX4 applies TC_G0_*" in lines[0] and "PX4 applies TC_G1_*" in lines[2]
    # ArduPilot: IMU instance n -> INS_TCAL(n+1)
    assert main(["calibrate", log, "-o", str(tmp_path / "one.params"), "--instance", "1", "-q"]) == 0
    one = parse(tmp_path / "one.params")
    assert one["TC_G1_ID"][0] == devices[1] and "TC_G0_ID" not in one


def test_check_says_when_px4_applies_nothing(tmp_path, capsys):
    """Defect 3 seen by --check: a file whose TC_G0_ID is not the gyro's applies nothing."""
    t, temp, body = heating()
    log = px4_ulg(tmp_path / "g.ulg", t, temp, body, np.eye(3), {"SENS_BOARD_ROT": 0})
    assert main(["calibrate", _csv(tmp_path, frame(t, temp, body)), "-o", str(tmp_path / "zero.params"), "-q"]) == 0
    assert parse(tmp_path / "zero.params")["TC_G0_ID"][0] == 0
    assert main(["calibrate", "--check", str(tmp_path / "zero.params"), log]) == 1
    out = capsys.readouterr().out
    assert "PX4 applies nothing to this gyro (no TC_G slot holds the gyro's device id 2424842" in out
    assert main(["calibrate", "--check", str(tmp_path / "zero.params"), log, "--instance", "0"]) == 1  # picks the gyro


def test_check_on_a_table_and_its_errors(tmp_path, capsys):
    t, temp, body = heating()
    table = _csv(tmp_path, frame(t, temp, body))
    assert main(["calibrate", table, "-o", str(tmp_path / "c.param"), "-q"]) == 0
    assert main(["calibrate", "--check", str(tmp_path / "c.param"), table]) == 0
    head, detail = capsys.readouterr().out.splitlines()
    assert "ArduPilot applies INS_TCAL1_*" in head and "about its mean" in detail
    left = [float(x.split()[1]) for x in detail.split("(peak): ")[1].split(" deg/s")[0].split(", ")]
    assert max(left) < 0.02
    assert main(["calibrate", table, "-o", str(tmp_path / "c.json"), "-q"]) == 0
    assert main(["calibrate", "--check", str(tmp_path / "c.json"), table]) == 2
    assert "no autopilot's" in capsys.readouterr().err
    assert main(["calibrate", table]) == 2
    assert "-o OUTPUT" in capsys.readouterr().err


def test_ardupilot_parameters_in_qgroundcontrols_file(tmp_path, capsys):
    """QGroundControl loads only its own tab-separated lines, whatever the autopilot."""
    t, temp, body = heating()
    log = ardupilot_bin(tmp_path / "r.bin", t, temp, body, {"AHRS_ORIENTATION": 8, "SYSID_THISMAV": 5})
    assert main(["calibrate", log, "-o", str(tmp_path / "q.params"), "--format", "ardupilot-qgc", "-q"]) == 0
    assert main(["calibrate", log, "-o", str(tmp_path / "c.param"), "-q"]) == 0
    text = (tmp_path / "q.params").read_text()
    assert "5\t1\tINS_TCAL1_ENABLE\t1\t2" in text and "5\t1\tINS_TCAL1_GYR1_X\t" in text
    q, c = parse(tmp_path / "q.params"), parse(tmp_path / "c.param")
    assert {k: v[0] for k, v in q.items()} == {k: v[0] for k, v in c.items()}
    assert main(["calibrate", "--check", str(tmp_path / "q.params"), log]) == 0
    assert "ArduPilot applies INS_TCAL1_*" in capsys.readouterr().out

"""Tests of the binary-log readers: PX4 ULog, ROS 1/2 bags, and the read_log dispatcher.

ULog tests read the real logs in ``shared/data/px4`` (skipped when absent) and edited
copies of them written with pyulog; ROS tests write small bags with rosbags' writers
in ``tmp_path`` (a known rotation, so every sign and unit is checked).
"""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from conftest import SHARED_DATA
from gyrodrift.compass import tilt_compensated_heading
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io import align as _align, read_log, read_rosbag, read_ulog
from gyrodrift.io import ulog as ulog_module

pyulog = pytest.importorskip("pyulog")
rosbags = pytest.importorskip("rosbags")

PX4 = SHARED_DATA / "px4"
SMALL = PX4 / "sample_log_small.ulg"
EVENTS = PX4 / "sample_px4_events.ulg"

CONTRACT = ["t", "gyro_z", "gyro_x", "gyro_y", "temp", "mag_x", "mag_y", "mag_z", "acc_x", "acc_y", "acc_z"]


def _raises(exc_type, func, *args, **kwargs) -> str:
    """Call ``func``; assert it raises ``exc_type`` with a one-line message; return it."""
    with pytest.raises(exc_type) as info:
        func(*args, **kwargs)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def _need(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(f"real PX4 log {path.name} not found in {PX4} (shared/data beside the repo)")
    return path


def _parse(path: Path, topics=None):
    with contextlib.redirect_stdout(io.StringIO()):
        return pyulog.ULog(str(path), message_name_filter_list=topics)


def _edited(tmp_path: Path, src: Path, edit=None, topics=None, name="edited.ulg") -> Path:
    """Copy of a real ULog, re-written by pyulog after ``edit(ulog)`` (only ``topics`` kept)."""
    ulog = _parse(src, topics)
    if edit is not None:
        edit(ulog)
    out = tmp_path / name
    ulog.write_ulog(str(out))
    return out


def _dataset(ulog, topic, instance=0):
    return ulog.get_dataset(topic, instance).data


def _set_temperature(topic, values_fn):
    def edit(ulog):
        data = _dataset(ulog, topic)
        data["temperature"] = values_fn(data["temperature"].size).astype(np.float32)

    return edit


def _board_to_body_scipy(params) -> Rotation:
    """Independent board-to-body rotation of sample_log_small.ulg's internal sensors.

    SENS_BOARD_ROT=4 (yaw 180 deg), then the level trims SENS_BOARD_{X,Y,Z}_OFF (deg)
    as Z-Y-X Euler angles.
    """
    assert params["SENS_BOARD_ROT"] == 4
    trims = Rotation.from_euler(
        "ZYX", [params["SENS_BOARD_Z_OFF"], params["SENS_BOARD_Y_OFF"], params["SENS_BOARD_X_OFF"]], degrees=True
    )
    return trims * Rotation.from_euler("Z", 180.0, degrees=True)


# ---------------------------------------------------------------------------
# PX4 ULog: an older logger's layout (sensor_combined alone)
# ---------------------------------------------------------------------------

OLD_COMBINED = [("uint64_t", "timestamp"), ("float[3]", "gyro_rad"), ("float", "gyro_integral_dt"),
                ("int32_t", "accelerometer_timestamp_relative"), ("float[3]", "accelerometer_m_s2"),
                ("float", "accelerometer_integral_dt"), ("int32_t", "magnetometer_timestamp_relative"),
                ("float[3]", "magnetometer_ga"), ("int32_t", "baro_timestamp_relative"), ("float", "baro_alt_meter"),
                ("float", "baro_temp_celcius")]


def _old_layout_ulog(path: Path, with_gyro: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A ULog as PX4 logged before ``sensor_gyro``: ``sensor_combined`` at 250 Hz with the gyro,
    the accelerometer and the magnetometer (a new sample every 5th row, held on the rows between,
    its own time ``magnetometer_timestamp_relative`` before the row's), no ``sensor_gyro``;
    returns the rows' times (µs), the magnetometer samples' times (µs) and their values."""
    from ulog_writer import records, write_ulog

    n = 2500
    ts = 2_000_000 + 4000 * np.arange(n, dtype=np.int64)
    gyro = np.column_stack([np.full(n, 0.01), np.full(n, -0.02), np.radians(5.0) * np.ones(n)])
    new = np.arange(n) % 5 == 0
    last = np.maximum.accumulate(np.where(new, np.arange(n), 0))
    rel = (ts[last] - 1500) - ts  # each row holds the last sample, timed 1.5 ms before its own row
    heading = np.radians(30.0 + 5.0 * (ts[last] - ts[0]) * 1e-6)
    mag = np.column_stack([0.2 * np.cos(heading), -0.2 * np.sin(heading), np.full(n, 0.4)])
    cols = dict(timestamp=ts, gyro_rad=gyro if with_gyro else np.zeros((n, 3)), gyro_integral_dt=np.full(n, 0.004),
                accelerometer_timestamp_relative=np.zeros(n, dtype=np.int64),
                accelerometer_m_s2=np.tile([0.0, 0.0, -9.81], (n, 1)), accelerometer_integral_dt=np.full(n, 0.004),
                magnetometer_timestamp_relative=rel, magnetometer_ga=mag, baro_timestamp_relative=np.zeros(n),
                baro_alt_meter=np.zeros(n), baro_temp_celcius=np.full(n, 31.0))
    fields = OLD_COMBINED if with_gyro else [f for f in OLD_COMBINED if f[1] != "gyro_rad"]
    if not with_gyro:
        cols.pop("gyro_rad")
    write_ulog(path, {("sensor_combined", 0): (fields, records(fields, **cols))})
    return ts, ts[new] - 1500, mag[new]


def test_an_older_ulog_with_sensor_combined_alone_is_read_with_its_compass(tmp_path):
    """A ULog of an older PX4 logger (no ``sensor_gyro``; ``sensor_combined`` carries the gyro,
    the accelerometer and the magnetometer, which it holds between its samples): the rates from
    ``sensor_combined`` in deg/s, each magnetometer sample once (none older than the first row);
    no temperature, and a note that says why; and ``compensate`` takes it."""
    from gyrodrift import compensate

    path = tmp_path / "old.ulg"
    ts, mag_t, mag = _old_layout_ulog(path)
    df = read_ulog(path)
    np.testing.assert_allclose(df["t"], ts * 1e-6)
    np.testing.assert_allclose(df["gyro_z"], 5.0, rtol=1e-6)
    np.testing.assert_allclose(df["gyro_x"], np.degrees(0.01), rtol=1e-6)
    assert (df["temp"] == 0.0).all()
    assert any("no sensor_gyro topic: the gyro is sensor_combined's" in n for n in df.attrs["notes"])
    rows = df["mag_x"].notna().to_numpy()
    inside = mag_t >= ts[0]  # the first sample is older than the first row
    assert rows.sum() == inside.sum() == mag_t.size - 1  # each sample once, not the 4 rows that hold it
    np.testing.assert_allclose(df.loc[rows, "mag_x"], mag[inside, 0], rtol=1e-6)
    assert "mag from sensor_combined" in df.attrs["summary"]
    out = compensate(df)
    heading = out["compass_heading"].to_numpy()[rows]  # the field turns 5 deg/s (by the rows' clock) from 30 deg
    np.testing.assert_allclose(heading, (30.0 + 5.0 * (mag_t[inside] + 1500 - ts[0]) * 1e-6) % 360.0, atol=1e-3)
    assert np.isfinite(out["heading_fused"].to_numpy()[(df["t"] - df["t"].iloc[0] >= 1.0).to_numpy()]).all()


def test_a_ulog_without_any_gyro_is_refused_naming_the_topic(tmp_path):
    """Neither ``sensor_gyro`` nor a gyro in ``sensor_combined``: refused, naming sensor_gyro."""
    path = tmp_path / "nogyro.ulg"
    _old_layout_ulog(path, with_gyro=False)
    with pytest.raises(LogFormatError, match="no 'sensor_gyro' topic"):
        read_ulog(path)


# ---------------------------------------------------------------------------
# PX4 ULog: real files
# ---------------------------------------------------------------------------


def test_ulog_small_default_uses_sensor_combined_in_deg_per_s():
    path = _need(SMALL)
    df = read_ulog(path)
    raw = _dataset(_parse(path, ["sensor_combined"]), "sensor_combined")
    assert list(df.columns) == CONTRACT + ["ref_heading"]
    assert len(df) == len(raw["timestamp"]) == 1298
    # absolute time in seconds, from the log's first sample (not shifted to 0)
    np.testing.assert_array_equal(df["t"], raw["timestamp"].astype(float) * 1e-6)
    assert df["t"].iloc[0] == pytest.approx(20.327, abs=1e-3)
    assert np.all(np.diff(df["t"]) > 0)
    # rad/s -> deg/s, FRD kept (PX4 is FRD already): each sample times 180/pi
    for axis, col in enumerate(("gyro_x", "gyro_y", "gyro_z")):
        np.testing.assert_allclose(df[col], np.degrees(raw[f"gyro_rad[{axis}]"].astype(float)), rtol=1e-12)
    sample = float(raw["gyro_rad[2]"][500])
    assert df["gyro_z"].iloc[500] == pytest.approx(sample * 180.0 / np.pi)
    assert 1.0 / np.median(np.diff(df["t"])) == pytest.approx(200.0, rel=0.05)
    # temperature of sensor_gyro instance 0, interpolated and held: the logged range
    assert 40.0 < df["temp"].min() and df["temp"].max() < 40.4
    # specific force: a roughly level vehicle reads acc_z close to -9.81 m/s^2
    assert df["acc_z"].mean() == pytest.approx(-9.6, abs=0.2)
    assert df[["acc_x", "acc_y", "acc_z"]].notna().all().all()
    assert df["mag_x"].notna().sum() == 318  # vehicle_magnetometer at 50 Hz, one per row
    assert df["ref_heading"].between(0.0, 360.0, inclusive="left").all()
    assert df.attrs["format"] == "ulog" and df.attrs["frame"] == "ned"
    assert df.attrs["gyro_unit"] == "deg/s" and df.attrs["compass"] == "mag"
    summary = df.attrs["summary"]
    assert "\n" not in summary
    for part in ("6.5 s", "sensor_combined", "sensor_gyro instance 0", "40.0..40.4 degC", "vehicle_magnetometer"):
        assert part in summary


@pytest.mark.parametrize(("instance", "temp_c"), [(0, 40.2), (1, 28.3), (2, 29.6)])
def test_ulog_small_selects_each_gyro_instance(instance, temp_c):
    df = read_ulog(_need(SMALL), instance=instance)
    assert df["temp"].mean() == pytest.approx(temp_c, abs=0.3)
    assert f"sensor_gyro instance {instance}" in df.attrs["summary"]


@pytest.mark.parametrize("instance", [1, 2])
def test_ulog_other_instance_rate_comes_from_its_own_chip(instance):
    # sensor_combined carries gyro 0 (sensor_selection), so instances 1 and 2 use their
    # own sensor_gyro (1 Hz here), rotated from the board frame: SENS_BOARD_ROT=4 (yaw
    # 180 deg) followed by the level trims SENS_BOARD_X_OFF/Y_OFF (deg)
    path = _need(SMALL)
    ulog = _parse(path, ["sensor_gyro"])
    raw = _dataset(ulog, "sensor_gyro", instance)
    raw_xyz = np.column_stack([raw[a].astype(float) for a in "xyz"])
    expected = np.degrees(_board_to_body_scipy(ulog.initial_parameters).apply(raw_xyz))
    df = read_ulog(path, instance=instance)
    assert len(df) == 6
    np.testing.assert_allclose(df[["gyro_x", "gyro_y", "gyro_z"]], expected, atol=1e-9)
    np.testing.assert_array_equal(df["temp"], raw["temperature"].astype(float))


def test_ulog_board_rotation_rule_turns_sensor_accel_into_sensor_combined():
    # real-data check of the board-to-body rule on the accelerometer of instance 0
    path = _need(SMALL)
    ulog = _parse(path, ["sensor_accel", "sensor_combined"])
    params = ulog.initial_parameters
    acc = _dataset(ulog, "sensor_accel")
    raw = np.column_stack([acc[a].astype(float) for a in "xyz"])
    offset = np.array([params[f"CAL_ACC0_{a}OFF"] for a in "XYZ"])
    scale = np.array([params[f"CAL_ACC0_{a}SCALE"] for a in "XYZ"])
    rot, how = ulog_module._board_to_body(params, "ACC", int(acc["device_id"][0]), "x")
    assert how.startswith("SENS_BOARD_ROT=4")
    body = ((raw - offset) * scale) @ rot.T
    comb = _dataset(ulog, "sensor_combined")
    t_acc = acc["timestamp_sample"].astype(float)
    ref = np.column_stack(
        [np.interp(t_acc, comb["timestamp"].astype(float), comb[f"accelerometer_m_s2[{i}]"]) for i in range(3)]
    )
    assert np.abs(body - ref).mean(axis=0) == pytest.approx([0.0, 0.0, 0.0], abs=0.05)


def test_ulog_mag_instances():
    path = _need(SMALL)
    ulog = _parse(path, ["sensor_mag"])
    df = read_ulog(path, mag_instance=1)  # external, CAL_MAG1_ROT=0: no rotation
    rows = df.dropna(subset=["mag_x"])
    raw = _dataset(ulog, "sensor_mag", 1)
    t_raw = raw["timestamp_sample"] * 1e-6
    inside = (t_raw >= df["t"].iloc[0]) & (t_raw <= df["t"].iloc[-1])
    np.testing.assert_allclose(rows["mag_x"], raw["x"][inside].astype(float))
    np.testing.assert_allclose(rows["mag_z"], raw["z"][inside].astype(float))
    # each sample sits on the first gyro row at or after it
    for t_mag, t_row in zip(raw["timestamp_sample"][inside] * 1e-6, rows["t"]):
        previous = df["t"][df["t"] < t_row]
        assert t_row >= t_mag and (previous.empty or previous.iloc[-1] < t_mag)
    # internal (CAL_MAG0_ROT=-1): the board rotation, yaw 180 deg then the level trims
    internal = read_ulog(path, mag_instance=0).dropna(subset=["mag_x"])
    raw0 = _dataset(ulog, "sensor_mag", 0)
    t0 = raw0["timestamp_sample"] * 1e-6
    inside0 = (t0 >= df["t"].iloc[0]) & (t0 <= df["t"].iloc[-1])
    expected = _board_to_body_scipy(ulog.initial_parameters).apply(
        np.column_stack([raw0[a].astype(float) for a in "xyz"])
    )[inside0]
    np.testing.assert_allclose(internal[["mag_x", "mag_y", "mag_z"]], expected, atol=1e-9)
    assert np.sign(internal["mag_x"].iloc[0]) == -np.sign(raw0["x"][inside0][0])  # x flipped
    assert "instances present: 0, 1" in _raises(ConfigError, read_ulog, path, mag_instance=2)


def test_ulog_missing_instance_lists_those_present():
    msg = _raises(ConfigError, read_ulog, _need(SMALL), instance=3)
    assert "sensor_gyro instance 3" in msg and "instances present: 0, 1, 2" in msg
    assert "instance must be a non-negative integer" in _raises(ConfigError, read_ulog, SMALL, instance=-1)


_NO_COMPASS_DOES = "the heading is relative to the first sample and the drift is learned from still periods only"
_NO_TEMP_DOES = "temp set to 0 degC; the drift is modelled as a trend in elapsed time"


def test_ulog_temperature_logged_as_zero_reads_as_a_bias_with_a_note():
    path = _need(EVENTS)
    df = read_ulog(path)
    assert len(df) == 7783 and list(df.columns) == CONTRACT + ["ref_heading"]
    assert df["temp"].dtype == np.float64 and (df["temp"] == 0.0).all()
    assert df.attrs["compass"] == "mag" and df.attrs["topics"]["temp"] is None
    assert df.attrs["notes"] == [
        f"{path}: no usable gyro temperature (sensor_gyro instance 0 logs 0 degC in all 31 samples, sensor_accel"
        f" instance 0 logs 0 degC in all 31 samples): {_NO_TEMP_DOES}"
    ]
    assert "no gyro temperature (temp set to 0 degC)" in df.attrs["summary"]
    assert read_log(path).attrs["notes"] == df.attrs["notes"]


def test_ulog_temperature_as_nan_without_an_accel_of_the_chip(tmp_path):
    path = _edited(tmp_path, _need(EVENTS), _set_temperature("sensor_gyro", lambda n: np.full(n, np.nan)),
                   topics=["sensor_combined", "sensor_gyro", "vehicle_magnetometer"])
    df = read_ulog(path)
    assert (df["temp"] == 0.0).all()
    assert df.attrs["notes"] == [
        f"{path}: no usable gyro temperature (sensor_gyro instance 0 logs NaN in all 31 samples, no sensor_accel of"
        f" the same chip): {_NO_TEMP_DOES}"
    ]


def test_ulog_without_a_gyro_temperature_names_an_instance_that_has_one(tmp_path):
    """A gyro that logs no temperature (a BMI088's, whose die has none) beside one that does: the
    note says which instance to read for a measured temperature."""
    def edit(ulog):
        _set_temperature("sensor_gyro", lambda n: np.full(n, np.nan))(ulog)
        _set_temperature("sensor_accel", lambda n: np.full(n, np.nan))(ulog)

    path = _edited(tmp_path, _need(SMALL), edit)
    df = read_ulog(path)
    assert (df["temp"] == 0.0).all()
    (note,) = df.attrs["notes"]
    assert "sensor_gyro instance 0 logs NaN" in note
    assert "sensor_gyro instance 1 logs one: instance=1 (--instance 1) reads that gyro" in note
    assert read_ulog(path, instance=1)["temp"].between(20.0, 40.0).all()


def test_ulog_without_magnetometer_reads_without_compass(tmp_path):
    path = _edited(tmp_path, _need(SMALL), topics=["sensor_combined", "sensor_gyro", "sensor_accel"])
    df = read_ulog(path)
    assert list(df.columns) == ["t", "gyro_z", "gyro_x", "gyro_y", "temp", "acc_x", "acc_y", "acc_z"]
    assert df.attrs["compass"] == "none" and "mag_unit" not in df.attrs and df.attrs["acc_unit"] == "m/s^2"
    assert df.attrs["topics"]["mag"] is None and df.attrs["topics"]["acc"] == "sensor_combined"
    assert df.attrs["notes"] == [
        f"{path}: no compass (no sensor_mag nor vehicle_magnetometer topic in the log): {_NO_COMPASS_DOES}"
    ]
    assert "; no compass; acc from sensor_combined" in df.attrs["summary"]
    # a magnetometer instance asked for by name is still required
    assert "no 'sensor_mag' topic" in _raises(LogFormatError, read_ulog, path, mag_instance=0)


def test_ulog_without_accelerometer_has_no_compass(tmp_path):
    path = _edited(tmp_path, _need(SMALL), topics=["sensor_gyro", "sensor_mag"])
    df = read_ulog(path)
    assert list(df.columns) == ["t", "gyro_z", "gyro_x", "gyro_y", "temp"]
    assert df.attrs["compass"] == "none" and "acc_unit" not in df.attrs and df["temp"].between(35, 45).all()
    assert df.attrs["notes"] == [
        f"{path}: no compass (no accelerometer for the tilt, neither sensor_combined.accelerometer_m_s2 nor a"
        f" sensor_accel of the gyro's chip): {_NO_COMPASS_DOES}"
    ]


def test_ulog_magnetometer_outside_the_gyro_record_is_no_compass(tmp_path):
    def later(ulog):
        data = _dataset(ulog, "vehicle_magnetometer")
        for key in ("timestamp", "timestamp_sample"):
            if key in data:
                data[key] = data[key] + np.uint64(10**10)

    path = _edited(tmp_path, _need(SMALL), later, topics=["sensor_combined", "sensor_gyro", "vehicle_magnetometer"])
    df = read_ulog(path)
    assert df.attrs["compass"] == "none" and "mag_x" not in df.columns
    (note,) = df.attrs["notes"]
    assert note.startswith(f"{path}: no compass (no sample of vehicle_magnetometer instance 0 falls within the gyro")
    assert note.endswith(f" s): {_NO_COMPASS_DOES}")


def test_ulog_events_rates_rows_and_interpolated_temperature(tmp_path):
    path = _edited(tmp_path, _need(EVENTS), _set_temperature("sensor_gyro", lambda n: np.linspace(30.0, 33.0, n)))
    df = read_ulog(path)
    ulog = _parse(path, ["sensor_gyro", "sensor_combined"])
    gyro = _dataset(ulog, "sensor_gyro")
    assert len(df) == 7783
    assert df["t"].iloc[-1] - df["t"].iloc[0] == pytest.approx(31.1, abs=0.1)
    assert 1.0 / np.median(np.diff(df["t"])) == pytest.approx(250.0, rel=0.01)
    t_temp = gyro["timestamp_sample"] * 1e-6
    temp = gyro["temperature"].astype(float)
    # linear between the 1 Hz samples, held before the first and after the last
    np.testing.assert_allclose(df["temp"], np.interp(df["t"], t_temp, temp))
    assert (df.loc[df["t"] < t_temp[0], "temp"] == temp[0]).all()
    assert (df.loc[df["t"] > t_temp[-1], "temp"] == temp[-1]).all()
    assert df["mag_x"].notna().sum() == 458
    assert "1 Hz" in df.attrs["summary"] and "250 Hz" in df.attrs["summary"]


def test_ulog_temperature_from_accel_when_gyro_has_none(tmp_path):
    path = _edited(tmp_path, _need(EVENTS), _set_temperature("sensor_accel", lambda n: np.full(n, 35.5)))
    df = read_ulog(path)
    assert (df["temp"] == 35.5).all()
    assert "sensor_accel instance 0" in df.attrs["topics"]["temp"]


def test_ulog_implausible_temperature(tmp_path):
    path = _edited(tmp_path, _need(EVENTS), _set_temperature("sensor_gyro", lambda n: np.full(n, 300.0)))
    msg = _raises(LogFormatError, read_ulog, path)
    assert "300.0 degC" in msg and "sensor_gyro instance 0" in msg


def test_ulog_missing_topic(tmp_path):
    """Without ``sensor_gyro`` the gyro is ``sensor_combined``'s, without a temperature (a note
    says why); without ``sensor_combined``'s gyro either, the log is refused naming sensor_gyro."""
    keep = ["sensor_combined", "sensor_accel", "sensor_mag", "vehicle_attitude"]
    path = _edited(tmp_path, _need(SMALL), topics=keep)
    df = read_ulog(path)
    assert (df["temp"] == 0.0).all() and "sensor_combined" in df.attrs["summary"]
    assert any("no sensor_gyro topic" in n for n in df.attrs["notes"])
    path = _edited(tmp_path, _need(SMALL), topics=["sensor_accel", "sensor_mag", "vehicle_attitude"])
    assert "no 'sensor_gyro' topic" in _raises(LogFormatError, read_ulog, path)


def test_ulog_too_few_gyro_samples(tmp_path):
    def one_sample(ulog):
        data = _dataset(ulog, "sensor_gyro")
        for key in data:
            data[key] = data[key][:1]

    path = _edited(tmp_path, _need(SMALL), one_sample, topics=["sensor_gyro", "sensor_accel", "sensor_mag"])
    assert "too few gyro samples (1)" in _raises(LogFormatError, read_ulog, path)


def test_ulog_reference_off_and_no_attitude(tmp_path):
    path = _need(SMALL)
    assert "ref_heading" not in read_ulog(path, reference=False).columns
    no_att = _edited(tmp_path, path, topics=["sensor_combined", "sensor_gyro", "vehicle_magnetometer"])
    df = read_ulog(no_att)
    assert "ref_heading" not in df.columns and "no vehicle_attitude" in df.attrs["summary"]


def test_ulog_reference_heading_is_the_attitude_yaw():
    path = _need(SMALL)
    df = read_ulog(path)
    att = _dataset(_parse(path, ["vehicle_attitude"]), "vehicle_attitude")
    q = np.column_stack([att[f"q[{i}]"].astype(float) for i in range(4)])
    # scipy wants scalar-last quaternions; Z-Y-X Euler angles, yaw first
    yaw = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_euler("ZYX", degrees=True)[:, 0]
    t_att = att["timestamp"] * 1e-6
    on_rows = np.interp(df["t"], t_att, np.unwrap(yaw, period=360.0)) % 360.0
    np.testing.assert_allclose(df["ref_heading"], on_rows, atol=1e-6)


def test_ulog_truncated_copy(tmp_path):
    data = _need(SMALL).read_bytes()
    half = tmp_path / "half.ulg"
    half.write_bytes(data[: len(data) // 2])
    msg = _raises(LogFormatError, read_ulog, half)
    assert str(half) in msg and "truncated" in msg
    # the advice works: the complete messages alone are a readable log
    keep = int(msg.split("the first ")[1].split(" bytes")[0])
    fixed = tmp_path / "fixed.ulg"
    fixed.write_bytes(data[:keep])
    assert 0 < len(read_ulog(fixed)) < 1298


@pytest.mark.parametrize("cut", [10, 100, 5000])
def test_ulog_cut_inside_header(tmp_path, cut):
    short = tmp_path / "short.ulg"
    short.write_bytes(_need(SMALL).read_bytes()[:cut])
    msg = _raises(LogFormatError, read_ulog, short)
    assert "not a ULog file" in msg or "truncated" in msg


def test_ulog_random_bytes(tmp_path):
    rng = np.random.default_rng(0)
    noise = tmp_path / "noise.ulg"
    noise.write_bytes(rng.bytes(4000))
    assert "not a ULog file" in _raises(LogFormatError, read_ulog, noise)
    # a valid magic followed by garbage: refused before pyulog (which can spin on it)
    fake = tmp_path / "fake.ulg"
    fake.write_bytes(b"ULog\x01\x12\x35\x01" + bytes(8) + rng.bytes(4000))
    assert "corrupt" in _raises(LogFormatError, read_ulog, fake)


def test_ulog_missing_empty_and_directory(tmp_path):
    assert "does not exist" in _raises(LogFormatError, read_ulog, tmp_path / "nope.ulg")
    empty = tmp_path / "empty.ulg"
    empty.write_bytes(b"")
    assert "empty" in _raises(LogFormatError, read_ulog, empty)
    assert "directory" in _raises(LogFormatError, read_ulog, tmp_path)


def test_ulog_without_pyulog(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyulog", None)
    msg = _raises(ConfigError, read_ulog, _need(SMALL))
    assert "gyrodrift[ulog]" in msg


# ---------------------------------------------------------------------------
# ROS bags: written here with a known rotation
# ---------------------------------------------------------------------------

T0 = 1_700_000_000.0
RATE_DPS = 10.0  # counter-clockwise seen from above, about ROS z (up)
FIELD_ENU = np.array([0.0, 2.0e-5, -4.0e-5])  # tesla: 20 uT north, 40 uT down


def _typestore(kind: str):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)


def _writer(path: Path, kind: str):
    if kind == "ros1":
        from rosbags.rosbag1 import Writer

        return Writer(path)
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    return Writer(path, version=9, storage_plugin=plugin)


def _write_bag(
    path: Path,
    kind: str = "ros2",
    *,
    imu_topics=("/imu/data",),
    temp_topic: str | None = "/imu/temperature",
    mag_topic: str | None = "/imu/mag",
    duration_s: float = 20.0,
    zero_stamps: bool = False,
    orientation: bool = True,
    temperature=lambda t: 30.0 + 0.1 * t,
    mag_stamp_offset_s: float = 0.0,
) -> Path:
    """A bag of a level IMU turning at +10 deg/s about ROS z; yaw 0 (east) at the start.

    Imu at 100 Hz, Temperature at 1 Hz, MagneticField at 10 Hz, all stamped on the
    same clock (the mag and temperature times coincide with Imu times; the mag header
    stamps are ``mag_stamp_offset_s`` later).
    """
    store = _typestore(kind)
    types = store.types
    ros1 = kind == "ros1"
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    vec, quat = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Quaternion"]

    def header(t):
        sec, nanosec = (0, 0) if zero_stamps else (int(t), int(round((t - int(t)) * 1e9)))
        stamp = types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
        extra = {"seq": 0} if ros1 else {}
        return types["std_msgs/msg/Header"](stamp=stamp, frame_id="imu_link", **extra)

    def imu(t):
        yaw = np.radians(RATE_DPS * (t - T0))
        q = quat(x=0.0, y=0.0, z=np.sin(yaw / 2), w=np.cos(yaw / 2))
        cov = np.zeros(9) if orientation else np.array([-1.0] + [0.0] * 8)
        return types["sensor_msgs/msg/Imu"](
            header=header(t),
            orientation=q,
            orientation_covariance=cov,
            angular_velocity=vec(x=0.0, y=0.0, z=np.radians(RATE_DPS)),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=vec(x=0.0, y=0.0, z=9.81),
            linear_acceleration_covariance=np.zeros(9),
        )

    def temp(t):
        return types["sensor_msgs/msg/Temperature"](
            header=header(t), temperature=temperature(t - T0), variance=0.0
        )

    def mag(t):
        yaw = np.radians(RATE_DPS * (t - T0))
        c, s = np.cos(yaw), np.sin(yaw)
        east, north, up = FIELD_ENU  # world field seen in the body (FLU) frame
        body = vec(x=c * east + s * north, y=-s * east + c * north, z=up)
        return types["sensor_msgs/msg/MagneticField"](
            header=header(t + mag_stamp_offset_s), magnetic_field=body, magnetic_field_covariance=np.zeros(9)
        )

    streams = [(topic, "sensor_msgs/msg/Imu", imu, 100) for topic in imu_topics]
    if temp_topic:
        streams.append((temp_topic, "sensor_msgs/msg/Temperature", temp, 1))
    if mag_topic:
        streams.append((mag_topic, "sensor_msgs/msg/MagneticField", mag, 10))
    with _writer(path, kind) as writer:
        records = []
        for topic, msgtype, make, rate in streams:
            conn = writer.add_connection(topic, msgtype, typestore=store)
            for k in range(int(duration_s * rate)):
                t = T0 + k / rate
                records.append((t, conn, serialize(make(t), msgtype)))
        for t, conn, data in sorted(records, key=lambda r: r[0]):
            writer.write(conn, int(round(t * 1e9)), data)
    return path


def _bag_path(tmp_path: Path, kind: str) -> Path:
    return tmp_path / ("log.bag" if kind == "ros1" else f"log_{kind}")


@pytest.mark.parametrize("kind", ["ros1", "ros2", "mcap"])
def test_rosbag_known_rotation_comes_out_in_ned(tmp_path, kind):
    df = read_rosbag(_write_bag(_bag_path(tmp_path, kind), kind))
    assert list(df.columns) == CONTRACT + ["ref_heading"]
    assert len(df) == 2000
    np.testing.assert_allclose(df["t"], T0 + np.arange(2000) / 100.0, atol=1e-6)
    # +10 deg/s counter-clockwise about ROS z (up) = heading decreasing in NED
    np.testing.assert_allclose(df["gyro_z"], -RATE_DPS, rtol=1e-12)
    np.testing.assert_allclose(df[["gyro_x", "gyro_y"]], 0.0, atol=1e-12)
    # level and still: ROS reads +9.81 up, the contract -9.81 (z down)
    np.testing.assert_allclose(df["acc_z"], -9.81)
    # yaw 0 = facing east = heading 90, then decreasing at 10 deg/s
    assert df["ref_heading"].iloc[0] == pytest.approx(90.0)
    steps = np.diff(np.unwrap(np.radians(df["ref_heading"])))
    np.testing.assert_allclose(np.degrees(steps), -RATE_DPS / 100.0, atol=1e-5)  # float time near 1.7e9 s
    # 1 Hz temperature, linear in between, held after the last sample (t = 20 s)
    np.testing.assert_allclose(df["temp"].iloc[50], 30.05, atol=1e-9)
    assert df["temp"].iloc[-1] == pytest.approx(30.0 + 0.1 * 19.0)
    # 10 Hz magnetometer on its own rows, NaN elsewhere, and it agrees with the orientation
    rows = df.dropna(subset=["mag_x"])
    assert len(rows) == 200 and rows.index[1] == 10
    heading = tilt_compensated_heading(*(rows[c] for c in ["mag_x", "mag_y", "mag_z", "acc_x", "acc_y", "acc_z"]))
    diff = (heading - rows["ref_heading"] + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(diff, 0.0, atol=1e-6)
    assert df.attrs["format"] == "rosbag" and df.attrs["frame"] == "ned" and df.attrs["compass"] == "mag"
    summary = df.attrs["summary"]
    assert "\n" not in summary and "20.0 s" in summary and "100 Hz" in summary and "'/imu/temperature'" in summary


@pytest.mark.parametrize(("kind", "suffix"), [("ros2", ".db3"), ("mcap", ".mcap")])
def test_rosbag2_storage_file_alone(tmp_path, kind, suffix):
    bag = _write_bag(_bag_path(tmp_path, kind), kind)
    storage = next(bag.glob(f"*{suffix}"))
    assert len(read_rosbag(storage)) == 2000
    assert len(read_log(storage)) == 2000


def test_rosbag_zero_stamp_uses_receive_time(tmp_path):
    df = read_rosbag(_write_bag(tmp_path / "zero.bag", "ros1", zero_stamps=True))
    np.testing.assert_allclose(df["t"], T0 + np.arange(2000) / 100.0, atol=1e-6)
    assert "zero header stamp" in df.attrs["summary"]


def test_rosbag_without_orientation_has_no_reference(tmp_path):
    df = read_rosbag(_write_bag(tmp_path / "b", orientation=False))
    assert "ref_heading" not in df.columns


def test_rosbag_wrong_topic_names(tmp_path):
    bag = _write_bag(tmp_path / "b")
    msg = _raises(ConfigError, read_rosbag, bag, imu_topic="/imu/raw")
    assert "'/imu/raw'" in msg and "'/imu/data'" in msg and "imu_topic" in msg
    msg = _raises(ConfigError, read_rosbag, bag, temp_topic="/imu/data")
    assert "has type sensor_msgs/msg/Imu" in msg and "temp_topic" in msg


def test_rosbag_two_imu_topics(tmp_path):
    bag = _write_bag(tmp_path / "b", imu_topics=("/imu/data", "/imu2/data"))
    msg = _raises(ConfigError, read_rosbag, bag)
    assert "'/imu/data'" in msg and "'/imu2/data'" in msg and "imu_topic" in msg
    assert read_rosbag(bag, imu_topic="/imu2/data").attrs["topics"]["imu"] == "topic '/imu2/data'"


def test_rosbag_without_imu_is_refused(tmp_path):
    bag = _write_bag(tmp_path / "b", imu_topics=())
    msg = _raises(LogFormatError, read_rosbag, bag)
    assert "no sensor_msgs/msg/Imu topic in the bag (needed for the gyro rate)" in msg


def test_rosbag_without_temperature_topic_reads_as_a_bias(tmp_path):
    bag = _write_bag(tmp_path / "b", temp_topic=None)
    df = read_rosbag(bag)
    assert list(df.columns) == CONTRACT + ["ref_heading"] and (df["temp"] == 0.0).all()
    assert df.attrs["compass"] == "mag" and df.attrs["topics"]["temp"] is None
    assert df.attrs["notes"] == [
        f"{bag}: no usable gyro temperature (no sensor_msgs/msg/Temperature topic in the bag): {_NO_TEMP_DOES}"
    ]
    assert "no gyro temperature (temp set to 0 degC)" in df.attrs["summary"]
    # a topic asked for by name is still required
    msg = _raises(ConfigError, read_rosbag, bag, temp_topic="/imu/temperature")
    assert "no topic '/imu/temperature'" in msg and "temp_topic" in msg


def test_rosbag_without_magnetometer_has_no_compass(tmp_path):
    bag = _write_bag(tmp_path / "b", mag_topic=None)
    df = read_rosbag(bag)
    assert [c for c in df.columns if c.startswith("mag_")] == [] and "acc_z" in df.columns
    assert df.attrs["compass"] == "none" and "mag_unit" not in df.attrs and df.attrs["topics"]["mag"] is None
    assert df.attrs["notes"] == [
        f"{bag}: no compass (no sensor_msgs/msg/MagneticField topic in the bag): {_NO_COMPASS_DOES}"
    ]
    assert "; no compass; acc from topic '/imu/data'" in df.attrs["summary"]


def test_rosbag_temperature_topic_without_messages_reads_as_a_bias(tmp_path):
    bag = _write_bag(tmp_path / "b", duration_s=0.5)  # 1 Hz temperature: no message in 0.5 s
    df = read_rosbag(bag)
    assert len(df) == 50 and (df["temp"] == 0.0).all() and df.attrs["compass"] == "mag"
    assert df.attrs["notes"] == [
        f"{bag}: no usable gyro temperature (no message on topic '/imu/temperature'): {_NO_TEMP_DOES}"
    ]


def test_rosbag_magnetometer_outside_the_imu_record_is_no_compass(tmp_path):
    bag = _write_bag(tmp_path / "b", duration_s=2.0, mag_stamp_offset_s=100.0)
    df = read_rosbag(bag)
    assert df.attrs["compass"] == "none" and "mag_x" not in df.columns
    assert df.attrs["notes"] == [
        f"{bag}: no compass (no message of topic '/imu/mag' falls within the Imu record,"
        f" t = {T0:.3f}..{T0 + 1.99:.3f} s): {_NO_COMPASS_DOES}"
    ]


def test_rosbag_without_compass_nor_temperature_gives_two_notes(tmp_path):
    bag = _write_bag(tmp_path / "b", mag_topic=None, temp_topic=None)
    notes = read_log(bag).attrs["notes"]
    assert len(notes) == 2 and "no compass" in notes[0] and "no usable gyro temperature" in notes[1]


@pytest.mark.parametrize(("value", "shown"), [(0.0, "0 degC"), (float("nan"), "NaN")])
def test_rosbag_temperature_not_measured_reads_as_a_bias(tmp_path, value, shown):
    bag = _write_bag(tmp_path / "b", temperature=lambda t: value)
    df = read_rosbag(bag)
    assert (df["temp"] == 0.0).all()
    assert df.attrs["notes"] == [
        f"{bag}: no usable gyro temperature (topic '/imu/temperature' is {shown} in all 20 messages): {_NO_TEMP_DOES}"
    ]


@pytest.mark.parametrize("kind", ["ros1", "ros2", "mcap"])
def test_rosbag_truncated(tmp_path, kind):
    bag = _write_bag(_bag_path(tmp_path, kind), kind, duration_s=5.0)
    storage = bag if kind == "ros1" else next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap"))
    storage.write_bytes(storage.read_bytes()[: storage.stat().st_size // 2])
    msg = _raises(LogFormatError, read_rosbag, bag)
    assert msg.startswith(str(bag)) and "not a readable ROS bag" in msg


def test_rosbag_corrupt_and_missing(tmp_path):
    noise = tmp_path / "noise.bag"
    noise.write_bytes(np.random.default_rng(0).bytes(3000))
    assert "not a readable ROS bag" in _raises(LogFormatError, read_rosbag, noise)
    assert "does not exist" in _raises(LogFormatError, read_rosbag, tmp_path / "nope.bag")
    assert "metadata.yaml" in _raises(LogFormatError, read_rosbag, tmp_path)


def test_rosbag_without_rosbags(monkeypatch, tmp_path):
    bag = _write_bag(tmp_path / "b", duration_s=1.0)
    for name in [m for m in sys.modules if m == "rosbags" or m.startswith("rosbags.")]:
        monkeypatch.setitem(sys.modules, name, None)
    assert "gyrodrift[ros]" in _raises(ConfigError, read_rosbag, bag)


# ---------------------------------------------------------------------------
# dispatcher
# ---------------------------------------------------------------------------


def test_read_log_dispatches_by_suffix_and_fmt(tmp_path):
    ros1 = _write_bag(tmp_path / "a.bag", "ros1", duration_s=2.0)
    ros2 = _write_bag(tmp_path / "dir", "ros2", duration_s=2.0)
    assert read_log(ros1).attrs["format"] == "rosbag"
    assert read_log(ros2).attrs["format"] == "rosbag"
    assert read_log(ros2, imu_topic="/imu/data").attrs["topics"]["imu"] == "topic '/imu/data'"
    csv = tmp_path / "log.csv"
    csv.write_text("t,gyro_z,temp,heading\n0,0.1,25,10\n0.1,0.2,25,\n")
    assert read_log(csv).attrs["format"] == "csv"


def test_read_log_ulog_and_options():
    path = _need(SMALL)
    assert read_log(path).attrs["format"] == "ulog"
    assert read_log(path, instance=1)["temp"].mean() == pytest.approx(28.3, abs=0.3)
    assert read_log(path, gyro_unit="dps").attrs["gyro_unit"] == "deg/s"


def test_read_log_fmt_overrides_suffix(tmp_path):
    renamed = tmp_path / "flight.dat"
    renamed.write_bytes(_need(SMALL).read_bytes())
    assert read_log(renamed, fmt="ulog").attrs["format"] == "ulog"
    assert read_log(renamed).attrs["format"] == "ulog"  # an unknown ending: told by the ULog header bytes
    unknown = tmp_path / "flight.xyz"
    unknown.write_bytes(b"t,gyro_z,temp\n0,0,25\n")
    msg = _raises(ConfigError, read_log, unknown)
    assert "flight.xyz" in msg and ".ulg" in msg and ".bin" in msg and ".bag" in msg and ".csv" in msg
    msg = _raises(ConfigError, read_log, renamed, fmt="xlsx")
    assert "csv, parquet, ulog, ardupilot, tlog, rosbag" in msg


@pytest.mark.parametrize(
    "options",
    [{"gyro_unit": "rad/s"}, {"frame": "enu"}, {"column_map": {"gyro_z": "gz"}}],
)
def test_read_log_units_are_stated_by_the_format(tmp_path, options):
    bag = _write_bag(tmp_path / "a.bag", "ros1", duration_s=1.0)
    msg = _raises(ConfigError, read_log, bag, **options)
    assert "states its units" in msg and next(iter(options)) in msg


def test_read_log_refuses_options_of_other_formats(tmp_path):
    bag = _write_bag(tmp_path / "a.bag", "ros1", duration_s=1.0)
    assert "instance=1" in _raises(ConfigError, read_log, bag, instance=1)
    csv = tmp_path / "log.csv"
    csv.write_text("t,gyro_z,temp,heading\n0,0.1,25,10\n")
    assert "imu_topic" in _raises(ConfigError, read_log, csv, imu_topic="/imu")
    assert "imu_topic" in _raises(ConfigError, read_log, _need(SMALL), imu_topic="/imu")


# ---------------------------------------------------------------------------
# shared alignment helpers
# ---------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.0, 100.0), min_size=2, max_size=40, unique=True),
    st.lists(st.floats(-5.0, 105.0), min_size=1, max_size=40),
)
def test_following_rows_property(rows, samples):
    t_rows = np.sort(np.array(rows))
    t_src = np.sort(np.array(samples))
    values = np.arange(t_src.size, dtype=float)[:, None]
    out, placed = _align.on_following_rows(t_rows, t_src, values)
    filled = np.flatnonzero(~np.isnan(out[:, 0]))
    assert placed == filled.size
    for row in filled:
        k = int(out[row, 0])  # the latest sample at or before this row, after the previous row
        assert t_src[k] <= t_rows[row]
        assert row == 0 or t_src[k] > t_rows[row - 1]
        later = t_src[k + 1 :]
        assert not np.any(later <= t_rows[row])


def test_heading_interpolation_across_north():
    t = np.array([0.0, 1.0])
    out = _align.interp_heading(t, np.array([350.0, 10.0]), np.array([-1.0, 0.5, 0.75, 2.0]))
    assert np.isnan(out[0]) and np.isnan(out[-1])
    np.testing.assert_allclose(out[1:3], [0.0, 5.0], atol=1e-9)


def test_increasing_drops_repeated_times():
    stream = _align.Stream("x", np.array([1.0, 0.0, 1.0, 2.0]), np.array([10.0, 0.0, 11.0, 20.0]))
    out, dropped = _align.increasing(stream)
    assert dropped == 1
    np.testing.assert_array_equal(out.t, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(out.values, [0.0, 10.0, 20.0])


def test_yaw_of_a_quaternion_that_is_not_normalised():
    q = Rotation.from_euler("ZYX", [123.0, 10.0, -20.0], degrees=True).as_quat()  # x, y, z, w
    x, y, z, w = 3.0 * q
    assert float(_align.yaw_deg(w, x, y, z)) == pytest.approx(123.0)


def test_enu_and_rad_per_s_convert_the_x_y_truth_like_their_gyros(tmp_path):
    """true_bias_x/y follow gyro_x/y: scaled to deg/s, and y flips from FLU to FRD."""
    import math

    import pandas as pd

    from gyrodrift.io import read_log

    df = pd.DataFrame({"t": [0.0, 0.1], "gyro_x": [0.01, 0.01], "gyro_y": [0.02, 0.02], "gyro_z": [0.03, 0.03],
                       "temp": [25.0, 25.0], "heading": [10.0, 10.0], "true_bias_x": [0.01, 0.01],
                       "true_bias_y": [0.02, 0.02], "true_bias_z": [0.03, 0.03]})
    path = tmp_path / "enu.csv"
    df.to_csv(path, index=False)
    log = read_log(path, gyro_unit="rad/s", frame="enu")
    k = 180.0 / math.pi
    for axis, sign in (("x", 1.0), ("y", -1.0), ("z", -1.0)):
        assert log[f"true_bias_{axis}"].tolist() == pytest.approx([sign * k * df[f"true_bias_{axis}"][0]] * 2)
        assert log[f"true_bias_{axis}"].tolist() == log[f"gyro_{axis}"].tolist()

"""A z-up table (ENU world, FLU body, as ROS logs) read as the FRD contract (issue 23, item 5).

Read as FRD it flips gyro_y and gyro_z: the drift, the heading and a calibration's y/z
coefficients change sign, without an error. Gravity on the accelerometer says which way z
points: the table is refused in one line naming --frame enu, unless the frame is given.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gyrodrift.cli import main
from gyrodrift.errors import LogFormatError
from gyrodrift.io import read_log
from gyrodrift.io.chunked import iter_log_chunks


def flu_log(n: int = 3000, fs_hz: float = 10.0, tilt_deg: float = 5.0) -> pd.DataFrame:
    """A still heating run logged in FLU (z up): acc_z = +1 g, gyro_z = -(FRD drift)."""
    t = np.arange(n) / fs_hz
    temp = 20.0 + 25.0 * t / t[-1]
    drift_frd = 0.2 + 0.02 * (temp - 30.0)
    tilt = np.radians(tilt_deg)
    return pd.DataFrame({
        "t": t, "gyro_x": 0.05, "gyro_y": -(0.1 + 0.01 * (temp - 30.0)), "gyro_z": -drift_frd, "temp": temp,
        "acc_x": np.sin(tilt), "acc_y": 0.0, "acc_z": np.cos(tilt),
    })


def test_a_z_up_table_is_refused_naming_frame_enu(tmp_path, capsys):
    path = tmp_path / "flu.csv"
    flu_log().to_csv(path, index=False)
    with pytest.raises(LogFormatError, match=r"column 'acc_z'.*z axis points up.*--frame enu"):
        read_log(path)
    with pytest.raises(LogFormatError, match="--frame enu"):
        next(iter(iter_log_chunks(path, chunk_rows=500)))
    for command in (["compensate", str(path), "-o", str(tmp_path / "o.csv")],
                    ["calibrate", str(path), "-o", str(tmp_path / "c.param")],
                    ["stream", str(path), "-o", str(tmp_path / "o.csv"), "-q", "--skip-bad"]):
        assert main(command) == 2
        err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
        assert len(err) == 1 and str(path) in err[0] and "--frame enu" in err[0]
        assert not (tmp_path / "o.csv").exists() and not (tmp_path / "c.param").exists()


def test_frame_enu_converts_and_frame_ned_reads_as_it_is(tmp_path, capsys):
    path = tmp_path / "flu.csv"
    log = flu_log()
    log.to_csv(path, index=False)
    enu = read_log(path, frame="enu")
    np.testing.assert_allclose(enu["gyro_z"], -log["gyro_z"])
    np.testing.assert_allclose(enu["acc_z"], -log["acc_z"])
    ned = read_log(path, frame="ned")  # a unit lying upside down: the user says so
    np.testing.assert_allclose(ned["gyro_z"], log["gyro_z"])
    assert main(["calibrate", str(path), "-o", str(tmp_path / "c.json"), "--frame", "enu", "-q"]) == 0
    from gyrodrift.paramfiles import read_calibration_json

    cal = read_calibration_json(tmp_path / "c.json")
    assert cal.drift("z", 30.0) == pytest.approx(0.2, abs=1e-6)  # FRD sign: heading-increasing drift
    assert cal.drift("y", 30.0) == pytest.approx(0.1, abs=1e-6)


def test_frd_tables_and_tables_without_accelerometer_read_as_before(tmp_path):
    frd = flu_log()
    frd["acc_z"] = -frd["acc_z"]
    frd.to_csv(tmp_path / "frd.csv", index=False)
    assert len(read_log(tmp_path / "frd.csv")) == len(frd)
    frd.drop(columns=["acc_x", "acc_y", "acc_z"]).to_csv(tmp_path / "noacc.csv", index=False)
    assert len(read_log(tmp_path / "noacc.csv")) == len(frd)
    steep = flu_log(tilt_deg=40.0)  # z up but tilted 40 deg: not taken as z up (median share 0.77)
    steep.to_csv(tmp_path / "steep.csv", index=False)
    assert len(read_log(tmp_path / "steep.csv")) == len(steep)

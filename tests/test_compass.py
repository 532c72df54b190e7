import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from gyrodrift.compass import field_norm_dip, roll_pitch_deg, tilt_compensated_heading
from gyrodrift.conventions import wrap_180

EARTH_FIELD_NED = np.array([20.0, 1.5, 45.0])  # µT: north, east, down (dip about 66 deg)


def body_readings(yaw_deg, pitch_deg, roll_deg, field_ned=EARTH_FIELD_NED, g=1.0):
    """Magnetometer and accelerometer (specific force) in FRD for a static attitude."""
    rot = Rotation.from_euler("ZYX", np.column_stack([yaw_deg, pitch_deg, roll_deg]), degrees=True)
    mag = rot.inv().apply(np.tile(field_ned, (len(np.atleast_1d(yaw_deg)), 1)))
    acc = rot.inv().apply(np.tile([0.0, 0.0, -g], (len(np.atleast_1d(yaw_deg)), 1)))
    return mag, acc


def test_random_attitudes_give_heading_back():
    rng = np.random.default_rng(42)
    n = 2000
    yaw = rng.uniform(0, 360, n)
    pitch = rng.uniform(-70, 70, n)
    roll = rng.uniform(-170, 170, n)
    mag, acc = body_readings(yaw, pitch, roll)
    declination_free_north = np.degrees(np.arctan2(EARTH_FIELD_NED[1], EARTH_FIELD_NED[0]))
    heading = tilt_compensated_heading(*mag.T, *acc.T)
    err = wrap_180(heading - (yaw - declination_free_north))
    assert np.max(np.abs(err)) < 1e-9
    r, p = roll_pitch_deg(*acc.T)
    assert np.max(np.abs(wrap_180(r - roll))) < 1e-9
    assert np.max(np.abs(p - pitch)) < 1e-9
    assert np.all((heading >= 0) & (heading < 360))


def test_units_do_not_matter():
    mag, acc = body_readings([123.0], [10.0], [-20.0])
    h_ut_g = tilt_compensated_heading(*mag.T, *acc.T)
    h_gauss_ms2 = tilt_compensated_heading(*(mag.T * 0.01), *(acc.T * 9.80665))
    np.testing.assert_allclose(h_ut_g, h_gauss_ms2, atol=1e-12)


def test_sign_convention_nose_east_is_90():
    mag, acc = body_readings([90.0], [0.0], [0.0], field_ned=np.array([20.0, 0.0, 45.0]))
    assert float(tilt_compensated_heading(*mag.T, *acc.T)[0]) == pytest.approx(90.0)
    # acc_z reads -1 g when level (specific force).
    assert acc[0, 2] == pytest.approx(-1.0)


def test_field_norm_and_dip():
    mag, acc = body_readings([10.0, 200.0], [5.0, -30.0], [40.0, 0.0])
    norm, dip = field_norm_dip(*mag.T, *acc.T)
    np.testing.assert_allclose(norm, np.linalg.norm(EARTH_FIELD_NED))
    expected_dip = np.degrees(np.arctan2(EARTH_FIELD_NED[2], np.hypot(*EARTH_FIELD_NED[:2])))
    np.testing.assert_allclose(dip, expected_dip)


def test_nan_in_nan_out():
    assert np.isnan(tilt_compensated_heading(np.nan, 1.0, 1.0, 0.0, 0.0, -1.0))


def test_real_log_two_ccw_turns_from_raw_mag(shared_data):
    """mpu6050_rotate_z: two counter-clockwise turns are about -720 deg of heading change."""
    log = pd.read_csv(shared_data / "mpu6050_rotate_z" / "contract.csv")
    rows = log[["mag_x", "mag_y", "mag_z"]].notna().all(axis=1)
    heading = tilt_compensated_heading(*log.loc[rows, ["mag_x", "mag_y", "mag_z", "acc_x", "acc_y", "acc_z"]].to_numpy().T)
    total = float(np.sum(wrap_180(np.diff(heading))))
    assert total == pytest.approx(-720.0, abs=10.0)


def test_one_row_and_many_give_the_same_bits():
    """A stream's row (``kernels.compass.row``, as :class:`Intake` calls it) and a whole log's
    rows (``compass_columns``) agree to the bit, NaN and a given heading included; the arrays
    keep their shape, scalars give 0-d arrays."""
    from gyrodrift.compass import compass_columns
    from gyrodrift.kernels import compass as kernel

    rng = np.random.default_rng(7)
    mag, acc = body_readings(rng.uniform(0, 360, 500), rng.uniform(-80, 80, 500), rng.uniform(-180, 180, 500))
    mag, acc = mag * rng.uniform(0.01, 100.0, (500, 1)), acc * 9.80665 + 0.05 * rng.standard_normal((500, 3))
    mag[3, 1] = np.nan
    acc[4] = np.nan
    heading, norm, dip = compass_columns(500, None, mag, acc)
    rows = np.array([kernel.row(*m, *a) for m, a in zip(mag.tolist(), acc.tolist())])
    assert np.array_equal(rows, np.column_stack([heading, norm, dip]), equal_nan=True)
    assert np.isnan(rows[3]).all() and np.isnan(rows[4]).all() and np.isfinite(rows[5:]).all()
    assert np.array_equal(tilt_compensated_heading(*mag.T, *acc.T), heading, equal_nan=True)
    grid = tilt_compensated_heading(mag[:6, 0].reshape(2, 3), mag[:6, 1].reshape(2, 3), mag[:6, 2].reshape(2, 3),
                                    0.0, 0.0, -1.0)
    assert grid.shape == (2, 3) and np.shape(tilt_compensated_heading(0.0, -0.2, 0.4, 0.0, 0.0, -1.0)) == ()

"""The scenario generator's classes (issue 21, item 4) as a log reader sees them."""

from __future__ import annotations

import numpy as np
import pytest

from gyrodrift.simulate.generator import generate, seeds


def test_a_held_compass_is_on_every_row_correlated_and_never_repeated():
    """``held-compass``: each magnetometer sample is held until the next and jittered per row,
    so the heading is on every logged row (no outage in this class), no two successive values
    are equal (a reader drops exact repeats as held cells), the sample rate leaves several rows
    per sample, and on still rows most steps are jitter alone and successive errors correlate."""
    case = generate("held-compass", seeds("tuning", 3)[2], duration_scale=0.2)
    log = case.log
    h = log["heading"].to_numpy()
    assert np.isfinite(h).all() and ((h >= 0.0) & (h < 360.0)).all()
    assert np.count_nonzero(np.diff(h) == 0.0) == 0
    still = log["true_rate_z"].to_numpy() == 0.0
    err = (h - log["ref_heading"].to_numpy() + 180.0) % 360.0 - 180.0
    step = np.diff(err)[still[1:] & still[:-1]]
    rows_per_sample = 1.0 / np.median(np.diff(log["t"])) / case.compass.rate_hz
    # held: most steps are jitter only (differences of two jitters), a few are new samples
    assert np.median(np.abs(step)) < 1.0 and rows_per_sample >= 2.5
    assert np.corrcoef(err[:-1][still[:-1]], err[1:][still[:-1]])[0, 1] > 0.5


def test_a_stalling_logger_loses_rows_inside_the_turns():
    """``handheld-stalls``: steps of 50-250 ms (20-100 times the median step at 200-400 Hz)
    after every 0.2-1.5 s of rows, some of them while the board turns, and a heading at 10 Hz."""
    log = generate("handheld-stalls", seeds("tuning", 1)[0], duration_scale=0.5).log
    t = log["t"].to_numpy()
    dt = np.diff(t)
    median = np.median(dt)
    stalls = dt > 10.0 * median
    assert median <= 0.005 + 1e-9 and 0.05 - median <= dt[stalls].min() and dt[stalls].max() <= 0.25 + median
    per_s = stalls.sum() / (t[-1] - t[0])
    assert 1.0 / 1.5 / 1.2 < per_s < 1.0 / 0.2 and stalls.sum() > 50
    turning = np.abs(log["true_rate_z"].to_numpy()) > 10.0
    assert np.count_nonzero(stalls & turning[1:] & turning[:-1]) > 10
    assert 9.0 < np.isfinite(log["heading"]).sum() / (t[-1] - t[0]) < 11.0


def test_a_logger_that_stamps_on_arrival_writes_clusters_and_loses_no_row():
    """``handheld-clustered``: every row of the 100-Hz run is kept (its mean step is 10 ms), but
    stamped in clusters of 4-10 rows 1-2.5 ms apart; a stamp is never earlier than its row's true
    time nor later than the next cluster's, and times still increase."""
    log = generate("handheld-clustered", seeds("tuning", 1)[0], duration_scale=0.5).log
    t = log["t"].to_numpy()
    dt = np.diff(t)
    assert np.all(dt > 0.0) and abs(dt.mean() - 0.01) < 1e-4
    within = dt < 0.003
    assert 0.001 - 1e-9 <= dt[within].min() and dt[within].max() <= 0.0025 + 1e-9
    starts = np.flatnonzero(np.r_[True, ~within])  # the first row of each cluster
    sizes = np.diff(np.r_[starts, t.size])
    assert sizes[:-1].min() >= 4 and sizes[:-1].max() <= 10
    true_t = np.arange(t.size) / 100.0
    assert np.all(t >= true_t - 1e-9) and np.all(t[starts] == true_t[starts + sizes - 1])


def test_an_uncalibrated_magnetometer_errs_with_the_heading():
    """``rawmag-uncalibrated``: the raw field's strength varies with the heading (hard iron), the
    tilt-compensated heading errs by a function of the heading that a constant cannot remove, and
    the same seed's ``rawmag-drive`` heading (the class it is built on) has none of it."""
    from gyrodrift.compass import field_norm_dip, tilt_compensated_heading
    from gyrodrift.conventions import ACC_COLS, MAG_COLS

    seed = seeds("tuning", 1)[0]
    case = generate("rawmag-uncalibrated", seed, duration_scale=0.3)
    hard = np.array(case.compass.hard_iron_ut)
    b_h = case.compass.field_ut * np.cos(np.radians(case.compass.dip_deg))
    assert 0.2 <= np.hypot(hard[0], hard[1]) / b_h <= 0.6
    errs = []
    for log in (case.log, generate("rawmag-drive", seed, duration_scale=0.3).log):
        rows = log["mag_x"].notna().to_numpy()
        parts = [log[c].to_numpy()[rows] for c in (*MAG_COLS, *ACC_COLS)]
        err = (tilt_compensated_heading(*parts) - log["ref_heading"].to_numpy()[rows] + 180.0) % 360.0 - 180.0
        norm, _ = field_norm_dip(*parts)
        errs.append((np.std(err), np.std(norm) / np.mean(norm)))
    (uncal_err, uncal_norm), (cal_err, cal_norm) = errs
    assert uncal_err > 5.0 > cal_err and uncal_norm > 3.0 * cal_norm


def test_a_banked_flight_turns_coordinated_with_all_three_gyros():
    """``banked-flight``: the bank follows the turn (``atan(V psi' / g)``), the accelerometer reads
    along body z in the turns (a coordinated turn: no lateral part), the z gyro reads the heading
    rate times cos(roll) cos(pitch), and with the true tilt the heading rate of the three gyros,
    (q sin(roll) + r cos(roll)) / cos(pitch), has the gain of the true one (the roll from the
    accelerometer's norm, ``1 / cos(roll)`` g in a level turn, averaged over 1 s against its noise)."""
    log = generate("banked-flight", seeds("tuning", 1)[0], duration_scale=0.5).log
    assert {"gyro_x", "gyro_y", "mag_x", "acc_x"} <= set(log.columns) and "heading" not in log.columns
    k = max(int(round(1.0 / np.median(np.diff(log["t"])))), 1)
    acc = log[["acc_x", "acc_y", "acc_z"]].rolling(k, center=True, min_periods=1).mean().to_numpy()
    rate = log["true_rate_z"].to_numpy()
    turning = np.abs(rate) > 4.0
    assert turning.mean() > 0.2
    # no lateral specific force in a coordinated turn (but sin(roll) (1 - cos(pitch)) of the mounting pitch)
    assert np.percentile(np.abs(acc[turning, 1]), 99) < 0.005 + 3.0 * 0.03 / np.sqrt(k)
    g = np.linalg.norm(acc[turning], axis=1)
    roll = np.arccos(np.clip(1.0 / g, -1.0, 1.0)) * np.sign(rate[turning])  # |f| = 1/cos(roll) g
    assert np.degrees(np.abs(roll)).max() > 15.0
    q, r = log["gyro_y"].to_numpy()[turning], log["gyro_z"].to_numpy()[turning]
    pitch = np.arcsin(np.clip(acc[turning, 0] / g, -1.0, 1.0))  # the mounting pitch: f_x = |f| sin(pitch)
    euler = (q * np.sin(roll) + r * np.cos(roll)) / np.cos(pitch)
    # within the offsets (under 2 deg/s) and the scale factor (2.5 %) of the gyros
    rate = rate[turning]

    def gain(y):  # the slope of a line y = k rate + c: the gyro's offset is in c
        return np.polyfit(rate, y, 1)[0]

    assert abs(gain(euler) - 1.0) < 0.03  # the scale-factor error is at most 2.5 %
    assert gain(r) < gain(euler) - 0.02  # the z gyro alone: cos(roll) of it


def test_a_drive_logged_by_a_whole_imu_reads_its_mounting_tilt_on_the_x_y_gyros():
    """``imu-drive``: ``rawmag-drive`` with the x/y gyros, which read the body rates of a unit
    mounted at a constant tilt turning about the vertical: ``p = -psi' sin(pitch)``,
    ``q = psi' sin(roll) cos(pitch)``, the tilt known from the accelerometer where the car is
    still (gravity alone). Each axis's gain on the heading rate is that, times its scale factor,
    plus its share of the z rate (cross-axis sensitivity, at most ``CROSS_AXIS_MAX``), and the
    shares are not both nil."""
    from gyrodrift.simulate.generator import CROSS_AXIS_MAX, SF_MAX

    log = generate("imu-drive", seeds("held-out", 1)[0], duration_scale=0.3).log
    assert {"gyro_x", "gyro_y", "mag_x", "acc_x"} <= set(log.columns) and "heading" not in log.columns
    rate = log["true_rate_z"].to_numpy()
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy()
    still = (np.abs(rate) < 1e-9) & (np.abs(np.linalg.norm(acc, axis=1) - 1.0) < 0.001)  # in g
    assert still.sum() > 100
    down = -acc[still].mean(axis=0)
    down /= np.linalg.norm(down)
    pitch, roll = -np.arcsin(down[0]), np.arctan2(down[1], down[2])
    assert 0.2 < abs(np.degrees(roll)) + abs(np.degrees(pitch)) < 10.0
    assert (np.abs(rate) > 2.0).mean() > 0.05
    # changes over 1 s: the offsets, which drift with the temperature, drop out
    k = int(round(1.0 / np.median(np.diff(log["t"]))))
    turn = rate[k:] - rate[:-k]
    shares = []
    for column, expected in (("gyro_x", -np.sin(pitch)), ("gyro_y", np.sin(roll) * np.cos(pitch))):
        reading = log[column].to_numpy()
        slope = np.polyfit(turn, reading[k:] - reading[:-k], 1)[0]
        share = (slope - expected) / (np.cos(roll) * np.cos(pitch))  # of the z rate
        assert abs(share) < CROSS_AXIS_MAX + SF_MAX * abs(expected) + 0.002, (column, slope, expected)
        shares.append(share)
    assert max(abs(v) for v in shares) > 0.002, shares


def test_a_hand_held_imu_wobbles_in_roll_and_reads_it_on_the_x_gyro():
    """``handheld-imu``: hand turns logged by a whole IMU at 100-400 Hz with a raw compass; its
    roll wobbles (the accelerometer's roll moves by degrees, gravity alone: its norm stays 1 g
    within its noise), and the x gyro reads the roll's rate (changes over 0.1 s: the offsets drop
    out) with the gain of its scale factor, within 2.5 % and a cross-axis share of the z rate."""
    from gyrodrift.simulate.generator import CROSS_AXIS_MAX, SF_MAX

    log = generate("handheld-imu", seeds("tuning", 1)[0], duration_scale=0.3).log
    assert {"gyro_x", "gyro_y", "mag_x", "acc_x"} <= set(log.columns) and "heading" not in log.columns
    fs = 1.0 / np.median(np.diff(log["t"]))
    assert fs >= 100.0
    k = max(int(round(fs / 10.0)), 1)
    acc = log[["acc_x", "acc_y", "acc_z"]].rolling(k, center=True, min_periods=1).mean().to_numpy()
    roll = np.degrees(np.arctan2(-acc[:, 1], -acc[:, 2]))
    assert np.ptp(roll) > 2.0
    assert abs(np.median(np.linalg.norm(acc, axis=1)) - 1.0) < 0.01
    rate = log["true_rate_z"].to_numpy()
    still = np.abs(rate) < 1e-9  # no yaw: the x gyro reads the roll's rate alone (and sin(pitch) of nothing)
    t = log["t"].to_numpy()
    d_roll = (roll[k:] - roll[:-k]) / (t[k:] - t[:-k])
    d_gx = log["gyro_x"].rolling(k, center=True, min_periods=1).mean().to_numpy()
    both = still[k:] & still[:-k]
    assert both.sum() > 1000
    gain = np.polyfit(d_roll[both], d_gx[k:][both] - 0.0, 1)[0]
    assert abs(gain - 1.0) < SF_MAX + CROSS_AXIS_MAX + 0.05, gain


def test_a_raw_compass_logs_a_noisy_accelerometer():
    """Every class that logs the raw magnetometer logs its accelerometer with white noise of
    ``ACC_NOISE_G`` per sample (a standard deviation drawn per run), and a class with a heading
    column logs none: the scatter of successive differences of a still stretch, over sqrt(2)."""
    from gyrodrift.simulate.generator import ACC_NOISE_G

    lo, hi = ACC_NOISE_G
    for cls in ("rawmag-drive", "imu-drive", "banked-flight", "handheld-imu"):
        log = generate(cls, seeds("tuning", 1)[0], duration_scale=0.3).log
        acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy()
        sd = np.std(np.diff(acc, axis=0), axis=0) / np.sqrt(2.0)
        assert np.all(sd > 0.8 * lo) and np.all(sd < 1.2 * hi), (cls, sd)
        assert np.allclose(sd, sd.mean(), rtol=0.2), (cls, sd)  # the same noise on every axis


def test_a_roll_per_row_rotates_as_one_roll_for_all():
    """The simulator's level-to-body rotation with a roll per vector (a banked flight) gives what
    the one-roll rotation gives each vector, to rounding."""
    from gyrodrift.simulate.sensors import _body_from_level

    vectors = np.random.default_rng(0).standard_normal((7, 3))
    rolls = np.linspace(-40.0, 40.0, 7)
    per_row = _body_from_level(vectors, rolls, -7.0)
    for i, roll in enumerate(rolls):
        np.testing.assert_allclose(per_row[i], _body_from_level(vectors[i:i + 1], float(roll), -7.0)[0], atol=1e-12)


def test_a_pitch_per_row_rotates_as_one_pitch_for_all():
    """The level-to-body rotation with a roll and a pitch per vector (a quadplane) gives what the
    one-attitude rotation gives each vector, to rounding."""
    from gyrodrift.simulate.sensors import _body_from_level

    vectors = np.random.default_rng(1).standard_normal((7, 3))
    rolls, pitches = np.linspace(-40.0, 40.0, 7), np.linspace(-17.0, 37.0, 7)
    per_row = _body_from_level(vectors, rolls, pitches)
    for i in range(7):
        one = _body_from_level(vectors[i:i + 1], float(rolls[i]), float(pitches[i]))[0]
        np.testing.assert_allclose(per_row[i], one, atol=1e-12)


def _attitude_truth(seed: int, scale: float, cls: str = "quadplane"):
    """A recipe's grid times, heading rate and attitude (the generator's own draws) of a class
    whose whole attitude changes."""
    import zlib

    import gyrodrift.simulate.generator as G

    rng = G.seeded_streams([zlib.crc32(cls.encode()), seed], G._STREAMS)
    rec = G._BUILDERS[cls](rng["recipe"], scale)
    t = np.arange(int(rec.duration_s * rec.fs_sim_hz) + 1) / rec.fs_sim_hz
    rate = rec.rate(t)
    return rec, t, rate, rec.attitude(t, rate)


@pytest.mark.parametrize("cls, min_pitch, min_roll", [("quadplane", 10.0, 20.0), ("vessel-imu", 2.0, 4.0),
                                                      ("multicopter-imu", 5.0, 5.0)])
def test_body_rates_turn_gravity_as_the_attitude_does(cls, min_pitch, min_roll):
    """``quadplane``, ``vessel-imu``: roll and pitch both change (a hover's wobble, a transition,
    climbs, a flare of the nose up; a seaway's swells); the body rates of ZYX Euler kinematics (with the pitch's rate:
    ``q = θ̇ cos φ + ψ̇ sin φ cos θ``, ``r = −θ̇ sin φ + ψ̇ cos φ cos θ``) turn the down vector, integrated
    without noise row by row, as the attitude itself does (within 0.1 deg over the whole run);
    without the pitch's rate in q and r it drifts by degrees."""
    from gyrodrift.simulate.generator import _attitude_rates

    rec, t, rate, att = _attitude_truth(seeds("tuning", 1)[0], {"quadplane": 0.4, "vessel-imu": 0.1}.get(cls, 0.3), cls)
    assert np.ptp(att.pitch_deg) > min_pitch and np.ptp(att.roll_deg) > min_roll
    phi, theta = np.radians(att.roll_deg), np.radians(att.pitch_deg)
    truth = np.column_stack([-np.sin(theta), np.sin(phi) * np.cos(theta), np.cos(phi) * np.cos(theta)])
    rows = np.arange(t.size)

    def worst_deg(p, q, r):
        w = np.radians(np.column_stack([p, q, r]))
        d, worst = truth[0].copy(), 0.0
        for i in range(1, t.size):
            om = 0.5 * (w[i - 1] + w[i]) * (t[i] - t[i - 1])
            angle = np.linalg.norm(om)
            if angle > 0.0:  # a body-frame view of a fixed vector turns against the body (Rodrigues)
                k = om / angle
                d = d * np.cos(angle) - np.cross(k, d) * np.sin(angle) + k * (k @ d) * (1.0 - np.cos(angle))
            worst = max(worst, float(np.degrees(np.arccos(np.clip(d @ truth[i], -1.0, 1.0)))))
        return worst

    p, q, r = _attitude_rates(t, rows, rate, att)
    assert worst_deg(p, q, r) < 0.1  # the trapezoid of the rates' own error
    pitch_rate = np.gradient(att.pitch_deg, t)
    assert worst_deg(p, q - pitch_rate * np.cos(phi), r + pitch_rate * np.sin(phi)) > 1.0


def test_a_quadplane_hovers_with_its_thrust_along_body_z_and_flies_coordinated():
    """``quadplane``: hovering (no airspeed, the lift motors' full vibration), a tilt is what moves
    it, so the logged accelerometer shows no bank however its roll wobbles; wing-borne, its turns
    are banked by degrees, and its gusts and climbs change the specific force's norm by more than
    5 % on some rows."""
    seed = seeds("tuning", 1)[0]
    rec, t, rate, att = _attitude_truth(seed, 1.0)
    log = generate("quadplane", seed).log
    assert {"gyro_x", "gyro_y", "mag_x", "acc_x"} <= set(log.columns) and "heading" not in log.columns
    grid = np.searchsorted(t, log["t"].to_numpy() - 1e-9)
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy()
    bank = np.degrees(np.arctan2(-acc[:, 1], -acc[:, 2]))
    vibration = rec.vibration(t[grid])
    hover = vibration > 1.0 + 0.999 * (vibration.max() - 1.0)
    roll = att.roll_deg[grid]
    assert hover.sum() > 20 and np.ptp(roll[hover]) > 1.0
    # the accelerometer's bank in the hover is its noise (at most 0.03 g a sample), not the roll
    assert np.sqrt(np.mean(bank[hover] ** 2)) < 0.5 * np.sqrt(np.mean(roll[hover] ** 2)) + 0.03 * np.degrees(1.0)
    wing = (vibration == 1.0) & (np.abs(log["true_rate_z"].to_numpy()) > 4.0)
    assert wing.sum() > 20 and np.median(np.abs(roll[wing])) > 10.0
    assert np.mean(np.abs(np.linalg.norm(acc, axis=1) - 1.0) > 0.05) > 0.05


def test_a_vessel_imu_sways_as_it_rolls_so_its_accelerometer_sees_more_roll():
    """``vessel-imu``: the unit, metres above the roll's centre, is thrown sideways as the boat
    rolls (``h φ̈``, towards the level at each end of a swing), so the accelerometer's roll is
    larger than the true one (``1 + h ω² / g`` at a swell's frequency ω), while the gyro-aided
    tilt follows the true roll within a degree RMS."""
    from gyrodrift.attitude import GravityFilter

    seed = seeds("tuning", 1)[0]
    rec, t, rate, att = _attitude_truth(seed, 0.2, "vessel-imu")
    log = generate("vessel-imu", seed, duration_scale=0.2).log
    grid = np.searchsorted(t, log["t"].to_numpy() - 1e-9)
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy()
    roll_true = att.roll_deg[grid]
    roll_acc = np.degrees(np.arctan2(-acc[:, 1], -acc[:, 2]))
    swing = roll_true - np.mean(roll_true)
    gain = np.polyfit(swing, roll_acc - np.mean(roll_acc), 1)[0]
    assert gain > 1.02, gain
    gyro = [log[c].to_numpy() for c in ("gyro_x", "gyro_y", "gyro_z")]
    down = GravityFilter().feed(log["t"].to_numpy(), *gyro, acc)
    roll_filter = np.degrees(np.arctan2(down[:, 1], down[:, 2]))
    late = log["t"].to_numpy() > 60.0
    assert np.sqrt(np.mean((roll_filter - roll_true)[late] ** 2)) < 1.0


def test_a_multicopter_imu_tilts_to_move_so_its_accelerometer_misreads_the_tilt():
    """``multicopter-imu``: it tilts its thrust to accelerate and brake, so where it accelerates
    hardest the accelerometer's tilt (the direction of ``a − g``) is degrees from the true one
    (by about ``atan(a/g)``), while hovering still the two agree within the wobble."""
    seed = seeds("tuning", 1)[0]
    rec, t, rate, att = _attitude_truth(seed, 0.5, "multicopter-imu")
    log = generate("multicopter-imu", seed, duration_scale=0.5).log
    grid = np.searchsorted(t, log["t"].to_numpy() - 1e-9)
    acc = log[["acc_x", "acc_y", "acc_z"]].rolling(5, center=True, min_periods=1).mean().to_numpy()
    down = -acc / np.linalg.norm(acc, axis=1)[:, None]
    phi, theta = np.radians(att.roll_deg[grid]), np.radians(att.pitch_deg[grid])
    truth = np.column_stack([-np.sin(theta), np.sin(phi) * np.cos(theta), np.cos(phi) * np.cos(theta)])
    error = np.degrees(np.arccos(np.clip(np.sum(down * truth, axis=1), -1.0, 1.0)))
    accel = np.hypot(att.accel_fwd_mps2[grid], att.accel_lat_mps2[grid])
    hard = accel > 2.0
    assert hard.sum() > 20 and np.median(error[hard]) > 8.0
    assert np.median(error[accel < 0.05]) < 1.0

"""Thermal calibration (gyrodrift.calibrate): the fit, PX4 and ArduPilot files, the prior, the CLI.

The autopilots' corrections are emulated here from their documented formulas (module
notes of gyrodrift.calibrate), reading the written files with a parser of their own, so
that names, coefficient order, units and signs are checked independently of the readers.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from gyrodrift.calibrate import BIN_WIDTH_C, CalibrationError, fit_calibration, prior_config, prior_notes
from gyrodrift.onboard import ARDUPILOT_SCALE, ARDUPILOT_TREF_C
from gyrodrift.paramfiles import (
    read_ardupilot_params,
    read_calibration_json,
    read_prior,
    read_px4_params,
    write_calibration,
)
from gyrodrift.errors import ConfigError
from gyrodrift.simulate import TriadModel, simulate

# Hand-made drift, deg/s, as c_0..c_3 about 30 degC, monotonic over 15..45 degC (exact median filter).
KNOWN = {"x": (-0.2, -0.01, 1e-4, 1e-6), "y": (0.05, 0.03, 0.0, 0.0), "z": (0.1, 0.02, 3e-4, -2e-6)}
YAW_90 = [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # board x = body y, board y = -body x


def known_log(t_lo=15.0, t_hi=45.0, duration_s=1200.0, fs_hz=10.0, axes="xyz") -> pd.DataFrame:
    """A noiseless still heating run from t_lo to t_hi degC with the KNOWN drift."""
    t = np.arange(0.0, duration_s, 1.0 / fs_hz)
    temp = t_lo + (t_hi - t_lo) * t / t[-1]
    cols = {"t": t, "temp": temp}
    for a in axes:
        cols[f"gyro_{a}"] = np.polynomial.polynomial.polyval(temp - 30.0, KNOWN[a])
    return pd.DataFrame(cols)


def parse(path) -> dict[str, tuple]:
    """Name -> the fields after it, of a QGC (tab) or ArduPilot (comma) parameter file."""
    out = {}
    for line in path.read_text().splitlines():
        if line and not line.startswith("#"):
            fields = line.split("\t") if "\t" in line else line.split(",")
            if len(fields) == 5:
                out[fields[2]] = (float(fields[3]), int(fields[4]), fields[0], fields[1])
            else:
                out[fields[0]] = (float(fields[1]),)
    return out


def px4_offset_dps(p: dict, T, slot=0) -> np.ndarray:
    """PX4's thermal offset per board axis (deg/s): X0 + X1 d + X2 d^2 + X3 d^3, d = clip(T) - TREF."""
    g = f"TC_G{slot}_"
    d = np.clip(T, p[g + "TMIN"][0], p[g + "TMAX"][0]) - p[g + "TREF"][0]
    cols = [sum(p[f"{g}X{k}_{a}"][0] * d**k for k in range(4)) for a in range(3)]
    return np.degrees(np.column_stack(cols))


def ardupilot_poly_dps(p: dict, T, imu=1) -> np.ndarray:
    """ArduPilot's P(T) per board axis (deg/s): (GYR1 d + GYR2 d^2 + GYR3 d^3) 1e-6, d = clip(T) - 35."""
    q = f"INS_TCAL{imu}_"
    d = np.clip(T, p[q + "TMIN"][0], p[q + "TMAX"][0]) - 35.0
    cols = [sum(p[f"{q}GYR{k}_{a}"][0] * d**k for k in (1, 2, 3)) * 1e-6 for a in "XYZ"]
    return np.degrees(np.column_stack(cols))


def bin_means(T, err) -> np.ndarray:
    """Mean of ``err`` in each occupied BIN_WIDTH_C temperature bin (as the residual is defined)."""
    b = np.floor((T - T.min()) / BIN_WIDTH_C).astype(int)
    n = np.bincount(b)
    return np.bincount(b, err)[n > 0] / n[n > 0]


def bin_rms(T, err) -> float:
    """RMS over temperature bins of the bin's mean ``err``: the residual's measure."""
    return float(np.sqrt(np.mean(bin_means(T, err) ** 2)))


@pytest.fixture(scope="module")
def heating():
    """A simulated 30-min still heating run, -10 -> 60 degC, whole triad, 10 Hz."""
    return simulate("calibration", seed=1, duration_s=1800.0, fs_hz=10.0, triad=TriadModel())


def test_known_polynomial_is_recovered_exactly_and_written_as_documented(tmp_path):
    cal = fit_calibration(known_log(), source="known.csv")
    assert (cal.temp_ref_c, cal.temp_min_c, cal.temp_max_c, cal.samples) == (30.0, 15.0, 45.0, 12000)
    for a in "xyz":
        np.testing.assert_allclose(cal.axes[a].coeffs, KNOWN[a], rtol=1e-9, atol=1e-13)
        assert cal.axes[a].residual_rms_dps < 1e-12
    write_calibration(cal, tmp_path / "c.params", device_id=2360328)
    write_calibration(cal, tmp_path / "c.param")
    px4, ap = parse(tmp_path / "c.params"), parse(tmp_path / "c.param")
    # PX4: X{k}_{axis} = coefficient of (T - TREF)^k in rad/s, axis 0..2 = x, y, z; the offset IS the drift
    assert px4["TC_G_ENABLE"][:2] == (1, 6) and px4["TC_G0_ID"][:2] == (2360328, 6)
    assert [px4[f"TC_G0_{n}"][0] for n in ("TREF", "TMIN", "TMAX")] == [30.0, 15.0, 45.0]
    for k in range(4):
        for i, a in enumerate("xyz"):
            name = f"TC_G0_X{k}_{i}"
            assert px4[name][1:] == (9, "1", "1")
            assert px4[name][0] == pytest.approx(math.radians(KNOWN[a][k]), rel=1e-9, abs=1e-15)
    # ArduPilot: GYR{k} = coefficient of (T - 35)^k, rad/s, times 1e6, no constant; by hand about 35 degC
    for a in "xyz":
        c0, c1, c2, c3 = KNOWN[a]
        by_hand = (c1 + 2 * c2 * 5 + 3 * c3 * 25, c2 + 3 * c3 * 5, c3)  # T - 30 = (T - 35) + 5
        for k in (1, 2, 3):
            assert ap[f"INS_TCAL1_GYR{k}_{a.upper()}"][0] == pytest.approx(
                math.radians(by_hand[k - 1]) * 1e6, rel=1e-9, abs=1e-9)
    assert [ap[f"INS_TCAL1_{n}"][0] for n in ("ENABLE", "TMIN", "TMAX")] == [1.0, 15.0, 45.0]
    # Signs, by the autopilots' own corrections: PX4 raw - offset, ArduPilot raw - (P(T) - P(T_cal)) - offset(T_cal)
    log = known_log()
    raw = log[["gyro_x", "gyro_y", "gyro_z"]].to_numpy()
    T = log["temp"].to_numpy()
    np.testing.assert_allclose(raw - px4_offset_dps(px4, T), 0.0, atol=1e-12)
    boot = raw[:300].mean(axis=0) - ardupilot_poly_dps(ap, T[:300]).mean(axis=0)  # gyro calibration at boot
    np.testing.assert_allclose(raw - ardupilot_poly_dps(ap, T) - boot, 0.0, atol=1e-9)


def test_axis_mapping_to_a_rotated_board_and_back(tmp_path):
    cal = fit_calibration(known_log(), source="known.csv")
    write_calibration(cal, tmp_path / "r.params", body_to_board=YAW_90)
    write_calibration(cal, tmp_path / "r.param", body_to_board=YAW_90)
    px4, ap = parse(tmp_path / "r.params"), parse(tmp_path / "r.param")
    assert px4["TC_G0_X1_0"][0] == pytest.approx(math.radians(KNOWN["y"][1]))   # board x = body y
    assert px4["TC_G0_X1_1"][0] == pytest.approx(-math.radians(KNOWN["x"][1]))  # board y = -body x
    assert px4["TC_G0_X3_2"][0] == pytest.approx(math.radians(KNOWN["z"][3]))
    assert ap["INS_TCAL1_GYR1_X"][0] == pytest.approx(math.radians(KNOWN["y"][1]) * 1e6)
    T = np.linspace(15.0, 45.0, 61)
    for back in (read_px4_params(tmp_path / "r.params", body_to_board=YAW_90),
                 read_ardupilot_params(tmp_path / "r.param", body_to_board=YAW_90)):
        for a in "xyz":
            want = cal.drift(a, T) - (0.0 if back.offset_known else cal.drift(a, ARDUPILOT_TREF_C))
            np.testing.assert_allclose(back.drift(a, T), want, atol=1e-12)
    with pytest.raises(ConfigError, match="rotation"):
        write_calibration(cal, tmp_path / "bad.params", body_to_board=np.diag([1.0, 1.0, -1.0]))


def test_simulated_heating_run_files_match_the_device_within_the_stated_residual(heating, tmp_path):
    cal = fit_calibration(heating, source="heat.csv")
    assert set(cal.axes) == {"x", "y", "z"} and cal.span_c > 69.0 and cal.samples == len(heating)
    write_calibration(cal, tmp_path / "h.params")
    write_calibration(cal, tmp_path / "h.param")
    px4, ap = parse(tmp_path / "h.params"), parse(tmp_path / "h.param")
    T = heating["temp"].to_numpy()
    truth = heating[["true_bias_x", "true_bias_y", "true_bias_z"]].to_numpy()
    px4_err = px4_offset_dps(px4, T) - truth
    ap_err = ardupilot_poly_dps(ap, T) - truth  # ArduPilot's constant is its own gyro calibration
    for i, a in enumerate("xyz"):
        residual = cal.axes[a].residual_rms_dps
        assert 0.0 < residual < 0.05
        assert bin_rms(T, px4_err[:, i]) <= residual, a
        constant = np.mean(bin_means(T, ap_err[:, i]))  # the best constant, for the curve's shape
        assert bin_rms(T, ap_err[:, i] - constant) <= residual, a


def test_round_trip_reproduces_the_fitted_curve(heating, tmp_path):
    cal = fit_calibration(heating, source="heat.csv")
    T = np.linspace(cal.temp_min_c - 5.0, cal.temp_max_c + 5.0, 301)
    mid = cal.temp_ref_c
    for name, read in (("c.params", read_px4_params), ("c.param", read_ardupilot_params),
                       ("c.json", read_calibration_json)):
        write_calibration(cal, tmp_path / name)
        back = read(tmp_path / name)
        assert (back.temp_min_c, back.temp_max_c) == (cal.temp_min_c, cal.temp_max_c)
        for a in "xyz":
            want, got = cal.drift(a, T), back.drift(a, T)
            if not back.offset_known:  # ArduPilot: the curve up to a constant
                want, got = want - cal.drift(a, mid), got - back.drift(a, mid)
            scale = np.max(np.abs(want))
            assert np.max(np.abs(got - want)) <= 1e-9 * scale, (name, a)
    assert read_prior(tmp_path / "c.params").offset_known and not read_prior(tmp_path / "c.param").offset_known
    assert read_prior(tmp_path / "c.json").axes["z"].coeffs == cal.axes["z"].coeffs


def test_too_small_a_span_is_refused_with_a_reason():
    with pytest.raises(CalibrationError) as err:
        fit_calibration(known_log(t_lo=25.0, t_hi=28.0), source="flat.csv")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("flat.csv: ") and "3.00 degC" in msg and "at least 5 degC" in msg
    assert fit_calibration(known_log(t_lo=25.0, t_hi=31.0), source="ok.csv").span_c == pytest.approx(6.0)


def test_a_unit_that_moved_is_refused():
    log = known_log()
    turning = (log["t"] > 500.0) & (log["t"] < 510.0)
    log.loc[turning, "gyro_z"] += 20.0  # someone turned the unit 200 deg
    with pytest.raises(CalibrationError, match=r"moved.*still") as err:
        fit_calibration(log, source="moved.csv")
    assert "t = 50" in str(err.value) and "gyro_z" in str(err.value)
    still = known_log()
    for c, v in zip(("acc_x", "acc_y", "acc_z"), (0.0, 0.0, -1.0)):
        still[c] = v
    fit_calibration(still, source="level.csv")
    tilted = still.copy()
    tilted.loc[tilted["t"] > 900.0, ["acc_x", "acc_z"]] = [math.sin(0.1), -math.cos(0.1)]  # 5.7 deg
    with pytest.raises(CalibrationError, match=r"accelerometer tilted 5\.7 deg"):
        fit_calibration(tilted, source="tilted.csv")


def noisy_still_log(fs_hz: float, duration_s: float, sigma_dps: float, seed: int = 3) -> pd.DataFrame:
    """A still heating run 15 -> 45 degC with the KNOWN drift and white noise of ``sigma_dps``,
    sampled from t = 0 to t = duration_s inclusive (the last sample alone in its second)."""
    t = np.arange(0.0, duration_s + 0.5 / fs_hz, 1.0 / fs_hz)
    log = known_log(duration_s=duration_s + 1.0 / fs_hz, fs_hz=fs_hz)
    log = log.iloc[: t.size].copy()
    log["t"] = t
    log["temp"] = 15.0 + 30.0 * t / t[-1]
    noise = np.random.default_rng(seed).normal(0.0, sigma_dps, (t.size, 3))
    for i, a in enumerate("xyz"):
        log[f"gyro_{a}"] = np.polynomial.polynomial.polyval(log["temp"] - 30.0, KNOWN[a]) + noise[:, i]
    return log


def test_a_last_second_holding_one_sample_is_no_false_motion():
    """Issue 23, defect 4: the final second holds one sample, whose median-filtered rate is
    the raw sample itself; its 1-s 'mean' was judged alone and a noise spike refused the log."""
    log = noisy_still_log(fs_hz=50.0, duration_s=600.0, sigma_dps=0.2)
    assert (np.floor(log["t"]) == 600.0).sum() == 1
    clean = fit_calibration(log, source="clean.csv")
    log.loc[log.index[-1], "gyro_x"] += 0.8  # a 4-sigma sample, last of the log
    cal = fit_calibration(log, source="spike.csv")  # refused before (and weighed as a whole bin)
    assert abs(cal.axes["x"].residual_rms_dps - clean.axes["x"].residual_rms_dps) < 0.002
    np.testing.assert_allclose(cal.drift("x", [15.0, 30.0, 45.0]), clean.drift("x", [15.0, 30.0, 45.0]), atol=0.01)
    # motion in the last second is still seen: the tail joins the window before it
    moved = log.copy()
    moved.loc[moved["t"] > 598.5, "gyro_z"] += 20.0
    with pytest.raises(CalibrationError, match="moved"):
        fit_calibration(moved, source="moved.csv")


def test_a_log_at_1_hz_is_judged_over_windows_of_ten_samples():
    """Irregular 1-10 Hz logs (telemetry): one sample a second is no mean of anything."""
    log = noisy_still_log(fs_hz=1.0, duration_s=3600.0, sigma_dps=0.15)
    cal = fit_calibration(log, source="slow.csv")
    for a in "xyz":
        np.testing.assert_allclose(cal.drift(a, [20.0, 30.0, 40.0]),
                                   np.polynomial.polynomial.polyval(np.array([-10.0, 0.0, 10.0]), KNOWN[a]),
                                   atol=0.05)


def test_only_gyro_z_writes_zero_x_y_and_says_so(tmp_path):
    cal = fit_calibration(known_log(axes="z"), source="z.csv")
    notes = write_calibration(cal, tmp_path / "z.params", instance=1, device_id=7)
    p = parse(tmp_path / "z.params")
    assert any("gyro_x, gyro_y not in the log" in n for n in notes)
    assert p["TC_G1_X1_0"][0] == 0.0 and p["TC_G1_X1_2"][0] == pytest.approx(math.radians(0.02))
    assert "gyro_x, gyro_y not in the log" in (tmp_path / "z.params").read_text()
    assert any("TC_G0_ID is 0" in n for n in write_calibration(cal, tmp_path / "u.params"))


def test_bad_parameter_files_are_one_line_errors(tmp_path):
    bad = tmp_path / "bad.params"
    bad.write_text("1\t1\tTC_G0_TREF\tabc\t9\n")
    with pytest.raises(ConfigError, match=r"bad\.params: line 1: the value of TC_G0_TREF is not a number"):
        read_px4_params(bad)
    cal = fit_calibration(known_log(), source="k.csv")
    write_calibration(cal, tmp_path / "k.params")
    with pytest.raises(ConfigError, match=r"TC_G2_TREF.*missing; the file has gyro slots: 0; choose one"):
        read_px4_params(tmp_path / "k.params", instance=2)
    other = tmp_path / "other.param"
    other.write_text("ATC_RAT_RLL_P,0.135\n")
    with pytest.raises(ConfigError, match=r"other\.param: no TC_G\* \(PX4\) or INS_TCAL\* \(ArduPilot\)"):
        read_prior(other)
    with pytest.raises(ConfigError, match="cannot tell the calibration format"):
        write_calibration(cal, tmp_path / "k.txt")


def test_prior_is_the_tangent_at_the_start_clamped_to_the_range(tmp_path):
    cal = fit_calibration(known_log(), source="k.csv")
    x0 = prior_config(cal, temp_c=20.0).kalman.x0
    slope = KNOWN["z"][1] + 2 * KNOWN["z"][2] * -10 + 3 * KNOWN["z"][3] * 100
    value = np.polynomial.polynomial.polyval(-10.0, KNOWN["z"])
    assert x0 == pytest.approx((slope, 0.0, value - slope * 20.0), rel=1e-9)
    at_edge = prior_config(cal, temp_c=60.0).kalman.x0  # beyond TMAX: the tangent at 45 degC
    assert at_edge[0] * 45.0 + at_edge[2] == pytest.approx(cal.drift("z", 45.0)[()])
    write_calibration(cal, tmp_path / "k.param")
    ap = read_ardupilot_params(tmp_path / "k.param")
    a, b, c = prior_config(ap, temp_c=20.0).kalman.x0
    assert a == pytest.approx(slope, rel=1e-9) and a * 20.0 + c == pytest.approx(0.0, abs=1e-12)
    assert prior_notes(cal, (16.0, 44.0)) == []
    assert "reaches 10.0 to 44.0 degC" in prior_notes(cal, (10.0, 44.0))[0]


def test_json_is_gyrodrifts_own_document(tmp_path):
    cal = fit_calibration(known_log(), source="k.csv")
    write_calibration(cal, tmp_path / "k.json")
    doc = json.loads((tmp_path / "k.json").read_text())
    assert doc["format"] == "gyrodrift-calibration" and doc["units"]["coeffs"] == "deg/s per degC**k"
    assert doc["axes"]["z"]["coeffs"] == pytest.approx(list(KNOWN["z"]), abs=1e-12)
    assert (doc["temp_ref_c"], doc["span_c"], doc["samples"]) == (30.0, 30.0, 12000)
    assert ARDUPILOT_SCALE == 1e6


# ---------------------------------------------------------------------------- command line


def test_cli_calibrate_writes_the_file_and_prints_one_line(heating, tmp_path, capsys):
    from gyrodrift.cli import main

    log = tmp_path / "heat.csv"
    heating.to_csv(log, index=False)
    assert main(["calibrate", str(log), "-o", str(tmp_path / "v.params"), "--device-id", "2360328"]) == 0
    out, err = capsys.readouterr()
    assert err == "" and len(out.splitlines()) == 1
    assert "span 70.1 degC" in out and "residual RMS" in out and "wrote" in out and str(log) in out
    fitted = fit_calibration(heating, source=str(log))
    back = read_px4_params(tmp_path / "v.params")
    T = np.linspace(-10.0, 60.0, 71)
    np.testing.assert_allclose(back.drift("z", T), fitted.drift("z", T), rtol=1e-9)
    # --format names the output whatever its name; --instance is the slot (not a ULog option for a CSV)
    assert main(["calibrate", str(log), "-o", str(tmp_path / "v.txt"), "--format", "ardupilot", "-q",
                 "--instance", "1"]) == 0
    assert capsys.readouterr().out == ""
    assert "INS_TCAL2_GYR3_Z," in (tmp_path / "v.txt").read_text()


def test_cli_calibrate_refusal_is_one_line(tmp_path, capsys):
    from gyrodrift.cli import main

    flat = tmp_path / "flat.csv"
    known_log(t_lo=25.0, t_hi=27.0).assign(heading=0.0).to_csv(flat, index=False)  # read_log wants a compass
    assert main(["calibrate", str(flat), "-o", str(tmp_path / "f.params")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith(f"gyrodrift: error: {flat}: the temperature spans only")
    assert not (tmp_path / "f.params").exists()


def test_compensate_prior_starts_from_the_tangent_and_warns_outside_the_range(tmp_path, capsys):
    from conftest import synthetic_log
    from gyrodrift.cli import main

    params = tmp_path / "k.params"
    cal = fit_calibration(known_log(), source="k.csv")  # calibrated 15..45 degC
    write_calibration(cal, params)
    drift = lambda t, temp: np.polynomial.polynomial.polyval(temp - 30.0, KNOWN["z"])  # noqa: E731
    inside, outside = tmp_path / "in.csv", tmp_path / "out.csv"
    synthetic_log(duration_s=300.0, temp_c=lambda t: 20.0 + t / 30.0, drift_dps=drift).to_csv(inside, index=False)
    synthetic_log(duration_s=300.0, temp_c=lambda t: 40.0 + t / 30.0, drift_dps=drift).to_csv(outside, index=False)
    assert main(["compensate", str(inside), "-o", str(tmp_path / "a.csv"), "-q", "--prior", str(params)]) == 0
    assert capsys.readouterr().err == ""
    first = pd.read_csv(tmp_path / "a.csv").iloc[0]
    a0, _, c0 = prior_config(cal, temp_c=20.0).kalman.x0
    assert first["a"] == pytest.approx(a0, abs=1e-3)  # without --prior the first rows have a = 0.008
    assert main(["compensate", str(outside), "-o", str(tmp_path / "b.csv"), "-q", "--prior", str(params)]) == 0
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1
    assert err.startswith(f"gyrodrift: warning: {params}: calibrated for 15.0 to 45.0 degC (TMIN..TMAX), "
                          "the log reaches 40.0 to 50.0 degC")
    prof = tmp_path / "dev.json"
    assert main(["compensate", str(inside), "-o", str(tmp_path / "c.csv"), "-q", "--save-profile", str(prof)]) == 0
    assert main(["compensate", str(inside), "-o", str(tmp_path / "d.csv"), "-q", "--prior", str(params),
                 "--profile", str(prof)]) == 2
    assert "--prior and --profile" in capsys.readouterr().err


def test_compensate_file_starts_from_a_prior_in_the_same_pass(tmp_path):
    """``compensate_file(prior=...)``: in memory and in chunks, the drift model starts from the
    calibration at the log's first temperature, and both give the same rows."""
    from conftest import synthetic_log
    from gyrodrift.pipeline import compensate_file

    cal = fit_calibration(known_log(), source="k.csv")
    drift = lambda t, temp: np.polynomial.polynomial.polyval(temp - 30.0, KNOWN["z"])  # noqa: E731
    log = tmp_path / "in.csv"
    synthetic_log(duration_s=300.0, temp_c=lambda t: 20.0 + t / 30.0, drift_dps=drift).to_csv(log, index=False)
    compensate_file(log, tmp_path / "m.csv", prior=cal, chunked=False)
    compensate_file(log, tmp_path / "c.csv", prior=cal, chunked=True, chunk_rows=500)
    whole, chunks = pd.read_csv(tmp_path / "m.csv"), pd.read_csv(tmp_path / "c.csv")
    a0, _, _ = prior_config(cal, temp_c=20.0).kalman.x0
    assert whole["a"].iloc[0] == pytest.approx(a0, abs=1e-3)
    pd.testing.assert_frame_equal(whole, chunks)


def test_ardupilot_files_in_every_layout_read_the_same(tmp_path):
    cal = fit_calibration(known_log(), source="k.csv")
    write_calibration(cal, tmp_path / "mp.param")  # Mission Planner: NAME,VALUE
    text = (tmp_path / "mp.param").read_text()
    (tmp_path / "mavproxy.parm").write_text(text.replace(",", " "))  # tempcal_IMU.py: NAME VALUE
    (tmp_path / "persistent.txt").write_text(text.replace(",", "="))  # firmware dump: NAME=VALUE
    T = np.linspace(15.0, 45.0, 31)
    want = read_ardupilot_params(tmp_path / "mp.param").drift("z", T)
    for name in ("mavproxy.parm", "persistent.txt"):
        np.testing.assert_array_equal(read_prior(tmp_path / name).drift("z", T), want)


def test_a_bench_log_without_compass_calibrates(tmp_path):
    """t, gyro_z and temp only (a bench heating run): read with a note, calibrated."""
    from gyrodrift.cli import main
    from gyrodrift.simulate import simulate

    log = simulate("calibration", seed=1, duration_s=3600, fs_hz=10)
    log.attrs = {}
    log[["t", "gyro_z", "temp"]].to_csv(tmp_path / "bench.csv", index=False)
    assert main(["calibrate", str(tmp_path / "bench.csv"), "-o", str(tmp_path / "cal.json"), "--format", "json"]) == 0
    assert (tmp_path / "cal.json").is_file()

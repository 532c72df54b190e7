"""Plausible input ranges (issue 16): no finite value can poison the output.

One huge finite gyro rate (a bit-flipped float gives 5e38) used to freeze ``heading`` for
the rest of the log and put ``heading_fused`` far outside [0, 360), exit 0. Every entry
point now refuses a value outside its plausible range (:mod:`gyrodrift.io.limits`), as it
refuses an implausible temperature: one line naming the file, row and column.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import Compensator, compensate, compensate_arrays
from gyrodrift.cli import main
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.estimators import AdaptiveConfig, FixedParams, KalmanConfig
from gyrodrift.io import read_log
from gyrodrift.io.align import contract_frame
from gyrodrift.io.chunked import iter_log_chunks
from gyrodrift.io.limits import GYRO_MAX_DPS, HEADING_MAX_ABS_DEG, MAG_MAX_ABS, Limit, first_outside
from gyrodrift.profile import Profile, compensate_warm


def one_line_error(err: str, *names: str) -> None:
    """``err`` is one ``gyrodrift: error:`` line that contains every one of ``names``."""
    assert "Traceback" not in err
    assert err.startswith("gyrodrift: error: ") and err.count("\n") == 1, err
    for name in names:
        assert name in err, (name, err)


@pytest.fixture(scope="module")
def log() -> pd.DataFrame:
    return synthetic_log(duration_s=200.0, gyro_noise_dps=0.05, compass_noise_deg=0.5)


def _with(log: pd.DataFrame, row: int, **cells) -> pd.DataFrame:
    out = log.copy()
    for col, value in cells.items():
        out.loc[out.index[row], col] = value
    return out


def _in_range(out: pd.DataFrame) -> None:
    for col in ("heading", "heading_fused"):
        values = out[col].to_numpy()
        if col == "heading_fused":  # empty until the first epoch with a compass sample has closed
            seen = np.isfinite(values)
            assert seen.any() and seen[int(np.argmax(seen)):].all(), col
            values = values[seen]
        assert np.all((values >= 0.0) & (values < 360.0)), col
    for col in ("rate_z", "bias_z", "heading_sd"):
        assert np.all(np.isfinite(out[col].to_numpy())), col
    fused = np.isfinite(out["heading_fused"].to_numpy())
    assert np.array_equal(np.isfinite(out["heading_fused_sd"].to_numpy()), fused)  # both empty at first


@pytest.mark.parametrize("value", [1e16, -5e38, 1.7976931348623157e308])
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
@pytest.mark.parametrize("extra", [[], ["--smooth"], ["--scale-factor"]])
def test_huge_gyro_rate_is_refused_naming_file_row_and_column(tmp_path, log, capsys, value, suffix, extra):
    path = tmp_path / f"flipped{suffix}"
    bad = _with(log, 2000, gyro_z=value)
    bad.to_csv(path, index=False) if suffix == ".csv" else bad.to_parquet(path, index=False)
    assert main(["compensate", str(path), "-o", str(tmp_path / "out.csv"), *extra]) == 2
    where = "line 2002" if suffix == ".csv" else "data row 2001"
    one_line_error(capsys.readouterr().err, str(path), where, "'gyro_z'", "plausible", "10000")
    assert not (tmp_path / "out.csv").exists()


def test_the_limit_is_in_the_files_gyro_unit_and_configurable(tmp_path, log):
    path = tmp_path / "rad.csv"
    rad = log.assign(gyro_z=np.radians(log["gyro_z"]))
    _with(rad, 10, gyro_z=200.0).to_csv(path, index=False)  # 200 rad/s = 11459 deg/s
    with pytest.raises(LogFormatError, match=r"line 12, column 'gyro_z': gyro_z = 200.0 rad/s .*174\.5"):
        read_log(path, gyro_unit="rad/s")
    assert read_log(path, gyro_unit="rad/s", gyro_max_dps=20_000.0)["gyro_z"].iloc[10] == pytest.approx(11459.156)
    with pytest.raises(ConfigError, match="gyro_max_dps"):
        read_log(path, gyro_max_dps=-1.0)


def test_chunked_reader_refuses_in_a_later_chunk(tmp_path, log):
    path = tmp_path / "late.csv"
    _with(log, 3500, gyro_x=5e38).assign(gyro_x=lambda d: d["gyro_x"].fillna(0.0)).to_csv(path, index=False)
    with pytest.raises(LogFormatError, match=r"line 3502, column 'gyro_x'"):
        for _ in iter_log_chunks(path, chunk_rows=1000):
            pass


@pytest.mark.parametrize("cells, first", [
    ({}, None), ({5: np.nan}, None), ({5: np.inf}, 5), ({7: -np.inf, 9: 20.0}, 7), ({3: 10.0 + 1e-9}, 3),
    ({2: -10.0, 4: 10.0}, None), ({0: np.nan, 6: -11.0}, 6),
])
def test_first_outside_finds_the_first_value_beyond_the_limit(cells, first):
    """NaN is never outside; an infinity always is; the limits themselves are inside."""
    values = np.zeros(12)
    for i, v in cells.items():
        values[i] = v
    assert first_outside(values, Limit(-10.0, 10.0, "u", "fix")) == first
    assert first_outside(np.full(4, np.nan), Limit(-10.0, 10.0, "u", "fix")) is None
    assert first_outside(np.zeros(0), Limit(-10.0, 10.0, "u", "fix")) is None


@pytest.mark.parametrize(
    "cells, column",
    [
        ({"heading": 1e308}, "heading"),
        ({"heading": -2 * HEADING_MAX_ABS_DEG}, "heading"),
        ({"ref_heading": 1e300}, "ref_heading"),
    ],
)
def test_huge_heading_is_refused(tmp_path, log, cells, column):
    path = tmp_path / "h.csv"
    _with(log, 40, **cells).to_csv(path, index=False)
    with pytest.raises(LogFormatError, match=rf"line 42, column '{column}': .*plausible"):
        read_log(path)


def test_headings_of_many_turns_still_wrap(tmp_path, log):
    path = tmp_path / "turns.csv"
    _with(log, 40, heading=720.0 + 90.0).to_csv(path, index=False)
    assert read_log(path)["heading"].iloc[40] == 90.0


def test_magnetometer_beyond_any_unit_is_refused(tmp_path, log):
    path = tmp_path / "mag.csv"
    raw = log.drop(columns=["heading"]).assign(mag_x=0.2, mag_y=0.0, mag_z=0.4, acc_x=0.0, acc_y=0.0, acc_z=-1.0)
    _with(raw, 7, mag_y=10 * MAG_MAX_ABS).to_csv(path, index=False)
    with pytest.raises(LogFormatError, match=r"line 9, column 'mag_y'"):
        read_log(path)


@pytest.mark.parametrize("cells", [{"gyro_z": 1e16}, {"temp": 1000.0}, {"heading": 1e308}])
def test_compensate_refuses_what_the_readers_refuse(log, cells):
    column = next(iter(cells))
    with pytest.raises(LogFormatError, match=rf"mylog: row 2000, column '{column}'"):
        compensate(_with(log, 2000, **cells), source="mylog")


def test_compensate_refuses_a_huge_x_rate_and_arrays_take_the_option(log):
    triad = log.assign(gyro_x=0.0, gyro_y=0.0, acc_x=0.0, acc_y=0.0, acc_z=-1.0)
    with pytest.raises(LogFormatError, match=r"row 5, column 'gyro_x'"):
        compensate(_with(triad, 5, gyro_x=-5e38))
    fast = _with(log, 5, gyro_z=1.5 * GYRO_MAX_DPS)
    with pytest.raises(LogFormatError, match=r"row 5, column 'gyro_z'"):
        compensate_arrays(fast["t"], fast["gyro_z"], fast["temp"], fast["heading"])
    out = compensate_arrays(fast["t"], fast["gyro_z"], fast["temp"], fast["heading"], gyro_max_dps=2 * GYRO_MAX_DPS)
    _in_range(out)


def test_binary_readers_refuse_a_bit_flipped_gyro_sample():
    t = np.arange(100) * 0.01
    gyro = np.zeros((100, 3))
    gyro[42, 2] = 5.3e38
    with pytest.raises(LogFormatError, match=r"f\.ulg: gyro sample 43 \(t = 0\.420000 s\): gyro_z = 5\.3e\+38"):
        contract_frame(t, gyro, np.full(100, 30.0), None, None, None, {"source": "f.ulg"})
    acc = np.zeros((100, 3))
    acc[3, 0] = math.inf
    with pytest.raises(LogFormatError, match=r"gyro sample 4 .*acc_x"):
        contract_frame(t, np.zeros((100, 3)), np.full(100, 30.0), None, acc, None, {"source": "f.ulg"})


def test_largest_plausible_rate_keeps_outputs_in_range(log):
    out = compensate(_with(log, 2000, gyro_z=GYRO_MAX_DPS))
    _in_range(out)


# --------------------------------------------------------------------------- streaming


def _started() -> Compensator:
    comp = Compensator(provisional=False)
    comp.push(0.0, 0.1, 30.0, heading_deg=90.0)
    return comp


@pytest.mark.parametrize(
    "kwargs, names",
    [
        ({"temp_c": 1000.0}, ["temp_c", "1000.0", "-60..150 degC"]),
        ({"temp_c": -300}, ["temp_c", "-300.0", "plausible"]),
        ({"heading_deg": 1e308}, ["heading_deg", "1e+308", "plausible"]),
        ({"gyro_z_dps": 1e16}, ["gyro_z_dps", "1e+16", "10000 deg/s"]),
        ({"gyro_z_dps": math.inf}, ["gyro_z_dps", "inf"]),
        ({"gyro_x_dps": -5e38, "gyro_y_dps": 0.0}, ["gyro_x_dps", "-5e+38"]),
        ({"mag": (0.2, 1e200, 0.4), "acc": (0, 0, -1)}, ["mag[1]", "mag_y", "1e+200"]),
        ({"acc": (0.0, 0.0, 1e300)}, ["acc[2]", "acc_z"]),
    ],
)
def test_push_refuses_what_a_file_refuses_and_keeps_its_state(kwargs, names):
    comp = _started()
    sample = {"t_s": 0.01, "gyro_z_dps": 0.1, "temp_c": 30.0, **kwargs}
    with pytest.raises(GyroDriftError) as info:
        comp.push(**sample)
    message = str(info.value)
    assert message.startswith("stream: ") and "\n" not in message
    for name in names:
        assert name in message, (name, message)
    # the refused sample was not taken: the same time is accepted next
    assert comp.push(0.01, 0.1, 30.0) == []


@pytest.mark.parametrize(
    "kwargs, arg",
    [
        ({"t_s": None}, "t_s"),
        ({"t_s": "0.01"}, "t_s"),
        ({"gyro_z_dps": "0.1"}, "gyro_z_dps"),
        ({"gyro_z_dps": None}, "gyro_z_dps"),
        ({"temp_c": True}, "temp_c"),
        ({"temp_c": 10**400}, "temp_c"),
        ({"heading_deg": [90.0]}, "heading_deg"),
        ({"heading_deg": 10**400}, "heading_deg"),
        ({"mag": 3.0, "acc": (0, 0, -1)}, "mag"),
        ({"acc": "xyz"}, "acc"),
        ({"acc": (0.0, 0.0)}, "acc"),
        ({"acc": (0.0, None, -1.0)}, "acc[1]"),
        ({"gyro_x_dps": object(), "gyro_y_dps": 0.0}, "gyro_x_dps"),
    ],
)
def test_push_refuses_values_that_are_not_numbers_naming_the_argument(kwargs, arg):
    comp = _started()
    with pytest.raises(GyroDriftError, match=rf"^stream: {re.escape(arg)}[ :]"):
        comp.push(**{"t_s": 0.01, "gyro_z_dps": 0.1, "temp_c": 30.0, **kwargs})


def test_push_takes_numpy_numbers_and_another_full_scale():
    comp = Compensator(gyro_max_dps=20_000.0)
    comp.push(np.float32(0.0), np.int64(0), np.float64(30.0), heading_deg=None)
    comp.push(0.01, 15_000.0, 30.0, heading_deg=np.nan)
    with pytest.raises(ConfigError, match="gyro_max_dps"):
        Compensator(gyro_max_dps=math.nan)


# --------------------------------------------------------------------------- drift model from Python


@pytest.mark.parametrize(
    "kwargs, names",
    [
        ({"x0": (0.0, 0.0, 1e308)}, ["x0", "1e+308", "|c| <= 50 deg/s"]),
        ({"x0": (2.0, 0.0, 0.0)}, ["x0", "|a| <= 1"]),
        ({"x0": (0.0, -5000.0, 0.0)}, ["x0", "|b| <= 1000"]),
        ({"p0_sd": (0.05, 5.0, 1e200)}, ["p0_sd", "plausible"]),
        ({"q_sd": (1e-4, 2000.0, 1e-3)}, ["q_sd", "plausible"]),
        ({"p0_cov": ((1e300, 0, 0), (0, 1, 0), (0, 0, 1))}, ["p0_cov", "plausible"]),
    ],
)
def test_kalman_settings_from_python_are_bounded_like_settings_files(kwargs, names):
    with pytest.raises(ConfigError) as info:
        KalmanConfig(**kwargs)
    for name in names:
        assert name in str(info.value), (name, str(info.value))


def test_estimator_parameters_from_python_are_bounded():
    with pytest.raises(ConfigError, match=r"drift_walk = nan is refused: give a number \(not nan\)"):
        AdaptiveConfig(drift_walk=float("nan"))
    with pytest.raises(ConfigError, match=r"fixed parameters .*\|c\| <= 50"):
        FixedParams((0.0, 0.0, 1e308))
    with pytest.raises(ConfigError, match="three finite numbers"):
        FixedParams((0.0, 0.0))
    assert FixedParams((0.01, 2.0, -0.5)).params.tolist() == [0.01, 2.0, -0.5]
    KalmanConfig(max_sd=(1e3,) * 3)  # a cap beyond the bounds is a filter without cap


def test_compensate_warm_notes_another_estimator_and_temperature_range(log):
    prof = Profile((0.0, 0.0, 0.3), ((1e-6, 0, 0), (0, 0.5, 0), (0, 0, 1e-3)), (0.0, 5.0), 10, 1, "stkf",
                   "2024-05-01T12:00:00+00:00", "gyrodrift 1.0.0")
    out = compensate_warm(log, prof, name="dev.json")  # log at 25..26 degC, default estimator adaptive
    notes = [n for n in out.attrs["notes"] if n.startswith("dev.json: ")]
    assert len(notes) == 2 and "'stkf'" in notes[0] and "0.0 to 5.0 degC" in notes[1]
    _in_range(out)
    same = compensate_warm(log, replace(prof, temp_range_c=(20.0, 30.0)), CompensatorConfig(estimator="stkf"))
    assert not [n for n in same.attrs["notes"] if n.startswith("profile: ")]


# --------------------------------------------------------------------------- montecarlo -o


def test_montecarlo_csv_cells_cannot_be_spreadsheet_formulas(tmp_path, monkeypatch, capsys):
    import gyrodrift.evaluate.montecarlo as mc

    real = mc.run_monte_carlo

    def with_bad_cells(*args, **kwargs):
        df = real(*args, **kwargs)
        df.loc[0, ["status", "error"]] = ["error", "=HYPERLINK(\"http://x\")"]
        df.loc[1, ["status", "error"]] = ["error", "-2+3 failed"]
        return df

    monkeypatch.setattr(mc, "run_monte_carlo", with_bad_cells)
    out = tmp_path / "mc.csv"
    main(["montecarlo", "--seeds", "1", "--families", "static", "--methods", "adaptive", "kf",
          "--duration-scale", "0.05", "--workers", "1", "-o", str(out)])
    capsys.readouterr()
    back = pd.read_csv(out, keep_default_na=False)
    assert back.loc[0, "error"] == "'=HYPERLINK(\"http://x\")" and back.loc[1, "error"] == "'-2+3 failed"
    for col in back.columns:
        assert not any(str(v).startswith(("=", "+", "@")) for v in back[col] if isinstance(v, str)), col
    parquet = tmp_path / "mc.parquet"  # Parquet holds the text as it is
    main(["montecarlo", "--seeds", "1", "--families", "static", "--methods", "adaptive", "kf",
          "--duration-scale", "0.05", "--workers", "1", "-o", str(parquet)])
    assert pd.read_parquet(parquet).loc[0, "error"] == "=HYPERLINK(\"http://x\")"


def test_a_single_sample_is_refused_not_crashed_on():
    # found by tests/test_fuzz.py: one sample gave ZeroDivisionError or LinAlgError
    with pytest.raises(LogFormatError, match="single sample"):
        compensate_arrays([0.0], [0.0], [20.0], [0.0])
    comp = Compensator(provisional=False)
    assert comp.push(0.0, 0.1, 30.0) == []
    with pytest.raises(GyroDriftError, match="single sample"):
        comp.flush()
    comp = Compensator()  # its provisional row is out; closing the window needs two samples
    assert len(comp.push(0.0, 0.1, 30.0)) == 1
    with pytest.raises(GyroDriftError, match="single sample"):
        comp.flush()


# --------------------------------------------------------------------------- time gaps


def _gap_log(gap_s: float) -> pd.DataFrame:
    """300 s of a still unit whose compass wanders (interference) in its last 100 s, a time
    gap of ``gap_s``, then 100 s more."""
    t1 = np.arange(0.0, 300.0, 0.1)
    t2 = 300.0 + gap_s + np.arange(0.0, 100.0, 0.1)
    t = np.concatenate([t1, t2])
    heading = np.full(t.size, 50.0)
    wander = (t > 200.0) & (t < 300.0)
    heading[wander] += np.linspace(0.0, 30.0, wander.sum())
    gyro = 0.1 + np.random.default_rng(0).normal(0.0, 0.02, t.size)
    return pd.DataFrame({"t": t, "gyro_z": gyro, "temp": 25.0, "heading": heading})


def test_a_gap_inside_a_refused_interval_is_labelled_gap():
    log = _gap_log(3600.0)
    t = log["t"].to_numpy()
    log["heading"] = np.where((t > 200.0) & (t < 300.0), 80.0, 50.0)  # a magnet by the still unit
    out = compensate(log)
    before, after = out.iloc[2999], out.iloc[3000]
    assert before["gate_reason"] == "interference"
    assert after["gate_reason"] == "gap"  # the gap outranks the refusal seen before it


def test_bias_sd_grows_with_the_time_a_gap_lasts():
    sd = {}
    for gap_s in (60.0, 3600.0, 30 * 86400.0):
        out = compensate(_gap_log(gap_s))
        sd[gap_s] = float(out["bias_sd"].iloc[3001])  # the row after the gap's interval end
    assert sd[60.0] < sd[3600.0] < sd[30 * 86400.0]
    # a month: at least the bias instability's random walk over the month (drift_walk per √s)
    # added to what was known before the gap, never more uncertain than before any data
    h = np.array([25.0, 0.0, 1.0])
    prior = float(np.sqrt(h @ Compensator().estimator.cov @ h))
    walk = AdaptiveConfig().drift_walk * np.sqrt(30 * 86400.0)
    assert np.hypot(walk, sd[60.0]) <= sd[30 * 86400.0] <= prior


def test_push_takes_a_triple_in_any_form_of_three_numbers_alike():
    """``mag`` and ``acc`` as tuples of floats (taken as they are), lists, numpy float64 scalars,
    whole numbers or a numpy array (checked one by one) give the same rows, NaN in a component
    included."""
    rng = np.random.default_rng(3)
    n = 400  # 40 s at 10 Hz: past the 30-s init window
    mag = np.column_stack([np.full(n, 20.0), np.full(n, 5.0), np.full(n, 40.0)]) + rng.integers(-3, 4, (n, 3))
    mag[7, 1] = math.nan
    acc = np.tile([0.0, 0.0, -1.0], (n, 1))

    def run(form):
        comp = Compensator(provisional=False)
        rows = []
        for i in range(n):
            rows += comp.push(0.1 * i, 0.2, 25.0 + 0.01 * i, mag=form(mag[i]), acc=form(acc[i]))
        return np.array([(r.t, r.heading, r.compass_heading, r.bias_z) for r in rows + comp.flush()])

    plain = run(lambda v: tuple(float(x) for x in v))
    assert plain.shape == (n, 4) and np.isfinite(plain[:, 2]).sum() == n - 1
    for form in (list, tuple, np.asarray, lambda v: [x if math.isnan(x) else int(x) for x in v.tolist()]):
        assert np.array_equal(run(form), plain, equal_nan=True)

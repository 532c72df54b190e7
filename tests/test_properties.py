"""Property-based tests (hypothesis) of the readers, the compass maths, the filter and the compensator.

Every test runs with a fixed, derandomized profile (:data:`REPRO`): CI sees the same
examples on every run and no example database is written.

Properties
----------
* A messy log (NaN cells in gyro/temp/heading, time gaps, duplicate or backward time
  stamps, saturated gyro values, constant or quantised temperature, compass lost
  after some row, heading or raw-magnetometer compass, CSV or Parquet) gives either
  a one-line :class:`GyroDriftError` or an output table without NaN/inf in the
  contract columns; never another exception.
* ``wrap_360`` / ``wrap_180`` ranges and their invariance to whole turns.
* The compass heading is invariant to the scale of mag and of acc.
* :class:`Compensator` (streaming) equals :func:`compensate` (batch), every column.
* The STKF covariance stays finite, symmetric positive definite and under its cap.

Cases that once failed keep their minimal example as an ``@example``.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from test_compensate import _without_empty_triad
from gyrodrift.compass import field_norm_dip, tilt_compensated_heading
from gyrodrift.compensator import Compensator, CompensatorConfig, compensate, uses_clock
from gyrodrift.conventions import wrap_180, wrap_360
from gyrodrift.errors import GyroDriftError
from gyrodrift.estimators import KalmanConfig
from gyrodrift.estimators.base import Observation
from gyrodrift.estimators.kalman import KalmanDrift
from gyrodrift.io import read_log, write_table

#: Reproducible profile: same examples on every run, no database, no deadline.
REPRO = settings(
    derandomize=True,
    database=None,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

#: Output columns that must be finite whenever compensation succeeds.
FINITE_COLS = ["t", "rate_z", "bias_z", "heading", "a", "b", "c", "updated", "gated"]
#: Earth field of the raw-magnetometer compass form, µT (horizontal, vertical down).
FIELD_H_UT, FIELD_V_UT = 20.0, 45.0


# --------------------------------------------------------------------------- strategies


@st.composite
def messy_logs(draw, *, allow_time_faults: bool = True, max_rows: int = 600):
    """A small log in the input contract with the faults of the module notes.

    Returns ``(frame, compass_form)``; the frame holds ``t, gyro_z, temp`` and either
    ``heading`` or ``mag_x..z`` + ``acc_x..z`` (level device).
    """
    fs = draw(st.sampled_from([1.0, 2.0, 5.0, 10.0]), label="fs_hz")
    duration = draw(st.integers(45, 150) | st.integers(1, 45), label="duration_s")
    n = max(3, min(max_rows, int(duration * fs) + 1))
    t0 = draw(st.sampled_from([0.0, 12.5, -50.0, 1.7e9]), label="t0")
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1), label="noise_seed"))

    dt = np.full(n, 1.0 / fs)
    if draw(st.booleans(), label="jitter"):
        dt *= rng.uniform(0.7, 1.3, n)
    for pos, gap in draw(st.lists(st.tuples(st.integers(1, n - 1), st.sampled_from([1.5, 7.0, 60.0, 3600.0])),
                                  max_size=3), label="gaps"):
        dt[pos] += gap
    t = t0 + np.cumsum(dt) - dt[0]
    if allow_time_faults:
        fault = draw(st.sampled_from([None] * 6 + ["duplicate", "backward"]), label="time_fault")
        if fault is not None:
            pos = draw(st.integers(1, n - 1), label="fault_row")
            t[pos] = t[pos - 1] if fault == "duplicate" else t[pos - 1] - 0.5

    temp_kind = draw(st.sampled_from(["ramp", "sine", "constant", "q0.0625", "q1"]), label="temp_kind")
    rel = (t - t[0]) / max(t[-1] - t[0], 1.0)
    if temp_kind == "constant":
        temp = np.full(n, 31.25)
    else:
        temp = 25.0 + (20.0 * rel if temp_kind == "ramp" else 5.0 * np.sin(6.0 * rel))
        temp = temp + 0.02 * rng.standard_normal(n)
        if temp_kind.startswith("q"):
            q = float(temp_kind[1:])
            temp = np.round(temp / q) * q

    true_rate = np.zeros(n)
    if draw(st.booleans(), label="turn"):
        a = draw(st.integers(0, n - 1), label="turn_row")
        true_rate[a : a + draw(st.integers(1, 100), label="turn_rows")] = draw(st.floats(-90.0, 90.0), label="turn_dps")
    gyro = true_rate + 0.3 + 0.01 * (temp - 25.0) + 0.05 * rng.standard_normal(n)
    for pos, sign in draw(st.lists(st.tuples(st.integers(0, n - 1), st.sampled_from([-1.0, 1.0])), max_size=5),
                          label="saturated"):
        gyro[pos] = 2000.0 * sign

    heading = np.mod(100.0 + np.cumsum(true_rate * np.r_[0.0, np.diff(t)]) + 0.3 * rng.standard_normal(n), 360.0)
    every = draw(st.sampled_from([1, 2, 5, 10]), label="compass_every")
    heading[np.arange(n) % every != 0] = np.nan
    if draw(st.sampled_from([False, False, False, True]), label="compass_lost"):
        heading[draw(st.integers(0, n - 1), label="compass_lost_from") :] = np.nan

    nan_rows = st.lists(st.integers(1, n - 1), max_size=8)
    columns = {"gyro": gyro, "temp": temp, "heading": heading}
    for name, col in columns.items():
        col[draw(nan_rows, label=f"nan_{name}")] = np.nan
    first_empty = draw(st.sampled_from([None] * 9 + list(columns)), label="first_row_empty")
    if first_empty is not None:
        columns[first_empty][0] = np.nan

    frame = pd.DataFrame({"t": t, "gyro_z": gyro, "temp": temp})
    form = draw(st.sampled_from(["heading", "mag"]), label="compass_form")
    if form == "heading":
        frame["heading"] = heading
    else:
        rad = np.radians(heading)
        frame["mag_x"] = FIELD_H_UT * np.cos(rad)
        frame["mag_y"] = -FIELD_H_UT * np.sin(rad)
        frame["mag_z"] = np.where(np.isfinite(heading), FIELD_V_UT, np.nan)
        frame["acc_x"], frame["acc_y"], frame["acc_z"] = 0.0, 0.0, -1.0
    return frame, form


def small_configs():
    """The default settings, or short init/update intervals (more updates per row)."""
    short = st.builds(
        lambda init_s, interval_s: CompensatorConfig(init_s=init_s, update_interval_s=interval_s),
        st.floats(1.0, 10.0), st.floats(0.5, 5.0),
    )
    return st.just(CompensatorConfig()) | short


# --------------------------------------------------------------------------- helpers


def check_error(err: GyroDriftError) -> None:
    """A user error: a non-empty message on one line."""
    msg = str(err)
    assert msg.strip() and "\n" not in msg and "\r" not in msg, repr(msg)


def check_output(out: pd.DataFrame, n_rows: int) -> None:
    """No NaN/inf in the contract columns; flags are 0/1; heading in [0, 360)."""
    assert len(out) == n_rows
    values = out[FINITE_COLS].to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    assert not bad.any(), f"non-finite in {[c for c, b in zip(FINITE_COLS, bad.any(axis=0)) if b]}"
    assert set(np.unique(out["updated"])) <= {0, 1} and set(np.unique(out["gated"])) <= {0, 1}
    assert ((out["heading"] >= 0.0) & (out["heading"] < 360.0)).all()


def stream(log: pd.DataFrame, cfg: CompensatorConfig | None) -> pd.DataFrame:
    """Feed a log sample by sample to :class:`Compensator`; return its rows as a table."""
    comp = Compensator(cfg, provisional=False)
    has_mag = "mag_x" in log.columns
    rows = []
    for r in log.itertuples(index=False):
        kw = {"heading_deg": getattr(r, "heading", math.nan)}
        if has_mag:
            kw["mag"] = (r.mag_x, r.mag_y, r.mag_z)
            kw["acc"] = (r.acc_x, r.acc_y, r.acc_z)
        rows += comp.push(r.t, r.gyro_z, r.temp, **kw)
    rows += comp.flush()  # a log shorter than the init window
    out = pd.DataFrame([asdict(s) for s in rows])
    return _without_empty_triad(out)


def assert_same_columns(batch: pd.DataFrame, streamed: pd.DataFrame) -> None:
    """Every column of the streamed table equals the batch one exactly (NaN = NaN)."""
    assert len(batch) == len(streamed)
    for col in streamed.columns:
        a, b = batch[col].to_numpy(), streamed[col].to_numpy()
        if a.dtype == object or b.dtype == object or a.dtype.kind in "OUT" or b.dtype.kind in "OUT":
            assert [str(v) for v in a] == [str(v) for v in b], col
        else:
            assert np.array_equal(a.astype(float), b.astype(float), equal_nan=True), col


def _kind(err: GyroDriftError) -> str:
    """The kind of a user error, for hypothesis' statistics (numbers and file names left out)."""
    text = str(err).split(": ")
    return " ".join(w for w in text[-1].split()[:6] if not any(ch.isdigit() for ch in w))


def tiny_log(n: int = 41, **cells) -> pd.DataFrame:
    """A still 1-Hz log, gyro 0, 25 degC, heading 0; ``cells={"gyro_z": {35: inf}}`` overrides cells."""
    log = pd.DataFrame({"t": np.arange(n, dtype=float), "gyro_z": 0.0, "temp": 25.0, "heading": 0.0})
    for col, values in cells.items():
        for row, value in values.items():
            log.loc[row, col] = value
    return log


# --------------------------------------------------------------------------- readers + compensator


@settings(REPRO, max_examples=150)
@given(messy_logs(), st.sampled_from(["csv", "parquet"]))
def test_messy_files_give_a_clear_error_or_a_finite_table(case, fmt):
    log, _ = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"log.{fmt}"
        write_table(log, path)
        try:
            out = compensate(read_log(path))
        except GyroDriftError as err:
            event(f"error: {_kind(err)}")
            check_error(err)
            return
    event("compensated")
    check_output(out, len(log))


@settings(REPRO, max_examples=150)
@given(messy_logs(), small_configs())
def test_messy_frames_give_a_clear_error_or_a_finite_table(case, cfg):
    log, _ = case
    try:
        out = compensate(log, cfg)
    except GyroDriftError as err:
        event(f"error: {_kind(err)}")
        check_error(err)
        return
    event("compensated")
    check_output(out, len(log))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@settings(REPRO, max_examples=20)
@example(col="temp", row=35, value=math.inf)
@example(col="gyro_z", row=35, value=math.inf)
@given(st.sampled_from(["gyro_z", "temp"]), st.integers(1, 60), st.sampled_from([math.inf, -math.inf]))
def test_infinite_cells_are_held_like_empty_ones(col, row, value):
    log = tiny_log(61, **{col: {row: value}})
    try:
        out = compensate(log)
    except GyroDriftError as err:
        check_error(err)
        return
    check_output(out, len(log))


# --------------------------------------------------------------------------- angles


finite_angles = st.floats(-1e12, 1e12, allow_nan=False, allow_infinity=False)


@settings(REPRO, max_examples=300)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_wrap_ranges(angle):
    w360 = float(wrap_360(angle))
    w180 = float(wrap_180(angle))
    assert 0.0 <= w360 < 360.0
    assert -180.0 <= w180 < 180.0


@settings(REPRO, max_examples=200)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=20))
def test_wrap_ranges_on_arrays(angles):
    w = wrap_360(np.array(angles))
    assert np.all((w >= 0.0) & (w < 360.0))
    w = wrap_180(np.array(angles))
    assert np.all((w >= -180.0) & (w < 180.0))


@settings(REPRO, max_examples=300)
@given(finite_angles)
def test_wrap_keeps_the_angle(angle):
    """wrap_360(x) is x plus a whole number of turns (up to rounding of that sum)."""
    turns = (angle - float(wrap_360(angle))) / 360.0
    assert abs(turns - round(turns)) <= 1e-9 * max(1.0, abs(turns))


# Angles on a 1/64-degree grid: every sum below is exact, so the invariance must be exact too.
grid_angles = st.integers(-(2**24), 2**24).map(lambda k: k / 64.0)


@settings(REPRO, max_examples=300)
@given(grid_angles, grid_angles, st.integers(-1000, 1000))
def test_wrap_180_difference_is_invariant_to_whole_turns_exactly(a, b, k):
    ref = float(wrap_180(a - b))
    assert float(wrap_180((a + 360.0 * k) - b)) == ref
    assert float(wrap_180(a - (b + 360.0 * k))) == ref


@settings(REPRO, max_examples=300)
@given(st.floats(-1e6, 1e6), st.floats(-1e6, 1e6), st.integers(-1000, 1000))
def test_wrap_180_difference_is_invariant_to_whole_turns(a, b, k):
    ref = float(wrap_180(a - b))
    tol = 8 * float(np.spacing(abs(a) + abs(b) + 360.0 * abs(k) + 360.0))
    for shifted in ((a + 360.0 * k) - b, a - (b + 360.0 * k)):
        assert abs(float(wrap_180(float(wrap_180(shifted)) - ref))) <= tol


# --------------------------------------------------------------------------- compass


vec_component = st.integers(-1000, 1000).map(lambda k: k / 1000.0)  # no subnormals: scaling stays exact


@st.composite
def compass_samples(draw):
    """Raw mag (any direction, not near vertical) and a tilted specific force (|f| ~ 1)."""
    mag = np.array([draw(vec_component) for _ in range(3)]) * draw(st.floats(1e-3, 1e3))
    roll, pitch = np.radians(draw(st.floats(-70.0, 70.0))), np.radians(draw(st.floats(-70.0, 70.0)))
    acc = -np.array([-np.sin(pitch), np.sin(roll) * np.cos(pitch), np.cos(roll) * np.cos(pitch)])
    _, dip = field_norm_dip(*mag, *acc)
    if not (np.linalg.norm(mag) > 0 and abs(float(dip)) < 85.0):  # heading undefined near vertical field
        mag = np.array([1.0, 0.3, 0.5])
    return mag, acc


@settings(REPRO, max_examples=300)
@given(compass_samples(), st.integers(-40, 40), st.integers(-40, 40))
def test_heading_is_exactly_invariant_to_power_of_two_scaling(sample, jm, ja):
    mag, acc = sample
    ref = float(tilt_compensated_heading(*mag, *acc))
    assert float(tilt_compensated_heading(*(mag * 2.0**jm), *acc)) == ref
    assert float(tilt_compensated_heading(*mag, *(acc * 2.0**ja))) == ref
    assert 0.0 <= ref < 360.0


@settings(REPRO, max_examples=300)
@given(compass_samples(), st.floats(1e-6, 1e6), st.floats(1e-3, 1e3))
def test_heading_is_invariant_to_mag_and_acc_scale(sample, k_mag, k_acc):
    """Any positive factor (µT vs gauss vs counts; g vs m/s²) leaves the heading unchanged."""
    mag, acc = sample
    ref = float(tilt_compensated_heading(*mag, *acc))
    for m, a in ((mag * k_mag, acc), (mag, acc * k_acc), (mag * k_mag, acc * k_acc)):
        assert abs(float(wrap_180(float(tilt_compensated_heading(*m, *a)) - ref))) < 1e-9


# --------------------------------------------------------------------------- streaming = batch


@settings(REPRO, max_examples=100)
@given(messy_logs(allow_time_faults=False, max_rows=500), small_configs())
def test_streaming_equals_batch(case, cfg):
    log, _ = case
    # what T is, as the batch decides it on the whole log ("auto"), given to the stream
    cfg = replace(cfg, temperature="clock" if uses_clock(cfg, log["temp"].to_numpy(float)) else "measured")
    try:
        batch = compensate(log, cfg)
    except GyroDriftError as err:
        event(f"batch refused: {_kind(err)}")
        return  # batch refuses the log (too short, no compass in the init window, ...)
    event(f"compared, T {cfg.temperature}")
    assert_same_columns(batch, stream(log, cfg))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@settings(REPRO, max_examples=10)
@example(col="gyro_z", row=35)
@given(st.sampled_from(["gyro_z", "temp"]), st.integers(31, 40))
def test_batch_and_streaming_refuse_an_infinite_cell_alike(col, row):
    # an infinite rate or temperature is a corrupt record, refused like an implausible one
    # (gyrodrift.io.limits); an empty cell is what holds the previous value
    log = tiny_log(41, **{col: {row: math.inf}})
    with pytest.raises(GyroDriftError, match=f"row {row}, column '{col}'"):
        compensate(log)
    with pytest.raises(GyroDriftError, match="outside the plausible range"):
        stream(log, None)
    log = tiny_log(41, **{col: {row: math.nan}})
    measured = CompensatorConfig(temperature="measured")  # the stream cannot see that the log's temperature is flat
    assert_same_columns(compensate(log, measured), stream(log, measured))


@settings(REPRO, max_examples=10)
@example(n_before=50, bad_t=math.inf)
@example(n_before=0, bad_t=math.nan)
@given(st.integers(0, 60), st.sampled_from([math.inf, math.nan, -math.inf]))
def test_streaming_rejects_non_finite_time_with_a_clear_error(n_before, bad_t):
    comp = Compensator()
    for i in range(n_before):
        comp.push(float(i), 0.1, 25.0, heading_deg=0.0)
    with pytest.raises(GyroDriftError) as info:
        comp.push(bad_t, 0.1, 25.0, heading_deg=0.0)
    check_error(info.value)
    if n_before:
        comp.push(float(n_before), 0.1, 25.0, heading_deg=0.0)  # still usable after the refusal


# --------------------------------------------------------------------------- filter


def _assert_healthy(P: np.ndarray, cap_var: np.ndarray) -> None:
    assert np.all(np.isfinite(P))
    assert np.abs(P - P.T).max() <= 1e-12 * np.abs(P).max()
    assert np.linalg.eigvalsh(P).min() > 0.0
    scale = np.sqrt(cap_var)
    assert np.linalg.eigvalsh(P / np.outer(scale, scale)).max() <= 1.0 + 1e-9


observation_rows = st.tuples(
    st.floats(-40.0, 85.0),  # T, degC
    st.sampled_from([0.0, 0.0, 1e-4, -2e-3, 0.05]),  # T', degC/s (0: constant temperature)
    st.floats(-5.0, 5.0),  # measurement, deg/s
    st.floats(1e-8, 1e2),  # variance, (deg/s)^2
)


@settings(REPRO, max_examples=150)
@given(
    st.floats(1.0, 3.0),
    st.lists(st.none() | st.lists(observation_rows, min_size=1, max_size=3), min_size=1, max_size=120),
)
def test_stkf_covariance_stays_spd_finite_and_capped(fading, steps):
    cfg = KalmanConfig(fading=fading)
    est = KalmanDrift(cfg)
    cap_var = np.square(np.array(cfg.p0_sd))
    for k, rows in enumerate(steps):
        if rows is None:
            est.hold()
        else:
            H = np.array([[T, Tp, 1.0] for T, Tp, _, _ in rows])
            y = np.array([m for _, _, m, _ in rows])
            R = np.diag([r for _, _, _, r in rows])
            est.update(Observation(t=10.0 * k, y=y, H=H, R=R))
        _assert_healthy(est.cov, cap_var)
        assert np.all(np.isfinite(est.params))


def test_stkf_covariance_is_exactly_symmetric_after_capping():
    est = KalmanDrift(KalmanConfig(fading=1.0))
    est.update(Observation(t=0.0, y=np.array([0.0]), H=np.array([[30.559355232017964, 0.0, 1.0]]),
                           R=np.array([[3.0]])))
    P = est.cov
    assert np.array_equal(P, P.T)

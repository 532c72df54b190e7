"""One front end for every entry point (issue 22, item 1): the batch ``compensate``, the
chunked file path and the streaming ``Compensator`` give the same rows for every front-end
setting (declination, tilt, magnetometer calibration, temperature or clock, x/y axes,
heading or raw magnetometer, profile, prior), paper and model engines alike.

The stream differs where it cannot see the whole log, and each such case says so:
``mag_calibration`` needs the whole log (the stream does not calibrate, and its notes say
so), and ``temperature="auto"`` takes the clock for a log whose temperature never changes,
which a stream learns only from :meth:`Compensator.temperature_absent`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import Compensator, CompensatorConfig, compensate
from gyrodrift.calibrate import AxisFit, Calibration, prior_config
from gyrodrift.pipeline import compensate_file
from gyrodrift.profile import Profile, warm_config
from gyrodrift.simulate import TriadModel, simulate

XY = ["gyro_x", "gyro_y", "true_bias_x", "true_bias_y"]
MAG = ["mag_x", "mag_y", "mag_z"]
ACC = ["acc_x", "acc_y", "acc_z"]
#: Rows per chunk of the file path: not a divisor of anything, and inside the init window.
CHUNK_ROWS = 777


def _vehicle(seconds: float = 200.0, seed: int = 3) -> pd.DataFrame:
    """A vehicle with a raw magnetometer, heading and x/y axes; 20 Hz gyro, 10 Hz compass."""
    return simulate("vehicle", seed=seed, duration_s=seconds, fs_hz=20.0, raw_mag=True, triad=TriadModel())


def _flat() -> pd.DataFrame:
    """A log whose temperature column reads a constant (a sensor without temperature)."""
    return simulate("no-temp", seed=5, duration_s=200.0, fs_hz=20.0)


def _with_holes(log: pd.DataFrame) -> pd.DataFrame:
    """Dead magnetometer samples (zeros), empty gyro and temperature cells and a heading of 359.5."""
    log = log.copy()
    log.loc[1000:1040, MAG] = 0.0
    log.loc[[1500, 2501], "gyro_z"] = math.nan
    log.loc[[1700, 2900], "temp"] = math.nan
    if "heading" in log.columns:
        log.loc[2200:2220:2, "heading"] = 359.5
    return log


_PROFILE = Profile(params=(0.01, 2.0, 0.1), cov=((1e-6, 0, 0), (0, 1e-2, 0), (0, 0, 1e-3)), temp_range_c=(20, 40),
                   samples=1, updates=1, estimator="adaptive", created="", software="")
_PRIOR = Calibration(axes={"z": AxisFit((0.1, 0.002, 0.0, 0.0))}, temp_ref_c=25.0, temp_min_c=10.0, temp_max_c=50.0)
C = CompensatorConfig

#: name: (log, config, what the stream does instead of the batch: None, "no magcal" or "clock unknown").
CASES = {
    "heading": (lambda: _vehicle().drop(columns=XY + MAG + ACC), C(), None),
    "heading, declination": (lambda: _vehicle().drop(columns=XY + MAG + ACC), C(declination_deg=7.0), None),
    "raw magnetometer": (lambda: _vehicle().drop(columns=["heading", *XY]), C(), None),
    "raw magnetometer, declination": (lambda: _vehicle().drop(columns=["heading", *XY]), C(declination_deg=-12.0), None),
    "heading and raw magnetometer": (lambda: _vehicle().drop(columns=XY), C(declination_deg=3.0), None),
    "dead samples and empty cells": (lambda: _with_holes(_vehicle().drop(columns=XY)), C(declination_deg=179.0), None),
    "x/y, accelerometer tilt": (lambda: _vehicle().drop(columns=["heading"]), C(), None),
    "x/y, gyro tilt": (lambda: _vehicle().drop(columns=["heading"]), C(tilt="gyro", declination_deg=5.0), None),
    "gyro tilt without x/y": (lambda: _vehicle().drop(columns=["heading", *XY]), C(tilt="gyro"), None),
    "x/y with a heading": (lambda: _vehicle().drop(columns=MAG), C(), None),
    "magnetometer calibration": (lambda: _vehicle(400.0, seed=4).drop(columns=["heading", *XY]), C(mag_calibration=True),
                                 "no magcal"),
    "clock": (lambda: _vehicle().drop(columns=XY + MAG + ACC), C(temperature="clock"), None),
    "flat temperature, measured": (_flat, C(temperature="measured"), None),
    "flat temperature, auto": (_flat, C(), "clock unknown"),
    "profile": (lambda: _vehicle().drop(columns=XY + MAG + ACC), warm_config(_PROFILE), None),
    "profile, flat temperature": (_flat, warm_config(_PROFILE), None),
    "prior": (lambda: _vehicle().drop(columns=XY + MAG + ACC), prior_config(_PRIOR, C(), 26.0), None),
    "stkf: x/y, gyro tilt, declination": (lambda: _vehicle().drop(columns=["heading"]),
                                          C(estimator="stkf", tilt="gyro", declination_deg=5.0), None),
    "stkf: dead samples and empty cells": (lambda: _with_holes(_vehicle().drop(columns=XY)),
                                           C(estimator="stkf", declination_deg=-30.0), None),
    "stkf: flat temperature, auto": (_flat, C(estimator="stkf"), "clock unknown"),
    "lsm: raw magnetometer, declination": (lambda: _vehicle().drop(columns=["heading", *XY]),
                                           C(estimator="lsm", declination_deg=7.0), None),
}


def _pushed(log: pd.DataFrame, cfg: CompensatorConfig, *, temperature_absent: bool = False,
            provisional: bool = False) -> tuple[pd.DataFrame, Compensator]:
    """The rows of a :class:`Compensator` fed ``log`` row by row, with the columns it has."""
    comp = Compensator(cfg, source="log", provisional=provisional)
    if temperature_absent:
        comp.temperature_absent()
    has = set(log.columns)
    rows = []
    for r in log.itertuples(index=False):
        kw = {}
        if "heading" in has:
            kw["heading_deg"] = r.heading
        if "mag_x" in has:
            kw["mag"] = (r.mag_x, r.mag_y, r.mag_z)
        if "acc_x" in has:
            kw["acc"] = (r.acc_x, r.acc_y, r.acc_z)
        if "gyro_x" in has:
            kw["gyro_x_dps"], kw["gyro_y_dps"] = r.gyro_x, r.gyro_y
        rows += comp.push(r.t, r.gyro_z, r.temp, **kw)
    rows += comp.flush()
    return pd.DataFrame([dataclasses.asdict(r) for r in rows]), comp


def _differences(expected: pd.DataFrame, got: pd.DataFrame) -> list[str]:
    """The columns of ``got`` (also in ``expected``) whose values are not identical."""
    bad = []
    assert len(expected) == len(got)
    for c in got.columns.intersection(expected.columns):
        x, y = expected[c], got[c]
        if x.dtype.kind in "fiub" and y.dtype.kind in "fiub":
            same = np.array_equal(x.to_numpy(float), y.to_numpy(float), equal_nan=True)
        else:
            same = list(x.astype(str)) == list(y.astype(str))
        if not same:
            bad.append(c)
    return bad


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Every case through the three entry points, once: batch, in-memory file, chunked file, stream."""
    done = {}

    def run(name: str):
        if name not in done:
            make, cfg, _ = CASES[name]
            log = make().reset_index(drop=True)
            path = tmp_path_factory.mktemp("front") / "in.parquet"
            log.to_parquet(path)
            whole = compensate_file(path, path.with_name("whole.parquet"), cfg, chunked=False)
            parts = compensate_file(path, path.with_name("parts.parquet"), cfg, chunked=True, chunk_rows=CHUNK_ROWS)
            done[name] = dict(log=log, cfg=cfg, batch=compensate(log, cfg), whole_stats=whole, parts_stats=parts,
                              whole=pd.read_parquet(path.with_name("whole.parquet")),
                              parts=pd.read_parquet(path.with_name("parts.parquet")), stream=_pushed(log, cfg))
        return done[name]

    return run


@pytest.mark.parametrize("name", list(CASES))
def test_batch_equals_chunked_file(runs, name):
    r = runs(name)
    assert list(r["whole"].columns) == list(r["parts"].columns)
    assert _differences(r["batch"], r["whole"]) == []
    assert _differences(r["whole"], r["parts"]) == []
    assert r["parts_stats"].notes == r["whole_stats"].notes
    assert np.array_equal(r["parts_stats"].final_params, r["whole_stats"].final_params)
    assert r["parts_stats"].regressor == r["whole_stats"].regressor


@pytest.mark.parametrize("name", list(CASES))
def test_batch_equals_stream(runs, name):
    r = runs(name)
    log, cfg, batch, (stream, comp) = r["log"], r["cfg"], r["batch"], r["stream"]
    instead = CASES[name][2]
    if instead is None:
        assert _differences(batch, stream) == []
        assert comp.notes == batch.attrs["notes"]
        assert np.array_equal(comp.params, batch.attrs["final_params"])
    elif instead == "no magcal":  # the fit needs the whole log: the stream is the batch without it, and says so
        assert any("magnetometer calibrated" in n for n in batch.attrs["notes"])
        uncalibrated = compensate(log, dataclasses.replace(cfg, mag_calibration=False))
        assert _differences(uncalibrated, stream) == []
        assert _differences(batch, stream) != []
        assert any("not calibrated" in n and "stream" in n for n in comp.notes), comp.notes
    else:  # "clock unknown": a stream takes the column until it is told there is no temperature
        assert batch.attrs["drift_regressor"] == "clock" and comp.regressor == "temperature"
        told, told_comp = _pushed(log, cfg, temperature_absent=True)
        assert _differences(batch, told) == []
        assert told_comp.notes == batch.attrs["notes"]


@pytest.mark.parametrize("name", ["x/y, gyro tilt", "dead samples and empty cells", "stkf: x/y, gyro tilt, declination"])
def test_provisional_stream_rows_equal_the_batch_after_the_init_window(runs, name):
    r = runs(name)
    stream, _ = _pushed(r["log"], r["cfg"], provisional=True)
    after = r["batch"]["t"] > r["batch"]["t"].iloc[0] + r["cfg"].init_s
    assert after.any()
    assert _differences(r["batch"][after].reset_index(drop=True), stream[after].reset_index(drop=True)) == []


@pytest.mark.parametrize("estimator", ["adaptive", "stkf"])
def test_declination_is_added_to_the_streamed_compass_after_the_init_window(estimator):
    log = synthetic_log(duration_s=120.0, fs_hz=10.0, heading_deg=lambda t: np.full_like(t, 90.0))
    cfg = CompensatorConfig(declination_deg=7.0, estimator=estimator)
    batch, (stream, _) = compensate(log, cfg), _pushed(log, cfg)
    assert np.nanmax(np.abs(batch["compass_heading"] - 97.0)) < 1e-9
    np.testing.assert_array_equal(stream["compass_heading"], batch["compass_heading"])
    np.testing.assert_array_equal(stream["heading_fused"], batch["heading_fused"])
    assert (stream["gate_reason"] == batch["gate_reason"]).all()


def test_a_file_is_read_once_before_its_pass_and_the_engine_built_once(tmp_path, monkeypatch):
    """The calibration and the flat-temperature check share one reading of the file; the
    engine is built once the clock is decided."""
    import gyrodrift.io.chunked as chunked
    from gyrodrift.compensator.model_engine import ModelEngine

    calls = {"read": 0, "engine": 0}
    read, init = chunked.iter_log_chunks, ModelEngine.__init__

    def counted_read(*args, **kwargs):
        calls["read"] += 1
        return read(*args, **kwargs)

    def counted_init(*args, **kwargs):
        calls["engine"] += 1
        init(*args, **kwargs)

    monkeypatch.setattr(chunked, "iter_log_chunks", counted_read)
    monkeypatch.setattr(ModelEngine, "__init__", counted_init)
    log = simulate("no-temp", seed=5, duration_s=200.0, fs_hz=20.0, raw_mag=True).drop(columns="heading")
    log.to_parquet(tmp_path / "in.parquet")
    stats = compensate_file(tmp_path / "in.parquet", tmp_path / "out.parquet", C(mag_calibration=True), chunked=True,
                            chunk_rows=CHUNK_ROWS)
    assert calls == {"read": 2, "engine": 1}
    assert stats.regressor == "clock" and any("magnetometer" in n and "calibrated" in n for n in stats.notes)

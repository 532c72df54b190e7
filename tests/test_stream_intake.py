"""The streaming path through the Intake (issue 22): the gyro-unit check and the time base
of a file, and the init window taken row by row, with the same results as the file path.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import Compensator
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.compensator.config import build_estimator
from gyrodrift.compensator.model_engine import make_engine
from gyrodrift.errors import GyroDriftError
from gyrodrift.io import read_log
from gyrodrift.stream import stream_rows

UNIT_NOTE = "times less than the compass"


def _turning_log(rad: bool) -> pd.DataFrame:
    """A vehicle turning +-90 deg every 2 minutes for 10 minutes at 10 Hz (6,000 rows: more
    than the Intake's UNIT_ROWS), its gyro in rad/s when ``rad``, else deg/s."""
    t = np.arange(0.0, 600.0, 0.1)
    true = 90.0 * np.sin(2 * np.pi * t / 120.0)
    rate = np.gradient(true, t) + 0.1
    return pd.DataFrame({"t": t, "gyro_z": np.radians(rate) if rad else rate, "temp": 30.0,
                         "heading": np.where(np.arange(t.size) % 5 == 0, np.mod(100.0 + true, 360.0), np.nan)})


def _unit_notes(notes) -> list[str]:
    """The gyro-unit notes, without the name of the source that starts them."""
    return [n.split(": ", 1)[1] for n in notes if "gyro_z" in n and "compass" in n]


def _pushed(log: pd.DataFrame, **kwargs) -> Compensator:
    comp = Compensator(**kwargs)
    for r in log.itertuples(index=False):
        comp.push(float(r.t), float(r.gyro_z), float(r.temp), heading_deg=float(r.heading))
    comp.flush()
    return comp


@pytest.mark.parametrize("unit", [None, "rad/s"])
def test_a_gyro_in_rad_per_s_read_as_deg_per_s_gets_the_files_note_in_every_stream(tmp_path, unit):
    log = _turning_log(rad=True)
    path = tmp_path / "rad.csv"
    log.to_csv(path, index=False)
    file_notes = _unit_notes(compensate(read_log(path)).attrs["notes"])
    assert len(file_notes) == 1 and UNIT_NOTE in file_notes[0]
    assert _unit_notes(_pushed(log).notes) == file_notes
    stats = stream_rows([path.read_text()], lambda text: None)
    assert _unit_notes(stats.notes) == file_notes
    if unit:  # read in the unit it was logged in: no note anywhere
        assert not _unit_notes(compensate(read_log(path, gyro_unit=unit)).attrs["notes"])
        assert not _unit_notes(stream_rows([path.read_text()], lambda text: None, gyro_unit=unit).notes)


def test_the_stream_unit_note_advises_for_the_unit_it_was_read_in(tmp_path):
    """rad/s read as rad/s: the gyro then turns 57.3 times more than the compass."""
    log = _turning_log(rad=False)
    path = tmp_path / "deg.csv"
    log.to_csv(path, index=False)
    file_notes = _unit_notes(compensate(read_log(path, gyro_unit="rad/s")).attrs["notes"])
    assert len(file_notes) == 1 and "drop --gyro-unit rad/s" in file_notes[0]
    stats = stream_rows([path.read_text()], lambda text: None, gyro_unit="rad/s")
    assert _unit_notes(stats.notes) == file_notes
    converted = log.assign(gyro_z=np.degrees(log["gyro_z"]))  # what the reader gives the compensator
    assert _unit_notes(_pushed(converted, gyro_unit="rad/s").notes) == file_notes


def test_a_right_unit_gets_no_note_in_a_stream():
    assert not _unit_notes(_pushed(_turning_log(rad=False)).notes)


def test_a_low_rate_is_one_note_of_a_stream(tmp_path):
    """One judge of the time base (the compensator's front end), so one note."""
    log = pd.DataFrame({"t": np.arange(60) * 2.5, "gyro_z": 0.1, "temp": 25.0, "heading": 10.0})
    warnings: list[str] = []
    stats = stream_rows([log.to_csv(index=False)], lambda text: None, warn=warnings.append)
    assert sum("below 1 Hz" in n for n in stats.notes) == 1
    assert sum("below 1 Hz" in w for w in warnings) == 1


def test_a_stream_refuses_a_time_base_naming_the_line():
    text = pd.DataFrame({"t": np.arange(60) * 10, "gyro_z": 0.1, "temp": 25.0}).to_csv(index=False)
    out: list[str] = []
    with pytest.raises(GyroDriftError, match=r"line 10, column 't'.*--time-unit ms"):
        stream_rows([text], out.append)
    assert "".join(out).count("\n") == 1 + 8  # the header and the rows before the ninth sample's line


def test_judge_times_as_comes_before_the_first_sample():
    comp = Compensator()
    comp.push(0.0, 0.1, 25.0)
    with pytest.raises(GyroDriftError, match="before the first sample"):
        comp.judge_times_as("ms")


@pytest.mark.parametrize("estimator", ["adaptive", "stkf"])
@pytest.mark.parametrize("rows", [1, 150, 601])
def test_window_rows_then_a_chunk_give_the_whole_logs_bits(estimator, rows):
    """The first ``rows`` rows one by one (``window_row``; the 601st completes the 30-s window at
    20 Hz, with held cells and a wrapped compass in it), the rest as one chunk: the outputs of
    the whole log in one chunk, bit for bit."""
    log = synthetic_log(duration_s=120.0, fs_hz=20.0)
    t, g, T, h = (log[k].to_numpy(float).copy() for k in ("t", "gyro_z", "temp", "heading"))
    g[[5, 90]] = np.nan
    T[40] = np.nan
    h[[3, 200]] = [365.0, -10.0]
    cfg = CompensatorConfig(estimator=estimator, declination_deg=7.0)

    def engine():
        return make_engine(cfg, build_estimator(cfg), record=False)

    whole = engine().feed(t, g, T, h)
    parts, split = engine(), []
    for i in range(rows):
        cols = parts.window_row(float(t[i]), float(g[i]), float(T[i]), float(h[i]))
        if cols is not None:
            split.append(cols)
    split.append(parts.feed(t[rows:], g[rows:], T[rows:], h[rows:]))
    assert sum(len(c["t"]) for c in split) == len(t)
    for name, column in whole.items():
        joined = np.concatenate([c[name] for c in split])
        np.testing.assert_array_equal(joined, column, err_msg=name)


@pytest.mark.parametrize("reason, unobs", [(0, 0), (3, 1)])
def test_a_streamed_sample_is_the_dataclass_made_from_its_values(reason, unobs):
    """The sample push makes without ``__init__``: the same fields, ``==``, ``repr`` and
    ``asdict`` as ``CompensatedSample(*values)``, the x/y fields at their defaults."""
    from dataclasses import asdict

    from gyrodrift.compensator.output import CompensatedSample
    from gyrodrift.compensator.streaming import _new_sample
    from gyrodrift.kernels import layout as L

    out = [0.5 + k for k in range(L.N_OUT)]
    codes = [0] * L.N_CODES
    codes[L.OC_REASON], codes[L.OC_UNOBS], codes[L.OC_UPDATE] = reason, unobs, 1
    made = _new_sample(12.5, out, codes, 91.0)
    built = CompensatedSample(*Compensator._values(12.5, out, codes, 91.0))
    assert made == built and repr(made) == repr(built) and asdict(made) == asdict(built)
    assert list(vars(made)) == [f for f in asdict(built)][:17] and math.isnan(made.rate_x) and made.tilt_gated == 0

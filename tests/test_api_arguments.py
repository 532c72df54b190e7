"""The Python API's arguments (issue 24, items 2 and 9): checked before any compiled code runs.

``compensate_arrays`` given arrays of unequal lengths used to compute the rows past the
shortest one from memory beyond it (the compiled kernels do not check bounds); wrong
kinds of arguments ended in AttributeError or ValueError deep inside. Each is now one
:class:`~gyrodrift.errors.GyroDriftError` saying what is expected (an
:class:`~gyrodrift.errors.ArgumentTypeError`, also a TypeError, for a wrong kind).

The hypothesis property at the end feeds ``compensate_arrays`` random arrays: it raises
a GyroDriftError or returns one finite row per sample. The slow suite runs it again
with numba's bounds checks on (``NUMBA_BOUNDSCHECK=1``), where a read past an input
is an IndexError.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import synthetic_log
from gyrodrift import Compensator, compensate, compensate_arrays, errors
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import GyroDriftError, LogFormatError

ROOT = Path(__file__).resolve().parents[1]
SHORT = CompensatorConfig(init_s=0.5, update_interval_s=0.5)
#: Examples of the property: a few in the default suite, more in the slow run.
PROPERTY_EXAMPLES = int(os.environ.get("GYRODRIFT_PROPERTY_EXAMPLES", "40"))


@pytest.fixture(scope="module")
def log() -> pd.DataFrame:
    return synthetic_log(duration_s=60.0, fs_hz=10.0)


# --------------------------------------------------------------------------- item 2: lengths and shapes


@pytest.mark.parametrize("short", ["t_s", "gyro_z_dps", "temp_c", "heading_deg"])
def test_arrays_of_unequal_length_are_refused(log, short):
    args = {"t_s": log["t"], "gyro_z_dps": log["gyro_z"], "temp_c": log["temp"], "heading_deg": log["heading"]}
    args[short] = args[short].to_numpy()[:-7]
    with pytest.raises(LogFormatError, match=r"has \d+ values but t_s has \d+|gyro_z_dps has \d+ values") as info:
        compensate_arrays(**args, config=SHORT)
    assert "\n" not in str(info.value) and "one value per sample" in str(info.value)


@pytest.mark.parametrize("name, value, expected", [
    ("mag", np.zeros((5, 3)), "shape"),
    ("acc", np.zeros((600, 2)), "shape"),
    ("gyro_xy", np.zeros(600), "shape"),
])
def test_rows_of_the_wrong_shape_are_refused(log, name, value, expected):
    n = len(log)
    args = {"mag": np.tile([20.0, 0.0, 40.0], (n, 1)), "acc": np.tile([0.0, 0.0, -1.0], (n, 1)), name: value}
    with pytest.raises(LogFormatError, match=expected):
        compensate_arrays(log["t"], log["gyro_z"], log["temp"], config=SHORT, **args)


@pytest.mark.parametrize("t", [None, "abc", ["a", "b"], np.zeros((3, 2)), {"t": 1}, np.array([1 + 1j, 2j])])
def test_time_that_is_not_an_array_of_numbers_is_refused(t):
    with pytest.raises(GyroDriftError) as info:
        compensate_arrays(t, [0.1, 0.1], [25.0, 25.0])
    assert "t_s" in str(info.value)


def test_the_rows_computed_do_not_depend_on_memory_past_the_inputs(log):
    """Views ending inside a larger buffer give what compact copies give: nothing past
    the last sample is read (the buffer's tail is garbage)."""
    n = len(log)
    cols = [log["t"].to_numpy(), log["gyro_z"].to_numpy(), log["temp"].to_numpy(), log["heading"].to_numpy()]
    views = []
    for col, junk in zip(cols, (1e300, -1e300, np.nan, 1e300)):
        buf = np.full(n + 100, junk)
        buf[:n] = col
        views.append(buf[:n])
    a = compensate_arrays(*views[:3], heading_deg=views[3], config=SHORT)
    b = compensate_arrays(*(c.copy() for c in cols[:3]), heading_deg=cols[3].copy(), config=SHORT)
    pd.testing.assert_frame_equal(a, b)


# --------------------------------------------------------------------------- item 9: kinds of argument


@pytest.mark.parametrize("make, words", [
    (lambda log: None, "pandas DataFrame"),
    (lambda log: log.to_dict("list"), "pandas DataFrame"),
    (lambda log: log.to_records(index=False), "pandas DataFrame"),
    (lambda log: log.to_numpy(), "pandas DataFrame"),
])
def test_compensate_wants_a_dataframe(log, make, words):
    with pytest.raises(errors.ArgumentTypeError, match=words) as info:
        compensate(make(log))
    assert isinstance(info.value, TypeError) and "\n" not in str(info.value)


def test_a_column_given_twice_is_refused(log):
    with pytest.raises(LogFormatError, match="column 'gyro_z' is given 2 times"):
        compensate(pd.concat([log, log[["gyro_z"]]], axis=1))


def test_a_number_column_of_text_is_refused_naming_it(log):
    with pytest.raises(LogFormatError, match="column 'temp' holds values that are not numbers, e.g. 'hot'"):
        compensate(log.assign(temp="hot"))


@pytest.mark.parametrize("kwargs, words", [
    ({"config": "string"}, "config must be a CompensatorConfig"),
    ({"config": {"init_s": 10}}, "config must be a CompensatorConfig"),
    ({"estimator": object()}, "estimator must be a drift estimator instance"),
    ({"estimator": "adaptive"}, "estimator must be a drift estimator instance"),
    ({"source": 3}, "source must be a str"),
    ({"progress": 5}, "progress must be a callable"),
])
def test_wrong_kinds_of_settings_are_one_type_error(log, kwargs, words):
    with pytest.raises(errors.ArgumentTypeError, match=words):
        compensate(log, **kwargs)
    with pytest.raises(errors.ArgumentTypeError, match=words):
        compensate_arrays(log["t"], log["gyro_z"], log["temp"], **kwargs)


@pytest.mark.parametrize("kwargs", [{"config": "x"}, {"estimator": object()}, {"source": None}])
def test_compensator_checks_its_arguments_when_made(kwargs):
    config = kwargs.pop("config", None)
    with pytest.raises(errors.ArgumentTypeError):
        Compensator(config, **kwargs)


def test_array_likes_of_numbers_are_taken(log):
    """Lists, object arrays and nullable float columns are numbers too."""
    got = compensate_arrays(list(log["t"]), pd.array(log["gyro_z"], dtype="Float64"), log["temp"].astype(object),
                            config=SHORT)
    ref = compensate_arrays(log["t"], log["gyro_z"], log["temp"], config=SHORT)
    pd.testing.assert_frame_equal(got, ref)


# --------------------------------------------------------------------------- the property

_anything = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                      st.sampled_from([0.0, 1e308, -1e308, 5e-324, 1e16, math.nan]))
#: Plausible values per argument (NaN: no value), so that most examples reach the engine.
_plausible = {"gyro_z_dps": st.floats(-50.0, 50.0), "temp_c": st.floats(-40.0, 120.0),
              "heading_deg": st.one_of(st.floats(0.0, 360.0), st.just(math.nan)),
              "mag": st.one_of(st.floats(-60.0, 60.0), st.just(0.0))}


@st.composite
def array_sets(draw):
    """Random arrays for compensate_arrays: lengths that mostly agree, values mostly plausible."""
    n = draw(st.integers(0, 40))

    def values(name: str, size: int) -> np.ndarray:
        kind = _anything if name not in _plausible or not draw(st.integers(0, 7)) else _plausible[name]
        return np.asarray(draw(st.lists(kind, min_size=size, max_size=size)), dtype=float)

    def length() -> int:
        return n if draw(st.integers(0, 15)) else max(0, n + draw(st.integers(-3, 3)))

    k = length()
    if draw(st.integers(0, 3)):  # increasing times: deeper into the engine
        t = np.cumsum(draw(st.lists(st.floats(0.01, 0.5), min_size=k, max_size=k)))
    else:
        t = values("t_s", k)
    arrays = {"t_s": np.asarray(t, dtype=float)}
    for name in ("gyro_z_dps", "temp_c", "heading_deg"):
        arrays[name] = values(name, length())
    if draw(st.booleans()):
        k = length()
        arrays["mag"] = values("mag", 3 * k).reshape(k, 3)
        arrays["acc"] = np.tile([0.0, 0.0, -1.0], (k, 1))
    return arrays


@settings(max_examples=PROPERTY_EXAMPLES, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(array_sets())
def test_compensate_arrays_raises_its_own_error_or_returns_finite_rows(arrays):
    try:
        out = compensate_arrays(**arrays, config=SHORT)
    except GyroDriftError as err:
        assert "\n" not in str(err)
        event("refused")
        return
    event("compensated")
    assert len(out) == arrays["t_s"].size
    for col in ("rate_z", "bias_z", "heading", "bias_sd"):
        assert np.isfinite(out[col].to_numpy()).all(), col
    assert ((out["heading"] >= 0) & (out["heading"] < 360)).all()


@pytest.mark.slow
def test_the_property_under_numba_bounds_checks(tmp_path):
    """The property again in a fresh process with ``NUMBA_BOUNDSCHECK=1`` (and its own
    numba cache, so that the kernels are compiled with the checks): an index past an
    input array raises IndexError there, which the property does not accept."""
    env = {**os.environ, "NUMBA_BOUNDSCHECK": "1", "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "GYRODRIFT_PROPERTY_EXAMPLES": "300"}
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "not slow",
         f"{Path(__file__)}::test_compensate_arrays_raises_its_own_error_or_returns_finite_rows",
         f"{Path(__file__)}::test_the_rows_computed_do_not_depend_on_memory_past_the_inputs"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=3600,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "2 passed" in proc.stdout

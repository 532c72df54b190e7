"""Fuzzing the entry points (issue 16): only the package's own errors escape, and what is
accepted comes out in range.

Each test runs :data:`FUZZ_EXAMPLES` hypothesis examples (60 by default, the file in well
under a minute; ``GYRODRIFT_FUZZ_EXAMPLES=2000`` for the long run of
``benchmarks/fuzz_long.py``). Properties:

* the CSV reader (:func:`gyrodrift.io.read_log`) and :func:`gyrodrift.compensate` on what it
  reads, the streaming :meth:`gyrodrift.Compensator.push`, the profile loader and the
  settings-file loader raise nothing but :class:`~gyrodrift.errors.GyroDriftError`;
* every row that comes out has ``heading`` in [0, 360), ``heading_fused`` in [0, 360)
  (NaN before the first compass sample, :mod:`gyrodrift.fusion`), and finite ``rate_z``,
  ``bias_z`` and ``bias_sd``.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyrodrift import Compensator, compensate
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.config import load_config
from gyrodrift.errors import GyroDriftError
from gyrodrift.io import read_log
from gyrodrift.profile import load_profile

#: Examples per entry point: bounded in CI, more for the long run.
FUZZ_EXAMPLES = int(os.environ.get("GYRODRIFT_FUZZ_EXAMPLES", "60"))
FUZZ = settings(
    max_examples=FUZZ_EXAMPLES,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
)
#: Short windows so that small examples get past the initialisation.
SHORT = CompensatorConfig(init_s=0.5, update_interval_s=0.5)

_numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-1e4, 1e4),
    st.integers(-(10**30), 10**30),
    st.sampled_from([0.0, -0.0, 1e16, -5e38, 1e308, 5e-324, 359.9999999999, 360.0, -60.0, 150.0, 150.1]),
)
_anything = st.one_of(_numbers, st.none(), st.text(max_size=8), st.booleans(), st.lists(_numbers, max_size=4))


def _check_row(heading: float, fused: float, rate: float, bias: float, bias_sd: float) -> None:
    assert 0.0 <= heading < 360.0, heading
    assert math.isnan(fused) or 0.0 <= fused < 360.0, fused  # NaN before the first compass sample
    assert math.isfinite(rate) and math.isfinite(bias) and math.isfinite(bias_sd), (rate, bias, bias_sd)


def _check_output(out) -> None:
    for row in zip(*(out[c].to_numpy() for c in ("heading", "heading_fused", "rate_z", "bias_z", "bias_sd"))):
        _check_row(*row)


# --------------------------------------------------------------------------- CSV reader


def _cell(draw) -> str:
    kind = draw(st.integers(0, 4))
    if kind == 0:
        return ""
    if kind == 1:
        return repr(draw(_numbers))
    if kind == 2:
        return draw(st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=6))
    return repr(draw(st.floats(-400.0, 400.0)))


@st.composite
def csv_logs(draw) -> bytes:
    columns = draw(st.lists(st.sampled_from(["t", "gyro_z", "temp", "heading", "gyro_x", "gyro_y", "mag_x", "mag_y",
                                             "mag_z", "acc_x", "acc_y", "acc_z", "note"]),
                            min_size=1, max_size=8, unique=True))
    rows = []
    n = draw(st.integers(0, 30))
    for i in range(n):
        cells = []
        for col in columns:
            if col == "t" and draw(st.booleans()):
                cells.append(repr(i * 0.1))
            elif col == "temp" and draw(st.booleans()):
                cells.append("25.0")
            else:
                cells.append(_cell(draw))
        rows.append(",".join(c.replace(",", ";").replace("\n", " ").replace("\r", " ") for c in cells))
    text = ",".join(columns) + "\n" + "\n".join(rows) + "\n"
    data = text.encode("utf-8")
    if draw(st.booleans()):
        cut = draw(st.integers(0, len(data)))
        data = data[:cut] + draw(st.binary(max_size=8)) + data[cut:]
    return data


@FUZZ
@given(csv_logs())
def test_csv_reader_and_compensate_raise_only_their_own_errors(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.csv"
        path.write_bytes(data)
        try:
            log = read_log(path)
        except GyroDriftError as err:
            assert "\n" not in str(err)
            return
        if "heading" in log.columns:
            h = log["heading"].to_numpy()
            assert np.all(np.isnan(h) | ((h >= 0.0) & (h < 360.0)))
        try:
            out = compensate(log, SHORT)
        except GyroDriftError as err:
            assert "\n" not in str(err)
            return
        _check_output(out)


@FUZZ
@given(csv_logs())
def test_structured_csv_logs_with_valid_columns_compensate_in_range(data):
    """As above, with a valid time and temperature more often (deeper into compensate)."""
    text = data.decode("utf-8", errors="replace")
    header, _, body = text.partition("\n")
    if "t" not in header.split(","):
        header, body = "t," + header, "\n".join(f"{i * 0.1!r},{line}" for i, line in enumerate(body.splitlines()))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.csv"
        path.write_text(header + "\n" + body + "\n", encoding="utf-8")
        try:
            out = compensate(read_log(path), SHORT)
        except GyroDriftError:
            return
        _check_output(out)


# --------------------------------------------------------------------------- streaming


@FUZZ
@given(st.lists(st.tuples(_anything, _anything, _anything, _anything, st.one_of(st.none(), _anything),
                          st.one_of(st.none(), _anything), st.one_of(st.none(), _anything)),
                min_size=1, max_size=40))
def test_push_raises_only_its_own_errors_and_rows_stay_in_range(samples):
    comp = Compensator(SHORT)
    rows = []
    for i, (gyro, temp, heading, mag, acc, gx, t_jitter) in enumerate(samples):
        t = i * 0.1 if not isinstance(t_jitter, float) or not math.isfinite(t_jitter) else t_jitter
        try:
            rows += comp.push(t, gyro, temp, heading_deg=heading, mag=mag, acc=acc, gyro_x_dps=gx, gyro_y_dps=gx)
        except GyroDriftError as err:
            assert "\n" not in str(err)
    try:
        rows += comp.flush()
    except GyroDriftError as err:  # a single sample cannot be compensated
        assert "single sample" in str(err)
    for r in rows:
        _check_row(r.heading, r.heading_fused, r.rate_z, r.bias_z, r.bias_sd)


@FUZZ
@given(st.lists(st.tuples(st.floats(-2e4, 2e4), st.floats(-100.0, 200.0), st.floats(-2e6, 2e6)), min_size=1,
                max_size=60))
def test_push_of_plain_numbers_gives_rows_in_range(samples):
    comp = Compensator(SHORT)
    rows = []
    for i, (gyro, temp, heading) in enumerate(samples):
        try:
            rows += comp.push(i * 0.1, gyro, temp, heading_deg=heading)
        except GyroDriftError:
            pass
    try:
        rows += comp.flush()
    except GyroDriftError as err:  # a single sample cannot be compensated
        assert "single sample" in str(err)
    for r in rows:
        _check_row(r.heading, r.heading_fused, r.rate_z, r.bias_z, r.bias_sd)


# --------------------------------------------------------------------------- profile and settings loaders

_json = st.recursive(
    st.one_of(st.none(), st.booleans(), st.floats(), st.integers(), st.text(max_size=10)),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=12), inner, max_size=6)),
    max_leaves=20,
)
_profile_keys = st.sampled_from(["format", "version", "software", "created", "estimator", "params", "cov",
                                 "temp_range_c", "samples", "updates", "a_dps_per_c", "b_deg", "c_dps"])


@FUZZ
@given(st.one_of(st.binary(max_size=300), _json.map(lambda v: json.dumps(v).encode()),
                 st.dictionaries(_profile_keys, _json, max_size=10).map(lambda v: json.dumps(v).encode())))
def test_profile_loader_raises_only_config_errors(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "dev.json"
        path.write_bytes(data)
        try:
            load_profile(path)
        except GyroDriftError as err:
            assert "\n" not in str(err)


_toml_keys = st.sampled_from(["init_s", "update_interval_s", "estimator", "stack_depth", "[kalman]", "x0", "p0_sd",
                              "q_sd", "fading", "[gate]", "[fusion]", "[adaptive]", "max_gap_s"])


@st.composite
def toml_texts(draw) -> bytes:
    lines = []
    for _ in range(draw(st.integers(0, 6))):
        key = draw(_toml_keys)
        if key.startswith("["):
            lines.append(key)
            continue
        value = draw(st.one_of(st.floats().map(repr), st.integers().map(str), st.text(max_size=6).map(json.dumps),
                               st.lists(st.floats(), max_size=4).map(lambda v: "[" + ", ".join(map(repr, v)) + "]"),
                               st.sampled_from(["true", "nan", "inf", "1e308", "[1, [2]]", "{a = 1}"])))
        lines.append(f"{key} = {value}")
    data = "\n".join(lines).encode("utf-8")
    return data if draw(st.booleans()) else data + draw(st.binary(max_size=20))


@FUZZ
@given(st.one_of(toml_texts(), st.binary(max_size=200)))
def test_settings_loader_raises_only_config_errors(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "s.toml"
        path.write_bytes(data)
        try:
            load_config(path)
        except GyroDriftError as err:
            assert "\n" not in str(err)

"""Figures of gyrodrift.evaluate.plots on short simulated logs: structure, labels, shading, decimation."""

from __future__ import annotations

import base64
import os
import sys

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("matplotlib")

from matplotlib.figure import Figure  # noqa: E402

from gyrodrift.evaluate import plotbase, plots  # noqa: E402
from gyrodrift.evaluate.allan import allan_deviation, noise_terms  # noqa: E402
from gyrodrift.evaluate.compare import run_methods  # noqa: E402
from gyrodrift.errors import ConfigError, LogFormatError  # noqa: E402
from gyrodrift.simulate import simulate  # noqa: E402

METHODS = ("stkf", "kf", "mlr", "oracle")


def _run(scenario: str):
    log = simulate(scenario, duration_s=900, fs_hz=10, seed=1)
    outputs, skipped = run_methods(log, methods=METHODS)
    assert not skipped
    return outputs


@pytest.fixture(scope="module")
def static_outputs():
    return _run("static-outages")


@pytest.fixture(scope="module")
def vehicle_outputs():
    return _run("vehicle")


def labels(ax) -> list[str]:
    return [ln.get_label() for ln in ax.get_lines() if not ln.get_label().startswith("_")]


def legend_texts(ax) -> list[str]:
    leg = ax.get_legend()
    return [t.get_text() for t in leg.get_texts()] if leg else []


def test_fig_temperature(static_outputs):
    fig = plots.fig_temperature(static_outputs["stkf"])
    assert isinstance(fig, Figure)
    ax_t, ax_r = fig.axes
    assert "degC" in ax_t.get_ylabel() and "degC/s" in ax_r.get_ylabel()
    assert ax_r.get_xlabel() == "time from start (min)"  # 900 s > 10 min
    assert labels(ax_t) == ["temp"] and labels(ax_r) == ["T'"]
    x = ax_t.get_lines()[0].get_xdata()
    assert x[0] == 0.0 and x[-1] == pytest.approx(15.0)


def test_fig_temperature_of_an_input_log_computes_the_rate():
    log = simulate("static", duration_s=300, fs_hz=10, seed=2)
    fig = plots.fig_temperature(log)
    rate = fig.axes[1].get_lines()[0].get_ydata()
    assert np.isfinite(rate).all() and np.abs(rate).max() > 0


def test_fig_rates(static_outputs):
    fig = plots.fig_rates(static_outputs["stkf"], method="stkf")
    (ax,) = fig.axes
    assert labels(ax) == ["raw gyro_z", "compensated rate_z (stkf)"]
    assert ax.get_ylabel() == "angular rate (deg/s)"
    assert all(len(ln.get_xdata()) == 9001 for ln in ax.get_lines())  # short log: not decimated


def test_fig_bias_draws_truth_and_every_method_but_the_oracle(static_outputs):
    fig = plots.fig_bias(static_outputs)
    (ax,) = fig.axes
    assert labels(ax) == ["raw gyro_z", "true drift (true_bias_z)", "stkf bias_z", "kf bias_z", "mlr bias_z"]
    assert "deg/s" in ax.get_ylabel()
    lo, hi = ax.get_ylim()
    truth = static_outputs["stkf"]["true_bias_z"]
    assert lo <= truth.min() and hi >= truth.max()


def test_fig_bias_without_truth(vehicle_outputs):
    outs = {k: v.drop(columns="true_bias_z") for k, v in vehicle_outputs.items() if k != "oracle"}
    ax = plots.fig_bias(outs).axes[0]
    assert labels(ax) == ["raw gyro_z", "stkf bias_z", "kf bias_z", "mlr bias_z"]
    # the moving log's turns (~20 deg/s) do not set the y range
    assert ax.get_ylim()[1] < 5.0


@pytest.mark.parametrize(
    "scenario, reasons", [("static", {"init", "interference"}), ("vehicle", {"init", "interference", "turning"})]
)
def test_fig_params_shades_gates_by_reason(scenario, reasons, static_outputs, vehicle_outputs):
    out = (static_outputs if scenario == "static" else vehicle_outputs)["stkf"]
    assert set(out["gate_reason"].unique()) - {""} == reasons
    fig = plots.fig_params(out, method="stkf")
    assert len(fig.axes) == 3
    assert [ax.get_ylabel() for ax in fig.axes] == ["a (deg/s/degC)", "b (deg/degC)", "c (deg/s)"]
    n_updates = int(out["updated"].sum())
    for ax in fig.axes:
        gids = {c.get_gid() for c in ax.collections}
        assert gids == {f"gate-{r}" for r in reasons}
        spans = [c for c in ax.collections if c.get_gid() == "gate-interference"][0]
        assert len(spans.get_paths()) >= 1
        (marks,) = [ln for ln in ax.get_lines() if ln.get_gid() == "updates"]
        assert len(marks.get_xdata()) == n_updates
    texts = legend_texts(fig.axes[0])
    assert {f"gated: {r}" for r in reasons} <= set(texts)
    assert f"filter update ({n_updates})" in texts


def test_fig_params_shading_covers_the_gated_rows(static_outputs):
    out = static_outputs["stkf"]
    ax = plots.fig_params(out).axes[0]
    (coll,) = [c for c in ax.collections if c.get_gid() == "gate-init"]
    (path,) = coll.get_paths()
    x0, x1 = path.vertices[:, 0].min(), path.vertices[:, 0].max()
    t_min = (out["t"] - out["t"].iloc[0]) / 60.0
    init = t_min[out["gate_reason"] == "init"]
    assert x0 == pytest.approx(init.min()) and x1 >= init.max()


def test_fig_heading_error_marks_non_causal_methods(vehicle_outputs):
    fig = plots.fig_heading_error(vehicle_outputs)
    (ax,) = fig.axes
    assert labels(ax) == ["stkf", "kf", "mlr (non-causal)", "oracle (non-causal)"]
    assert ax.get_ylabel() == "heading error (deg)"
    for ln in ax.get_lines()[:4]:
        y = ln.get_ydata()
        assert np.nanmin(y) >= -180 and np.nanmax(y) < 180
    fig = plots.fig_heading_error({"stkf": vehicle_outputs["stkf"]}, causal={"stkf": False})
    assert labels(fig.axes[0]) == ["stkf (non-causal)"]


def test_fig_heading_error_needs_ref_heading(vehicle_outputs):
    with pytest.raises(LogFormatError, match="ref_heading"):
        plots.fig_heading_error({"stkf": vehicle_outputs["stkf"].drop(columns="ref_heading")})


def test_fig_heading_is_unwrapped(vehicle_outputs):
    out = vehicle_outputs["stkf"]
    fig = plots.fig_heading(out, method="stkf")
    (ax,) = fig.axes
    assert labels(ax) == ["compass heading", "compensated gyro heading (stkf)", "reference (ref_heading)"]
    gyro, ref = ax.get_lines()[1].get_ydata(), ax.get_lines()[2].get_ydata()
    assert np.nanmax(ref) > 360.0  # loops: no wrap back to 0
    assert np.max(np.abs(np.diff(ref))) < 10.0
    assert np.nanmax(np.abs(gyro - ref)) < 45.0  # same branch as the reference
    assert "deg" in ax.get_ylabel()


def test_fig_allan_curves_bands_and_terms(static_outputs):
    out = static_outputs["stkf"]
    curves = {
        "raw gyro_z": allan_deviation(out["gyro_z"].to_numpy(), 10.0),
        "stkf rate_z": allan_deviation(out["rate_z"].to_numpy(), 10.0),
    }
    terms = {k: noise_terms(v) for k, v in curves.items()}
    fig = plots.fig_allan(curves, terms)
    (ax,) = fig.axes
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert [ln.get_label() for ln in ax.get_lines() if ln.get_gid() == "curve"] == list(curves)
    assert len(ax.collections) == 2  # one confidence band per curve
    found = sum(t is not None for tt in terms.values() for t in (tt.arw, tt.bias_instability, tt.rrw))
    assert found >= 2
    assert len([ln for ln in ax.get_lines() if ln.get_gid() == "term"]) == found
    assert sum(txt.get_text().startswith("N = ") for txt in ax.texts) == sum(t.arw is not None for t in terms.values())
    assert "deg/s" in ax.get_ylabel() and "τ (s)" in ax.get_xlabel()
    assert "N at τ = 1 s" in legend_texts(ax)
    no_terms = plots.fig_allan(curves)
    assert not [ln for ln in no_terms.axes[0].get_lines() if ln.get_gid() == "term"]


def test_minmax_decimate_caps_points_and_keeps_extremes():
    rng = np.random.default_rng(0)
    x = np.arange(123_457.0)
    y = rng.normal(size=x.size)
    y[77_777] = 50.0
    y[3] = -60.0
    xd, yd = plotbase.minmax_decimate(x, y, 20_000)
    assert len(xd) <= 20_000 and len(xd) == len(yd)
    assert yd.max() == 50.0 and yd.min() == -60.0
    assert np.all(np.diff(xd) >= 0)  # time order kept
    assert plotbase.minmax_decimate(x[:100], y[:100])[0].size == 100
    with pytest.raises(ConfigError):
        plotbase.minmax_decimate(x, y, 1)


def test_long_log_lines_are_decimated():
    n = 3 * 3600 * 20 + 1  # 3 h at 20 Hz
    t = np.arange(n) / 20.0
    raw = 0.1 * np.sin(t / 600.0)
    raw[100_000] = 9.0
    out = pd.DataFrame(
        {"t": t, "gyro_z": raw, "rate_z": raw - 0.05, "temp": 25 + t / 3600, "temp_rate": np.full(n, 1 / 3600)}
    )
    fig = plots.fig_rates(out)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time from start (h)"
    for ln in ax.get_lines():
        assert len(ln.get_xdata()) <= plotbase.MAX_POINTS
    assert ax.get_lines()[0].get_ydata().max() == 9.0
    assert any("min/max envelope" in t.get_text() for t in ax.texts)
    for a in plots.fig_temperature(out).axes:
        assert all(len(ln.get_xdata()) <= plotbase.MAX_POINTS for ln in a.get_lines())


def test_missing_column_is_named(static_outputs):
    with pytest.raises(LogFormatError, match="gate_reason"):
        plots.fig_params(static_outputs["stkf"].drop(columns="gate_reason"))


def test_save_png_is_atomic_and_png_base64_decodes(tmp_path, static_outputs):
    fig = plots.fig_rates(static_outputs["stkf"])
    path = tmp_path / "rates.png"
    path.write_bytes(b"old")
    plotbase.save_png(fig, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert os.listdir(tmp_path) == ["rates.png"]  # no temporary file left
    assert base64.b64decode(plotbase.png_base64(fig))[:4] == b"\x89PNG"
    with pytest.raises(ConfigError, match="no-such-folder"):
        plotbase.save_png(fig, tmp_path / "no-such-folder" / "x.png")


def test_save_png_keeps_the_old_file_when_rendering_fails(tmp_path, static_outputs, monkeypatch):
    fig = plots.fig_rates(static_outputs["stkf"])
    path = tmp_path / "rates.png"
    path.write_bytes(b"old")

    def fail(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(ConfigError, match="No space left"):
        plotbase.save_png(fig, path)
    assert path.read_bytes() == b"old"
    assert os.listdir(tmp_path) == ["rates.png"]


def test_missing_matplotlib_names_the_extra(monkeypatch, static_outputs):
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(ConfigError, match=r"gyrodrift\[plot\]"):
        plots.fig_rates(static_outputs["stkf"])


def test_no_pyplot_state_is_created(static_outputs):
    import matplotlib

    before = "matplotlib.pyplot" in sys.modules
    plots.fig_bias(static_outputs)
    if not before:
        assert "matplotlib.pyplot" not in sys.modules
    if "matplotlib.pyplot" in sys.modules:
        assert not sys.modules["matplotlib.pyplot"].get_fignums()
    assert matplotlib.get_backend()  # untouched, whatever it is

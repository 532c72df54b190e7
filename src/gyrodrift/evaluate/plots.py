"""Figures of a compensated log, after Figures 1–11 of Feng, Li, Zhang (Sensors 2015).

Each ``fig_*`` function returns a new matplotlib Figure the caller owns; what each draws:
docs/evaluation.md, section "Figures".
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
import pandas as pd

from gyrodrift.calibrate import BIN_WIDTH_C
from gyrodrift.compensator.output import updated_column
from gyrodrift.conventions import REF_HEADING, TRUE_BIAS_Z
from gyrodrift.errors import ConfigError
from gyrodrift.evaluate.allan import BIAS_INSTABILITY_FACTOR
from gyrodrift.evaluate.compare import CAUSAL, method_label
from gyrodrift.evaluate.metrics import heading_error_deg
from gyrodrift.evaluate.plotbase import (
    MAX_POINTS,
    WIDTH_IN,
    align_turns,
    envelope_note,
    float_column,
    need_columns,
    new_figure,
    plot_line,
    require_matplotlib,
    robust_limits,
    time_axis,
    true_runs,
    unwrap_deg,
)
from gyrodrift.model import temp_rate

__all__ = [
    "GATE_COLORS",
    "METHOD_COLORS",
    "fig_temperature",
    "fig_rates",
    "fig_bias",
    "fig_params",
    "fig_heading_error",
    "fig_heading",
    "fig_allan",
    "fig_scale_factor",
]


#: Shading colour of each ``gate_reason`` (see :mod:`gyrodrift.gating`).
GATE_COLORS = {
    "init": "#9e9e9e",
    "gap": "#8c564b",
    "no_compass": "#ff9f1c",
    "field": "#9467bd",
    "turning": "#1f77b4",
    "interference": "#d62728",
}

#: Line colour of each method (the paper's, and magenta for gyrodrift's default estimator).
METHOD_COLORS = {
    "adaptive": "#c51b7d",
    "stkf": "#1f4fd6",
    "kf": "#d62728",
    "mlr": "#2ca02c",
    "lsm": "#222222",
    "stkf-s1": "#9467bd",
    "poly3": "#ff7f0e",
    "oracle": "#7f7f7f",
}

_RAW_COLOR = "#b8b8b8"
_TRUTH_COLOR = "#000000"
_EXTRA_COLORS = ("#17becf", "#bcbd22", "#e377c2", "#8c564b")


def _method_color(name: str, index: int) -> str:
    return METHOD_COLORS.get(name, _EXTRA_COLORS[index % len(_EXTRA_COLORS)])


def _check_methods(out_by_method: Mapping[str, pd.DataFrame], what: str) -> None:
    if not out_by_method:
        raise ConfigError(f"{what} needs at least one method's output table")


def _labelled(fig, ax, ylabel: str, xlabel: str, title: str, n: int, legend_at: str, **legend):
    """``fig`` with its one axes labelled, a legend at ``legend_at`` and the envelope note of ``n`` points."""
    ax.set_ylabel(ylabel)
    ax.set_xlabel(xlabel)
    ax.set_title(title)
    ax.legend(loc=legend_at, fontsize=8, **legend)
    envelope_note(ax, n)
    return fig


# ----------------------------------------------------------------------- figures


def fig_temperature(out: pd.DataFrame):
    """Temperature and its rate of change T' over time (paper Figs. 1a and 7), from an output table or a log."""
    need_columns(out, ("t", "temp"), "fig_temperature")
    t = float_column(out, "t")
    temp = float_column(out, "temp")
    if "temp_rate" in out.columns:
        rate = float_column(out, "temp_rate")
    else:
        rate = temp_rate(t, pd.Series(temp).ffill().bfill().to_numpy())
    x, xlabel = time_axis(t)
    fig, (ax_t, ax_r) = new_figure(4.8, 2)
    plot_line(ax_t, x, temp, color="#d62728", lw=1.0, label="temp")
    ax_t.set_ylabel("temperature (degC)")
    ax_t.set_title("Gyro temperature and its rate of change")
    plot_line(ax_r, x, rate, color="#1f77b4", lw=1.0, label="T'")
    ax_r.axhline(0.0, color="#555555", lw=0.6)
    ax_r.set_ylabel("T' (degC/s)")
    ax_r.set_xlabel(xlabel)
    envelope_note(ax_r, t.size)
    return fig


def fig_rates(out: pd.DataFrame, *, method: str | None = None):
    """Raw ``gyro_z`` and compensated ``rate_z`` of an output table (paper Fig. 3); ``method`` names it."""
    need_columns(out, ("t", "gyro_z", "rate_z"), "fig_rates")
    t = float_column(out, "t")
    x, xlabel = time_axis(t)
    fig, (ax,) = new_figure(3.8)
    plot_line(ax, x, float_column(out, "gyro_z"), color=_RAW_COLOR, lw=0.8, label="raw gyro_z")
    name = f" ({method})" if method else ""
    plot_line(ax, x, float_column(out, "rate_z"), color="#d62728", lw=0.8, alpha=0.85, label=f"compensated rate_z{name}")
    return _labelled(fig, ax, "angular rate (deg/s)", xlabel, "Uncompensated and compensated angular rate", t.size,
                     "upper right")


def fig_bias(out_by_method: Mapping[str, pd.DataFrame]):
    """Each method's ``bias_z`` against the true drift (paper Fig. 2); raw rate and truth from the first table."""
    _check_methods(out_by_method, "fig_bias")
    first = next(iter(out_by_method.values()))
    need_columns(first, ("t", "gyro_z"), "fig_bias")
    t = float_column(first, "t")
    x, xlabel = time_axis(t)
    fig, (ax,) = new_figure(4.0)
    raw = float_column(first, "gyro_z")
    plot_line(ax, x, raw, color=_RAW_COLOR, lw=0.6, alpha=0.7, label="raw gyro_z", zorder=1)
    core = []
    has_truth = TRUE_BIAS_Z in first.columns
    if has_truth:
        truth = float_column(first, TRUE_BIAS_Z)
        core.append(truth)
        plot_line(ax, x, truth, color=_TRUTH_COLOR, lw=1.6, ls="--", label="true drift (true_bias_z)", zorder=3)
    for i, (name, out) in enumerate(out_by_method.items()):
        if has_truth and name == "oracle":
            continue
        need_columns(out, ("t", "bias_z"), f"fig_bias ({name})")
        bias = float_column(out, "bias_z")
        core.append(bias)
        xm = time_axis(float_column(out, "t"))[0]
        plot_line(ax, xm, bias, color=_method_color(name, i), lw=1.1, label=f"{method_label(name)} bias_z", zorder=2)
    limits = robust_limits(core, raw)
    if limits is not None:
        ax.set_ylim(*limits)
    title = "Estimated gyro drift" + (" and the true drift" if has_truth else "")
    return _labelled(fig, ax, "drift / rate (deg/s)", xlabel, title, t.size, "upper right", ncols=2)


def fig_params(out: pd.DataFrame, *, method: str | None = None):
    """Drift-model parameters a, b, c of an output table over time, updates as dots, refused rows shaded."""
    need_columns(out, ("t", "a", "b", "c", "gate_reason"), "fig_params")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    t = float_column(out, "t")
    x, xlabel = time_axis(t)
    reason = out["gate_reason"].fillna("").astype(str).to_numpy()
    upd = pd.to_numeric(updated_column(out, "fig_params"), errors="coerce").fillna(0).to_numpy() > 0
    fig, axes = new_figure(6.6, 3)
    units = {"a": "a (deg/s/degC)", "b": "b (deg/degC)", "c": "c (deg/s)"}
    reasons = [r for r in GATE_COLORS if (reason == r).any()]
    reasons += sorted(set(reason[reason != ""]) - set(GATE_COLORS))
    for ax, name in zip(axes, ("a", "b", "c")):
        values = float_column(out, name)
        for r in reasons:
            _shade(ax, x, reason == r, GATE_COLORS.get(r, "#cccccc"), f"gate-{r}")
        plot_line(ax, x, values, color="#1f4fd6", lw=1.1)
        ax.plot(x[upd], values[upd], ".", color="#111111", ms=2.5, gid="updates")
        ax.set_ylabel(units[name])
    handles = [Patch(facecolor=GATE_COLORS.get(r, "#cccccc"), alpha=0.35, label=f"gated: {r}") for r in reasons]
    handles.append(Line2D([], [], ls="", marker=".", color="#111111", label=f"filter update ({int(upd.sum())})"))
    axes[0].legend(handles=handles, loc="upper right", fontsize=7, ncols=min(4, len(handles)))
    axes[-1].set_xlabel(xlabel)
    name = f" ({method})" if method else ""
    axes[0].set_title(f"Drift model a·T + b·T' + c{name}: parameters, aiding refusals shaded")
    return fig


def _shade(ax, x: np.ndarray, mask: np.ndarray, color: str, gid: str) -> None:
    """Shade the x spans of each run of ``mask`` over the full height of ``ax``."""
    runs = true_runs(mask)
    if not runs:
        return
    from matplotlib.collections import PolyCollection

    trans = ax.get_xaxis_transform()  # x in data, y in axes fraction
    step = float(np.median(np.diff(x))) if x.size > 1 else 0.0
    polys = []
    for i0, i1 in runs:
        x0, x1 = x[i0], (x[i1 + 1] if i1 + 1 < x.size else x[i1] + step)
        polys.append([(x0, 0.0), (x1, 0.0), (x1, 1.0), (x0, 1.0)])
    coll = PolyCollection(polys, facecolors=color, edgecolors="none", alpha=0.3, transform=trans, zorder=0)
    coll.set_gid(gid)
    ax.add_collection(coll, autolim=False)


def fig_heading_error(out_by_method: Mapping[str, pd.DataFrame], causal: Mapping[str, bool] | None = None):
    """Each method's wrapped heading error against ``ref_heading`` (paper Figs. 4, 5, 9), non-causal ones dashed.

    ``causal`` says which methods are causal (default :data:`gyrodrift.evaluate.compare.CAUSAL`).
    """
    _check_methods(out_by_method, "fig_heading_error")
    causal = CAUSAL if causal is None else causal
    fig, (ax,) = new_figure(4.0)
    xlabel = "time"
    n = 0
    for i, (name, out) in enumerate(out_by_method.items()):
        need_columns(out, ("t", "heading", REF_HEADING), f"fig_heading_error ({name})")
        t = float_column(out, "t")
        x, xlabel = time_axis(t)
        n = max(n, t.size)
        err = heading_error_deg(float_column(out, "heading"), float_column(out, REF_HEADING))
        live = causal.get(name, True)
        label = method_label(name) if live else f"{method_label(name)} (non-causal)"
        plot_line(ax, x, err, color=_method_color(name, i), lw=1.0, ls="-" if live else "--", label=label)
    ax.axhline(0.0, color="#555555", lw=0.6)
    return _labelled(fig, ax, "heading error (deg)", xlabel, "Heading error against the reference heading", n,
                     "upper left", ncols=2)


def fig_heading(out: pd.DataFrame, *, method: str | None = None):
    """Compass, compensated gyro and (when present) reference heading, unwrapped (paper Fig. 8)."""
    need_columns(out, ("t", "heading", "compass_heading"), "fig_heading")
    t = float_column(out, "t")
    x, xlabel = time_axis(t)
    gyro = unwrap_deg(float_column(out, "heading"))
    anchor = gyro
    fig, (ax,) = new_figure(4.0)
    if REF_HEADING in out.columns:
        ref = unwrap_deg(float_column(out, REF_HEADING))
        anchor = ref
        gyro = align_turns(gyro, anchor)
    compass = align_turns(unwrap_deg(float_column(out, "compass_heading")), anchor)
    ok = np.isfinite(compass)
    plot_line(ax, x[ok], compass[ok], color="#1f77b4", lw=0.8, alpha=0.8, label="compass heading")
    name = f" ({method})" if method else ""
    plot_line(ax, x, gyro, color="#d62728", lw=1.1, label=f"compensated gyro heading{name}")
    if REF_HEADING in out.columns:
        plot_line(ax, x, anchor, color="#2ca02c", lw=1.1, ls="--", label="reference (ref_heading)")
    return _labelled(fig, ax, "heading, unwrapped (deg)", xlabel, "Heading: compass, compensated gyro and reference",
                     t.size, "best")


def fig_allan(curves: Mapping[str, object], terms: Mapping[str, object] | None = None):
    """Allan deviation curves (label → AllanResult, one unit) with their bands (paper Fig. 6).

    ``terms`` (label → NoiseTerms) marks N, B and K on the curves.
    """
    if not curves:
        raise ConfigError("fig_allan needs at least one Allan-deviation curve")
    from matplotlib.lines import Line2D

    fig, (ax,) = new_figure(4.8)
    unit = next(iter(curves.values())).unit
    palette = ("#707070",) + tuple(METHOD_COLORS[m] for m in ("stkf", "kf", "mlr")) + _EXTRA_COLORS
    for i, (label, res) in enumerate(curves.items()):
        color = palette[i % len(palette)]
        ax.loglog(res.tau_s, res.adev, "-", marker=".", color=color, lw=1.3, label=label, gid="curve")
        ax.fill_between(res.tau_s, res.adev_lo, res.adev_hi, color=color, alpha=0.18, lw=0)
        if terms and terms.get(label) is not None:
            _mark_terms(ax, terms[label], color, i)
    ax.set_xlabel("averaging time τ (s)")
    ax.set_ylabel(f"Allan deviation ({unit})" if unit else "Allan deviation")
    ax.set_title(f"Allan deviation of the angular-rate error ({100 * next(iter(curves.values())).ci:.0f} % bands)")
    handles, _ = ax.get_legend_handles_labels()
    if terms:
        for marker, text in (("o", "N at τ = 1 s"), ("s", "B at its τ (σ = 0.664 B)"), ("^", "K at τ = 3 s")):
            handles.append(Line2D([], [], ls="", marker=marker, mfc="white", mec="#333333", label=text))
    ax.legend(handles=handles, loc="best", fontsize=8)
    ax.grid(True, which="minor", alpha=0.12, linewidth=0.5)
    return fig


def _bin_means(temp: np.ndarray, rate: np.ndarray, temp_min: float, width: float):
    """Centres (degC) and mean rates of the occupied ``width``-degC temperature bins from ``temp_min``."""
    bins = np.floor((temp - temp_min) / width).astype(np.int64)
    counts = np.bincount(bins)
    occupied = np.flatnonzero(counts)
    return temp_min + (occupied + 0.5) * width, np.bincount(bins, rate)[occupied] / counts[occupied]


def fig_calibration(log: pd.DataFrame, cal):
    """A thermal calibration (:func:`gyrodrift.calibrate.fit_calibration`) against the log it was fitted on."""
    names = list(cal.axes)
    need_columns(log, ("temp", *(f"gyro_{a}" for a in names)), "fig_calibration")
    Figure, FigureCanvasAgg = require_matplotlib()
    fig = Figure(figsize=(WIDTH_IN, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.subplots(2, len(names), sharex=True, squeeze=False)
    temp = float_column(log, "temp")
    curve = np.linspace(cal.temp_min_c, cal.temp_max_c, 200)
    for k, axis in enumerate(names):
        top, bottom = grid[0, k], grid[1, k]
        rate = float_column(log, f"gyro_{axis}")
        ok = np.isfinite(temp) & np.isfinite(rate)
        step = max(1, int(ok.sum()) // MAX_POINTS)
        top.plot(temp[ok][::step], rate[ok][::step], ".", ms=1, color=_RAW_COLOR, label="samples", rasterized=True)
        centres, means = _bin_means(temp[ok], rate[ok], cal.temp_min_c, BIN_WIDTH_C)
        fitted = cal.drift(axis, curve)
        top.plot(centres, means, ".", ms=3, color="#1f77b4", label=f"mean per {BIN_WIDTH_C:g} degC")
        top.plot(curve, fitted, color="#d62728", lw=1.4, label="fitted cubic")
        limits = robust_limits([means, fitted], rate[ok])
        if limits is not None:
            top.set_ylim(*limits)
        rms = cal.axes[axis].residual_rms_dps
        bottom.plot(centres, means - cal.drift(axis, centres), ".", ms=3, color="#1f77b4")
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3, linewidth=0.6)
            ax.axvline(cal.temp_ref_c, color="#555555", lw=0.8, ls=":")
        for sign in (1.0, -1.0):
            bottom.axhline(sign * rms, color="#d62728", lw=0.8, ls="--")
        top.set_title(f"gyro_{axis}")
        bottom.set_title(f"residual RMS {rms:.4g} deg/s", fontsize=9)
        bottom.set_xlabel("temperature (degC)")
    grid[0, 0].set_ylabel("rate (deg/s)")
    grid[1, 0].set_ylabel("mean − fit (deg/s)")
    grid[0, 0].legend(loc="best", fontsize=8, markerscale=3)
    fig.suptitle(f"Thermal calibration: {cal.temp_min_c:.1f} to {cal.temp_max_c:.1f} degC (span {cal.span_c:.1f} "
                 f"degC), T_ref {cal.temp_ref_c:.1f} degC (dotted)")
    return fig


def fig_scale_factor(fig10: pd.DataFrame, fig11: pd.DataFrame):
    """Scale factor and the heading error it causes (paper Figs. 10 and 11), from the tables of
    :func:`gyrodrift.evaluate.paper.scale_factor_experiment`."""
    need_columns(fig10, ("t", "sf_ideal", "sf_fixed", "sf_adaptive"), "fig_scale_factor")
    need_columns(fig11, ("t", "err_none", "err_fixed", "err_adaptive"), "fig_scale_factor")
    x, xlabel = time_axis(float_column(fig10, "t"))
    fig, (ax_sf, ax_err) = new_figure(5.6, 2)
    styles = {"ideal": ("#1f77b4", "-"), "fixed": ("#2ca02c", "-"), "adaptive": ("#d62728", "-"), "none": ("#1f77b4", "-")}
    for key in ("ideal", "fixed", "adaptive"):
        color, ls = styles[key]
        plot_line(ax_sf, x, float_column(fig10, f"sf_{key}"), color=color, ls=ls, lw=1.1, label=f"{key} SF")
    ax_sf.set_ylabel("scale factor")
    ax_sf.set_title("Scale factor: ideal, fixed parameters, adaptive (paper Fig. 10)")
    ax_sf.legend(loc="best", fontsize=8)
    x11, _ = time_axis(float_column(fig11, "t"))
    labels = {"none": "no SF compensation", "fixed": "fixed SF", "adaptive": "adaptive SF", "ideal": "true SF"}
    for key in ("none", "fixed", "adaptive", "ideal"):
        if f"err_{key}" not in fig11.columns:
            continue
        color, ls = styles[key] if key != "ideal" else ("#7f7f7f", "--")
        plot_line(ax_err, x11, float_column(fig11, f"err_{key}"), color=color, ls=ls, lw=0.9, label=labels[key])
    ax_err.axhline(0.0, color="#555555", lw=0.6)
    ax_err.set_ylabel("heading error (deg)")
    ax_err.set_title("Heading error (paper Fig. 11)")
    ax_err.set_xlabel(xlabel)
    ax_err.legend(loc="best", fontsize=8)
    envelope_note(ax_err, len(fig11))
    return fig


def _mark_terms(ax, terms, color: str, index: int) -> None:
    """Mark and annotate N, B, K of one curve."""
    marks = []
    if terms.arw is not None:
        marks.append(("o", 1.0, terms.arw.value, f"N = {terms.arw.value:.3g} {terms.arw.unit}"))
    if terms.bias_instability is not None:
        b = terms.bias_instability
        marks.append(("s", b.tau_s, b.value * BIAS_INSTABILITY_FACTOR, f"B = {b.value:.3g} {b.unit}"))
    if terms.rrw is not None:
        marks.append(("^", 3.0, terms.rrw.value, f"K = {terms.rrw.value:.3g} {terms.rrw.unit}"))
    for marker, tau, sigma, text in marks:
        if not (math.isfinite(sigma) and sigma > 0):
            continue
        ax.plot([tau], [sigma], ls="", marker=marker, ms=7, mfc="white", mec=color, mew=1.6, gid="term")
        ax.annotate(
            text, (tau, sigma), xytext=(8, -12 - 10 * index), textcoords="offset points",
            fontsize=7, color=color,
        )

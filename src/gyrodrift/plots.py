"""Figures of a compensated log, after Figures 1–9 of Feng, Li, Zhang (Sensors 2015).

Every ``fig_*`` function takes output tables of :func:`gyrodrift.compensator.compensate`
(or :func:`gyrodrift.compare.run_methods`) or arrays and returns a new
:class:`matplotlib.figure.Figure` drawn with the Agg renderer. pyplot is never
used, so no global figure state is created or changed: the caller owns the figure
(save it with :func:`save_png` or embed it with :func:`png_base64`).

==========================  ===============================================  =========
function                    what it shows                                    paper
==========================  ===============================================  =========
:func:`fig_temperature`     temperature (degC) and its rate T' (degC/s)      Fig. 1a, 7
:func:`fig_rates`           raw ``gyro_z`` and compensated ``rate_z``        Fig. 3
:func:`fig_bias`            estimated drift of each method and the truth     Fig. 2
:func:`fig_params`          drift-model a, b, c with the gated intervals     --
:func:`fig_heading_error`   heading error of each method (wrapped)           Fig. 4, 5, 9
:func:`fig_heading`         compass, compensated gyro and reference heading  Fig. 8
:func:`fig_allan`           Allan deviation with intervals and noise terms   Fig. 6
:func:`fig_calibration`     thermal calibration fit per axis, its residual   --
==========================  ===============================================  =========

Time axes run from the first row of the table, in s, min (logs longer than
10 min) or h (longer than 2 h). Long series are drawn as a min/max envelope
(:func:`minmax_decimate`): at most :data:`MAX_POINTS` points per line, keeping
every spike that the full series has.

matplotlib is an optional dependency: ``pip install 'gyrodrift[plot]'``.
"""

from __future__ import annotations

import base64
import io
import math
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from gyrodrift.allan import BIAS_INSTABILITY_FACTOR
from gyrodrift.compensator.output import updated_column
from gyrodrift.conventions import REF_HEADING, TRUE_BIAS_Z
from gyrodrift._atomic import write_bytes_atomic
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.metrics import heading_error_deg

__all__ = [
    "MAX_POINTS",
    "GATE_COLORS",
    "METHOD_COLORS",
    "minmax_decimate",
    "time_axis",
    "fig_temperature",
    "fig_rates",
    "fig_bias",
    "fig_params",
    "fig_heading_error",
    "fig_heading",
    "fig_allan",
    "fig_scale_factor",
    "save_png",
    "png_base64",
    "require_matplotlib",
]

#: Most points drawn per line; longer series are reduced to a min/max envelope.
MAX_POINTS = 20_000

#: Shading colour of each ``gate_reason`` (see :mod:`gyrodrift.gating`).
GATE_COLORS = {
    "init": "#9e9e9e",
    "gap": "#8c564b",
    "no_compass": "#ff9f1c",
    "field": "#9467bd",
    "turning": "#1f77b4",
    "interference": "#d62728",
}

#: Line colour of each method (the paper's: adaptive blue, KF red, MLR green, LSM black; the paper's
#: adaptive filter is ``stkf`` here, and gyrodrift's default estimator ``adaptive`` is magenta).
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
_WIDTH_IN = 10.0


# ----------------------------------------------------------------------- helpers


def require_matplotlib():
    """The Figure class and the Agg canvas, or a ConfigError naming the extra to install."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise ConfigError("plots need the optional package matplotlib: pip install 'gyrodrift[plot]'") from exc
    return Figure, FigureCanvasAgg


def _figure(height_in: float, nrows: int = 1, *, sharex: bool = True):
    """A new Agg figure with ``nrows`` stacked axes (no pyplot); returns (fig, axes list)."""
    Figure, FigureCanvasAgg = require_matplotlib()
    fig = Figure(figsize=(_WIDTH_IN, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False)[:, 0]
    for ax in axes:
        ax.grid(True, alpha=0.3, linewidth=0.6)
    return fig, list(axes)


def _need(table: pd.DataFrame, columns, what: str) -> None:
    """Raise LogFormatError naming the columns ``what`` needs and the table lacks."""
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise LogFormatError(f"{what} needs the column(s) {', '.join(missing)}, which the table lacks")


def _column(table: pd.DataFrame, name: str) -> np.ndarray:
    return pd.to_numeric(table[name], errors="coerce").to_numpy(dtype=float)


def _method_color(name: str, index: int) -> str:
    return METHOD_COLORS.get(name, _EXTRA_COLORS[index % len(_EXTRA_COLORS)])


def _method_label(name: str) -> str:
    """A method's legend name: the default estimator's says so (:func:`gyrodrift.compare.method_label`)."""
    from gyrodrift.compare import method_label

    return method_label(name)


def _check_methods(out_by_method: Mapping[str, pd.DataFrame], what: str) -> None:
    if not out_by_method:
        raise ConfigError(f"{what} needs at least one method's output table")


def minmax_decimate(x, y, max_points: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Reduce a long series to at most ``max_points`` points by a min/max envelope.

    The series is cut into equal bins of consecutive samples; each bin keeps its
    smallest and its largest value, in time order, so the drawn line covers the
    same band as the full series and no spike is lost.

    Parameters
    ----------
    x, y : (N,) array_like
        Abscissa (e.g. time) and values; NaN values are kept only where a whole
        bin is NaN (a gap in the line).
    max_points : int
        Largest number of points returned (at least 2).

    Returns
    -------
    x, y : ndarray
        The input itself when N <= ``max_points``, else the envelope points.

    Examples
    --------
    >>> x = np.arange(100_000.0)
    >>> y = np.zeros_like(x); y[54_321] = 5.0
    >>> xd, yd = minmax_decimate(x, y, 1000)
    >>> len(xd) <= 1000, float(yd.max()), float(xd[np.argmax(yd)])
    (True, 5.0, 54321.0)
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if not (isinstance(max_points, (int, np.integer)) and max_points >= 2):
        raise ConfigError(f"max_points must be a whole number >= 2, got {max_points!r}")
    n = y.size
    if n <= max_points:
        return x, y
    k = math.ceil(n / (max_points // 2))  # samples per bin
    bins = math.ceil(n / k)
    padded = np.full(bins * k, np.nan)
    padded[:n] = y
    block = padded.reshape(bins, k)
    lo = np.argmin(np.where(np.isnan(block), np.inf, block), axis=1)
    hi = np.argmax(np.where(np.isnan(block), -np.inf, block), axis=1)
    base = np.arange(bins) * k
    idx = np.sort(np.column_stack([base + lo, base + hi]), axis=1).ravel()
    idx = np.minimum(idx, n - 1)
    return x[idx], y[idx]


def time_axis(t_s) -> tuple[np.ndarray, str]:
    """Time from the first sample in s, min or h, and the matching axis label.

    Minutes for spans longer than 10 min, hours for spans longer than 2 h.

    >>> time_axis([0.0, 1800.0])[1]
    'time from start (min)'
    """
    t = np.asarray(t_s, dtype=float)
    rel = t - t[0] if t.size else t
    span = float(rel[-1]) if t.size else 0.0
    if span > 2 * 3600.0:
        return rel / 3600.0, "time from start (h)"
    if span > 600.0:
        return rel / 60.0, "time from start (min)"
    return rel, "time from start (s)"


def _envelope_note(ax, n: int) -> None:
    """Say on the axes that long lines are drawn as min/max envelopes."""
    if n > MAX_POINTS:
        k = math.ceil(n / (MAX_POINTS // 2))
        ax.text(
            0.995, 0.01, f"long lines drawn as min/max envelope of {k}-sample bins",
            transform=ax.transAxes, ha="right", va="bottom", fontsize=7, color="#555555",
        )


def _plot(ax, x, y, **kwargs):
    """``ax.plot`` of a series reduced by :func:`minmax_decimate`."""
    xd, yd = minmax_decimate(x, y)
    return ax.plot(xd, yd, **kwargs)[0]


def _robust_limits(core, background, max_ratio: float = 6.0) -> tuple[float, float] | None:
    """y limits covering ``core`` fully and ``background`` robustly (1–99 %), not wider than
    ``max_ratio`` times the core span (so a moving log's turns don't squash the drift)."""
    core = np.concatenate([np.asarray(c, dtype=float).ravel() for c in core]) if core else np.array([])
    core = core[np.isfinite(core)]
    if core.size == 0:
        return None
    lo, hi = float(core.min()), float(core.max())
    span = max(hi - lo, 1e-3)
    bg = np.asarray(background, dtype=float)
    bg = bg[np.isfinite(bg)]
    if bg.size:
        b_lo, b_hi = np.percentile(bg, [1.0, 99.0])
        mid = 0.5 * (lo + hi)
        half = 0.5 * max_ratio * span
        lo, hi = min(lo, max(float(b_lo), mid - half)), max(hi, min(float(b_hi), mid + half))
    pad = 0.05 * max(hi - lo, 1e-3)
    return lo - pad, hi + pad


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) row of each run of True in ``mask``."""
    edges = np.diff(np.r_[0, np.asarray(mask, dtype=np.int8), 0])
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), stops.tolist()))


def _unwrap(deg: np.ndarray) -> np.ndarray:
    """Unwrap the finite values of a heading series (deg), keeping NaN where it was."""
    out = np.full(deg.shape, np.nan)
    ok = np.isfinite(deg)
    if ok.any():
        out[ok] = np.unwrap(deg[ok], period=360.0)
    return out


def _align(unwrapped: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """Shift an unwrapped heading by whole turns to lie within 180 deg of ``anchor`` at
    their first common finite row."""
    both = np.flatnonzero(np.isfinite(unwrapped) & np.isfinite(anchor))
    if both.size == 0:
        return unwrapped
    i = both[0]
    turns = np.round((anchor[i] - unwrapped[i]) / 360.0)
    return unwrapped + 360.0 * turns


# ----------------------------------------------------------------------- figures


def fig_temperature(out: pd.DataFrame):
    """Temperature and its rate of change over time (paper Fig. 1a and 7).

    Parameters
    ----------
    out : DataFrame
        An output table (``t``, ``temp``, ``temp_rate``) or an input log (``t``,
        ``temp``); without ``temp_rate`` T' is computed as the compensator does
        (:func:`gyrodrift.model.temp_rate`, default settings).

    Returns
    -------
    matplotlib.figure.Figure
        Two stacked axes: temperature (degC) and T' (degC/s).
    """
    _need(out, ("t", "temp"), "fig_temperature")
    t = _column(out, "t")
    temp = _column(out, "temp")
    if "temp_rate" in out.columns:
        rate = _column(out, "temp_rate")
    else:
        from gyrodrift.model import temp_rate

        rate = temp_rate(t, pd.Series(temp).ffill().bfill().to_numpy())
    x, xlabel = time_axis(t)
    fig, (ax_t, ax_r) = _figure(4.8, 2)
    _plot(ax_t, x, temp, color="#d62728", lw=1.0, label="temp")
    ax_t.set_ylabel("temperature (degC)")
    ax_t.set_title("Gyro temperature and its rate of change")
    _plot(ax_r, x, rate, color="#1f77b4", lw=1.0, label="T'")
    ax_r.axhline(0.0, color="#555555", lw=0.6)
    ax_r.set_ylabel("T' (degC/s)")
    ax_r.set_xlabel(xlabel)
    _envelope_note(ax_r, t.size)
    return fig


def fig_rates(out: pd.DataFrame, *, method: str | None = None):
    """Raw and compensated angular rate (paper Fig. 3).

    Parameters
    ----------
    out : DataFrame
        Output table with ``t``, ``gyro_z`` (raw input, deg/s) and ``rate_z``
        (compensated, deg/s).
    method : str, optional
        Method name for the legend.

    Returns
    -------
    matplotlib.figure.Figure
        One axes with two lines; each line has at most :data:`MAX_POINTS` points
        (min/max envelope of the full series, so peaks are kept).
    """
    _need(out, ("t", "gyro_z", "rate_z"), "fig_rates")
    t = _column(out, "t")
    x, xlabel = time_axis(t)
    fig, (ax,) = _figure(3.8)
    _plot(ax, x, _column(out, "gyro_z"), color=_RAW_COLOR, lw=0.8, label="raw gyro_z")
    name = f" ({method})" if method else ""
    _plot(ax, x, _column(out, "rate_z"), color="#d62728", lw=0.8, alpha=0.85, label=f"compensated rate_z{name}")
    ax.set_ylabel("angular rate (deg/s)")
    ax.set_xlabel(xlabel)
    ax.set_title("Uncompensated and compensated angular rate")
    ax.legend(loc="upper right", fontsize=8)
    _envelope_note(ax, t.size)
    return fig


def fig_bias(out_by_method: Mapping[str, pd.DataFrame]):
    """Estimated drift of each method against the true drift (paper Fig. 2).

    Parameters
    ----------
    out_by_method : mapping of str to DataFrame
        Output table per method (same log). The raw ``gyro_z`` and, when present,
        ``true_bias_z`` are taken from the first table. The ``oracle`` method is not
        drawn when the truth is (its bias is the truth). The default estimator's
        line is labelled "adaptive (default)".

    Returns
    -------
    matplotlib.figure.Figure
        One axes: raw rate (faint), true drift (black dashed) and one ``bias_z``
        line per method, deg/s. The y range follows the drift lines; a moving
        log's turns in the raw rate are clipped.
    """
    _check_methods(out_by_method, "fig_bias")
    first = next(iter(out_by_method.values()))
    _need(first, ("t", "gyro_z"), "fig_bias")
    t = _column(first, "t")
    x, xlabel = time_axis(t)
    fig, (ax,) = _figure(4.0)
    raw = _column(first, "gyro_z")
    _plot(ax, x, raw, color=_RAW_COLOR, lw=0.6, alpha=0.7, label="raw gyro_z", zorder=1)
    core = []
    has_truth = TRUE_BIAS_Z in first.columns
    if has_truth:
        truth = _column(first, TRUE_BIAS_Z)
        core.append(truth)
        _plot(ax, x, truth, color=_TRUTH_COLOR, lw=1.6, ls="--", label="true drift (true_bias_z)", zorder=3)
    for i, (name, out) in enumerate(out_by_method.items()):
        if has_truth and name == "oracle":
            continue
        _need(out, ("t", "bias_z"), f"fig_bias ({name})")
        bias = _column(out, "bias_z")
        core.append(bias)
        xm = time_axis(_column(out, "t"))[0]
        _plot(ax, xm, bias, color=_method_color(name, i), lw=1.1, label=f"{_method_label(name)} bias_z", zorder=2)
    limits = _robust_limits(core, raw)
    if limits is not None:
        ax.set_ylim(*limits)
    ax.set_ylabel("drift / rate (deg/s)")
    ax.set_xlabel(xlabel)
    ax.set_title("Estimated gyro drift" + (" and the true drift" if has_truth else ""))
    ax.legend(loc="upper right", fontsize=8, ncols=2)
    _envelope_note(ax, t.size)
    return fig


def fig_params(out: pd.DataFrame, *, method: str | None = None):
    """Drift-model parameters a, b, c over time, with the gated intervals shaded.

    Parameters
    ----------
    out : DataFrame
        Output table with ``t``, ``a``, ``b``, ``c``, ``updated`` and ``gate_reason``
        (an older table's ``update`` is read as ``updated``, with a FutureWarning).
    method : str, optional
        Method name for the title.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes: a (deg/s/degC), b (deg/degC), c (deg/s). Rows refused for
        compass aiding are shaded in the colour of their reason
        (:data:`GATE_COLORS`; one shading collection per reason and axes, with
        ``gid`` ``"gate-<reason>"``); filter updates are marked with dots. The
        legend lists the reasons present.
    """
    _need(out, ("t", "a", "b", "c", "gate_reason"), "fig_params")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    t = _column(out, "t")
    x, xlabel = time_axis(t)
    reason = out["gate_reason"].fillna("").astype(str).to_numpy()
    upd = pd.to_numeric(updated_column(out, "fig_params"), errors="coerce").fillna(0).to_numpy() > 0
    fig, axes = _figure(6.6, 3)
    units = {"a": "a (deg/s/degC)", "b": "b (deg/degC)", "c": "c (deg/s)"}
    reasons = [r for r in GATE_COLORS if (reason == r).any()]
    reasons += sorted(set(reason[reason != ""]) - set(GATE_COLORS))
    for ax, name in zip(axes, ("a", "b", "c")):
        values = _column(out, name)
        for r in reasons:
            _shade(ax, x, reason == r, GATE_COLORS.get(r, "#cccccc"), f"gate-{r}")
        _plot(ax, x, values, color="#1f4fd6", lw=1.1)
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
    runs = _runs(mask)
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
    """Heading error of each method against ``ref_heading`` (paper Figs. 4, 5, 9).

    Parameters
    ----------
    out_by_method : mapping of str to DataFrame
        Output table per method, each with ``t``, ``heading`` and ``ref_heading``.
    causal : mapping of str to bool, optional
        Whether each method is causal (default :data:`gyrodrift.compare.CAUSAL`);
        non-causal methods are dashed and marked "(non-causal)" in the legend;
        the default estimator is labelled "adaptive (default)".

    Returns
    -------
    matplotlib.figure.Figure
        One axes, one line per method: ``heading − ref_heading`` wrapped to
        [−180, 180), deg.
    """
    _check_methods(out_by_method, "fig_heading_error")
    if causal is None:
        from gyrodrift.compare import CAUSAL as causal
    fig, (ax,) = _figure(4.0)
    xlabel = "time"
    n = 0
    for i, (name, out) in enumerate(out_by_method.items()):
        _need(out, ("t", "heading", REF_HEADING), f"fig_heading_error ({name})")
        t = _column(out, "t")
        x, xlabel = time_axis(t)
        n = max(n, t.size)
        err = heading_error_deg(_column(out, "heading"), _column(out, REF_HEADING))
        live = causal.get(name, True)
        label = _method_label(name) if live else f"{_method_label(name)} (non-causal)"
        _plot(ax, x, err, color=_method_color(name, i), lw=1.0, ls="-" if live else "--", label=label)
    ax.axhline(0.0, color="#555555", lw=0.6)
    ax.set_ylabel("heading error (deg)")
    ax.set_xlabel(xlabel)
    ax.set_title("Heading error against the reference heading")
    ax.legend(loc="upper left", fontsize=8, ncols=2)
    _envelope_note(ax, n)
    return fig


def fig_heading(out: pd.DataFrame, *, method: str | None = None):
    """Compass heading, compensated gyro heading and reference heading, unwrapped (paper Fig. 8).

    Parameters
    ----------
    out : DataFrame
        Output table with ``t``, ``heading`` and ``compass_heading``; ``ref_heading``
        is drawn when present.
    method : str, optional
        Method name for the legend.

    Returns
    -------
    matplotlib.figure.Figure
        One axes, deg. Each heading is unwrapped (no jumps at 0/360) and shifted by
        whole turns to start within 180 deg of the reference (or the gyro heading).
    """
    _need(out, ("t", "heading", "compass_heading"), "fig_heading")
    t = _column(out, "t")
    x, xlabel = time_axis(t)
    gyro = _unwrap(_column(out, "heading"))
    anchor = gyro
    fig, (ax,) = _figure(4.0)
    if REF_HEADING in out.columns:
        ref = _unwrap(_column(out, REF_HEADING))
        anchor = ref
        gyro = _align(gyro, anchor)
    compass = _align(_unwrap(_column(out, "compass_heading")), anchor)
    ok = np.isfinite(compass)
    _plot(ax, x[ok], compass[ok], color="#1f77b4", lw=0.8, alpha=0.8, label="compass heading")
    name = f" ({method})" if method else ""
    _plot(ax, x, gyro, color="#d62728", lw=1.1, label=f"compensated gyro heading{name}")
    if REF_HEADING in out.columns:
        _plot(ax, x, anchor, color="#2ca02c", lw=1.1, ls="--", label="reference (ref_heading)")
    ax.set_ylabel("heading, unwrapped (deg)")
    ax.set_xlabel(xlabel)
    ax.set_title("Heading: compass, compensated gyro and reference")
    ax.legend(loc="best", fontsize=8)
    _envelope_note(ax, t.size)
    return fig


def fig_allan(curves: Mapping[str, object], terms: Mapping[str, object] | None = None):
    """Allan deviation curves with confidence bands and noise terms (paper Fig. 6).

    Parameters
    ----------
    curves : mapping of str to AllanResult
        Label → :class:`gyrodrift.allan.AllanResult` (e.g. raw and compensated rate
        error), all in the same unit.
    terms : mapping of str to NoiseTerms, optional
        Label → :class:`gyrodrift.allan.NoiseTerms`; each term found is marked on
        its curve and annotated: N at τ = 1 s (circle), B at the τ of its minimum
        (σ = 0.664 B, square), K at τ = 3 s (triangle).

    Returns
    -------
    matplotlib.figure.Figure
        One log-log axes: one line per curve (``gid`` ``"curve"``) with its
        confidence band (shaded), term markers (``gid`` ``"term"``).
    """
    if not curves:
        raise ConfigError("fig_allan needs at least one Allan-deviation curve")
    from matplotlib.lines import Line2D

    fig, (ax,) = _figure(4.8)
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
    """A thermal calibration fit against its data (:func:`gyrodrift.calibrate.fit_calibration`).

    Parameters
    ----------
    log : DataFrame
        The still heating or cooling log the calibration was fitted on (``temp`` degC;
        ``gyro_x``, ``gyro_y``, ``gyro_z`` deg/s for the fitted axes).
    cal : gyrodrift.calibrate.Calibration
        The fit.

    Returns
    -------
    matplotlib.figure.Figure
        One column per fitted axis. Top: the rate against temperature (grey: the
        samples, at most :data:`MAX_POINTS`; blue: their mean per
        :data:`gyrodrift.calibrate.BIN_WIDTH_C` bin) and the fitted cubic (red) over
        the calibrated range, ``T_ref`` dotted. Bottom: bin mean minus fit, deg/s,
        with ± the fit's residual RMS dashed. The title gives the temperature span.
    """
    from gyrodrift.calibrate import BIN_WIDTH_C

    names = list(cal.axes)
    _need(log, ("temp", *(f"gyro_{a}" for a in names)), "fig_calibration")
    Figure, FigureCanvasAgg = require_matplotlib()
    fig = Figure(figsize=(_WIDTH_IN, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.subplots(2, len(names), sharex=True, squeeze=False)
    temp = _column(log, "temp")
    curve = np.linspace(cal.temp_min_c, cal.temp_max_c, 200)
    for k, axis in enumerate(names):
        top, bottom = grid[0, k], grid[1, k]
        rate = _column(log, f"gyro_{axis}")
        ok = np.isfinite(temp) & np.isfinite(rate)
        step = max(1, int(ok.sum()) // MAX_POINTS)
        top.plot(temp[ok][::step], rate[ok][::step], ".", ms=1, color=_RAW_COLOR, label="samples", rasterized=True)
        centres, means = _bin_means(temp[ok], rate[ok], cal.temp_min_c, BIN_WIDTH_C)
        fitted = cal.drift(axis, curve)
        top.plot(centres, means, ".", ms=3, color="#1f77b4", label=f"mean per {BIN_WIDTH_C:g} degC")
        top.plot(curve, fitted, color="#d62728", lw=1.4, label="fitted cubic")
        limits = _robust_limits([means, fitted], rate[ok])
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
    """Scale factor and the heading error it causes (paper Figs. 10 and 11).

    Parameters
    ----------
    fig10 : DataFrame
        ``t`` (s), ``sf_ideal``, ``sf_fixed``, ``sf_adaptive`` (unitless).
    fig11 : DataFrame
        ``t`` (s) and heading errors (deg) ``err_none``, ``err_fixed``,
        ``err_adaptive`` (and optionally ``err_ideal``), as returned by
        :func:`gyrodrift.paper.scale_factor_experiment`.
    """
    _need(fig10, ("t", "sf_ideal", "sf_fixed", "sf_adaptive"), "fig_scale_factor")
    _need(fig11, ("t", "err_none", "err_fixed", "err_adaptive"), "fig_scale_factor")
    x, xlabel = time_axis(_column(fig10, "t"))
    fig, (ax_sf, ax_err) = _figure(5.6, 2)
    styles = {"ideal": ("#1f77b4", "-"), "fixed": ("#2ca02c", "-"), "adaptive": ("#d62728", "-"), "none": ("#1f77b4", "-")}
    for key in ("ideal", "fixed", "adaptive"):
        color, ls = styles[key]
        _plot(ax_sf, x, _column(fig10, f"sf_{key}"), color=color, ls=ls, lw=1.1, label=f"{key} SF")
    ax_sf.set_ylabel("scale factor")
    ax_sf.set_title("Scale factor: ideal, fixed parameters, adaptive (paper Fig. 10)")
    ax_sf.legend(loc="best", fontsize=8)
    x11, _ = time_axis(_column(fig11, "t"))
    labels = {"none": "no SF compensation", "fixed": "fixed SF", "adaptive": "adaptive SF", "ideal": "true SF"}
    for key in ("none", "fixed", "adaptive", "ideal"):
        if f"err_{key}" not in fig11.columns:
            continue
        color, ls = styles[key] if key != "ideal" else ("#7f7f7f", "--")
        _plot(ax_err, x11, _column(fig11, f"err_{key}"), color=color, ls=ls, lw=0.9, label=labels[key])
    ax_err.axhline(0.0, color="#555555", lw=0.6)
    ax_err.set_ylabel("heading error (deg)")
    ax_err.set_title("Heading error (paper Fig. 11)")
    ax_err.set_xlabel(xlabel)
    ax_err.legend(loc="best", fontsize=8)
    _envelope_note(ax_err, len(fig11))
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


# --------------------------------------------------------------------------- output


def _png_bytes(fig, dpi: float) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def png_base64(fig, *, dpi: float = 100) -> str:
    """The figure as a base64-encoded PNG (ASCII), for ``<img src="data:image/png;base64,...">``."""
    return base64.b64encode(_png_bytes(fig, dpi)).decode("ascii")


def save_png(fig, path, *, dpi: float = 100) -> None:
    """Write the figure as PNG, atomically.

    The image goes to a hidden temporary file in the destination folder, which then
    replaces ``path`` in one step (:func:`os.replace`): no reader sees a partial file
    and an existing ``path`` is kept if rendering fails.

    Raises
    ------
    ConfigError
        The destination folder does not exist, ``path`` is a folder, or writing fails.
    """
    path = Path(path)
    data = _png_bytes(fig, dpi)
    _atomic_write(path, data)


def _atomic_write(path: Path, data: bytes) -> None:
    """Write bytes to ``path`` atomically."""
    write_bytes_atomic(path, data)
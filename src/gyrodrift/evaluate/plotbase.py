"""The canvas of gyrodrift's figures: matplotlib on demand, new Agg figures, time axes,
min/max envelopes of long series, robust limits, and PNG output (docs/evaluation.md, section
"Figures").
"""

from __future__ import annotations

import base64
import io
import math
from pathlib import Path

import numpy as np
import pandas as pd

from gyrodrift._atomic import write_bytes_atomic
from gyrodrift.errors import ConfigError, LogFormatError

__all__ = ["MAX_POINTS", "WIDTH_IN", "require_matplotlib", "new_figure", "need_columns", "float_column",
           "minmax_decimate", "time_axis", "envelope_note", "plot_line", "robust_limits", "true_runs", "unwrap_deg",
           "align_turns", "png_base64", "save_png"]


#: Most points drawn per line; longer series are reduced to a min/max envelope.
MAX_POINTS = 20_000
#: Width of every figure, inches.
WIDTH_IN = 10.0


def require_matplotlib():
    """The Figure class and the Agg canvas, or a ConfigError naming the extra to install."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise ConfigError("plots need the optional package matplotlib: pip install 'gyrodrift[plot]'") from exc
    return Figure, FigureCanvasAgg


def new_figure(height_in: float, nrows: int = 1, *, sharex: bool = True):
    """A new Agg figure with ``nrows`` stacked axes (no pyplot); returns (fig, axes list)."""
    Figure, FigureCanvasAgg = require_matplotlib()
    fig = Figure(figsize=(WIDTH_IN, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False)[:, 0]
    for ax in axes:
        ax.grid(True, alpha=0.3, linewidth=0.6)
    return fig, list(axes)


def need_columns(table: pd.DataFrame, columns, what: str) -> None:
    """Raise LogFormatError naming the columns ``what`` needs and the table lacks."""
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise LogFormatError(f"{what} needs the column(s) {', '.join(missing)}, which the table lacks")


def float_column(table: pd.DataFrame, name: str) -> np.ndarray:
    return pd.to_numeric(table[name], errors="coerce").to_numpy(dtype=float)


def minmax_decimate(x, y, max_points: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` reduced to at most ``max_points`` points by a min/max envelope (the input when shorter).

    Each bin of consecutive samples keeps its smallest and largest value, so no spike is lost.
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
    """Time from the first sample in s, min (spans over 10 min) or h (over 2 h), and the axis label."""
    t = np.asarray(t_s, dtype=float)
    rel = t - t[0] if t.size else t
    span = float(rel[-1]) if t.size else 0.0
    if span > 2 * 3600.0:
        return rel / 3600.0, "time from start (h)"
    if span > 600.0:
        return rel / 60.0, "time from start (min)"
    return rel, "time from start (s)"


def envelope_note(ax, n: int) -> None:
    """Say on the axes that long lines are drawn as min/max envelopes."""
    if n > MAX_POINTS:
        k = math.ceil(n / (MAX_POINTS // 2))
        ax.text(
            0.995, 0.01, f"long lines drawn as min/max envelope of {k}-sample bins",
            transform=ax.transAxes, ha="right", va="bottom", fontsize=7, color="#555555",
        )


def plot_line(ax, x, y, **kwargs):
    """``ax.plot`` of a series reduced by :func:`minmax_decimate`."""
    xd, yd = minmax_decimate(x, y)
    return ax.plot(xd, yd, **kwargs)[0]


def robust_limits(core, background, max_ratio: float = 6.0) -> tuple[float, float] | None:
    """y limits covering ``core`` fully and ``background`` robustly (1–99 %), at most ``max_ratio`` core spans."""
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


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) row of each run of True in ``mask``."""
    edges = np.diff(np.r_[0, np.asarray(mask, dtype=np.int8), 0])
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), stops.tolist()))


def unwrap_deg(deg: np.ndarray) -> np.ndarray:
    """Unwrap the finite values of a heading series (deg), keeping NaN where it was."""
    out = np.full(deg.shape, np.nan)
    ok = np.isfinite(deg)
    if ok.any():
        out[ok] = np.unwrap(deg[ok], period=360.0)
    return out


def align_turns(unwrapped: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """Shift an unwrapped heading by whole turns to within 180 deg of ``anchor`` at their first common row."""
    both = np.flatnonzero(np.isfinite(unwrapped) & np.isfinite(anchor))
    if both.size == 0:
        return unwrapped
    i = both[0]
    turns = np.round((anchor[i] - unwrapped[i]) / 360.0)
    return unwrapped + 360.0 * turns


def _png_bytes(fig, dpi: float) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def png_base64(fig, *, dpi: float = 100) -> str:
    """The figure as a base64-encoded PNG (ASCII), for ``<img src="data:image/png;base64,...">``."""
    return base64.b64encode(_png_bytes(fig, dpi)).decode("ascii")


def save_png(fig, path, *, dpi: float = 100) -> None:
    """Write the figure as PNG, atomically (docs/output_files.md, section "Atomic outputs").

    Raises
    ------
    ConfigError
        The destination folder does not exist, ``path`` is a folder, or writing fails.
    """
    write_bytes_atomic(Path(path), _png_bytes(fig, dpi))

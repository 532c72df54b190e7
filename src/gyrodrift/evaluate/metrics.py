"""Accuracy of a compensated log against a reference heading or the true drift.

Heading and bias errors, their statistics, the paper's Table 2 and a Markdown renderer:
docs/evaluation.md, section "Error statistics".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping, NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.conventions import REF_HEADING, TRUE_BIAS_Z, T, wrap_180
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.kernels.integrate import trapezoid

__all__ = [
    "heading_error_deg",
    "raw_heading_deg",
    "Accuracy",
    "accuracy",
    "bias_error",
    "error_stats",
    "heading_error_stats",
    "TABLE2_STATS",
    "TABLE2_KINDS",
    "table2",
    "MeanVariance",
    "PAPER_TABLE2",
    "PAPER_METHODS",
    "paper_table2",
    "markdown_table",
]


def heading_error_deg(heading_deg, ref_heading_deg) -> np.ndarray:
    """Heading minus reference, deg, wrapped to [-180, 180)."""
    return wrap_180(np.asarray(heading_deg, dtype=float) - np.asarray(ref_heading_deg, dtype=float))


def raw_heading_deg(t_s, gyro_z_dps, start_deg: float) -> np.ndarray:
    """Heading integrated (trapezoid rule) from the uncompensated gyro, deg (unwrapped)."""
    return start_deg + trapezoid(t_s, gyro_z_dps)


@dataclass(frozen=True)
class Accuracy:
    """Errors of one run (deg against ``ref_heading``, deg/s against ``true_bias_z``); None without that column."""

    heading_rms_raw: float | None
    heading_rms: float | None
    heading_max_raw: float | None
    heading_max: float | None
    bias_rms_raw: float | None
    bias_rms: float | None


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def accuracy(out: pd.DataFrame) -> Accuracy:
    """Accuracy of a :func:`gyrodrift.compensator.compensate` output table, raw and compensated."""
    h_rms_raw = h_rms = h_max_raw = h_max = b_rms_raw = b_rms = None
    if REF_HEADING in out.columns:
        ok = out[REF_HEADING].notna().to_numpy()
        raw = raw_heading_deg(out["t"], out["gyro_z"], float(out["heading"].iloc[0]))
        e_raw = heading_error_deg(raw, out[REF_HEADING])[ok]
        e = heading_error_deg(out["heading"], out[REF_HEADING])[ok]
        h_rms_raw, h_rms = _rms(e_raw), _rms(e)
        h_max_raw, h_max = float(np.max(np.abs(e_raw))), float(np.max(np.abs(e)))
    if TRUE_BIAS_Z in out.columns:
        truth = out[TRUE_BIAS_Z].to_numpy(float)
        b_rms_raw = _rms(truth)
        b_rms = _rms(out["bias_z"].to_numpy(float) - truth)
    return Accuracy(h_rms_raw, h_rms, h_max_raw, h_max, b_rms_raw, b_rms)


# ----------------------------------------------------------------- Table 2 (paper)


def _column(out: pd.DataFrame, name: str, what: str) -> np.ndarray:
    if name not in out.columns:
        raise LogFormatError(f"{what} needs a {name!r} column; the table has {', '.join(map(str, out.columns))}")
    return out[name].to_numpy(dtype=float)


def _window_means(t_s: np.ndarray, x: np.ndarray, window_s: float) -> np.ndarray:
    """Means of ``x`` over the complete windows of ``window_s`` seconds (docs/evaluation.md)."""
    t_s = np.asarray(t_s, dtype=float)
    x = np.asarray(x, dtype=float)
    if t_s.size < 2:
        raise ConfigError("averaging windows need at least two samples")
    dt = float(np.median(np.diff(t_s)))
    # Rounding keeps samples that sit on a window edge (t = k·w in floating point) in the right window.
    k = np.floor(np.round((t_s - t_s[0]) / window_s, 9)).astype(np.int64)
    n_complete = int(math.floor(round((t_s[-1] - t_s[0] + dt) / window_s, 9)))
    if n_complete < 1:
        raise ConfigError(
            f"average_s={window_s:g} s is longer than the log ({t_s[-1] - t_s[0] + dt:g} s): no complete window"
        )
    keep = (k < n_complete) & np.isfinite(x)
    sums = np.bincount(k[keep], weights=x[keep], minlength=n_complete)
    counts = np.bincount(k[keep], minlength=n_complete)
    return sums[counts > 0] / counts[counts > 0]


def bias_error(out: pd.DataFrame, *, average_s: float | None = None) -> np.ndarray:
    """Bias drift error of a compensated log, deg/s (the static rows of the paper's Table 2).

    ``bias_z − true_bias_z``, or ``rate_z`` without the truth (docs/evaluation.md, section
    "Error statistics").

    Parameters
    ----------
    out : DataFrame
        Output table of :func:`gyrodrift.compensator.compensate`.
    average_s : float, optional
        Average over consecutive windows of this many seconds; only complete windows count.

    Returns
    -------
    ndarray
        One error per row, or one mean per window with ``average_s``.
    """
    if TRUE_BIAS_Z in out.columns:
        e = _column(out, "bias_z", "bias_error") - out[TRUE_BIAS_Z].to_numpy(dtype=float)
    else:
        e = _column(out, "rate_z", "bias_error")
    if average_s is None:
        return e
    if not (isinstance(average_s, (int, float)) and math.isfinite(average_s) and average_s > 0):
        raise ConfigError(f"average_s must be a positive number of seconds, got {average_s!r}")
    return _window_means(_column(out, T, "bias_error with average_s"), e, float(average_s))


def error_stats(errors) -> dict[str, float]:
    """``mean``, ``variance``, ``std`` (ddof=1), ``min``, ``max``, ``rms``, ``max_abs``, ``n`` of the finite errors."""
    e = np.asarray(errors, dtype=float).ravel()
    e = e[np.isfinite(e)]
    if e.size == 0:
        raise LogFormatError("no finite error values to summarise")
    var = float(np.var(e, ddof=1)) if e.size > 1 else math.nan
    return {
        "mean": float(np.mean(e)),
        "variance": var,
        "std": math.sqrt(var) if e.size > 1 else math.nan,
        "min": float(np.min(e)),
        "max": float(np.max(e)),
        "rms": _rms(e),
        "max_abs": float(np.max(np.abs(e))),
        "n": int(e.size),
    }


def heading_error_stats(out: pd.DataFrame) -> dict[str, float]:
    """:func:`error_stats` of the wrapped heading error against ``ref_heading``, deg (docs/evaluation.md)."""
    ref = _column(out, REF_HEADING, "heading_error_stats")
    e = heading_error_deg(_column(out, "heading", "heading_error_stats"), ref)
    e = e[np.isfinite(ref)]
    if "compass_heading" in out.columns and e.size and not np.isfinite(out["compass_heading"].to_numpy(float)).any():
        e = heading_error_deg(e - e[0], 0.0)
    return error_stats(e)


#: Rows of :func:`table2`: the paper's mean and variance, then extra statistics.
TABLE2_STATS = ("mean", "variance", "std", "rms", "max_abs")

#: Kinds of :func:`table2` and the quantity each summarises.
TABLE2_KINDS = MappingProxyType({"static": "bias drift error (deg/s)", "dynamic": "heading error (deg)"})


def table2(
    out_by_method: Mapping[str, pd.DataFrame],
    *,
    kind: str = "static",
    average_s: float | None = None,
) -> pd.DataFrame:
    """Table 2 of the paper for your own runs: one column per method.

    Parameters
    ----------
    out_by_method : mapping of str to DataFrame
        Output table per method name, in column order.
    kind : {"static", "dynamic"}
        Bias drift error (deg/s) of motionless logs, or heading error (deg).
    average_s : float, optional
        Static only: the averaging window of :func:`bias_error`.

    Returns
    -------
    DataFrame
        Rows :data:`TABLE2_STATS`, named after the quantity; compare with :func:`paper_table2`.
    """
    if kind not in TABLE2_KINDS:
        raise ConfigError(f"kind must be one of {', '.join(TABLE2_KINDS)}, got {kind!r}")
    if not out_by_method:
        raise ConfigError("table2 needs at least one method")
    if average_s is not None and kind != "static":
        raise ConfigError("average_s applies to the static (bias drift error) table only")
    cols = {}
    for method, out in out_by_method.items():
        stats = (
            error_stats(bias_error(out, average_s=average_s)) if kind == "static" else heading_error_stats(out)
        )
        cols[method] = [stats[s] for s in TABLE2_STATS]
    df = pd.DataFrame(cols, index=pd.Index(TABLE2_STATS, name=TABLE2_KINDS[kind]), columns=list(out_by_method))
    return df


class MeanVariance(NamedTuple):
    """Mean and variance of one cell pair of the paper's Table 2."""

    mean: float
    variance: float


#: Method columns of the paper's Table 2, in its order.
PAPER_METHODS = ("MLR", "KF", "Modified LSM", "Adaptive Algorithm")


def _paper_rows(means, variances):
    return MappingProxyType({m: MeanVariance(a, v) for m, a, v in zip(PAPER_METHODS, means, variances)})


#: Table 2 of Feng, Li, Zhang (Sensors 2015, 15, 11222–11238), transcribed (docs/evaluation.md).
PAPER_TABLE2 = MappingProxyType(
    {
        "static": _paper_rows(
            (0.002134, -1.1496e-4, -2.4515e-4, 2.1619e-5),
            (5.5005e-4, 7.5105e-5, 1.1416e-4, 6.7660e-5),
        ),
        "static_interference": _paper_rows(
            (0.002134, 0.003023, -2.0156e-4, 1.7511e-4),
            (5.5005e-4, 3.4361e-4, 1.8643e-4, 9.3155e-5),
        ),
        "dynamic": _paper_rows(
            (1.4882, -1.9085, -11.5318, 0.2743),
            (46.9166, 9.8503, 34.7090, 0.9926),
        ),
    }
)


def paper_table2(kind: str = "static") -> pd.DataFrame:
    """The paper's ``mean`` and ``variance`` of one experiment (a key of :data:`PAPER_TABLE2`) per method."""
    if kind not in PAPER_TABLE2:
        raise ConfigError(f"kind must be one of {', '.join(PAPER_TABLE2)}, got {kind!r}")
    rows = PAPER_TABLE2[kind]
    name = TABLE2_KINDS["dynamic" if kind == "dynamic" else "static"]
    return pd.DataFrame(
        {m: [rows[m].mean, rows[m].variance] for m in PAPER_METHODS},
        index=pd.Index(["mean", "variance"], name=name),
    )


# ------------------------------------------------------------------------ Markdown


def _cell(value, floatfmt: str) -> str:
    if value is None:
        return ""
    if isinstance(value, (float, np.floating)):
        return "" if math.isnan(value) else format(float(value), floatfmt)
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        return str(int(value))
    return str(value).replace("|", "\\|").replace("\n", " ")


def markdown_table(df: pd.DataFrame, floatfmt: str = ".4g", *, index: bool = True) -> str:
    """A table as GitHub-flavoured Markdown, no trailing newline (docs/evaluation.md).

    ``floatfmt`` is the :func:`format` spec of float cells; ``index`` puts the index first.
    """
    columns = [str(c) for c in df.columns]
    right = [pd.api.types.is_numeric_dtype(df[c]) and not pd.api.types.is_bool_dtype(df[c]) for c in df.columns]
    body = [[_cell(v, floatfmt) for v in row] for row in df.itertuples(index=False, name=None)]
    if index:
        columns = [str(df.index.name) if df.index.name is not None else ""] + columns
        right = [False] + right
        body = [[_cell(i, floatfmt)] + r for i, r in zip(df.index, body)]
    columns = [_cell(c, floatfmt) for c in columns]
    lines = [
        "| " + " | ".join(columns) + " |",
        "| " + " | ".join("---:" if r else ":---" for r in right) + " |",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in body]
    return "\n".join(lines)

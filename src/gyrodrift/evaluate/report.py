"""A self-contained HTML report of one log compensated by several methods (``gyrodrift report``).

What the page holds: docs/evaluation.md, section "The HTML report"; its figures and their
notes: :mod:`gyrodrift.evaluate.report_figures`.
"""

from __future__ import annotations

import math
import sys
from dataclasses import fields, is_dataclass
from importlib import metadata
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from gyrodrift._atomic import write_bytes_atomic
from gyrodrift._progress import progress_iter as _progress
from gyrodrift._text import printable
from gyrodrift._version import __version__
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.compensator.output import updated_column
from gyrodrift.conventions import MAG_COLS, REF_HEADING, TRUE_BIAS_Z
from gyrodrift.errors import GyroDriftError
from gyrodrift.evaluate.compare import is_causal
from gyrodrift.evaluate.compare import method_label as _label
from gyrodrift.evaluate.metrics import bias_error, error_stats, heading_error_deg, raw_heading_deg
from gyrodrift.evaluate.plotbase import require_matplotlib
from gyrodrift.evaluate.plots import GATE_COLORS
from gyrodrift.evaluate.report_figures import esc, figure_plan, html_table, render_figure

__all__ = ["build_report", "write_report"]


_NONE = "–"


# ----------------------------------------------------------------------- helpers


def _num(value, spec: str = ".4g") -> str:
    """A number for a table cell; a dash for None/NaN."""
    if value is None:
        return _NONE
    value = float(value)
    return _NONE if not math.isfinite(value) else format(value, spec)


def _duration_text(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    if seconds < 600:
        return f"{seconds:.1f} s"
    h, rest = divmod(int(round(seconds)), 3600)
    m, s = divmod(rest, 60)
    return (f"{h} h {m:02d} min {s:02d} s" if h else f"{m} min {s:02d} s") + f" ({seconds:.0f} s)"


# ------------------------------------------------------------------ what was read


def _compass_form(log: pd.DataFrame) -> str:
    form = log.attrs.get("compass")  # read_log's compass form (simulate() puts its model here)
    if isinstance(form, str) and form:
        return {"heading": "heading column", "mag": "raw magnetometer + accelerometer (tilt-compensated)",
                "both": "heading column and raw magnetometer"}.get(form, str(form))
    if "heading" in log.columns:
        return "heading column"
    if all(c in log.columns for c in MAG_COLS):
        return "raw magnetometer + accelerometer (tilt-compensated)"
    return "none"


def _compass_samples(log: pd.DataFrame) -> int:
    if "heading" in log.columns:
        return int(log["heading"].notna().sum())
    if MAG_COLS[0] in log.columns:
        return int(log[MAG_COLS[0]].notna().sum())
    return 0


def _read_section(log, outputs, skipped, source: str) -> str:
    t = log["t"].to_numpy(float)
    dur = float(t[-1] - t[0]) if t.size > 1 else 0.0
    fs = (t.size - 1) / dur if dur > 0 else float("nan")
    temp = log["temp"]
    n_compass = _compass_samples(log)
    compass = _compass_form(log)
    if n_compass and dur > 0:
        compass += f", {n_compass} samples ({n_compass / dur:.3g} Hz mean)"
    evaluation = [c for c in (REF_HEADING, TRUE_BIAS_Z) if c in log.columns]
    units = []
    if "gyro_unit" in log.attrs:
        units.append(f"gyro unit in file {log.attrs['gyro_unit']}")
    if "frame" in log.attrs:
        units.append(f"frame {str(log.attrs['frame']).upper()}")
    run = [f"{esc(_label(m))}" + ("" if is_causal(m) else " <span class=nc>(non-causal)</span>") for m in outputs]
    rows = [
        ("file", esc(source)),
        ("rows", f"{len(log)}"),
        ("duration", esc(_duration_text(dur))),
        ("sample rate", f"{fs:.4g} Hz (mean)"),
        ("temperature", f"{temp.min():.2f} to {temp.max():.2f} degC"),
        ("compass", esc(compass)),
        ("evaluation columns", esc(", ".join(evaluation)) if evaluation else "none (no error statistics)"),
    ]
    if units:
        rows.append(("read as", esc(", ".join(units))))
    rows.append(("methods run", ", ".join(run) if run else "none"))
    if skipped:
        items = "".join(f"<li><b>{esc(m)}</b>: {esc(r)}</li>" for m, r in skipped.items())
        rows.append(("methods skipped", f"<ul>{items}</ul>"))
    body = "".join(f"<tr><th scope=row>{k}</th><td>{v}</td></tr>" for k, v in rows)
    return f'<section id="read"><h2>What was read</h2><table class="facts">{body}</table></section>'


# ------------------------------------------------------------------ summary table


def _raw_errors(log_like: pd.DataFrame, start_heading: float):
    """Bias error and heading error of the uncompensated gyro (None where no truth)."""
    bias = heading = None
    if TRUE_BIAS_Z in log_like.columns:
        bias = -log_like[TRUE_BIAS_Z].to_numpy(float)
    if REF_HEADING in log_like.columns:
        gyro = log_like["gyro_z"].ffill().to_numpy(float)
        raw = raw_heading_deg(log_like["t"].to_numpy(float), gyro, start_heading)
        heading = heading_error_deg(raw, log_like[REF_HEADING].to_numpy(float))
    return bias, heading


def _stats(errors) -> dict | None:
    if errors is None:
        return None
    e = np.asarray(errors, dtype=float)
    if not np.isfinite(e).any():
        return None
    return error_stats(e)


def _summary_section(log, outputs) -> str:
    if not outputs:
        return '<section id="summary"><h2>Summary</h2><p class="note">No method ran: nothing to summarise.</p></section>'
    has_truth = TRUE_BIAS_Z in log.columns
    has_ref = REF_HEADING in log.columns
    reasons = []
    for out in outputs.values():
        for r in out["gate_reason"].fillna("").astype(str).unique():
            if r and r not in reasons:
                reasons.append(r)
    reasons.sort(key=lambda r: list(GATE_COLORS).index(r) if r in GATE_COLORS else len(GATE_COLORS))
    header = ["method"]
    if has_truth:
        header += ["bias error mean (deg/s)", "bias error variance ((deg/s)²)", "bias error RMS (deg/s)"]
    if has_ref:
        header += ["heading error mean (deg)", "heading error variance (deg²)", "heading error RMS (deg)",
                   "heading error max |·| (deg)"]
    header += ["filter updates", "gated rows (all reasons)"] + [f"gated: {esc(r)}" for r in reasons]

    def error_cells(bias, heading):
        cells = []
        if has_truth:
            s = _stats(bias)
            cells += [_num(s and s["mean"]), _num(s and s["variance"]), _num(s and s["rms"])]
        if has_ref:
            s = _stats(heading)
            cells += [_num(s and s["mean"]), _num(s and s["variance"]), _num(s and s["rms"]), _num(s and s["max_abs"])]
        return cells

    rows = []
    first = next(iter(outputs.values()))
    if has_truth or has_ref:
        bias, heading = _raw_errors(first, float(first["heading"].iloc[0]))
        rows.append(["raw gyro (no compensation)"] + error_cells(bias, heading) + [_NONE] * (2 + len(reasons)))
    for name, out in outputs.items():
        bias = bias_error(out) if has_truth and TRUE_BIAS_Z in out.columns else None
        heading = (
            heading_error_deg(out["heading"].to_numpy(float), out[REF_HEADING].to_numpy(float))
            if has_ref and REF_HEADING in out.columns else None
        )
        reason = out["gate_reason"].fillna("").astype(str)
        n = max(len(out), 1)
        share = [f"{100.0 * float((reason == r).sum()) / n:.1f} %" for r in reasons]
        label = esc(_label(name)) + ("" if is_causal(name) else " †")
        rows.append(
            [label] + error_cells(bias, heading)
            + [str(int(pd.to_numeric(updated_column(out, name), errors="coerce").fillna(0).sum())),
               f"{100.0 * float((reason != '').sum()) / n:.1f} %"] + share
        )
    notes = []
    if has_truth:
        notes.append("bias error = <code>bias_z − true_bias_z</code> on every row (deg/s); the raw gyro's is "
                     "<code>−true_bias_z</code> (no drift removed)")
    else:
        notes.append("no true_bias_z: bias error not computed")
    if has_ref:
        notes.append("heading error = <code>heading − ref_heading</code> wrapped to ±180 deg on rows with a "
                     "reference; the raw gyro's heading is integrated from the same start")
    else:
        notes.append("no ref_heading: heading error not computed")
    notes.append("variance with ddof = 1; filter updates = accepted compass-aiding intervals; gated = share of "
                 "rows where compass aiding was refused, by reason (see the parameter figure)")
    notes.append("† non-causal: uses the whole log (mlr) or the true drift (oracle), not possible in real time")
    note = "<ul class=how>" + "".join(f"<li>{n}</li>" for n in notes) + "</ul>"
    return f'<section id="summary"><h2>Summary</h2>{html_table(header, rows, cls="summary")}{note}</section>'


# ----------------------------------------------------------------------- settings


def _flatten(obj, prefix: str = ""):
    for f in fields(obj):
        value = getattr(obj, f.name)
        if is_dataclass(value):
            yield from _flatten(value, f"{prefix}{f.name}.")
        else:
            yield f"{prefix}{f.name}", value


def _versions() -> list[tuple[str, str]]:
    out = [("gyrodrift", __version__), ("Python", sys.version.split()[0])]
    for dist in ("numpy", "pandas", "matplotlib", "allantools"):
        try:
            out.append((dist, metadata.version(dist)))
        except metadata.PackageNotFoundError:
            out.append((dist, "not installed"))
    return out


def _settings_section(config: CompensatorConfig, outputs) -> str:
    versions = ", ".join(f"{esc(k)} {esc(v)}" for k, v in _versions())
    rows = [[f"<code>{esc(k)}</code>", f"<code>{esc(v)}</code>"] for k, v in _flatten(config)]
    estimators = [f"{esc(_label(m))}: {esc(o.attrs.get('estimator', m))}" for m, o in outputs.items()]
    text = f"<p>Software: {versions}.</p>"
    if estimators:
        text += (f"<p>Estimator of each method: {', '.join(estimators)} (every method sees the same gates and "
                 "settings; only the drift estimate differs).</p>")
    return (f'<section id="settings"><h2>Software and settings</h2>{text}'
            f'{html_table(["setting (CompensatorConfig)", "value"], rows, cls="settings")}</section>')


# --------------------------------------------------------------------------- page


_CSS = """
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#1d1d1f;
background:#fff;margin:0 auto;max-width:1060px;padding:1.2em 1.5em 3em}
h1{font-size:1.6em;margin:.2em 0 .1em}h2{font-size:1.2em;margin:1.6em 0 .5em;border-bottom:1px solid #ddd;
padding-bottom:.2em}.sub{color:#555;margin:0 0 1em}
table{border-collapse:collapse;font-size:.86em;margin:.4em 0}th,td{border:1px solid #d4d4d4;padding:.25em .5em;
vertical-align:top}thead th{background:#f3f3f3;font-weight:600}
table.summary td:not(:first-child),table.summary th:not(:first-child){text-align:right}
table.facts th{text-align:left;background:#f7f7f7;white-space:nowrap}table.facts ul{margin:0;padding-left:1.2em}
img{display:block;max-width:100%;height:auto;margin:.3em 0;border:1px solid #eee}
.how{color:#333;font-size:.9em}.missing{color:#8a4b00;background:#fff6e5;border-left:4px solid #f0a030;
padding:.4em .7em}.nc{color:#8a4b00}.note{color:#555}code{font-size:.92em}
footer{margin-top:2.5em;color:#666;font-size:.85em}
"""

_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"


def build_report(
    log: pd.DataFrame,
    outputs: Mapping[str, pd.DataFrame],
    skipped: Mapping[str, str] | None = None,
    *,
    title: str,
    source: str,
    config: CompensatorConfig | None = None,
) -> str:
    """One self-contained HTML page reporting a log compensated by several methods.

    Parameters
    ----------
    log : DataFrame
        The input log (input contract).
    outputs : mapping of str to DataFrame
        Method name → output table (:func:`gyrodrift.evaluate.compare.run_methods`).
    skipped : mapping of str to str, optional
        Method name → why it did not run.
    title : str
        Page title and heading (control characters shown as escapes, :mod:`gyrodrift._text`).
    source : str
        What was read (file name), shown likewise.
    config : CompensatorConfig, optional
        Settings the methods ran with (default: the defaults).

    Returns
    -------
    str
        The HTML document.

    Raises
    ------
    ConfigError
        matplotlib is not installed (``pip install 'gyrodrift[plot]'``).
    """
    config = config or CompensatorConfig()
    skipped = dict(skipped or {})
    outputs = dict(outputs)
    title, source = printable(title), printable(source)  # one line each, whatever the file name holds
    require_matplotlib()
    plan = figure_plan(log, outputs, config)
    parts = []
    for entry in _progress(plan, len(plan), "report figures"):
        try:
            parts.append(render_figure(entry))
        except GyroDriftError as err:  # e.g. allantools missing: leave this figure out, say why
            entry.make, entry.missing = None, f"{entry.title} not shown: {err}"
            parts.append(render_figure(entry))
    omitted = [e for e in plan if e.make is None and e.missing]
    toc = "".join(
        f'<li><a href="#fig-{e.key}">{esc(e.title)}</a>' + (" (not shown)" if e.make is None else "") + "</li>"
        for e in plan
    )
    body = [
        f"<header><h1>{esc(title)}</h1>",
        f'<p class="sub">Temperature-drift compensation of a MEMS gyro with compass aiding (gyrodrift '
        f"{esc(__version__)}, after Feng, Li, Zhang, Sensors 2015, doi:10.3390/s150511222).</p></header>",
        _read_section(log, outputs, skipped, source),
        _summary_section(log, outputs),
        f'<nav><h2>Figures</h2><ul><li><a href="#summary">Summary table</a></li>{toc}'
        f'<li><a href="#settings">Software and settings</a></li></ul></nav>',
        *parts,
        _settings_section(config, outputs),
        f"<footer>Generated by gyrodrift {esc(__version__)}. "
        f"{len(plan) - len(omitted)} of {len(plan)} figures shown.</footer>",
    ]
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        '<link rel="icon" href="data:,">'
        f"<title>{esc(title)}</title><style>{_CSS}</style></head>\n<body>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )


def write_report(path, html: str) -> None:
    """Write the report atomically (docs/output_files.md, section "Atomic outputs").

    Raises
    ------
    ConfigError
        The folder does not exist (named in the message), ``path`` is a folder, or
        writing fails.
    """
    write_bytes_atomic(Path(path), html.encode("utf-8"))

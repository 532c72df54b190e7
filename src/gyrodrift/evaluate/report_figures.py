"""The figures of ``gyrodrift report``: which figures a log supports, each with its note on
how to read it, and the HTML they are embedded in.

The Allan figure's rate error and true rate: docs/evaluation.md, section "The HTML report".
"""

from __future__ import annotations

import html as _html
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np
import pandas as pd

from gyrodrift.calibrate import CalibrationError, fit_calibration
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.conventions import REF_HEADING, TRUE_BIAS_Z
from gyrodrift.evaluate import plots
from gyrodrift.evaluate.allan import allan_deviation, even_rate, noise_terms
from gyrodrift.evaluate.compare import DEFAULT_METHOD
from gyrodrift.evaluate.compare import method_label as _label
from gyrodrift.evaluate.plotbase import png_base64

__all__ = ["ALLAN_METHODS", "esc", "html_table", "main_method", "figure_plan", "render_figure"]


def esc(value) -> str:
    return _html.escape(str(value), quote=True)


def html_table(header: list[str], rows: list[list[str]], *, cls: str = "") -> str:
    """An HTML table; cells are already-escaped HTML."""
    head = "".join(f"<th>{h}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    attr = f' class="{cls}"' if cls else ""
    return f"<table{attr}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def main_method(outputs: Mapping[str, pd.DataFrame]) -> str | None:
    """The default estimator if it ran, else ``stkf`` if it ran, else the first method that ran."""
    for name in (DEFAULT_METHOD, "stkf"):
        if name in outputs:
            return name
    return next(iter(outputs), None)


#: Methods whose compensated rate error gets an Allan-deviation curve (paper Fig. 6), the default estimator first.
ALLAN_METHODS = (DEFAULT_METHOD, "stkf", "kf", "mlr")


_DPI = 100


@dataclass(frozen=True)
class _AllanInput:
    rates: dict  # label -> rate error array, deg/s
    fs_hz: float
    truth: str  # how the true rate was obtained
    span: str  # which rows were used


def _longest_even_stretch(t: np.ndarray) -> slice:
    """Rows of the longest stretch without a time gap (a step > 1.5 median steps)."""
    dt = np.diff(t)
    med = float(np.median(dt))
    breaks = np.flatnonzero(dt > 1.5 * med)
    edges = np.r_[0, breaks + 1, t.size]
    k = int(np.argmax(np.diff(edges)))
    return slice(int(edges[k]), int(edges[k + 1]))


def _moving_by_rate(out: pd.DataFrame, config: CompensatorConfig) -> bool:
    """True when the 1-s mean compensated rate exceeds the turning threshold anywhere."""
    t = out["t"].to_numpy(float)
    rate = out["rate_z"].ffill().to_numpy(float)
    fs = (t.size - 1) / (t[-1] - t[0])
    n = max(1, int(round(config.gate.turn_window_s * fs)))
    if rate.size < n:
        return False
    mean = np.convolve(rate, np.ones(n) / n, mode="valid")
    return bool(np.nanmax(np.abs(mean)) > config.gate.turn_rate_dps)


def _allan_inputs(outputs, config: CompensatorConfig) -> _AllanInput | str:
    """Rate-error records for the Allan figure, or the reason it cannot be drawn."""
    main = main_method(outputs)
    if main is None:
        return "no method ran: Allan deviation not shown"
    base = outputs[main]
    t = base["t"].to_numpy(float)
    if t.size < 3:
        return "too few rows: Allan deviation not shown"
    ref = base[REF_HEADING].to_numpy(float) if REF_HEADING in base.columns else None
    true_rate = np.zeros(t.size)
    usable = np.ones(t.size, dtype=bool)
    if ref is not None and np.isfinite(ref).sum() >= 2:
        ok = np.isfinite(ref)
        unwrapped = np.interp(t, t[ok], np.unwrap(ref[ok], period=360.0))
        if float(np.ptp(unwrapped[ok])) < 1.0:
            truth = "0 (motionless: ref_heading changes by less than 1 deg)"
        else:
            true_rate = np.gradient(unwrapped, t)
            usable = (t >= t[ok][0]) & (t <= t[ok][-1])
            truth = "d(ref_heading)/dt (the log moves)"
    elif _moving_by_rate(base, config):
        return ("the log moves (1-s mean rate above the turning threshold) and has no ref_heading, so the true "
                "rate is unknown: Allan deviation not shown")
    else:
        truth = "0 (motionless: the 1-s mean compensated rate never exceeds the turning threshold)"
    stretch = _longest_even_stretch(t)
    rows = np.flatnonzero(usable)
    rows = rows[(rows >= stretch.start) & (rows < stretch.stop)]
    if rows.size < 3:
        return "no evenly sampled stretch of 3 rows or more: Allan deviation not shown"
    rows = slice(int(rows[0]), int(rows[-1]) + 1)
    tt = t[rows]
    rates = {"raw gyro_z": base["gyro_z"].ffill().to_numpy(float)[rows] - true_rate[rows]}
    chosen = [m for m in ALLAN_METHODS if m in outputs] or [main]
    for name in chosen:
        rates[f"{_label(name)} rate_z"] = outputs[name]["rate_z"].to_numpy(float)[rows] - true_rate[rows]
    even = {label: even_rate(tt, r) for label, r in rates.items()}  # a jittery time base resampled
    rates = {label: r for label, (r, _, _) in even.items()}
    _, fs, resampled = next(iter(even.values()))
    span = "all rows" if tt.size == t.size else f"rows {rows.start}–{rows.stop - 1} (longest stretch without a time gap)"
    if resampled:
        span += ", resampled to an even time base (the time stamps jitter)"
    return _AllanInput(rates=rates, fs_hz=float(fs), truth=truth, span=span)


@dataclass
class _Figure:
    key: str
    title: str
    how: str
    make: Callable[[], object] | None = None  # returns a Figure
    missing: str | None = None  # one-line note when left out
    extra: str = ""  # HTML after the figure (e.g. a table)


_HOW = {
    "temperature": "Top: the gyro temperature. Bottom: its rate of change T′ as the compensator computed it. "
    "The drift model a·T + b·T′ + c uses both; a gyro drifts fastest where |T′| is large, while heating or "
    "cooling (paper Fig. 1a and 7).",
    "rates": "Grey: the raw gyro rate; red: the rate after subtracting the estimated drift. On a motionless log "
    "the red line should stay centred on zero however the temperature changes (paper Fig. 3); on a moving log "
    "both show the motion and differ by the drift estimate.",
    "bias": "Each method's drift estimate bias_z. Black dashed: the true drift (simulated logs); grey: the raw "
    "rate, which on a motionless log is the drift plus noise (paper Fig. 2). The closer a line follows the "
    "truth, the smaller its bias error in the summary table. Steps happen at filter updates.",
    "params": "The parameters of drift = a·T + b·T′ + c in force at each row. Dots: filter updates, one per "
    "accepted interval. Shaded: rows where compass aiding was refused, coloured by reason (init, gap, "
    "no_compass, field, turning, interference); there the parameters are held and keep compensating (paper "
    "eq. 5). Long shaded stretches are where the filter could not learn.",
    "heading": "Blue: the compass heading; red: the heading integrated from the compensated gyro, starting at "
    "the first compass heading; green dashed: the reference. All unwrapped (no jump at 0/360 deg). Compass "
    "disturbances show as blue bumps that the gyro heading does not follow (paper Fig. 8).",
    "heading_error": "Heading minus reference, wrapped to ±180 deg. Solid lines: causal methods (possible in "
    "real time); dashed: non-causal ones (mlr is fitted on the whole log; oracle removes the true drift and "
    "shows the limit set by gyro noise alone). Growth during the shaded stretches of the parameter figure shows "
    "how well a method holds its drift model through aiding outages (paper Figs. 4, 5, 9).",
    "calibration": "What gyrodrift calibrate would write for an autopilot from this log: per gyro axis, the drift "
    "as a cubic in temperature (red) over the temperatures seen (TMIN..TMAX), fitted to the still samples (grey; "
    "blue: their mean per temperature bin, each bin weighing the same). Bottom: bin mean minus fit; dashed: ± the "
    "residual RMS calibrate prints. A residual with a shape (a loop, a trend) is drift a cubic in temperature does "
    "not explain, e.g. heating-rate dependence, which the adaptive filter's b·T′ term and the compass take up.",
    "allan": "Allan deviation of the angular-rate error (rate minus the true rate) against averaging time τ, "
    "with 68 % confidence bands. Slope −1/2: angle random walk N (read at τ = 1 s); flat bottom: bias "
    "instability B; +1/2: rate random walk K (read at τ = 3 s); +1: rate ramp. Temperature compensation should "
    "lower the long-τ (right-hand) part of the raw curve (paper Fig. 6).",
}


def figure_plan(log, outputs, config) -> list[_Figure]:
    main = main_method(outputs)
    first = next(iter(outputs.values()), None)
    temp_table = first if first is not None else log
    plan = [_Figure("temperature", "Temperature", _HOW["temperature"], make=lambda: plots.fig_temperature(temp_table)),
            _calibration_figure(log)]
    if main is None:
        note = "no method ran: compensation figures not shown"
        for key, title in (("rates", "Raw and compensated rate"), ("bias", "Drift estimates"),
                           ("params", "Drift-model parameters"), ("heading", "Headings"),
                           ("heading_error", "Heading error"), ("allan", "Allan deviation")):
            plan.append(_Figure(key, title, _HOW[key], missing=note))
        return plan
    out = outputs[main]
    label = _label(main)
    plan.append(_Figure("rates", f"Raw and compensated rate ({label})", _HOW["rates"],
                        make=lambda: plots.fig_rates(out, method=label)))
    how = _HOW["bias"] if TRUE_BIAS_Z in log.columns else _HOW["bias"] + " No true_bias_z: the true drift is not drawn."
    plan.append(_Figure("bias", "Drift estimates of every method", how, make=lambda: plots.fig_bias(outputs)))
    if out[["a", "b", "c"]].notna().any().any():
        plan.append(_Figure("params", f"Drift-model parameters and aiding gates ({label})", _HOW["params"],
                            make=lambda: plots.fig_params(out, method=label)))
    else:
        plan.append(_Figure("params", "Drift-model parameters", _HOW["params"],
                            missing=f"{label} has no a, b, c parameters: parameter figure not shown"))
    plan.append(_Figure("heading", f"Headings ({label})", _HOW["heading"],
                        make=lambda: plots.fig_heading(out, method=label)))
    if REF_HEADING in log.columns:
        plan.append(_Figure("heading_error", "Heading error of every method", _HOW["heading_error"],
                            make=lambda: plots.fig_heading_error(outputs)))
    else:
        plan.append(_Figure("heading_error", "Heading error", _HOW["heading_error"],
                            missing="no ref_heading: heading error not shown"))
    plan.append(_allan_figure(outputs, config))
    return plan


def _calibration_figure(log) -> _Figure:
    """The thermal calibration fit of the log, or a note saying why the log gives none."""
    title = "Thermal calibration fit (gyrodrift calibrate)"
    try:
        cal = fit_calibration(log, source="this log")
    except CalibrationError as err:
        return _Figure("calibration", title, _HOW["calibration"], missing=f"no thermal calibration fit: {err}")
    return _Figure("calibration", title, _HOW["calibration"] + f" {cal.summary()}.",
                   make=lambda: plots.fig_calibration(log, cal))


def _allan_figure(outputs, config) -> _Figure:
    """The Allan entry; the curves are computed when it is rendered (inside :func:`_progress`)."""
    inputs = _allan_inputs(outputs, config)
    if isinstance(inputs, str):
        return _Figure("allan", "Allan deviation", _HOW["allan"], missing=inputs)
    how = _HOW["allan"] + f" True rate: {inputs.truth}; {inputs.span}."
    entry = _Figure("allan", "Allan deviation of the rate error", how)

    def make():
        curves = {label: allan_deviation(r, inputs.fs_hz) for label, r in inputs.rates.items()}
        terms = {label: noise_terms(c) for label, c in curves.items()}
        entry.extra = _terms_table(terms)
        return plots.fig_allan(curves, terms)

    entry.make = make
    return entry


def _term_cell(term, per_hour=None, *, at_tau: bool = False) -> str:
    if term is None:
        return "not seen"
    text = f"{term.value:.3g} [{term.lo:.3g}, {term.hi:.3g}] {esc(term.unit)}"
    if per_hour is not None:
        text += f" = {per_hour.value:.3g} {esc(per_hour.unit)}"
    if at_tau:
        text += f" at τ = {term.tau_s:.3g} s"
    return text


def _terms_table(terms: Mapping[str, object]) -> str:
    rows = []
    for label, t in terms.items():
        per_h = t.unit == "deg/s"
        rows.append([
            esc(label),
            _term_cell(t.arw, t.arw_deg_rt_h if per_h else None),
            _term_cell(t.bias_instability, t.bias_instability_deg_h if per_h else None, at_tau=True),
            _term_cell(t.rrw),
            _term_cell(t.rate_ramp),
        ])
    header = ["rate error", "angle random walk N", "bias instability B", "rate random walk K", "rate ramp R"]
    note = ("<p class=how>Noise terms read off each curve by the slope method of IEEE Std 952 "
            "(<code>gyrodrift.evaluate.allan.noise_terms</code>), with 68 % intervals; “not seen”: the curve has no "
            "region of that slope.</p>")
    return html_table(header, rows, cls="terms") + note


def render_figure(entry: _Figure) -> str:
    head = f'<section class="figure" id="fig-{entry.key}"><h2>{esc(entry.title)}</h2>'
    if entry.make is None:
        return head + f'<p class="missing">{esc(entry.missing)}</p></section>'
    fig = entry.make()
    w, h = (int(round(v * _DPI)) for v in fig.get_size_inches())
    data = png_base64(fig, dpi=_DPI)
    img = (f'<img src="data:image/png;base64,{data}" width="{w}" height="{h}" '
           f'alt="{esc(entry.title)}">')
    return head + img + f'<p class="how"><b>How to read this:</b> {esc(entry.how)}</p>' + entry.extra + "</section>"

"""Every experiment of the paper (Section 4, Table 2, Figures 1–11), regenerated on simulated data.

``gyrodrift paper -o DIR`` writes ``table2.md``, ``results.json`` and the figures. The
experiments, the claims checked and the outputs: docs/evaluation.md, section "The paper's
experiments".
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from gyrodrift._version import __version__
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.conventions import REF_HEADING, TEMP, T, wrap_360
from gyrodrift.errors import ConfigError
from gyrodrift.evaluate import plotbase, plots
from gyrodrift.evaluate.allan import allan_deviation, noise_terms
from gyrodrift.evaluate.compare import METHODS, run_methods
from gyrodrift.evaluate.metrics import (
    bias_error,
    error_stats,
    heading_error_deg,
    heading_error_stats,
    markdown_table,
    paper_table2,
)
from gyrodrift.evaluate.report import write_report
from gyrodrift.fusion import FusionConfig
from gyrodrift.scale_factor import ScaleFactorConfig, estimate_scale_factor, heading_error, integrate_heading
from gyrodrift.scale_factor.batch import heading_anchor
from gyrodrift.simulate import DEFAULT_DURATION_S, TRUE_SF, interference_windows_static, simulate

__all__ = [
    "PaperSettings", "PaperRun", "run_paper", "OURS_TO_PAPER", "table2_comparison", "aligned", "envelope",
    "Claim", "check_claims", "allan_claims", "scale_factor_experiment", "scale_factor_run",
    "scale_factor_claims", "write_paper",
]

#: Our method names for the paper's Table 2 columns.
OURS_TO_PAPER = {"mlr": "MLR", "kf": "KF", "lsm": "Modified LSM", "stkf": "Adaptive Algorithm"}


@dataclass(frozen=True, kw_only=True)
class PaperSettings:
    """What to run (the defaults: docs/evaluation.md, section "The paper's experiments")."""

    seed: int = 1  # of every simulated run (the calibration run's is seed + 1000)
    fs_hz: float = 10.0
    duration_scale: float = 1.0  # times every scenario's default length
    methods: tuple[str, ...] = tuple(m for m in METHODS if m not in ("smoothed", "fusion-offset"))
    config: CompensatorConfig = field(  # the paper's estimator, whatever the package default
        default_factory=lambda: CompensatorConfig(estimator="stkf", fusion=FusionConfig.tolerant()))


@dataclass
class PaperRun:
    """One experiment: its log and the output table of every method."""

    name: str
    log: pd.DataFrame
    outputs: dict[str, pd.DataFrame]
    skipped: dict[str, str]


def aligned(out: pd.DataFrame) -> pd.DataFrame:
    """A copy whose ``ref_heading`` starts where the output's heading starts (heading errors are drifts)."""
    out = out.copy()
    e0 = float(heading_error_deg(out["heading"].iloc[0], out[REF_HEADING].iloc[0]))
    out[REF_HEADING] = wrap_360(out[REF_HEADING].to_numpy() + e0)
    return out


def _blank_windows(log: pd.DataFrame, windows) -> pd.DataFrame:
    """Remove the compass inside (start_s, duration_s, _) windows: forced outages."""
    log = log.copy()
    for start, dur, _ in windows:
        inside = (log["t"] >= start) & (log["t"] < start + dur)
        log.loc[inside, "heading"] = np.nan
    return log


def run_paper(settings: PaperSettings = PaperSettings(), progress=None) -> dict[str, PaperRun]:
    """Run every experiment of the paper but the scale factor's; ``progress(name)`` is called before each."""
    s = settings
    say = progress or (lambda name: None)

    def dur(scenario):
        return DEFAULT_DURATION_S[scenario] * s.duration_scale

    say("calibration run")
    calibration = simulate("calibration", seed=s.seed + 1000, duration_s=dur("calibration"), fs_hz=s.fs_hz)
    runs = {}

    def run(name, log):
        say(name)
        outputs, skipped = run_methods(log, s.methods, s.config, calibration=calibration)
        runs[name] = PaperRun(name, log, outputs, skipped)

    static_clean = simulate("static", seed=s.seed, duration_s=dur("static"), fs_hz=s.fs_hz)
    run("static", static_clean)
    windows = interference_windows_static(dur("static"))
    run("static-outages", _blank_windows(static_clean, windows))
    run("static-interference", simulate("static-outages", seed=s.seed, duration_s=dur("static"), fs_hz=s.fs_hz))
    run("vehicle", simulate("vehicle", seed=s.seed, duration_s=dur("vehicle"), fs_hz=s.fs_hz))
    return runs


def _bias_stats(out):
    return error_stats(bias_error(out))


def _heading_stats(out):
    return heading_error_stats(aligned(out))


def table2_comparison(runs: dict[str, PaperRun]) -> dict[str, pd.DataFrame]:
    """Table 2, ours beside the paper's: one DataFrame per row group (``static``, ``static_interference``,
    ``dynamic``), rows (source, statistic), a column per method."""
    groups = {"static": ("static", _bias_stats), "static_interference": ("static-outages", _bias_stats),
              "dynamic": ("vehicle", _heading_stats)}
    tables = {}
    for kind, (run_name, stat) in groups.items():
        paper = paper_table2(kind)
        outputs = runs[run_name].outputs
        cols = [OURS_TO_PAPER.get(m, m) for m in outputs]
        rows = {}
        for label in ("mean", "variance"):
            rows[("paper", label)] = [
                paper.loc[label, OURS_TO_PAPER[m]] if m in OURS_TO_PAPER else np.nan for m in outputs
            ]
        ours = {m: stat(o) for m, o in outputs.items()}
        for label in ("mean", "variance", "rms", "max_abs"):
            rows[("ours", label)] = [ours[m][label] for m in outputs]
        df = pd.DataFrame(rows, index=cols).T
        df.index = pd.MultiIndex.from_tuples(df.index, names=["source", "statistic"])
        tables[kind] = df
    return tables


def envelope(out: pd.DataFrame) -> tuple[float, float]:
    """Lowest and highest heading error (deg) of a run, reference aligned at the start."""
    st = _heading_stats(out)
    return st["min"], st["max"]


# ----------------------------------------------------------------------------- claims


@dataclass(frozen=True)
class Claim:
    """One quantitative statement of the paper, checked on our runs."""

    where: str  # figure / table of the paper
    claim: str  # what the paper says
    paper: str  # the paper's number
    ours: str  # our number
    reproduced: bool


def _fmt_env(env) -> str:
    return f"{env[0]:.2f} .. {env[1]:.2f} deg"


def _within(env, lo, hi) -> bool:
    return lo <= env[0] and env[1] <= hi


def same_size(paper: float, ours: float) -> bool:
    """The rule for a Table-2 cell: same sign and within a factor of 2 in magnitude."""
    if paper == 0.0:
        return ours == 0.0
    ratio = ours / paper
    return 0.5 <= ratio <= 2.0


def check_claims(runs: dict[str, PaperRun], allan_terms: dict | None = None) -> list[Claim]:
    """The paper's claims about Figs. 4, 5, 9, Table 2 (and Fig. 6 with ``allan_terms`` of :func:`allan_static`)."""
    claims = []
    static, outages, vehicle = (runs[k].outputs for k in ("static", "static-outages", "vehicle"))

    def env(outputs, m):
        return envelope(outputs[m]) if m in outputs else None

    for m, (lo, hi), where in (
        ("stkf", (-0.6, 0.4), "Fig. 4"),
        ("kf", (-1.5, 0.5), "Fig. 4"),
        ("mlr", (-12.5, 15.0), "Fig. 4"),
    ):
        e = env(static, m)
        if e is not None:
            claims.append(Claim(where, f"static heading error of {OURS_TO_PAPER[m]} stays within {lo}..{hi} deg",
                                f"{lo} .. {hi} deg", _fmt_env(e), _within(e, lo, hi)))
    if "oracle" in static:
        e = env(static, "oracle")
        claims.append(Claim("Fig. 4 (context)", "noise floor: heading error with the true drift removed (oracle)",
                            "not given", _fmt_env(e), True))
    if "stkf" in outages:
        e = env(outages, "stkf")
        worst = max(abs(e[0]), abs(e[1]))
        claims.append(Claim("Fig. 5", "with three outages (300/300/600 s) the adaptive heading error stays below 1.8 deg",
                            "< 1.8 deg", f"{worst:.2f} deg", worst < 1.8))
    if {"stkf", "kf"} <= set(outages):
        ws = max(abs(v) for v in env(outages, "stkf"))
        wk = max(abs(v) for v in env(outages, "kf"))
        claims.append(Claim("Fig. 5", "the adaptive algorithm beats KF, MLR and modified LSM when aiding is lost",
                            "adaptive best", f"max |error|: stkf {ws:.2f}, kf {wk:.2f} deg", ws < min(
                                max(abs(v) for v in env(outages, m)) for m in ("kf", "mlr", "lsm") if m in outages)))
    for m, (lo, hi) in (("stkf", (-2.0, 5.0)), ("kf", (-10.0, 5.0)), ("mlr", (-13.0, 15.0))):
        e = env(vehicle, m)
        if e is not None:
            claims.append(Claim("Fig. 9", f"vehicle heading error of {OURS_TO_PAPER[m]} within {lo}..{hi} deg",
                                f"{lo} .. {hi} deg", _fmt_env(e), _within(e, lo, hi)))
    tables = table2_comparison(runs)
    for kind, label in (("static", "static, no interference"), ("static_interference", "static with outages"),
                        ("dynamic", "vehicle heading")):
        df = tables[kind]
        for stat in ("mean", "variance"):
            paper_row = df.loc[("paper", stat)]
            ours_row = df.loc[("ours", stat)]
            for col in OURS_TO_PAPER.values():
                if col not in df.columns:
                    continue
                p, o = float(paper_row[col]), float(ours_row[col])
                claims.append(Claim("Table 2", f"{label}: {stat} of {col}", f"{p:.4g}", f"{o:.4g}", same_size(p, o)))
        ours_var = df.loc[("ours", "variance")]
        cols = [c for c in OURS_TO_PAPER.values() if c in df.columns]
        if "Adaptive Algorithm" in cols:
            best = min(cols, key=lambda c: float(ours_var[c]))
            claims.append(Claim("Table 2", f"{label}: the adaptive algorithm has the smallest variance of the four",
                                "Adaptive Algorithm", best, best == "Adaptive Algorithm"))
    if allan_terms:
        claims += allan_claims(allan_terms)
    return claims


def _adev_at(result, tau_s: float) -> float:
    """Allan deviation at the computed tau nearest to ``tau_s`` in log tau."""
    i = int(np.argmin(np.abs(np.log(result.tau_s / tau_s))))
    return float(result.adev[i])


def allan_claims(allan: dict) -> list[Claim]:
    """The paper's claims about Fig. 6: the long-tau growth removed, stkf and kf alike, the 10-s bump kept."""
    claims = []
    curves = {k: v[0] for k, v in allan.items()}
    terms = {k: v[1] for k, v in allan.items()}
    if "raw" in curves and "stkf" in curves:
        t_long = float(curves["raw"].tau_s[-1])
        raw_l, ours_l = _adev_at(curves["raw"], t_long), _adev_at(curves["stkf"], t_long)
        claims.append(Claim("Fig. 6", "rate random walk and rate ramp are clearly decreased by the compensation",
                            "decreased", f"adev at τ = {t_long:.0f} s: raw {raw_l:.3g}, stkf {ours_l:.3g} deg/s; "
                            f"rate ramp seen: raw {terms['raw'].rate_ramp is not None}, "
                            f"stkf {terms['stkf'].rate_ramp is not None}", ours_l < 0.2 * raw_l))
    if {"stkf", "kf"} <= set(curves):
        ratios = [_adev_at(curves["stkf"], tau) / _adev_at(curves["kf"], tau) for tau in (10.0, 100.0, 1000.0)]
        claims.append(Claim("Fig. 6", "without interference the adaptive algorithm and KF perform alike",
                            "similar", "adev stkf/kf at τ = 10, 100, 1000 s: " + ", ".join(f"{r:.2f}" for r in ratios),
                            all(0.5 <= r <= 2.0 for r in ratios)))
    if {"stkf", "oracle"} <= set(curves):
        bump = max(_adev_at(curves["stkf"], tau) / _adev_at(curves["oracle"], tau) for tau in (10.0, 20.0, 40.0))
        claims.append(Claim("Fig. 6", "the noise near τ = 10 s (the update interval) is not decreased",
                            "bump stays", f"stkf / oracle adev near 10–40 s: up to {bump:.2f}x", bump > 1.1))
    return claims


# ----------------------------------------------------------------------------- outputs


def allan_static(run: PaperRun, fs_hz: float, methods=("stkf", "kf", "mlr", "oracle")) -> dict:
    """``{label: (AllanResult, NoiseTerms)}`` of the raw and compensated rate of a motionless run (Fig. 6)."""
    series = {"raw": run.log["gyro_z"].to_numpy(float)}
    series.update({m: run.outputs[m]["rate_z"].to_numpy(float) for m in methods if m in run.outputs})
    curves = {}
    for label, rate in series.items():
        res = allan_deviation(rate, fs_hz)
        curves[label] = (res, noise_terms(res))
    return curves


def _term(term, scale=1.0, unit=""):
    if term is None:
        return "not seen"
    return f"{term.value * scale:.3g} {unit} (τ = {term.tau_s:.3g} s)".strip()


def report_markdown(runs: dict[str, PaperRun], claims: list[Claim], allan: dict, settings: PaperSettings) -> str:
    """``table2.md``: Table 2 ours beside the paper's, the claims, the Allan noise terms."""
    lines = [
        "# The paper's experiments, regenerated",
        "",
        f"gyrodrift {__version__}, `gyrodrift paper` with seed {settings.seed}, {settings.fs_hz:g} Hz, "
        f"durations × {settings.duration_scale:g}. Simulated data (gyrodrift.simulate); the paper's numbers "
        "are from Feng, Li, Zhang, Sensors 2015, Table 2 and Section 4.",
        "",
        "Bias drift error: estimated minus true drift, deg/s, every row. Heading error: heading minus the "
        "reference aligned at the start, deg. `mlr` is non-causal (fitted on the whole run); `oracle` "
        "removes the true drift (the limit set by sensor noise).",
        "",
    ]
    titles = {"static": "Static, no interference: bias drift error (deg/s)",
              "static_interference": "Static with three outages (300/300/600 s): bias drift error (deg/s)",
              "dynamic": "Vehicle: heading error (deg)"}
    for kind, df in table2_comparison(runs).items():
        flat = df.copy()
        flat.index = [f"{src}: {stat}" for src, stat in df.index]
        lines += [f"## {titles[kind]}", "", markdown_table(flat, floatfmt=".4g"), ""]
    lines += ["## Heading-error envelopes (deg)", ""]
    env_rows = {name: {m: "{:.2f} .. {:.2f}".format(*envelope(o)) for m, o in run.outputs.items()}
                for name, run in runs.items()}
    lines += [markdown_table(pd.DataFrame(env_rows).T), ""]
    lines += ["## The paper's claims on our runs", "",
              "Table-2 cells count as reproduced when ours has the same sign and is within a factor of 2.", "",
              "| where | claim | paper | ours | reproduced |", "| :--- | :--- | :--- | :--- | :--- |"]
    lines += [f"| {c.where} | {c.claim} | {c.paper} | {c.ours} | {'yes' if c.reproduced else '**no**'} |" for c in claims]
    if allan:
        lines += ["", "## Allan deviation of the static rate (Fig. 6): noise terms (IEEE Std 952 slopes)", "",
                  "| rate | ARW N | bias instability B | rate random walk K | rate ramp R |",
                  "| :--- | :--- | :--- | :--- | :--- |"]
        for label, (_, t) in allan.items():
            lines.append(f"| {label} | {_term(t.arw, 60, 'deg/√h')} | {_term(t.bias_instability, 3600, 'deg/h')} | "
                         f"{_term(t.rrw, 1, 'deg/s/√s')} | {_term(t.rate_ramp, 1, 'deg/s²')} |")
    return "\n".join(lines) + "\n"


def results_json(runs: dict[str, PaperRun], claims: list[Claim], allan: dict) -> dict:
    """Every number of the run, JSON-able."""
    out = {"table2": {}, "envelopes": {}, "claims": [asdict(c) for c in claims], "allan": {}}
    for kind, df in table2_comparison(runs).items():
        out["table2"][kind] = {f"{src}:{stat}": {c: (None if pd.isna(v) else float(v)) for c, v in row.items()}
                               for (src, stat), row in df.iterrows()}
    for name, run in runs.items():
        out["envelopes"][name] = {m: list(envelope(o)) for m, o in run.outputs.items()}
        out["envelopes"][name + ":skipped"] = run.skipped
    for label, (res, terms) in allan.items():
        out["allan"][label] = {
            "tau_s": res.tau_s.tolist(), "adev": res.adev.tolist(),
            **{k: (None if getattr(terms, k) is None else getattr(terms, k).value)
               for k in ("arw", "bias_instability", "rrw", "rate_ramp")},
        }
    return out


def write_figures(out_dir, runs: dict[str, PaperRun], allan: dict) -> list:
    """PNG figures corresponding to the paper's Figures 1–9; returns the paths written."""
    out_dir = Path(out_dir)
    static, outages, vehicle = runs["static"], runs["static-outages"], runs["vehicle"]
    ours = "stkf" if "stkf" in static.outputs else next(iter(static.outputs))

    def heading_errors(run):
        return {m: aligned(o) for m, o in run.outputs.items()}

    figures = {
        "fig01_temperature_static.png": plots.fig_temperature(static.outputs[ours]),
        "fig02_bias_static.png": plots.fig_bias(static.outputs),
        "fig03_rates_static.png": plots.fig_rates(static.outputs[ours]),
        "fig04_heading_error_static.png": plots.fig_heading_error(heading_errors(static)),
        "fig05_heading_error_outages.png": plots.fig_heading_error(heading_errors(outages)),
        "fig07_temperature_vehicle.png": plots.fig_temperature(vehicle.outputs[ours]),
        "fig08_heading_vehicle.png": plots.fig_heading(aligned(vehicle.outputs[ours])),
        "fig09_heading_error_vehicle.png": plots.fig_heading_error(heading_errors(vehicle)),
        "params_static.png": plots.fig_params(static.outputs[ours]),
    }
    if allan:
        figures["fig06_allan_static.png"] = plots.fig_allan(
            {k: v[0] for k, v in allan.items()}, {k: v[1] for k, v in allan.items()}
        )
    written = []
    for name, fig in sorted(figures.items()):
        plotbase.save_png(fig, out_dir / name)
        written.append(out_dir / name)
    return written


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else math.nan


def _max_abs(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x))) if x.size else math.nan


def scale_factor_experiment(
    seed: int = 0,
    duration_s: float | None = None,
    fs_hz: float = 50.0,
    *,
    device=None,
    compass=None,
    config: ScaleFactorConfig | None = None,
    compensator_config=None,
    causal: bool = False,
) -> dict:
    """Section 4.3 on simulated data: drift compensation, then the fixed and the adaptive scale factor.

    Parameters
    ----------
    seed : int
        Seed of the simulation.
    duration_s : float, optional
        Run length, s (default: the scenario's 3 h).
    fs_hz : float
        Gyro sample rate, Hz.
    device : DeviceModel, optional
        Gyro model; scale-factor coefficients left ``None`` take the scenario's.
    compass : CompassModel, optional
    config : ScaleFactorConfig, optional
    compensator_config : CompensatorConfig, optional
        Settings of the drift compensator.
    causal : bool
        Use the causal pass of :func:`gyrodrift.scale_factor.estimate_scale_factor`.

    Returns
    -------
    dict
        ``log``, ``out``, ``sf``, ``turns``, ``fig10``, ``fig11``, ``summary`` and ``config``
        (docs/evaluation.md, section "The paper's experiments").
    """
    config = config or ScaleFactorConfig()
    log = simulate(
        "scale-factor", seed=seed, duration_s=duration_s, fs_hz=fs_hz, device=device, compass=compass
    )
    model_config = compensator_config or CompensatorConfig()
    # the paper's drift stage: the drift alone, the default model's own scale factor held at 1
    # (its share of the turns would otherwise leave the stage after it little to estimate)
    drift_config = model_config.without_scale_factor()
    out = compensate(log, drift_config)
    model_heading = compensate(log, model_config)["heading"].to_numpy(float)
    sf = estimate_scale_factor(out, config, causal=causal)
    turns = sf.attrs["turns"]

    t = out[T].to_numpy(float)
    ref = out[REF_HEADING].to_numpy(float)
    true_sf = out[TRUE_SF].to_numpy(float)
    fig10 = pd.DataFrame(
        {
            "t": t,
            "temp": out[TEMP].to_numpy(float),
            "sf_ideal": true_sf,
            "sf_fixed": sf["sf_fixed"].to_numpy(),
            "sf_adaptive": sf["sf"].to_numpy(),
        }
    )
    heading_ideal = integrate_heading(t, out["rate_z"].to_numpy(float) / true_sf, *heading_anchor(out))
    headings = {
        "none": out["heading"].to_numpy(float),
        "fixed": sf["heading_sf_fixed"].to_numpy(),
        "adaptive": sf["heading_sf"].to_numpy(),
        "model": model_heading,  # the default model, its scale factor learned with the drift
    }
    errors = {k: heading_error(h, ref) for k, h in headings.items()}
    errors["ideal"] = heading_error(heading_ideal, ref)
    sf_part = {k: heading_error(h, heading_ideal) for k, h in headings.items()}
    fig11 = pd.DataFrame({"t": t, **{f"err_{k}": v for k, v in errors.items() if k != "model"}})  # the paper's lines

    ups = np.flatnonzero(sf["sf_update"].to_numpy())
    after = slice(int(ups[0]) + 1 if ups.size else t.size, t.size)
    sf_err = {
        "none": 1.0 - true_sf[after],
        "fixed": fig10["sf_fixed"].to_numpy()[after] - true_sf[after],
        "adaptive": fig10["sf_adaptive"].to_numpy()[after] - true_sf[after],
    }
    summary = {
        "heading_rms_deg": {k: _rms(v) for k, v in errors.items()},
        "heading_max_deg": {k: _max_abs(v) for k, v in errors.items()},
        "sf_heading_rms_deg": {k: _rms(v) for k, v in sf_part.items()},
        "sf_heading_max_deg": {k: _max_abs(v) for k, v in sf_part.items()},
        "sf_rms": {k: _rms(v) for k, v in sf_err.items()},
        "sf_max": {k: _max_abs(v) for k, v in sf_err.items()},
        "turns": int(len(turns)),
        "sf_updates": int(turns["accepted"].sum()),
        "sf_fixed": float(sf.attrs["sf_fixed"]),
    }
    return {
        "log": log,
        "out": out,
        "sf": sf,
        "turns": turns,
        "fig10": fig10,
        "fig11": fig11,
        "summary": summary,
        "config": config,
    }


def scale_factor_run(settings: PaperSettings) -> dict:
    """The scale-factor simulation of Section 4.3 (Figs. 10 and 11)."""
    return scale_factor_experiment(
        seed=settings.seed, duration_s=DEFAULT_DURATION_S["scale-factor"] * settings.duration_scale,
        fs_hz=settings.fs_hz, compensator_config=settings.config,
    )


def scale_factor_claims(sf: dict) -> list[Claim]:
    """The paper's claims about Figs. 10 and 11: the adaptive SF follows the ideal one, with the least error."""
    s = sf["summary"]
    rms = s["sf_rms"]
    part = s["sf_heading_rms_deg"]
    whole = s["heading_rms_deg"]
    return [
        Claim("Fig. 10", "the adaptive SF follows the ideal SF (better than fixed parameters)", "follows",
              f"SF error RMS: adaptive {rms['adaptive']:.2g}, fixed {rms['fixed']:.2g}, none {rms['none']:.2g}",
              rms["adaptive"] < rms["fixed"] < rms["none"]),
        Claim("Fig. 11", "heading error: adaptive SF < fixed SF < no SF compensation (SF share alone)",
              "adaptive smallest", f"RMS adaptive {part['adaptive']:.2f}, fixed {part['fixed']:.2f}, "
              f"none {part['none']:.2f} deg", part["adaptive"] < part["fixed"] < part["none"]),
        Claim("Fig. 11", "heading error: adaptive SF < fixed SF < no SF compensation (whole heading error)",
              "adaptive smallest", f"RMS adaptive {whole['adaptive']:.2f}, fixed {whole['fixed']:.2f}, "
              f"none {whole['none']:.2f} deg", whole["adaptive"] < whole["fixed"] < whole["none"]),
    ]


def write_paper(out_dir, settings: PaperSettings = PaperSettings(), *, progress=None, figures: bool = True) -> list:
    """Run every experiment and write ``table2.md``, ``results.json`` and the figures."""
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise ConfigError(f"{out_dir}: output folder does not exist; create it first")
    say = progress or (lambda step: None)
    runs = run_paper(settings, progress=say)
    say("Allan deviation")
    allan = allan_static(runs["static"], settings.fs_hz)
    say("scale factor")
    sf = scale_factor_run(settings)
    claims = check_claims(runs, allan) + scale_factor_claims(sf)
    write_report(out_dir / "table2.md", report_markdown(runs, claims, allan, settings))
    numbers = results_json(runs, claims, allan)
    numbers["scale_factor"] = sf["summary"]
    write_report(out_dir / "results.json", json.dumps(numbers, indent=1))
    written = [out_dir / "table2.md", out_dir / "results.json"]
    if figures:
        say("figures")
        written += write_figures(out_dir, runs, allan)
        path = out_dir / "fig10_11_scale_factor.png"
        plotbase.save_png(plots.fig_scale_factor(sf["fig10"], sf["fig11"]), path)
        written.append(path)
    return written

"""Every experiment of the paper (Section 4, Table 2, Figures 1–11), regenerated on simulated data.

``gyrodrift paper -o DIR`` runs them with default settings and writes ``DIR/table2.md``
(our numbers beside the paper's), ``DIR/results.json`` (every number) and the figures.

The experiments
---------------
``static``
    The motionless heating run (23 → 58 degC and back, 3 h): Figs. 1–4, Table 2 row 1.
``static-outages``
    The same run with aiding stopped in three windows of 300, 300 and 600 s. The paper
    "makes the algorithms not work" there, so the compass is removed in those windows
    (``no_compass`` outages): Fig. 5, Table 2 row 2.
``static-interference``
    Not in the paper: the same windows with the compass *disturbed* instead of
    removed (the simulator's interference), so the gates must find them.
``vehicle``
    A car on rectangular loops, 26 → 37 degC, against a fibre-optic-gyro reference:
    Figs. 7–9, Table 2 row 3.
``allan``
    Allan deviation of the raw and compensated static rate: Fig. 6.

The poly3 baseline is fitted on a separate simulated heating run of the same device
(``calibration`` scenario, another seed).

Heading errors are drifts: the reference is aligned to each output's first heading
(the gyro heading starts at the compass, whose own error at that moment would
otherwise be counted as a constant offset for every method alike).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from gyrodrift.compare import CAUSAL, METHODS, run_methods
from gyrodrift.compensate import CompensatorConfig
from gyrodrift.conventions import REF_HEADING, wrap_360
from gyrodrift.metrics import (
    PAPER_METHODS,
    bias_error,
    error_stats,
    heading_error_deg,
    heading_error_stats,
    paper_table2,
)
from gyrodrift.simulate import DEFAULT_DURATION_S, interference_windows_static, simulate

__all__ = ["PaperSettings", "PaperRun", "run_paper", "OURS_TO_PAPER", "table2_comparison", "aligned"]

#: Our method names for the paper's Table 2 columns.
OURS_TO_PAPER = {"mlr": "MLR", "kf": "KF", "lsm": "Modified LSM", "stkf": "Adaptive Algorithm"}


@dataclass(frozen=True, kw_only=True)
class PaperSettings:
    """What to run.

    Attributes
    ----------
    seed : int
        Seed of every simulated run (the calibration run uses ``seed + 1000``).
    fs_hz : float
        Gyro sample rate of the simulated runs, Hz.
    duration_scale : float
        Multiplies every scenario's default duration (0.1 for a quick check).
    methods : tuple of str
        Methods to compare (see :mod:`gyrodrift.compare`).
    config : CompensatorConfig
        Compensator settings shared by every method.
    """

    seed: int = 1
    fs_hz: float = 10.0
    duration_scale: float = 1.0
    methods: tuple[str, ...] = METHODS
    config: CompensatorConfig = field(default_factory=CompensatorConfig)


@dataclass
class PaperRun:
    """One experiment: its log and the output table of every method."""

    name: str
    log: pd.DataFrame
    outputs: dict[str, pd.DataFrame]
    skipped: dict[str, str]


def aligned(out: pd.DataFrame) -> pd.DataFrame:
    """A copy whose ``ref_heading`` starts where the output's heading starts (module notes)."""
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
    """Run every experiment (module notes); ``progress(name)`` is called before each."""
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
    """Table 2, ours beside the paper's, one DataFrame per row group.

    Keys ``static``, ``static_interference`` (from the ``static-outages`` run: the
    paper's outages) and ``dynamic``; rows are ``mean`` and ``variance`` for each of
    ``paper`` and ``ours``; columns are the paper's four methods, then our extra
    methods (``stkf-s1``, ``poly3``, ``oracle``, no paper value).
    """
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


def causal_label(name: str) -> str:
    return name if CAUSAL.get(name, True) else f"{name} (non-causal)"

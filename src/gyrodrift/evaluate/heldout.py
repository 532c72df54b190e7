"""Every method on the generator's scenarios (:mod:`gyrodrift.simulate.generator`), scored
against truth, tuning and held-out seeds reported side by side.

The methods, the scores and the acceptance: docs/evaluation.md, section "The generator's
classes on held-out seeds".
"""

from __future__ import annotations

import math
from typing import Callable, Iterable, Sequence

import numpy as np
import pandas as pd

from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError
from gyrodrift.evaluate.compare import run_method
from gyrodrift.evaluate.metrics import heading_error_deg, markdown_table
from gyrodrift.fleet import check_workers, error_line, map_jobs
from gyrodrift.simulate.generator import CLASSES, generate, seeds, split_of, truth_labels

__all__ = ["METHODS", "CAUSAL_BASELINES", "COLUMNS", "run_case", "run_generated", "summarise", "acceptance",
           "markdown", "pooled_labels"]

#: Methods of a run, in order (``default`` is gyrodrift's default estimator).
METHODS = ("default", "stkf", "kf", "mlr-causal", "poly3", "fusion-offset", "fusion-ahrs", "smoothed")
#: The causal baselines the default is held against (heading and bias).
CAUSAL_BASELINES = ("stkf", "kf", "mlr-causal", "poly3", "fusion-offset")
#: The fused-heading baseline.
FUSED_BASELINE = "fusion-ahrs"

COLUMNS = ("class", "seed", "split", "method", "rows", "heading_rms_deg", "bias_rms_dps", "fused_rms_deg",
           "bias_in_1sd", "bias_in_2sd", "fused_in_1sd", "fused_in_2sd", "interference_precision",
           "interference_recall", "turning_precision", "turning_recall", "interference_said", "interference_true",
           "interference_hits", "turning_said", "turning_true", "turning_hits", "status", "error")
#: The label counts per case (rows labelled, rows truly so, rows both), pooled over a class's cases
#: for its precision and recall: a case with a few labels and no truth has precision 0 alone.
LABELS = ("interference", "turning")
LABEL_COUNTS = tuple(f"{name}_{k}" for name in LABELS for k in ("said", "true", "hits"))


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else math.nan


def _share_within(err, sd, k) -> float:
    ok = np.isfinite(err) & np.isfinite(sd)
    return float(np.mean(np.abs(err[ok]) <= k * sd[ok])) if ok.any() else math.nan


def _ratios(said, true, hits) -> tuple[float, float]:
    """Precision and recall from counts of rows labelled, truly so and both (NaN where undefined)."""
    return (hits / said if said > 0 else math.nan), (hits / true if true > 0 else math.nan)


def _label_row(name: str, said: np.ndarray, truth: np.ndarray) -> dict:
    """A label's counts (boolean rows said and true) and its precision and recall."""
    n_said, n_true, hits = int(said.sum()), int(truth.sum()), int(np.sum(said & truth))
    p, r = _ratios(n_said, n_true, hits)
    return {f"{name}_precision": p, f"{name}_recall": r, f"{name}_said": n_said, f"{name}_true": n_true,
            f"{name}_hits": hits}


def _score(log: pd.DataFrame, out: pd.DataFrame, own: bool) -> dict:
    ref = log["ref_heading"].to_numpy(float)
    truth = log["true_bias_z"].to_numpy(float)
    row = {"heading_rms_deg": _rms(heading_error_deg(out["heading"].to_numpy(float), ref)),
           "bias_rms_dps": _rms(out["bias_z"].to_numpy(float) - truth)}
    if "heading_fused" in out:
        fused_err = heading_error_deg(out["heading_fused"].to_numpy(float), ref)
        row["fused_rms_deg"] = _rms(fused_err)
    if own:
        bias_err = out["bias_z"].to_numpy(float) - truth
        sd = out["bias_sd"].to_numpy(float)
        fsd = out["heading_fused_sd"].to_numpy(float)
        row.update(bias_in_1sd=_share_within(bias_err, sd, 1), bias_in_2sd=_share_within(bias_err, sd, 2),
                   fused_in_1sd=_share_within(fused_err, fsd, 1), fused_in_2sd=_share_within(fused_err, fsd, 2))
        labels = truth_labels(log)
        reason = out["gate_reason"].astype(str).to_numpy()
        compass = np.isfinite(out["compass_heading"].to_numpy(float))
        # `field` is the same verdict (a disturbed compass), reached by the field strength and dip
        said = np.isin(reason, ("interference", "field")) & compass
        row.update(_label_row("interference", said, labels["disturbed"].to_numpy() & compass))
        row.update(_label_row("turning", reason == "turning", labels["turning"].to_numpy()))
    return row


def _run(name: str, log: pd.DataFrame, config: CompensatorConfig, case) -> pd.DataFrame:
    if name == "default":
        return run_method(config.estimator, log, config)
    if name == "fusion-ahrs":
        from gyrodrift.fusion_offset import fusion_ahrs_heading

        if "heading" not in log and "mag_x" not in log:  # no compass: nothing to fuse
            return pd.DataFrame({c: np.full(len(log), np.nan) for c in ("heading", "bias_z", "heading_fused")})
        return pd.DataFrame({"heading": np.full(len(log), np.nan), "bias_z": np.full(len(log), np.nan),
                             "heading_fused": fusion_ahrs_heading(log)})
    if name == "poly3":
        return run_method("poly3", log, config, calibration=case.calibration())
    return run_method(name, log, config)


def run_case(cls: str, seed: int, methods: Sequence[str] = METHODS, *, config: CompensatorConfig | None = None,
             duration_scale: float = 1.0) -> list[dict]:
    """Generate one case and run every method on it; one row (:data:`COLUMNS`) per method."""
    config = config or CompensatorConfig()
    base = {"class": cls, "seed": int(seed), "split": split_of(int(seed))}
    blank = {c: math.nan for c in COLUMNS if c not in ("class", "seed", "split", "method", "status", "error")}
    try:
        case = generate(cls, seed, duration_scale=duration_scale)
    except Exception as err:  # reported per case, never stops the whole run
        return [{**base, **blank, "method": m, "status": "error", "error": "generator: " + error_line(err)}
                for m in methods]
    rows = []
    for name in methods:
        row = {**base, **blank, "method": name, "rows": len(case.log), "status": "ok", "error": ""}
        try:
            out = _run(name, case.log, config, case)
            row.update(_score(case.log, out, own=name == "default"))
        except Exception as err:  # one failing method must not hide the others
            row.update(status="error", error=error_line(err))
        rows.append(row)
    return rows


def _task(task):
    cls, seed, methods, config, scale = task
    return run_case(cls, seed, methods, config=config, duration_scale=scale)


def _failed(task, err):
    cls, seed, methods, _, _ = task
    return [{"class": cls, "seed": seed, "split": split_of(seed), "method": m, "status": "error",
             "error": "worker: " + error_line(err)} for m in methods]


def run_generated(classes: Iterable[str] | None = None, splits: Sequence[str] = ("held-out",), n_seeds: int = 20,
                  methods: Sequence[str] = METHODS, *, config: CompensatorConfig | None = None,
                  workers: int | None = None, duration_scale: float = 1.0,
                  progress: Callable | None = None) -> pd.DataFrame:
    """Every method on ``n_seeds`` cases of each class in each split; one row per case and method.

    The rows do not depend on ``workers``.
    """
    classes = list(CLASSES) if classes is None else list(classes)
    unknown = [c for c in classes if c not in CLASSES]
    if unknown:
        raise ConfigError(f"unknown scenario class(es) {', '.join(unknown)}; choose from: {', '.join(CLASSES)}")
    bad = [m for m in methods if m not in METHODS]
    if bad:
        raise ConfigError(f"unknown method(s) {', '.join(bad)}; choose from: {', '.join(METHODS)}")
    tasks = [(c, s, tuple(methods), config or CompensatorConfig(), duration_scale)
             for split in splits for c in classes for s in seeds(split, n_seeds)]
    results = map_jobs(_task, tasks, check_workers(workers), progress, on_error=_failed)
    df = pd.DataFrame([r for rows in results for r in rows], columns=list(COLUMNS))
    order = {m: i for i, m in enumerate(methods)}
    return df.sort_values(["split", "class", "seed", "method"], key=lambda s: s.map(order) if s.name == "method" else s,
                          kind="stable").reset_index(drop=True)


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    """Median per (split, class, method) of every score, and the cases that ran and failed."""
    ok = df[df["status"] == "ok"]
    scores = [c for c in COLUMNS if c not in ("class", "seed", "split", "method", "rows", "status", "error")
              and c not in LABEL_COUNTS]  # counts are pooled (pooled_labels), not medians
    med = ok.groupby(["split", "class", "method"], sort=False)[scores].median()
    counts = df.groupby(["split", "class", "method"], sort=False)["status"].agg(
        n=lambda s: int((s == "ok").sum()), failed=lambda s: int((s != "ok").sum()))
    return counts.join(med).reset_index()


def acceptance(summary: pd.DataFrame) -> pd.DataFrame:
    """Per (split, class): the default's medians against the best causal baseline and Fusion's AHRS.

    Columns: the default's ``heading``, ``bias`` and ``fused`` median RMS; ``best_heading``,
    ``best_bias`` (the lowest of :data:`CAUSAL_BASELINES`, and which) and ``ahrs``; ``ok_*``.
    """
    rows = []
    for (split, cls), part in summary.groupby(["split", "class"], sort=False):
        by = part.set_index("method")
        if "default" not in by.index:
            continue
        base = by.loc[[m for m in CAUSAL_BASELINES if m in by.index]]
        row = {"split": split, "class": cls, "heading": by.at["default", "heading_rms_deg"],
               "bias": by.at["default", "bias_rms_dps"], "fused": by.at["default", "fused_rms_deg"]}
        for what, col in (("heading", "heading_rms_deg"), ("bias", "bias_rms_dps")):
            vals = base[col].dropna()
            row[f"best_{what}"] = float(vals.min()) if len(vals) else math.nan
            row[f"best_{what}_method"] = str(vals.idxmin()) if len(vals) else ""
            row[f"ok_{what}"] = bool(row[what] <= row[f"best_{what}"]) if len(vals) else True
        row["ahrs"] = by.at[FUSED_BASELINE, "fused_rms_deg"] if FUSED_BASELINE in by.index else math.nan
        row["ok_fused"] = bool(row["fused"] <= row["ahrs"]) if math.isfinite(row["ahrs"]) else True
        rows.append(row)
    return pd.DataFrame(rows)


def tuning_score(acc: pd.DataFrame) -> float:
    """The sum over the rows of an :func:`acceptance` table of the log ratios of the default's
    medians to the best causal baseline's (heading, bias) and to Fusion's AHRS (fused): one
    number to compare settings on the same seeds, lower is better (``benchmarks/tune_adaptive.py``)."""
    return float(np.nansum(np.log(acc["heading"] / acc["best_heading"])) + np.nansum(np.log(acc["bias"] / acc["best_bias"]))
                 + np.nansum(np.log(acc["fused"] / acc["ahrs"])))


def markdown(df: pd.DataFrame) -> str:
    """The acceptance table and the per-method medians of a run, Markdown."""
    summ = summarise(df)
    acc = acceptance(summ)
    parts = []
    for split in dict.fromkeys(acc["split"]):
        a = acc[acc["split"] == split].drop(columns=["split"])
        parts += [f"**{split}** seeds: the default against the best causal baseline (median RMS per class)", "",
                  markdown_table(a, ".3g", index=False), ""]
    wide = summ.pivot_table(index=["split", "class"], columns="method",
                            values=["heading_rms_deg", "bias_rms_dps", "fused_rms_deg"], sort=False)
    parts += ["Medians per method", "", markdown_table(wide.reset_index(), ".3g", index=False)]
    own = summ[summ["method"] == "default"][["split", "class", "bias_in_1sd", "bias_in_2sd", "fused_in_1sd",
                                               "fused_in_2sd", "interference_precision", "interference_recall",
                                               "turning_precision", "turning_recall"]]
    parts += ["", "The default's honesty (medians over cases)", "", markdown_table(own, ".2f", index=False)]
    parts += ["", "The default's labels, rows pooled over cases (precision / recall)", "",
              markdown_table(pooled_labels(df), ".2f", index=False)]
    return "\n".join(parts)


def pooled_labels(df: pd.DataFrame) -> pd.DataFrame:
    """Per (split, class): the default's label precision and recall over all its cases' rows."""
    own = df[(df["status"] == "ok") & (df["method"] == "default")]
    sums = own.groupby(["split", "class"], sort=False)[list(LABEL_COUNTS)].sum()
    out = sums.index.to_frame(index=False)
    for name in LABELS:
        pr = [_ratios(*row) for row in sums[[f"{name}_said", f"{name}_true", f"{name}_hits"]].to_numpy()]
        out[f"{name}_precision"] = [p for p, _ in pr]
        out[f"{name}_recall"] = [r for _, r in pr]
    return out



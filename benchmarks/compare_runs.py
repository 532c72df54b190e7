"""Compare two runs of the default on the same generator seeds, seed by seed (a tuning aid).

    python benchmarks/compare_runs.py before.csv after.csv [--baseline runs.csv] [--worst 5]

``before.csv`` and ``after.csv`` are ``tune_adaptive.py -o`` (or ``gyrodrift montecarlo -o``)
outputs; only their ``default`` rows are used, matched by class and seed. Prints per class the
geometric mean over seeds of the per-seed ratios after/before of heading, bias and fused RMS (a
change that moves every seed a little and one that breaks a few seeds look different here and
alike in the medians), the mean fused RMS of each (what a trap does to a class), and the seeds
whose fused heading moved most either way. With ``--baseline`` (a run holding the baselines of
those seeds) it also prints each run's score as ``tune_adaptive.py`` computes it.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import pandas as pd

METRICS = ("heading_rms_deg", "bias_rms_dps", "fused_rms_deg")


def own(path: str) -> pd.DataFrame:
    """The default's rows of a run, one per class and seed."""
    df = pd.read_csv(path)
    return df[df["method"] == "default"].set_index(["class", "seed"])


def ratios(before: pd.DataFrame, after: pd.DataFrame) -> pd.DataFrame:
    """Per class and seed, after/before of each metric (seeds in both runs only)."""
    common = before.index.intersection(after.index)
    return pd.DataFrame({m: after.loc[common, m] / before.loc[common, m] for m in METRICS})


def geometric_means(r: pd.DataFrame) -> pd.DataFrame:
    """Per class and over all, the geometric mean of the finite positive ratios."""
    logs = np.log(r.where(r > 0))
    out = logs.groupby(level="class").mean()
    out.loc["all"] = logs.mean()
    return np.exp(out)


def score(run: pd.DataFrame, baseline_path: str) -> float:
    """The sum over classes of the log ratios of the run's medians to the best causal baseline's
    (heading, bias) and to Fusion's AHRS (fused), as ``tune_adaptive.py`` prints it."""
    from gyrodrift.evaluate import heldout

    runs = run.reset_index()
    base = pd.read_csv(baseline_path)
    base = base[(base["method"] != "default") & base["split"].isin(runs["split"].unique())
                & base["seed"].isin(runs["seed"]) & base["class"].isin(runs["class"])]
    return heldout.tuning_score(heldout.acceptance(heldout.summarise(pd.concat([runs, base]))))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--baseline", help="a run with the baselines of these seeds: print both scores")
    p.add_argument("--worst", type=int, default=3, help="seeds to list per class each way (fused)")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    before, after = own(args.before), own(args.after)
    r = ratios(before, after)
    if r.empty:
        raise SystemExit(f"no class and seed is in both {args.before} and {args.after}")
    gm = geometric_means(r)
    means = pd.DataFrame({"fused_mean_before": before["fused_rms_deg"].groupby(level="class").mean(),
                          "fused_mean_after": after["fused_rms_deg"].groupby(level="class").mean()})
    table = gm.rename(columns={m: m.split("_")[0] for m in METRICS}).join(means)
    pd.set_option("display.width", 200)
    print("geometric means of per-seed ratios after/before; mean fused RMS (deg) of each run")
    print(table.to_string(float_format=lambda v: f"{v:.3f}"))
    k = args.worst
    for cls, grp in r["fused_rms_deg"].groupby(level="class"):
        g = grp.droplevel("class").dropna().sort_values()
        show = lambda s: " ".join(f"{seed}: {before.loc[(cls, seed), 'fused_rms_deg']:.3g} -> "
                                  f"{after.loc[(cls, seed), 'fused_rms_deg']:.3g}" for seed in s.index)
        print(f"{cls}: better {show(g.head(k))} | worse {show(g.tail(k)[::-1])}")
    if args.baseline:
        print(f"score before {score(before, args.baseline):+.2f}, after {score(after, args.baseline):+.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

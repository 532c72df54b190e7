"""Run the default (adaptive) model on generator seeds and compare with stored baselines (a tuning aid).

    python benchmarks/tune_adaptive.py --baseline runs.csv --split tuning --seeds 10 [--set name=value ...]
        [--temp-rate-window-s S] [--temp-rate-short-s S] [--tilt accel|gyro]

``runs.csv`` is a ``gyrodrift montecarlo --tuning/--held-out -o`` output with the baselines;
only ``default`` is recomputed here (with the settings given; ``--temp-rate-window-s`` and
``--temp-rate-short-s`` set the front end's T', and ``--tilt`` the raw compass's tilt, which the
file's baselines keep as they were run),
so a setting can be tried in a minute. Prints per class the default's median heading, bias and
fused RMS beside the best causal baseline's and Fusion's AHRS, and the honesty columns.
"""

from __future__ import annotations

import argparse
import warnings
from dataclasses import replace

import pandas as pd

from gyrodrift.evaluate import heldout
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.estimators.adaptive import AdaptiveConfig


def main(argv=None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--baseline", required=True)
    p.add_argument("--split", default="tuning")
    p.add_argument("--seeds", type=int, default=10)
    p.add_argument("--classes", nargs="+")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--set", nargs="*", default=[], help="AdaptiveConfig field=value")
    p.add_argument("--temp-rate-window-s", type=float, help="the T' window (TempRateConfig.window_s), s")
    p.add_argument("--temp-rate-short-s", type=float, help="the T' short window (TempRateConfig.short_s), s")
    p.add_argument("--tilt", choices=("accel", "gyro"), help="the raw compass's tilt (CompensatorConfig.tilt)")
    p.add_argument("-o", "--output")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    import ast
    ev = AdaptiveConfig(**{k: ast.literal_eval(v) for k, v in (s.split("=") for s in args.set)})
    cfg = CompensatorConfig(adaptive=ev)
    if args.tilt is not None:
        cfg = replace(cfg, tilt=args.tilt)
    if args.temp_rate_window_s is not None:
        cfg = replace(cfg, temp_rate=replace(cfg.temp_rate, window_s=args.temp_rate_window_s))
    if args.temp_rate_short_s is not None:
        cfg = replace(cfg, temp_rate=replace(cfg.temp_rate, short_s=args.temp_rate_short_s))
    df = heldout.run_generated(args.classes, [args.split], args.seeds, ["default"], config=cfg, workers=args.workers)
    if args.output:
        df.to_csv(args.output, index=False)
    base = pd.read_csv(args.baseline)
    base = base[(base["split"] == args.split) & (base["method"] != "default") & base["seed"].isin(df["seed"])
                & base["class"].isin(df["class"])]
    summ = heldout.summarise(pd.concat([df, base]))
    acc = heldout.acceptance(summ)
    pd.set_option("display.width", 250)
    print(acc.drop(columns=["split"]).to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    own = summ[summ["method"] == "default"][["class", "bias_in_1sd", "bias_in_2sd", "fused_in_1sd", "fused_in_2sd",
                                             "interference_precision", "interference_recall", "turning_precision",
                                             "turning_recall"]]
    print(own.to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    score = heldout.tuning_score(acc)
    print(f"score {score:+.2f} (sum of log ratios to the best baseline; lower is better)")
    print("ok heading", int(acc.ok_heading.sum()), "bias", int(acc.ok_bias.sum()), "fused", int(acc.ok_fused.sum()),
          "of", len(acc), "; failed runs", int((df.status != "ok").sum()))
    bad = df[df.status != "ok"]
    for _, r in bad.head(3).iterrows():
        print("failed", r["class"], r["seed"], r["error"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

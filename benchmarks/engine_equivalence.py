"""Outputs of every method on the Monte Carlo families and the demo log, saved or compared.

A refactor of the engine must not move the numbers: run ``--save FILE.npz`` on the code
before the change and ``--check FILE.npz`` after it. Every numeric output column of every
(family, seed, method) and of the demo is compared; the largest absolute difference per
column is printed and the run fails (exit 1) above ``--tol`` (default 1e-9).

    python benchmarks/engine_equivalence.py --save /tmp/before.npz
    python benchmarks/engine_equivalence.py --check /tmp/before.npz
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from gyrodrift import compensate
from gyrodrift.evaluate.compare import run_method
from gyrodrift.io import read_log
from gyrodrift.evaluate.montecarlo import FAMILIES, draw_case, simulate_case

METHODS = ("adaptive", "stkf", "stkf-s1", "kf", "lsm", "mlr", "poly3", "smoothed")
COLUMNS = ("rate_z", "bias_z", "heading", "a", "b", "c", "updated", "gated", "bias_sd",
           "heading_fused", "heading_fused_sd", "heading_sd")


def outputs(seeds: int, scale: float) -> dict[str, np.ndarray]:
    from gyrodrift.cli.commands import demo_log_path

    found = {}
    demo = compensate(read_log(demo_log_path()))
    for col in COLUMNS:
        found[f"demo/{col}"] = demo[col].to_numpy(float)
    for family in FAMILIES:
        for seed in range(seeds):
            log, cal = simulate_case(draw_case(family, seed, duration_scale=scale))
            for method in METHODS:
                out = run_method(method, log, calibration=cal)
                for col in COLUMNS:
                    if col in out.columns:
                        found[f"{family}/{seed}/{method}/{col}"] = out[col].to_numpy(float)
                print(f"{family} {seed} {method}", file=sys.stderr, flush=True)
    return found


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--save", metavar="FILE.npz")
    what.add_argument("--check", metavar="FILE.npz")
    p.add_argument("--seeds", type=int, default=2)
    p.add_argument("--scale", type=float, default=0.25, help="log length as a multiple of the family's default")
    p.add_argument("--tol", type=float, default=1e-9)
    args = p.parse_args(argv)
    found = outputs(args.seeds, args.scale)
    if args.save:
        np.savez_compressed(args.save, **found)
        print(f"saved {len(found)} columns to {args.save}")
        return 0
    before = dict(np.load(args.check))
    worst = {}
    bad = []
    for key, old in before.items():
        new = found.get(key)
        if new is None or new.shape != old.shape:
            bad.append(f"{key}: missing or shape {None if new is None else new.shape} != {old.shape}")
            continue
        both_nan = np.isnan(old) & np.isnan(new)
        diff = np.where(both_nan, 0.0, np.abs(new - old))
        if key.endswith(("heading", "heading_fused")):  # angles: across the wrap
            diff = np.minimum(diff, 360.0 - diff)
        d = float(np.nanmax(np.where(np.isnan(diff), np.inf, diff))) if diff.size else 0.0
        col = key.rsplit("/", 1)[1]
        worst[col] = max(worst.get(col, 0.0), d)
        if d > args.tol:
            bad.append(f"{key}: max |diff| {d:.3g}")
    for col, d in sorted(worst.items()):
        print(f"{col:18s} max |after - before| = {d:.3g}")
    print(f"{len(before)} columns compared, {len(bad)} above {args.tol:g}")
    by_what: dict[str, list[str]] = {}
    for line in bad:
        key = line.split(":")[0]
        what = key.split("/")[-2] + "/" + key.split("/")[-1] if key.count("/") >= 2 else key
        by_what.setdefault(what, []).append(line)
    for what, lines in sorted(by_what.items()):
        print(f"  {what}: {len(lines)} runs, e.g. {lines[0]}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

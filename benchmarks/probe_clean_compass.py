"""How often the default's fused heading is worse than a clean compass, on random draws of the
clean-compass invariant's scenarios (``tests/test_invariants.py``; docs/results.md, issue 21).

The property test stops at its first counterexample; this probe draws ``N`` scenarios of the
same kind from one seed (numpy, not hypothesis) and counts those where ``heading_fused`` is worse
than the compass alone (RMS against the truth after 30 s), listing the worst:

    PYTHONPATH=src python benchmarks/probe_clean_compass.py [N] [SEED] [--set motion_memory_s=120 ...]
    # 90 draws and seed 7 by default; --set: AdaptiveConfig settings, as tune_adaptive.py takes them

About 3 s for 90 draws on the 2-core machine.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

# the property's own scenarios and measure
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from sweep_slow_turns import config_of
from test_invariants import fused_and_compass_rms

KINDS = ("still", "sway", "turn")


def draw(rng: np.random.Generator, k: int) -> dict:
    """One scenario of the property's kind; the kinds in turn, and the turn rate a hundredth of
    its range half the time (slow turns are where the property fails)."""
    return {"a": rng.uniform(-0.02, 0.02), "c": rng.uniform(-0.5, 0.5), "t0": rng.uniform(10.0, 40.0),
            "rise": rng.choice([0.0, rng.uniform(0.0, 20.0)]), "kind": KINDS[k % 3], "h0": rng.uniform(0.0, 359.0),
            "amp": rng.uniform(5.0, 60.0), "period": rng.uniform(30.0, 300.0),
            "rate": rng.uniform(-5.0, 5.0) * rng.choice([1.0, 0.02]), "gyro_noise": rng.uniform(0.01, 0.2),
            "compass_noise": rng.uniform(0.3, 3.0), "seed": int(rng.integers(0, 10_000))}


def main(n: int = 90, seed: int = 7, settings: list[str] | None = None) -> None:
    warnings.simplefilter("ignore")
    config = config_of(settings or [])
    rng = np.random.default_rng(seed)
    fails = []
    ratios: dict[str, list[float]] = {kind: [] for kind in KINDS}
    for k in range(n):
        p = draw(rng, k)
        fused, compass = fused_and_compass_rms(p, config)
        ratios[p["kind"]].append(fused / compass)
        if fused > compass:
            fails.append((fused, compass, p))
    print(f"{len(fails)} of {n} draws: heading_fused worse than the clean compass")
    print("geometric mean of fused / compass RMS: " + ", ".join(
        f"{kind} {np.exp(np.mean(np.log(r))):.3f} ({len(r)})" for kind, r in ratios.items() if r))
    for fused, compass, p in sorted(fails, key=lambda f: -f[0])[:8]:
        motion = f"rate {p['rate']:+.3f} deg/s" if p["kind"] == "turn" else f"{p['amp']:.1f} deg, {p['period']:.0f} s"
        print(f"  fused {fused:6.2f} deg, compass {compass:5.2f} deg: {p['kind']:5s} {motion}, "
              f"compass noise {p['compass_noise']:.2f} deg, gyro noise {p['gyro_noise']:.3f} deg/s, "
              f"temperature rise {p['rise']:.1f} degC, seed {p['seed']}")


if __name__ == "__main__":
    args = sys.argv[1:]
    sets = [args[i + 1] for i, a in enumerate(args) if a == "--set"]
    rest = [a for i, a in enumerate(args) if a != "--set" and (i == 0 or args[i - 1] != "--set")]
    main(*(int(a) for a in rest[:2]), settings=sets)

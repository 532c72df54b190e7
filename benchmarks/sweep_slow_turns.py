"""Where a slow steady turn under a clean compass stops being taken for a still platform whose
compass drifts (docs/results.md, "Where slow turns end and compass ramps begin"; issue 21).

Each cell draws ``N`` scenarios of the clean-compass invariant's kind (``tests/test_invariants.py``:
still for a minute, then a steady turn, 10 min at 10 Hz; compass noise 0.3-3 deg, gyro noise
0.01-0.2 deg/s, drift slope and offset as the property draws them) at one turn rate, on a flat
temperature and on a unit warming 10 degC, and counts the draws whose ``heading_fused`` is worse
than the compass alone (RMS against the truth after 30 s):

    PYTHONPATH=src python benchmarks/sweep_slow_turns.py [N] [--set steady_walk=0.03 ...]
    # 6 draws a cell by default; --set: AdaptiveConfig settings, as tune_adaptive.py takes them

About 5 s on the 2-core machine once compiled.
"""

from __future__ import annotations

import ast
import sys
import warnings
from pathlib import Path

import numpy as np

# the property's own scenarios and measure
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_invariants import fused_and_compass_rms

from gyrodrift.compensator import CompensatorConfig
from gyrodrift.estimators import AdaptiveConfig

RATES_DPS = (0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.5)
RISES_DEGC = (0.0, 10.0)


def draw(draw_seed: int, rate_dps: float, rise_degc: float) -> dict:
    """One scenario of the property's kind turning at ``rate_dps`` (either way)."""
    rng = np.random.default_rng(100 + draw_seed)
    return {"a": rng.uniform(-0.02, 0.02), "c": rng.uniform(-0.5, 0.5), "t0": rng.uniform(10.0, 40.0),
            "rise": rise_degc, "kind": "turn", "h0": rng.uniform(0.0, 359.0), "amp": 10.0, "period": 100.0,
            "rate": rate_dps * rng.choice([-1.0, 1.0]), "gyro_noise": rng.uniform(0.01, 0.2),
            "compass_noise": rng.uniform(0.3, 3.0), "seed": draw_seed}


def config_of(settings: list[str]) -> CompensatorConfig:
    """The default configuration with ``name=value`` settings of :class:`AdaptiveConfig`, each
    value a Python literal (a tuple as ``name=v1,v2,...``), as ``tune_adaptive.py`` takes them."""
    return CompensatorConfig(adaptive=AdaptiveConfig(**{k: ast.literal_eval(v) for k, v in
                                                        (s.split("=", 1) for s in settings)}))


def main(n: int = 6, settings: list[str] | None = None) -> None:
    warnings.simplefilter("ignore")
    config = config_of(settings or [])
    print("| temperature rise (degC) | turn rate (deg/s) | fused worse than the compass | median fused / compass RMS |")
    print("|---|---|---|---|")
    for rise in RISES_DEGC:
        for rate in RATES_DPS:
            ratios = []
            for k in range(n):
                fused, compass = fused_and_compass_rms(draw(k, rate, rise), config)
                ratios.append(fused / compass)
            worse = sum(r > 1.0 for r in ratios)
            print(f"| {rise:g} | {rate:g} | {worse} of {n} | {np.median(ratios):.2f} |", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    sets = [args[i + 1] for i, a in enumerate(args) if a == "--set"]
    rest = [a for i, a in enumerate(args) if a != "--set" and (i == 0 or args[i - 1] != "--set")]
    main(*(int(a) for a in rest[:1]), settings=sets)

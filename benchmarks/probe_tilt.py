"""Rows refused and heading errors of the raw compass's tilt sources on the Monte Carlo's
``vehicle-rawmag`` logs (docs/results.md, issue 14): the accelerometer alone, the gyro-aided
gravity, and that with the magnetometer calibration.

    PYTHONPATH=src python benchmarks/probe_tilt.py [SEEDS]
"""

from __future__ import annotations

import sys

import numpy as np

import gyrodrift
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.conventions import wrap_180
from gyrodrift.evaluate.montecarlo import draw_case, simulate_case

SETTINGS = {
    "accel": CompensatorConfig(tilt="accel"),
    "gyro": CompensatorConfig(tilt="gyro"),
    "gyro+cal": CompensatorConfig(tilt="gyro", mag_calibration=True),
}


def main(seeds: int = 10) -> None:
    rows = {k: [] for k in SETTINGS}
    for seed in range(seeds):
        log, _ = simulate_case(draw_case("vehicle-rawmag", seed), calibration=False)
        for name, cfg in SETTINGS.items():
            out = gyrodrift.compensate(log, cfg)
            reason = out["gate_reason"]

            def rms(col):
                return float(np.sqrt(np.mean(wrap_180(out[col] - out["ref_heading"]) ** 2)))

            compass = np.abs(wrap_180(out["compass_heading"] - out["ref_heading"]))
            rows[name].append([100 * np.mean(reason == "interference"), 100 * np.mean(reason == "field"),
                               100 * np.mean(reason == "turning"), rms("heading"), rms("heading_fused"),
                               float(np.nanpercentile(compass, 95))])
    print("| tilt | interference % | field % | turning % | heading RMS deg | heading_fused RMS deg "
          "| compass error p95 deg |")
    print("|---|---|---|---|---|---|---|")
    for name, values in rows.items():
        m = np.mean(values, axis=0)
        print(f"| {name} | " + " | ".join(f"{v:.2f}" for v in m) + " |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)

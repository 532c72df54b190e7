"""The fused heading after a disturbance ends: the ramp-interference family (10 min of
wandering magnetic interference, 20-35 deg, while the temperature falls 0.8 degC/min)."""

import numpy as np

from gyrodrift import compensate
from gyrodrift.evaluate.montecarlo import draw_case, simulate_case
from gyrodrift.simulate.adversarial import ramp_interference_window

#: Seconds a heading must stay within 3 deg to count as re-anchored.
STAY_S = 60.0


def reanchor_s(seed: int) -> float:
    """Seconds from the end of the disturbance until ``heading_fused`` is within 3 deg of the
    truth and stays there for STAY_S (inf: never)."""
    log, _ = simulate_case(draw_case("ramp-interference", seed), calibration=False)
    out = compensate(log)
    start, length = ramp_interference_window(float(log["t"].iloc[-1]))
    end = start + length
    t = out["t"].to_numpy()
    ok = np.abs((out["heading_fused"] - log["ref_heading"] + 180.0) % 360.0 - 180.0).to_numpy() < 3.0
    bad_after = np.flatnonzero(~ok & (t >= end))  # rows after the end still off
    for i in np.flatnonzero(t >= end)[::10]:
        later_bad = bad_after[bad_after >= i]
        if later_bad.size == 0 or t[later_bad[0]] >= t[i] + STAY_S:
            return float(t[i] - end)
    return float("inf")


def test_fused_heading_re_anchors_after_the_disturbance():
    """Measured over seeds 0-9 (docs/results.md): 9 of 10 within 2 min (seed 3: 310 s).
    Asked: the median within 2 min, at least 8 of 10, none locked out for over 10 min."""
    times = np.array([reanchor_s(seed) for seed in range(10)])
    assert np.median(times) <= 120.0, times
    assert (times <= 120.0).sum() >= 8, times
    assert times.max() <= 600.0, times

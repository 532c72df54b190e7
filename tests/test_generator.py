"""The scenario generator's classes (issue 21, item 4) as a log reader sees them."""

from __future__ import annotations

import numpy as np

from gyrodrift.simulate.generator import generate, seeds


def test_a_held_compass_is_on_every_row_correlated_and_never_repeated():
    """``held-compass``: each magnetometer sample is held until the next and jittered per row,
    so the heading is on every logged row (no outage in this class), no two successive values
    are equal (a reader drops exact repeats as held cells), the sample rate leaves several rows
    per sample, and on still rows most steps are jitter alone and successive errors correlate."""
    case = generate("held-compass", seeds("tuning", 3)[2], duration_scale=0.2)
    log = case.log
    h = log["heading"].to_numpy()
    assert np.isfinite(h).all() and ((h >= 0.0) & (h < 360.0)).all()
    assert np.count_nonzero(np.diff(h) == 0.0) == 0
    still = log["true_rate_z"].to_numpy() == 0.0
    err = (h - log["ref_heading"].to_numpy() + 180.0) % 360.0 - 180.0
    step = np.diff(err)[still[1:] & still[:-1]]
    rows_per_sample = 1.0 / np.median(np.diff(log["t"])) / case.compass.rate_hz
    # held: most steps are jitter only (differences of two jitters), a few are new samples
    assert np.median(np.abs(step)) < 1.0 and rows_per_sample >= 2.5
    assert np.corrcoef(err[:-1][still[:-1]], err[1:][still[:-1]])[0, 1] > 0.5

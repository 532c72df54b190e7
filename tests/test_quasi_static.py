"""Quasi-static windows: a parked or moored unit measures its drift through compass outages."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.kernels.aiding import _detrended_p2p

FS_HZ = 10.0
OUTAGE = (900.0, 4500.0)  # s: no compass in between


def outage_log(turn_dps: float = 0.0, sway_deg: float = 3.0, seed: int = 0) -> pd.DataFrame:
    """A unit at a steady temperature whose drift bends by 0.1 deg/s during a 1-h compass
    outage (nothing the temperature model could predict); it sways in yaw (``sway_deg``
    amplitude, 6-min period) and, from the outage on, turns at ``turn_dps``. Columns of the
    input contract plus the truth."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 5400.0, 1.0 / FS_HZ)
    temp = np.full(t.size, 30.0)
    drift = 0.3 + 0.1 * np.clip((t - OUTAGE[0]) / 3600.0, 0.0, 1.0) ** 2
    omega = 2.0 * np.pi / 360.0
    true_rate = sway_deg * omega * np.cos(omega * t) + turn_dps * (t >= OUTAGE[0])
    true_heading = 100.0 + sway_deg * np.sin(omega * t) + turn_dps * np.clip(t - OUTAGE[0], 0.0, None)
    heading = (true_heading + rng.normal(0.0, 0.3, t.size)) % 360.0
    heading[(t >= OUTAGE[0]) & (t < OUTAGE[1])] = np.nan
    gyro = true_rate + drift + rng.normal(0.0, 0.05, t.size)
    return pd.DataFrame({"t": t, "gyro_z": gyro, "temp": temp, "heading": heading,
                         "ref_heading": true_heading % 360.0, "true_bias_z": drift})


def run(log, quasi_static_s):
    # the windows on the temperature model: a steady temperature would otherwise make the
    # model's T the elapsed time (CompensatorConfig.temperature), whose trend uncertainty,
    # grown through the hour's outage, lets the 0.2 deg/s turn below pass the gate
    cfg = CompensatorConfig(temperature="measured")
    cfg = replace(cfg, adaptive=replace(cfg.adaptive, quasi_static_s=quasi_static_s))
    return compensate(log, cfg)


def outage_error(out) -> float:
    """Largest |heading error| (deg) over the outage."""
    inside = (out.t >= OUTAGE[0]) & (out.t < OUTAGE[1])
    err = (out.heading - out.ref_heading + 180.0) % 360.0 - 180.0
    return float(np.abs(err[inside]).max())


def outage_updates(out) -> int:
    inside = (out.t > OUTAGE[0] + 20.0) & (out.t < OUTAGE[1])
    return int(out["updated"][inside].sum())


def bias_error(out) -> float:
    """Mean |bias error| (deg/s) over the outage."""
    inside = (out.t >= OUTAGE[0]) & (out.t < OUTAGE[1])
    return float(np.abs(out.bias_z - out.true_bias_z)[inside].mean())


@pytest.mark.parametrize("sway_deg", [0.0, 3.0])
def test_a_parked_or_swaying_unit_measures_its_drift_through_an_outage(sway_deg):
    log = outage_log(sway_deg=sway_deg)
    on, off = run(log, 300.0), run(log, 0.0)
    assert outage_updates(off) == 0
    assert outage_updates(on) >= 10  # one per 300-s window: 12 in the outage
    # without the windows the drift's bend integrates to over a hundred degrees
    assert outage_error(off) > 100.0
    assert outage_error(on) < 0.4 * outage_error(off)
    assert bias_error(on) < 0.4 * bias_error(off)


def test_a_slow_real_turn_is_not_taken_for_drift():
    # 0.2 deg/s: below the turning gate, but a mean rate the drift in force does not explain
    log = outage_log(turn_dps=0.2)
    on = run(log, 300.0)
    assert outage_updates(on) == 0
    assert bias_error(on) == pytest.approx(bias_error(run(log, 0.0)), abs=1e-12)


def test_a_wide_sway_is_not_quasi_static():
    on = run(outage_log(sway_deg=20.0), 300.0)  # 40 deg peak to peak: not a parked unit
    assert outage_updates(on) == 0


def test_detrended_peak_to_peak_of_a_line_plus_a_sinusoid():
    t = np.linspace(0.0, 600.0, 61)
    y = 5.0 + 0.03 * t + 2.0 * np.sin(2.0 * np.pi * t / 150.0)
    resid = y - np.polyval(np.polyfit(t, y, 1), t)
    assert _detrended_p2p(np.column_stack([t, y])) == pytest.approx(np.ptp(resid), rel=1e-9)
    assert 4.0 <= np.ptp(resid) < 5.0
    assert _detrended_p2p(np.column_stack([t, 0.7 * t - 3.0])) == pytest.approx(0.0, abs=1e-9)


def test_intervals_as_long_as_the_window_show_too_little_to_be_used():
    # one point per 300-s interval: no sway could be seen, so no window is taken
    cfg = CompensatorConfig(update_interval_s=150.0)
    out = compensate(outage_log(), replace(cfg, adaptive=replace(cfg.adaptive, quasi_static_s=300.0)))
    assert outage_updates(out) == 0

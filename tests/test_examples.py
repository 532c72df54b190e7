"""Small known answers of the simulator, the scale-factor estimate and other parts (they were docstring examples)."""

from __future__ import annotations

import numpy as np

from gyrodrift.simulate.device import DeviceModel, random_device, temperature_reading


def test_device_model_examples():
    assert DeviceModel.noiseless().noise_density_dps_rthz == 0.0
    assert DeviceModel.noiseless(noise_density_dps_rthz=0.04).bias_instability_dps == 0.0
    assert float(DeviceModel().drift(25.0, 0.0)) == 0.15
    assert float(DeviceModel().scale_factor(40.0)) == 1.0
    assert round(float(DeviceModel(sf_ppm=1e4, sf_ppm_per_c=700.0).scale_factor(35.0)), 6) == 1.017
    assert DeviceModel().with_scenario_scale_factor("static").sf_ppm == 0.0
    assert DeviceModel(sf_ppm=0.0).with_scenario_scale_factor("scale-factor").sf_ppm == 0.0
    assert not DeviceModel().with_scenario_memory("static").has_memory()
    assert DeviceModel().with_scenario_memory("hysteresis").has_memory()


def test_backlash_stays_after_heating_by_more_than_its_width():
    dev = DeviceModel(play_dps=0.1, play_width_c=2.0, k_rate_dps_per_cps=0.0, hyst_dps=0.0)
    up = dev.drift_series(np.arange(5.0), [25.0, 26.0, 27.0, 28.0, 29.0], np.zeros(5))
    assert round(float(up[-1] - dev.drift(29.0, 0.0)), 6) == 0.1


def test_temperature_reading_is_quantised():
    reading = temperature_reading(np.array([25.01, 25.04]), DeviceModel.noiseless(), np.random.default_rng(0))
    assert reading.tolist() == [25.0, 25.0625]


def test_random_device_is_reproducible_and_has_memory_for_hysteresis_only():
    a = random_device(np.random.default_rng(5))
    assert a == random_device(np.random.default_rng(5))
    assert not a.has_memory()
    assert random_device(np.random.default_rng(5), scenario="hysteresis").has_memory()


def test_ramp_pieces():
    from gyrodrift.simulate.motion import hold_s, ramp_slice, smooth_step, sum_of_steps

    assert smooth_step(np.array([-2.0, 0.0, 1.0, 3.0])).tolist() == [0.0, 0.0, 1.0, 1.0]
    assert round(float(smooth_step(0.5)), 12) == 0.5
    assert ramp_slice(np.arange(10.0), 2.5, 4.0) == slice(3, 5, None)
    steps = sum_of_steps(np.arange(8.0), [(1.0, 2.0, 4.0), (4.0, 2.0, -4.0)])
    assert steps.round(12).tolist() == [0.0, 0.0, 2.0, 4.0, 4.0, 2.0, 0.0, 0.0]
    assert (hold_s(3600.0), hold_s(120.0)) == (60.0, 12.0)


def test_checks_name_the_field():
    import pytest

    from gyrodrift.errors import ConfigError
    from gyrodrift.simulate.checks import finite, nonneg, positive

    assert finite("rate_hz", 10, "CompassModel") == 10.0
    assert nonneg("noise_deg", 0, "CompassModel") == 0.0
    with pytest.raises(ConfigError, match=r"^simulate\.fs_hz must be > 0, got 0\.0$"):
        positive("fs_hz", 0.0, "simulate")


def test_seed_splits():
    from gyrodrift.simulate.generator import seeds

    assert (seeds("tuning", 3), seeds("held-out", 2)) == ([0, 1, 2], [1000000, 1000001])


def test_sf_filter_pulls_s0_towards_the_measurements():
    import pandas as pd

    from gyrodrift.scale_factor import sf_filter

    turns = pd.DataFrame({"sf_meas": [1.02] * 3, "temp_dev_c": [0.0] * 3, "r": [1e-8] * 3, "accepted": [True] * 3})
    x, _ = sf_filter(turns)
    assert round(float(x[-1, 0]), 4) == 1.02


def test_moving_mask_of_a_four_second_turn():
    from gyrodrift.scale_factor import moving_mask

    t = np.arange(0.0, 20.0, 0.1)
    m = moving_mask(t, np.where((t > 8) & (t < 12), 45.0, 0.0))
    assert (float(t[m][0]), float(t[m][-1])) == (7.7, 12.3)


def test_tracker_of_a_still_unit_keeps_the_prior_and_few_rows():
    import math

    from gyrodrift.scale_factor import ScaleFactorTracker

    tr = ScaleFactorTracker()
    rows = [tr.push(0.1 * i, 0.0, 30.0, 40.0 if i % 10 == 0 else math.nan) for i in range(1000)]
    assert (rows[-1].sf, rows[-1].heading_sf) == (1.0, 40.0)
    assert tr.buffered_rows < 200


def test_gravity_filter_of_a_still_level_unit_points_down():
    from gyrodrift.attitude import GravityFilter

    d = GravityFilter().feed([0.0, 0.1], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [[0, 0, -1.0], [0, 0, -1.0]])
    assert (d[-1] + 0.0).tolist() == [0.0, 0.0, 1.0]


def test_triad_learns_constant_x_and_y_drifts_of_a_still_level_unit():
    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.triad import TriadCompensator

    t = np.arange(0.0, 300.0, 0.1)
    acc = np.tile([0.0, 0.0, -1.0], (t.size, 1))
    out = TriadCompensator(CompensatorConfig()).feed(t, np.full(t.size, 0.1), np.full(t.size, -0.2),
                                                     np.full(t.size, 25.0), np.zeros(t.size), acc)
    assert (round(float(out["bias_x"][-1]), 4), round(float(out["bias_y"][-1]), 4)) == (0.1, -0.2)

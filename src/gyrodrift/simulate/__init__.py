"""Deterministic, seeded simulator of gyro + compass logs with truth columns.

Each scenario (:data:`SCENARIOS`) is a motion, the true heading integrated from it, and
the common gyro and compass error models; :func:`simulate` writes it as a log in the
input contract. What each scenario, model and column is: ``docs/simulator.md``.

Examples
--------
>>> df = simulate("static", seed=1, duration_s=120.0)
>>> list(df.columns)
['t', 'gyro_z', 'temp', 'heading', 'ref_heading', 'true_bias_z']
>>> int(df["heading"].notna().sum())  # 10 Hz compass over 120 s, both ends included
1201
"""

from gyrodrift.conventions import TRUE_BIAS_X, TRUE_BIAS_Y  # the x/y drift truth of simulate(..., triad=...)
from gyrodrift.simulate.adversarial import (
    BURSTY_RECORD_S, BURSTY_SPACING_S, NO_TEMP_CHANNEL_C, SWAY_MAX_RATE_DPS, bursty_records, ramp_interference_window,
    sway_outages,
)
from gyrodrift.simulate.device import SCENARIO_MEMORY, SCENARIO_SCALE_FACTOR_PPM, DeviceModel, TriadModel, random_device
from gyrodrift.simulate.motion import (
    Motion, calibration_temperature, cold_start_temperature, hysteresis_temperature, soak_ramps, soak_temperature,
    static_temperature, vehicle_temperature,
)
from gyrodrift.simulate.scenarios import (
    DEFAULT_DURATION_S, SCENARIOS, TRUE_SF, interference_windows_static, interference_windows_wander, rotation_plan,
    scenario_calibration, scenario_cold_start, scenario_hysteresis, scenario_interference_wander,
    scenario_scale_factor, scenario_soak, scenario_static, scenario_static_outages, scenario_vehicle, simulate,
    soak_outages, wander_offset,
)
from gyrodrift.simulate.sensors import GRAVITY_MPS2, CompassModel, random_compass

__all__ = [
    "DeviceModel", "TriadModel", "TRUE_BIAS_X", "TRUE_BIAS_Y", "CompassModel", "Motion", "SCENARIOS",
    "DEFAULT_DURATION_S", "GRAVITY_MPS2", "simulate", "static_temperature", "vehicle_temperature",
    "calibration_temperature", "interference_windows_static", "scenario_static", "scenario_static_outages",
    "scenario_vehicle", "scenario_calibration", "scenario_scale_factor", "rotation_plan",
    "SCENARIO_SCALE_FACTOR_PPM", "TRUE_SF", "SCENARIO_MEMORY", "hysteresis_temperature", "cold_start_temperature",
    "soak_temperature", "soak_ramps", "soak_outages", "interference_windows_wander", "wander_offset",
    "scenario_interference_wander", "scenario_hysteresis", "scenario_cold_start", "scenario_soak", "random_device",
    "random_compass", "BURSTY_RECORD_S", "BURSTY_SPACING_S", "NO_TEMP_CHANNEL_C", "SWAY_MAX_RATE_DPS",
    "bursty_records", "ramp_interference_window", "sway_outages",
]

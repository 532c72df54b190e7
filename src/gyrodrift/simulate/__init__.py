"""Deterministic, seeded simulator of gyro + compass logs with truth columns.

The simulator writes logs in the gyrodrift input contract (:mod:`gyrodrift.conventions`)
plus truth columns, for tests, the demo and the experiments of Feng, Li, Zhang (2015),
Section 4. Every scenario is built the same way:

1. a **motion**: true temperature ``T(t)`` (degC) with its exact rate ``T'(t)``
   (degC/s), the true heading rate (deg/s) and a constant mounting attitude;
2. the true heading is the trapezoid integral of the true heading rate at the sample
   times (so ``ref_heading`` and the true rate agree to rounding error);
3. the common error model: :class:`DeviceModel` for the gyro and temperature sensor,
   :class:`CompassModel` for the compass.

The gyro drift is deliberately **not** the paper's ``a*T + b*T' + c`` (eq. 2): it is a
cubic in temperature plus a rate term, a heating/cooling hysteresis and stochastic
bias terms (see :meth:`DeviceModel.drift`), so a filter that assumes eq. (2) has to
track slowly changing parameters, as on a real sensor.

The gyro scale factor is exactly 1 except in the ``scale-factor`` scenario (Section
4.3: the static heating run with full turns on a turntable), where it changes by
about 3 % with temperature (:meth:`DeviceModel.scale_factor`).

Scenarios (:data:`SCENARIOS`, default lengths in :data:`DEFAULT_DURATION_S`): the
paper's ``static``, ``static-outages``, ``vehicle``, ``calibration`` and
``scale-factor``, and four beyond the paper:

* ``interference-wander``: ``static`` with magnetic interference whose offset wanders
  by a few degrees over minutes (:func:`wander_offset`), too slowly for a
  disagreement gate to notice;
* ``hysteresis``: a 10 → 70 → 10 degC cycle and a minor loop, with a device whose
  drift depends on the temperature history (a thermal lag and a backlash hysteresis,
  :data:`SCENARIO_MEMORY`, :meth:`DeviceModel.drift_series`);
* ``cold-start``: a warm-up from -20 to +60 degC after a cold soak;
* ``soak``: 12 h of slow yaw sway, temperature plateaus and ramps, and long compass
  outages (missing or interfered) during the ramps (:func:`soak_outages`).

and seven adversarial ones, built to break a design that relies on what the paper's
runs offer (:mod:`gyrodrift.simulate.adversarial`): ``bursty`` (5-s records every
~300 s, with or without a compass), ``ramp-interference`` (about 30 deg of wandering
interference during a fast temperature fall), ``sway`` (a moored platform, slow sway,
long outages, a day/night cycle), ``vehicle-rawmag`` (``vehicle`` with the raw
magnetometer and accelerometer, no heading column), ``vessel`` (a slow continuous
turn), ``no-temp`` (a temperature column that reads a constant 0 degC) and ``short``
(tens of seconds).

:func:`random_device` and :func:`random_compass` draw randomised sensors for Monte
Carlo runs (:mod:`gyrodrift.evaluate.montecarlo`).

Output columns
--------------
==================  ========  =====================================================
column              unit      meaning
==================  ========  =====================================================
``t``               s         sample time, ``k / fs_hz``
``gyro_z``          deg/s     raw gyro: SF × true body rate + drift + white noise
``temp``            degC      sensor temperature reading (noise, quantisation)
``heading``         deg       compass heading in [0, 360); NaN between compass samples
``ref_heading``     deg       true heading in [0, 360) (a perfect FOG reference)
``true_bias_z``     deg/s     true drift (deterministic + bias instability + RRW)
``true_sf``         --        true gyro scale factor ``SF(T)``; only in ``scale-factor``
                              or when a device scale-factor coefficient is non-zero
``mag_x/y/z``       µT        ``raw_mag=True`` only: FRD body field, NaN off compass rows
``acc_x/y/z``       g         ``raw_mag=True`` only: FRD specific force (still: z = -1)
==================  ========  =====================================================

A scenario may log differently (see :func:`simulate`): ``bursty`` keeps the rows of its
records only, ``no-temp`` writes a constant ``temp``, ``vehicle-rawmag`` writes the raw
columns instead of ``heading``, and a ``bursty`` log may have no compass column.

The ``heading`` column is always the tilt-compensated heading
(:func:`gyrodrift.compass.tilt_compensated_heading`) of the simulated field and
specific force, whether or not the raw columns are written. With
``CompassModel.kinematic_tilt`` the accelerometer also feels the vehicle's
acceleration (braking, cornering), which tilts the computed heading, as on a real
strapdown compass. The Earth's rotation (at most 0.004 deg/s) is not simulated: it
would be a constant part of the drift.

Randomness: one :class:`numpy.random.SeedSequence` of ``seed`` is split into
independent streams (trajectory, gyro white noise, bias instability, rate random
walk, temperature noise, compass noise), so switching one noise term off leaves the
others unchanged.

Modules
-------
:mod:`~gyrodrift.simulate.device`
    :class:`DeviceModel`, :class:`TriadModel`, the bias processes, :func:`random_device`.
:mod:`~gyrodrift.simulate.sensors`
    :class:`CompassModel`, :func:`random_compass`, compass and accelerometer synthesis.
:mod:`~gyrodrift.simulate.motion`
    :class:`Motion` and the temperature profiles.
:mod:`~gyrodrift.simulate.scenarios`
    The scenarios, :data:`SCENARIOS`, :data:`DEFAULT_DURATION_S` and :func:`simulate`.
:mod:`~gyrodrift.simulate.adversarial`
    The adversarial scenarios.
:mod:`~gyrodrift.simulate.checks`
    Validation of the models' numbers.

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
    BURSTY_RECORD_S,
    BURSTY_SPACING_S,
    NO_TEMP_CHANNEL_C,
    SWAY_MAX_RATE_DPS,
    bursty_records,
    ramp_interference_window,
    sway_outages,
)
from gyrodrift.simulate.device import SCENARIO_MEMORY, SCENARIO_SCALE_FACTOR_PPM, DeviceModel, TriadModel, random_device
from gyrodrift.simulate.motion import (
    Motion,
    calibration_temperature,
    cold_start_temperature,
    hysteresis_temperature,
    soak_ramps,
    soak_temperature,
    static_temperature,
    vehicle_temperature,
)
from gyrodrift.simulate.scenarios import (
    DEFAULT_DURATION_S,
    SCENARIOS,
    TRUE_SF,
    interference_windows_static,
    interference_windows_wander,
    rotation_plan,
    scenario_calibration,
    scenario_cold_start,
    scenario_hysteresis,
    scenario_interference_wander,
    scenario_scale_factor,
    scenario_soak,
    scenario_static,
    scenario_static_outages,
    scenario_vehicle,
    simulate,
    soak_outages,
    wander_offset,
)
from gyrodrift.simulate.sensors import GRAVITY_MPS2, CompassModel, random_compass

__all__ = [
    "DeviceModel",
    "TriadModel",
    "TRUE_BIAS_X",
    "TRUE_BIAS_Y",
    "CompassModel",
    "Motion",
    "SCENARIOS",
    "DEFAULT_DURATION_S",
    "GRAVITY_MPS2",
    "simulate",
    "static_temperature",
    "vehicle_temperature",
    "calibration_temperature",
    "interference_windows_static",
    "scenario_static",
    "scenario_static_outages",
    "scenario_vehicle",
    "scenario_calibration",
    "scenario_scale_factor",
    "rotation_plan",
    "SCENARIO_SCALE_FACTOR_PPM",
    "TRUE_SF",
    "SCENARIO_MEMORY",
    "hysteresis_temperature",
    "cold_start_temperature",
    "soak_temperature",
    "soak_ramps",
    "soak_outages",
    "interference_windows_wander",
    "wander_offset",
    "scenario_interference_wander",
    "scenario_hysteresis",
    "scenario_cold_start",
    "scenario_soak",
    "random_device",
    "random_compass",
    "BURSTY_RECORD_S",
    "BURSTY_SPACING_S",
    "NO_TEMP_CHANNEL_C",
    "SWAY_MAX_RATE_DPS",
    "bursty_records",
    "ramp_interference_window",
    "sway_outages",
]

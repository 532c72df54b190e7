"""Adaptive estimate of the temperature-dependent gyro scale factor (Feng et al. 2015, Sec. 4.3).

Section 4.3 compensates the scale factor (SF) "with the adaptive algorithm"
(Figs. 10, 11) but gives no equations; this package is gyrodrift's design in the
spirit of Section 3.

Model
-----
After the drift compensation of :func:`gyrodrift.compensator.compensate`
(``rate_z = gyro_z - bias_z``, eqs. 1, 2, 5), the gyro still reads

    rate_z = SF(T) * true_rate + (drift residual) + noise,
    SF(T) = s0 + s1 * (T - T_ref)                                  (cf. eq. 2)

with ``T`` the gyro temperature (degC, empty cells held) and ``T_ref`` = ``t_ref_c``.
``x = [s0 (unitless), s1 (1/degC)]`` are the states of a strong tracking Kalman
filter, constant between updates (Φ = Γ = I): at each accepted measurement
``P- = s*P + Q``, a Joseph-form correction (eq. 10), P capped at ``P0``.
``rate_sf = rate_z / SF(T)``.

Measurement: one per rotation
-----------------------------
The SF filter updates only over a **rotation**: a run of rows whose centred
``turn_window_s`` mean of ``rate_z`` exceeds ``turn_rate_dps``. Two still windows
of ``still_s``, ``guard_s`` before and after it, bracket it; over each window's
compass samples the gyro heading ``psi_g`` and the unwrapped compass heading
``psi_c`` are averaged. Then

    y = (psi_g(after) - psi_g(before)) / (psi_c(after) - psi_c(before))
      ≈ rate-weighted mean of SF over the rotation,
    H = [1, mean(T - T_ref)]   (mean weighted by |rate_z|, i.e. over the angle turned),
    R = (σ_c² (1/n_before + 1/n_after) + N² Δt + (d_res Δt)²) / Δψ_c²

with σ_c = ``compass_sigma_deg``, N = ``gyro_noise_dps_rthz``, d_res =
``residual_drift_dps``, Δt between the window centres. The compass is unwrapped
against the gyro (``psi_c = psi_g + unwrap(wrap_180(compass - psi_g))``), so a full
turn counts 360°.

A rotation is ``accepted`` when both windows are still and inside the log, each
holds ``min_compass_samples``, no compass gap exceeds ``max_compass_gap_s``, no row
was refused by the drift compensator (:data:`REJECT_GATES`), the compass turned at
least ``min_turn_deg`` and ``|y - 1| <= max_sf_error``. The new parameters apply from
the row after the second window; the rows before the first accepted rotation get
its SF.

Causal and non-causal
---------------------
The default pass of :func:`estimate_scale_factor` (the paper reproduction) looks
ahead ``guard_s + turn_window_s/2`` and applies the first rotation's SF
retroactively. ``causal=True`` and :class:`ScaleFactorTracker` (row by row or in
chunks, bounded memory) measure the same rotations, but an update applies from the
row at which it can be decided, the prior ``x0`` holds until the first update,
``heading_sf`` is NaN before the first compass heading, and a rotation longer than
``max_turn_s`` is dropped (``long_turn``). The cost is mostly the first turn,
integrated with the prior SF (docs/results.md); a prior from a calibration removes it.

Where the paper is silent (choices made here)
---------------------------------------------
* Linear SF model in temperature (the paper's SF "model" has unknown form); states
  ``[s0, s1]`` like ``[c, a]`` of eq. (2).
* The compass heading change must be true: full turns, or a deviation-calibrated
  compass.
* No fading or process noise between rotations: a still unit keeps its SF.
* "Fixed parameters" (the paper's green line): the inverse-variance mean of the
  first ``fixed_turns`` accepted measurements, frozen (1.0 if none).
* The SF does not feed back into the drift filter, which updates only when still.

Modules: ``config``, ``turns`` (rotation test, measurements), ``filter`` (the SF
filter, the fixed SF), ``batch`` (:func:`estimate_scale_factor`), ``streaming``
(:class:`ScaleFactorTracker`). The experiment of Section 4.3 is
:func:`gyrodrift.evaluate.paper.scale_factor_experiment`.
"""

from gyrodrift.scale_factor.batch import estimate_scale_factor, heading_error, integrate_heading
from gyrodrift.scale_factor.config import ScaleFactorConfig
from gyrodrift.scale_factor.filter import fixed_scale_factor, sf_filter
from gyrodrift.scale_factor.streaming import (
    TRACKER_COLUMNS,
    CompensatedSFSample,
    ScaleFactorRow,
    ScaleFactorTracker,
)
from gyrodrift.scale_factor.turns import REJECT_GATES, moving_mask, turn_measurements

__all__ = [
    "ScaleFactorConfig",
    "moving_mask",
    "turn_measurements",
    "sf_filter",
    "fixed_scale_factor",
    "integrate_heading",
    "heading_error",
    "estimate_scale_factor",
    "ScaleFactorTracker",
    "ScaleFactorRow",
    "TRACKER_COLUMNS",
    "CompensatedSFSample",
    "REJECT_GATES",
]

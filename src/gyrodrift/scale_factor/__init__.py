"""Adaptive estimate of the temperature-dependent gyro scale factor (Feng et al. 2015, Sec. 4.3).

Section 4.3 of the paper compensates the scale factor (SF) "with the adaptive
algorithm" on simulated rotations combined with the static heating data, and shows
the ideal, a fixed-parameter and the adaptive SF (Fig. 10) and the heading error
without SF compensation, with the fixed SF and with the adaptive SF (Fig. 11). It
gives no equations; this package is gyrodrift's design in the spirit of Section 3.

Model
-----
After the drift compensation of :func:`gyrodrift.compensator.compensate`
(``rate_z = gyro_z - bias_z``, eqs. 1, 2, 5), the gyro still reads

    rate_z = SF(T) * true_rate + (drift residual) + noise,
    SF(T) = s0 + s1 * (T - T_ref)                                  (cf. eq. 2)

with ``T`` the measured gyro temperature (degC; an empty cell holds the previous value,
as in the drift compensator) and ``T_ref`` = ``t_ref_c``. The parameters
``x = [s0 (unitless), s1 (1/degC)]`` are the states of a strong tracking
Kalman filter modelled as constant between updates (Φ = Γ = I, Section 3.2): at each
accepted measurement ``P- = s*P + Q`` then a Joseph-form correction (eq. 10,
:func:`gyrodrift.kernels.numeric.correct`), and P is capped at the prior ``P0``
(:func:`gyrodrift.kernels.numeric.cap_covariance`). The SF compensated rate
is ``rate_sf = rate_z / SF(T)``.

Measurement: one per rotation
-----------------------------
The drift filter updates only when the unit is still or straight; the SF filter is
its mirror image and updates only over a **rotation**. A rotation is a run of rows
whose centred ``turn_window_s`` mean of ``rate_z`` exceeds ``turn_rate_dps`` in
magnitude. For
each one, two still windows of ``still_s`` seconds, ``guard_s`` before its start and
``guard_s`` after its end, bracket it; over the compass samples of each window the
gyro heading ``psi_g`` (trapezoid integral of ``rate_z``) and the unwrapped compass
heading ``psi_c`` are averaged (which divides the compass noise variance by the
number of samples). Then

    y = (psi_g(after) - psi_g(before)) / (psi_c(after) - psi_c(before))
      ≈ rate-weighted mean of SF over the rotation,
    H = [1, mean(T - T_ref)]   (mean weighted by |rate_z|, i.e. over the angle turned),
    R = (σ_c² (1/n_before + 1/n_after) + N² Δt + (d_res Δt)²) / Δψ_c²

with σ_c = ``compass_sigma_deg``, N = ``gyro_noise_dps_rthz`` (angle random walk),
d_res = ``residual_drift_dps`` (drift left after the drift compensation), Δt the
time between the window centres, and Δψ_c the compass heading change. The compass
is unwrapped against the gyro: ``psi_c = psi_g + unwrap(wrap_180(compass - psi_g))``,
so a full turn counts 360° (not 0°) and the unwrapping survives compass gaps as long
as compass and gyro disagree by less than 180°.

A rotation counts (``accepted``) only if both windows are still (no moving row within
``guard_s`` of them) and inside the log, each window holds ``min_compass_samples``
compass samples, no compass gap inside the span exceeds ``max_compass_gap_s``, no
row of the span was refused by the drift compensator for a gap, a field anomaly or
magnetic interference, the compass turned by at least ``min_turn_deg`` (a small
turn measures the SF badly, R ∝ 1/Δψ²) and ``|y - 1| <= max_sf_error``. The new
parameters apply from the row after the end of the second window, and the rows up to the
first accepted rotation are compensated with the SF it produced (as the drift
compensator emits the rows of its initialisation window with the parameters the window
gave), so the first turn is not integrated with the bare prior.

Causal and non-causal
---------------------
The default pass of :func:`estimate_scale_factor` (the paper reproduction) is not
strictly causal, in two ways: (1) the rotation test is a centred window, half a
``turn_window_s`` of look-ahead, and the update at the end of the second still window
is decided with the not-still check of the ``guard_s`` after it, so with ``guard_s`` +
``turn_window_s/2`` of look-ahead; (2) the rows up to the first accepted rotation get
that rotation's result retroactively.

``estimate_scale_factor(..., causal=True)``, and :class:`ScaleFactorTracker`, which
computes the same numbers row by row or in chunks with bounded memory (for
:class:`gyrodrift.compensator.Compensator` and streaming), make every row depend only on
itself and the rows before it. The rotations and their measurements are the same; what
differs:

* an update applies from the first row at which it could be decided from the rows so
  far (``guard_s + turn_window_s/2``, 2.5 s by default, after the end of the second
  still window, where the default pass applies it from the row after that end);
* no retroactive initialisation: the prior ``x0`` applies until the first update;
* ``heading_sf`` is NaN before the first compass heading (it cannot be anchored yet);
* a rotation whose rotating rows last longer than ``max_turn_s`` is dropped
  (``long_turn``), which bounds the rows the tracker keeps; a rotation not decided by
  the end of the log is ``edge``.

What the causal pass loses, on the 3-h experiment
(:func:`gyrodrift.paper.scale_factor_experiment`, seed 0, 10 Hz, default settings; causal
against default): SF RMS after the first update
2.864e-4 against 2.845e-4 (max 1.379e-3 against 1.359e-3); the SF's share of the
heading error (``sf_heading_rms_deg``) 3.28 against 0.32 deg RMS, and the whole heading
error 4.92 against 2.48 deg RMS. The heading loss is the first turn, integrated with the
prior SF 1 while the true SF is 1.0086: a 3.15-deg offset that the open-loop heading
keeps for the rest of the run. The 2.5-s later updates cost less than 1e-4 deg per
rotation. A prior ``x0`` from a calibration removes most of it.

Where the paper is silent (choices made here)
---------------------------------------------
* Linear SF model in temperature (the paper's SF "model" has unknown form); states
  ``[s0, s1]`` like ``[c, a]`` of eq. (2).
* The measurement is a ratio of heading changes over a turn between still windows;
  the compass heading change must be true, which holds for full turns (the
  deviation is a function of heading) or for a deviation-calibrated compass.
* No fading or process noise is applied between rotations: without a measurement
  there is nothing to discount, so a still unit keeps its SF estimate and covariance.
* "Fixed parameters" (the paper's green line): a one-off calibration, the
  inverse-variance weighted mean of the first ``fixed_turns`` accepted SF
  measurements (at the start temperature), then frozen and applied to the whole run
  (as a calibration done before the run would be). 1.0 if no rotation was accepted.
* The SF compensation does not feed back into the drift filter: the drift filter
  updates only when still, where the SF does not matter.

==================  ================================================================
module              what it holds
==================  ================================================================
:mod:`.config`      :class:`ScaleFactorConfig`
:mod:`.turns`       the rotation test and the measurements (:func:`moving_mask`,
                    :func:`turn_measurements`, :data:`REJECT_GATES`)
:mod:`.filter`      the SF Kalman filter (:func:`sf_filter`) and the one-off
                    calibration (:func:`fixed_scale_factor`)
:mod:`.batch`       :func:`estimate_scale_factor`, :func:`integrate_heading`,
                    :func:`heading_error`
:mod:`.streaming`   :class:`ScaleFactorTracker`, :class:`ScaleFactorRow`,
                    :data:`TRACKER_COLUMNS`, :class:`CompensatedSFSample`
==================  ================================================================

The experiment of Section 4.3 (Figs. 10 and 11) is
:func:`gyrodrift.paper.scale_factor_experiment`.
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

"""The adaptive drift compensator: per sample (:class:`Compensator`) or per log (:func:`compensate`).

Method (Feng, Li, Zhang 2015, Sections 2–3)
-------------------------------------------
Every sample: ``bias_z = a*T + b*T' + c`` (eq. 2/5) with the parameters in force,
``rate_z = gyro_z - bias_z``, and the heading integrated from ``rate_z`` by the
trapezoid rule, starting at the first compass heading.

Every update interval (``update_interval_s``, 10 s) the change of
(gyro heading − compass heading) over the interval measures the drift:

    m = z̄ + Δ(A_gyro − A_compass)/Δt                      (eqs. 4 and 6)

where ``z̄`` is the mean drift the compensator subtracted over the interval. With
``gyro = true rate + drift`` (eq. 1), the compensated gyro heading gains
``(drift − z̄)Δt`` against the compass, so this sign makes ``m`` the mean drift
over the interval. The paper prints eq. (6) as Δ(A_compass − A_gyro); with eq. (1)
that would give ``2 z̄ − drift``, so gyrodrift uses the sign that measures the drift
(tested: a constant bias on a static log drives c to that bias). Algebraically
``m = (∫gyro_z dt − ΔA_compass)/Δt``: it does not depend on the compensation.
The matching row of H is the interval mean of ``[T, T', 1]`` (the paper takes the
values at the interval end); the last ``stack_depth`` accepted measurements are
stacked into y and H (eq. 3, ``y = [m_{k+1}, m_k, m_{k-1}]``) and the estimator is
updated. Measurement noise: ``R = 2 σ_compass²/Δt² + N_gyro²/Δt`` per measurement.

Refused intervals (see :mod:`gyrodrift.gating`) do not update the parameters, which
keep compensating through the outage (eq. 5), the paper's key property.

Initialisation
--------------
The first ``init_s`` seconds (30 s: the paper's y1..y3) are split into
``stack_depth`` sub-windows; each motionless one (gyro std and compass change below
the ``still_*`` thresholds) gives one drift measurement, its mean gyro rate, as the
paper does. They form the first stacked measurement (update at the end of the
init window) from the prior ``x0, P0``. A log that starts in motion gets no init
measurement: the filter starts from its prior and learns from the compass. Rows of the
init window are emitted when it ends, compensated with the parameters it produced.

Missing values: an empty gyro or temperature cell holds the previous value and
refuses that interval (``gap``); an empty compass cell is "no compass sample here".
A temperature that never changes over the log explains no drift: the model's ``T`` is
then the elapsed time (``CompensatorConfig.temperature``, :func:`uses_clock`).

Causality: every output row depends only on earlier rows, except init rows, which
depend on the whole init window. The equations are in :mod:`gyrodrift.kernels`;
:class:`ChunkEngine` runs them and :class:`~gyrodrift.compensator.intake.Intake` (the
compass, tilt, clock and x/y axes before and after it) feeds it for :class:`Compensator`,
:func:`compensate` and the chunked file path alike, so all three give the same numbers.

==================  ================================================================
module              what it holds
==================  ================================================================
:mod:`.config`      :class:`CompensatorConfig`, :func:`build_estimator`, :func:`uses_clock`
:mod:`.engine`      :class:`ChunkEngine`: the state, chunk by chunk
:mod:`.intake`      :class:`Intake`: the front end of every entry point
:mod:`.memory`      output memory (:class:`OutputBuffers`)
:mod:`.output`      :class:`CompensatedSample`, the output table
:mod:`.batch`       :func:`compensate`, :func:`compensate_arrays`
:mod:`.streaming`   :class:`Compensator`
==================  ================================================================
"""

from gyrodrift.compensator.batch import compensate, compensate_arrays
from gyrodrift.compensator.config import CompensatorConfig, build_estimator, clock_config, uses_clock
from gyrodrift.compensator.engine import ChunkEngine
from gyrodrift.compensator.memory import OutputBuffers
from gyrodrift.compensator.output import (
    MEASUREMENT_COLUMNS,
    UNOBSERVABLE,
    CompensatedSample,
    append_input_columns,
    check_input_columns,
    output_frame,
)
from gyrodrift.compensator.streaming import Compensator

__all__ = [
    "CompensatorConfig", "build_estimator", "CompensatedSample", "Compensator", "compensate", "compensate_arrays",
    "OutputBuffers", "ChunkEngine", "MEASUREMENT_COLUMNS", "UNOBSERVABLE", "output_frame", "check_input_columns",
    "append_input_columns", "uses_clock", "clock_config",
]

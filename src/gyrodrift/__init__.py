"""gyrodrift: adaptive compensation of MEMS gyroscope temperature drift.

Implements, then extends, Feng, Li, Zhang, "An Adaptive Compensation Algorithm for
Temperature Drift of MEMS Gyroscopes Using a Strong Tracking Kalman Filter",
Sensors 2015, 15(5), 11222-11238 (doi:10.3390/s150511222).

Data flow: :func:`gyrodrift.io.read_log` → compass heading
(:mod:`gyrodrift.compass`) → aiding gates (:mod:`gyrodrift.gating`) → drift
estimator (:mod:`gyrodrift.estimators`) → :func:`compensate` /
:class:`Compensator` → :mod:`gyrodrift.metrics`.

Conventions (all in :mod:`gyrodrift.conventions`): time in s, rates in deg/s,
temperature in degC, headings in deg clockwise from magnetic north in [0, 360),
body frame FRD / world NED, so ``gyro_z > 0`` means the heading increases.
The gyro reads ``true rate + drift``; ``drift = a*T + b*T' + c`` and
``rate_z = gyro_z - bias_z``.
"""

__version__ = "0.1.0"

from gyrodrift.compensator import (
    CompensatedSample,
    Compensator,
    CompensatorConfig,
    compensate,
    compensate_arrays,
    OutputBuffers,
)
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.estimators import KalmanConfig
from gyrodrift.gating import GateConfig
from gyrodrift.model import TempRateConfig

__all__ = [
    "__version__",
    "CompensatedSample",
    "Compensator",
    "CompensatorConfig",
    "compensate",
    "compensate_arrays",
    "OutputBuffers",
    "ConfigError",
    "GyroDriftError",
    "LogFormatError",
    "KalmanConfig",
    "GateConfig",
    "TempRateConfig",
]

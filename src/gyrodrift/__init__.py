"""gyrodrift: adaptive compensation of MEMS gyroscope temperature drift.

Implements, then extends, Feng, Li, Zhang, "An Adaptive Compensation Algorithm for
Temperature Drift of MEMS Gyroscopes Using a Strong Tracking Kalman Filter",
Sensors 2015, 15(5), 11222-11238 (doi:10.3390/s150511222).

Data flow: :func:`gyrodrift.io.read_log` → compass heading
(:mod:`gyrodrift.compass`) → aiding gates (:mod:`gyrodrift.gating`) → drift
estimator (:mod:`gyrodrift.estimators`) → :func:`compensate` /
:class:`Compensator` → :mod:`gyrodrift.evaluate.metrics`.

Conventions (all in :mod:`gyrodrift.conventions`): time in s, rates in deg/s,
temperature in degC, headings in deg clockwise from magnetic north in [0, 360),
body frame FRD / world NED, so ``gyro_z > 0`` means the heading increases.
The gyro reads ``true rate + drift``; ``drift = a*T + b*T' + c`` and
``rate_z = gyro_z - bias_z``.
"""

from gyrodrift._version import __version__

from gyrodrift.compensator import (
    CompensatedSample,
    Compensator,
    CompensatorConfig,
    compensate,
    compensate_arrays,
    OutputBuffers,
)
from gyrodrift.config import load_config
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.estimators import AdaptiveConfig, KalmanConfig
from gyrodrift.fusion import FusionConfig
from gyrodrift.gating import GateConfig
from gyrodrift.io import ReadOptions, read_log
from gyrodrift.model import TempRateConfig
from gyrodrift.pipeline import compensate_file

__all__ = [
    "__version__",
    "CompensatedSample",
    "Compensator",
    "CompensatorConfig",
    "compensate",
    "compensate_arrays",
    "OutputBuffers",
    "read_log",
    "ReadOptions",
    "compensate_file",
    "load_config",
    "ConfigError",
    "GyroDriftError",
    "LogFormatError",
    "AdaptiveConfig",
    "KalmanConfig",
    "FusionConfig",
    "ScaleFactorConfig",
    "GateConfig",
    "TempRateConfig",
]


def __getattr__(name: str):
    """:class:`~gyrodrift.scale_factor.ScaleFactorConfig` on first use: its package imports
    scipy (a third of a second), which ``import gyrodrift`` does not need."""
    if name == "ScaleFactorConfig":
        from gyrodrift.scale_factor import ScaleFactorConfig

        return ScaleFactorConfig
    raise AttributeError(f"module 'gyrodrift' has no attribute {name!r}")

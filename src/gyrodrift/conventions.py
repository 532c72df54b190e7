"""Units, frames, sign conventions and column names: declared once, here.

Every quantity inside gyrodrift is in these units (the table: docs/conventions.md, section
"Units, frames and signs"); readers convert on the way in. The gyro measurement model is
eq. (1) of Feng et al. (2015), ``gyro_z = true_rate + drift + noise`` with the drift of
eq. (2), so the compensated rate is ``rate_z = gyro_z - bias_z``.
"""

from __future__ import annotations

import numpy as np

from gyrodrift.kernels.numeric import wrap360_all

__all__ = [
    "T",
    "GYRO_Z",
    "GYRO_X",
    "GYRO_Y",
    "TEMP",
    "HEADING",
    "MAG_COLS",
    "ACC_COLS",
    "REF_HEADING",
    "TRUE_BIAS_Z",
    "TRUE_BIAS_X",
    "TRUE_BIAS_Y",
    "REQUIRED_COLS",
    "OUTPUT_COLS",
    "GYRO_UNITS",
    "TIME_UNITS",
    "FRAMES",
    "TEMP_RANGE_C",
    "wrap_360",
    "wrap_180",
]

# Input contract column names.
T = "t"
GYRO_Z = "gyro_z"
GYRO_X = "gyro_x"
GYRO_Y = "gyro_y"
TEMP = "temp"
HEADING = "heading"
MAG_COLS = ("mag_x", "mag_y", "mag_z")
ACC_COLS = ("acc_x", "acc_y", "acc_z")
REF_HEADING = "ref_heading"
TRUE_BIAS_Z = "true_bias_z"
#: Simulation truth of the x and y drift, deg/s (evaluation only; FRD signs like gyro_x, gyro_y).
TRUE_BIAS_X = "true_bias_x"
TRUE_BIAS_Y = "true_bias_y"

REQUIRED_COLS = (T, GYRO_Z, TEMP)

#: Output contract of ``gyrodrift compensate`` (extra input columns follow).
OUTPUT_COLS = (
    "t",
    "rate_z",
    "bias_z",
    "heading",
    "a",
    "b",
    "c",
    "updated",
    "gated",
    "gate_reason",
)

#: Multiplier from each accepted gyro unit to deg/s.
GYRO_UNITS = {"deg/s": 1.0, "dps": 1.0, "rad/s": float(np.degrees(1.0))}

#: Multiplier from each accepted time unit of a table's ``t`` column to s.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}

#: Accepted body/world frame conventions of input logs.
FRAMES = ("ned", "enu")

#: Physically plausible gyro temperature range, degC (outside = bad input).
TEMP_RANGE_C = (-60.0, 150.0)


def wrap_360(angle_deg):
    """Wrap an angle (deg) to [0, 360).

    >>> float(wrap_360(-90.0))
    270.0
    """
    x = np.asarray(angle_deg, dtype=float)
    flat = np.ascontiguousarray(x).ravel()
    out = np.empty_like(flat)
    wrap360_all(flat, out)  # the kernels' wrap360, element by element
    return out.reshape(x.shape)


def wrap_180(angle_deg):
    """Wrap an angle (deg) to [-180, 180).

    >>> float(wrap_180(270.0))
    -90.0
    """
    return wrap_360(np.asarray(angle_deg) + 180.0) - 180.0

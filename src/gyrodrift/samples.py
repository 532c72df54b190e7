"""One row of the streaming compensator: :class:`CompensatedSample`, and
:class:`CompensatedSFSample` when it also tracks the scale factor (Sec. 4.3).

Plain records with no dependencies, so that the compensator and the scale-factor
tracker, which fill them, both build on them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

__all__ = ["CompensatedSample", "CompensatedSFSample"]


@dataclass(frozen=True)
class CompensatedSample:
    """One output row (the output contract of ``gyrodrift compensate``)."""

    t: float
    rate_z: float
    bias_z: float
    heading: float
    a: float
    b: float
    c: float
    updated: int
    gated: int
    gate_reason: str
    temp_rate: float
    compass_heading: float
    unobservable: str
    bias_sd: float
    heading_fused: float
    heading_fused_sd: float
    heading_sd: float
    #: x and y axes (deg/s; :mod:`gyrodrift.triad`), when the samples carry ``gyro_x_dps``,
    #: ``gyro_y_dps`` and ``acc``; NaN (and ``tilt_gated`` 0) otherwise.
    rate_x: float = math.nan
    rate_y: float = math.nan
    bias_x: float = math.nan
    bias_y: float = math.nan
    tilt_gated: int = 0
    #: Scale factor: NaN here; fields of :class:`CompensatedSFSample`. Class attributes, not
    #: fields, so that ``asdict`` and ``fields`` of a sample without a scale factor give the
    #: columns of :func:`gyrodrift.compensate`.
    sf = math.nan
    sf_sd = math.nan
    rate_sf = math.nan
    heading_sf = math.nan


@dataclass(frozen=True)
class CompensatedSFSample(CompensatedSample):
    """A :class:`CompensatedSample` with the scale factor, as the streaming
    :class:`gyrodrift.compensator.Compensator` returns it when given ``scale_factor``: ``sf``
    (unitless), ``sf_sd``, ``rate_sf`` (deg/s) and ``heading_sf`` (deg) of
    :class:`gyrodrift.scale_factor.ScaleFactorTracker`."""

    sf: float = math.nan
    sf_sd: float = math.nan
    rate_sf: float = math.nan
    heading_sf: float = math.nan

    @classmethod
    def of(cls, sample: CompensatedSample, row) -> "CompensatedSFSample":
        """``sample`` with the SF columns of ``row`` (a :class:`~gyrodrift.scale_factor.ScaleFactorRow`)."""
        base = {f.name: getattr(sample, f.name) for f in fields(CompensatedSample)}
        return cls(**base, sf=row.sf, sf_sd=row.sf_sd, rate_sf=row.rate_sf, heading_sf=row.heading_sf)

"""Fused heading: the compensated gyro and the compass combined, with its standard deviation.

``heading_fused``/``heading_fused_sd`` are a one-state Kalman filter on the heading, propagated
by the compensated rate and corrected by the compass samples the gates allow;
``heading_sd`` is the uncertainty of the gyro-alone heading. The row update is
:func:`gyrodrift.kernels.fusion.step`; the filter and its settings: ``docs/heading_and_axes.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyrodrift.kernels import fusion as fusion_kernel
from gyrodrift.settings import check, setting

__all__ = ["FusionConfig", "FusionState", "fuse_rows"]


@dataclass(frozen=True, kw_only=True)
class FusionConfig:
    """Settings of the fused heading: the defaults are (B), :meth:`tolerant` gives (A).

    Each setting and what was measured with it: ``docs/heading_and_axes.md`` (fused heading).
    """

    heading_sigma_deg: float = setting(2.0, "deg", gt=0.0)
    bias_corr_s: float = setting(30.0, "s", gt=0.0)
    nis_gate: float = setting(9.0, gt=0.0)
    relock_s: float = setting(math.inf, "s", gt=0.0, inf=True)
    consistent_s: float = setting(300.0, "s", gt=0.0, inf=True)
    magnetic_gates: bool = True

    @classmethod
    def tolerant(cls, **overrides) -> "FusionConfig":
        """Settings (A), for estimators whose refusals cannot be trusted (``stkf``, the baselines):
        interference refusals ignored, re-anchoring after 60 s of refusals, τ_b = 300 s."""
        settings = {"bias_corr_s": 300.0, "relock_s": 60.0, "magnetic_gates": False}
        settings.update(overrides)
        return cls(**settings)

    def __post_init__(self):
        check(self)

    def vector(self, gyro_noise_dps_rthz: float) -> np.ndarray:
        """The settings as the kernel takes them: [σ_c², N², τ_b, nis_gate, relock_s, consistent_s]."""
        return np.array([self.heading_sigma_deg**2, gyro_noise_dps_rthz**2, self.bias_corr_s, self.nis_gate,
                         self.relock_s, self.consistent_s])


class FusionState:
    """State of the fused heading of one log, fed rows in time order (the kernel the compensator runs)."""

    def __init__(self, config: FusionConfig, gyro_noise_dps_rthz: float, max_gap_s: float = math.inf):
        self.cfg = config.vector(gyro_noise_dps_rthz)
        self.st = np.zeros(11)
        #: Across a time step longer than this (s) the heading holds (the unit is taken as still).
        self.max_gap_s = float(max_gap_s)

    def row(self, t: float, rate: float, compass: float, allow: bool, bias_sd: float) -> tuple[float, float, float]:
        """One row: (heading_fused deg, heading_fused_sd deg, heading_sd deg)."""
        h, sd, gsd = self.rows(np.array([t]), np.array([rate]), np.array([compass]), np.array([allow]),
                               np.array([bias_sd]))
        return float(h[0]), float(sd[0]), float(gsd[0])

    def rows(self, t, rate, compass, allow, bias_sd) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Many rows at once (the same numbers as :meth:`row` on each)."""
        n = len(t)
        out = np.empty((3, n))
        fusion_kernel.fuse_rows(self.st, np.ascontiguousarray(t, dtype=float), np.ascontiguousarray(rate, dtype=float),
               np.ascontiguousarray(compass, dtype=float), np.ascontiguousarray(allow, dtype=np.bool_),
               np.ascontiguousarray(bias_sd, dtype=float), self.cfg, self.max_gap_s, out[0], out[1], out[2])
        return out[0], out[1], out[2]


def fuse_rows(t_s, rate_dps, compass_deg, allow, bias_sd_dps, config: FusionConfig | None = None,
              gyro_noise_dps_rthz: float = 0.04):
    """Fused heading of a whole log.

    Parameters
    ----------
    t_s, rate_dps, compass_deg : (N,) array_like
        Time (s), compensated rate (deg/s), compass heading (deg, NaN = no sample).
    allow : (N,) bool array_like
        False where the compass must not be used (a magnetic refusal).
    bias_sd_dps : (N,) array_like
        Standard deviation of the compensated drift, deg/s.
    config : FusionConfig, optional
    gyro_noise_dps_rthz : float
        Gyro white-noise density N, deg/s/√Hz.

    Returns
    -------
    heading_fused_deg, heading_fused_sd_deg, heading_sd_deg : (N,) ndarray
    """
    return FusionState(config or FusionConfig(), gyro_noise_dps_rthz).rows(t_s, rate_dps, compass_deg, allow, bias_sd_dps)

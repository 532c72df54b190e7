"""PX4-style thermal calibration baseline (``poly3``): a cubic in temperature, fitted offline on a
still heating run of the same device and clamped to its range in use; no T' term, no adaptation
(``docs/engine.md``, "The least-squares baselines").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.kernels.thermal import fit_polynomial

__all__ = ["Poly3Calibration", "fit_poly3"]


@dataclass(frozen=True)
class Poly3Calibration:
    """A fitted thermal calibration.

    Attributes
    ----------
    coeffs : tuple of 4 floats
        Highest power first (``numpy.polyval`` order), deg/s per degC^k.
    temp_ref_c, temp_min_c, temp_max_c : float
        Reference temperature and calibrated range, degC.
    """

    coeffs: tuple[float, float, float, float]
    temp_ref_c: float
    temp_min_c: float
    temp_max_c: float

    def drift(self, temp_c):
        """Drift (deg/s) at temperatures clamped to the calibrated range."""
        x = np.clip(np.asarray(temp_c, dtype=float), self.temp_min_c, self.temp_max_c) - self.temp_ref_c
        return np.polyval(self.coeffs, x)


def fit_poly3(temp_c, gyro_z_dps, *, median_window: int = 31, order: int = 3) -> Poly3Calibration:
    """Fit the cubic on a motionless calibration run (the gyro reads only its drift).

    Examples
    --------
    >>> T = np.linspace(-10, 60, 5000)
    >>> cal = fit_poly3(T, 0.1 + 0.02 * (T - 25) + 1e-4 * (T - 25) ** 2)
    >>> round(float(cal.drift(25.0)), 6), round(float(cal.drift(100.0) - cal.drift(60.0)), 6)
    (0.1, 0.0)
    """
    temp_c = np.asarray(temp_c, dtype=float)
    rate = np.asarray(gyro_z_dps, dtype=float)
    ok = np.isfinite(temp_c) & np.isfinite(rate)
    temp_c, rate = temp_c[ok], rate[ok]
    if temp_c.size < 10 * (order + 1) or np.ptp(temp_c) < 1.0:
        raise ConfigError(
            "calibration run too short or too flat for a cubic fit: it needs a still heating run "
            f"spanning several degC (got {temp_c.size} samples over {np.ptp(temp_c) if temp_c.size else 0:.2f} degC)"
        )
    from scipy.ndimage import median_filter  # imported here: scipy.ndimage costs 0.2 s at start-up

    rate = median_filter(rate, size=median_window, mode="nearest")
    t_min, t_max = float(temp_c.min()), float(temp_c.max())
    t_ref = 0.5 * (t_min + t_max)
    coeffs = fit_polynomial(temp_c, rate, t_ref, order)[::-1]  # highest power first, as polyval
    return Poly3Calibration(tuple(float(c) for c in coeffs), t_ref, t_min, t_max)

"""The thermal calibration's cubic in ``T - T_ref``, fitted once for the ``poly3`` baseline and
``gyrodrift calibrate``: one least-squares solve over a whole run (numpy, not compiled).
"""

from __future__ import annotations

import numpy as np

__all__ = ["fit_polynomial"]


def fit_polynomial(temp_c, rate_dps, temp_ref_c: float, order: int = 3, weights=None) -> np.ndarray:
    """Least-squares polynomial of the rate in the temperature.

    Parameters
    ----------
    temp_c, rate_dps : array_like
        Temperatures (degC) and gyro rates (deg/s) of a still run, finite.
    temp_ref_c : float
        The polynomial's origin (degC).
    order : int, default 3
        Its degree.
    weights : array_like, optional
        Weight of each sample in the sum of squares (default: equal).

    Returns
    -------
    numpy.ndarray
        ``order + 1`` coefficients, lowest power first: deg/s per degC**k of ``T - T_ref``
        (``numpy.polynomial.polynomial.polyval`` order). The fit is solved in the temperature
        scaled to about ±1 over the run, for conditioning, and scaled back.

    Examples
    --------
    >>> T = np.linspace(10.0, 50.0, 200)
    >>> c = fit_polynomial(T, 0.1 + 0.02 * (T - 30) - 1e-4 * (T - 30) ** 3, 30.0)
    >>> np.allclose(c, [0.1, 0.02, 0.0, -1e-4], rtol=0, atol=1e-12)
    True
    """
    temp_c = np.asarray(temp_c, dtype=float)
    rate_dps = np.asarray(rate_dps, dtype=float)
    half = max(0.5 * (float(temp_c.max()) - float(temp_c.min())), 1e-9)
    vander = np.vander((temp_c - temp_ref_c) / half, order + 1, increasing=True)
    if weights is None:
        scaled, *_ = np.linalg.lstsq(vander, rate_dps, rcond=None)
    else:
        root_w = np.sqrt(np.asarray(weights, dtype=float))
        scaled, *_ = np.linalg.lstsq(vander * root_w[:, None], rate_dps * root_w, rcond=None)
    return scaled / half ** np.arange(order + 1)

"""The heading integral of a whole array, the trapezoid rule of eq. (5), for the code outside the
compiled row loops (baselines, smoother, metrics): numpy, not compiled.
"""

from __future__ import annotations

import numpy as np

__all__ = ["trapezoid"]


def trapezoid(t_s, rate, hold=None) -> np.ndarray:
    """Cumulative trapezoid integral of ``rate`` over ``t_s``, 0 at the first row.

    Parameters
    ----------
    t_s, rate : array_like
        Times (s) and the rate to integrate (deg/s gives deg), one per row.
    hold : array_like of bool, optional
        Rows whose step from the row before adds nothing (a time gap, across which the
        engine holds the heading).

    Examples
    --------
    >>> trapezoid([0.0, 1.0, 2.0, 12.0], [1.0, 3.0, 3.0, 3.0], hold=[False, False, False, True])
    array([0., 2., 5., 5.])
    """
    t_s = np.asarray(t_s, dtype=float)
    rate = np.asarray(rate, dtype=float)
    out = np.zeros(rate.size)
    if rate.size > 1:
        inc = 0.5 * (rate[1:] + rate[:-1]) * np.diff(t_s)
        if hold is not None:
            inc = np.where(np.asarray(hold, dtype=bool)[1:], 0.0, inc)
        np.cumsum(inc, out=out[1:])
    return out

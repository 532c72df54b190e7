"""Validation of the numbers given to the simulator's models and to :func:`~gyrodrift.simulate.simulate`.

Each check returns the value as a float or raises :class:`~gyrodrift.errors.ConfigError`
naming the field as ``owner.name``.
"""

from __future__ import annotations

import math

from gyrodrift.errors import ConfigError

__all__ = ["finite", "nonneg", "positive"]


def finite(name: str, value, owner: str) -> float:
    """A finite real number (not a bool), as float.

    Parameters
    ----------
    name : str
        Field name, for the error message.
    value : object
        The value to check.
    owner : str
        Class or function the field belongs to, for the error message.

    Returns
    -------
    float

    Raises
    ------
    ConfigError
        ``value`` is not an int or float, is a bool, or is not finite.

    Examples
    --------
    >>> finite("rate_hz", 10, "CompassModel")
    10.0
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{owner}.{name} must be a finite number, got {value!r}")
    return float(value)


def nonneg(name: str, value, owner: str) -> float:
    """A finite number >= 0, as float (see :func:`finite` for the parameters).

    Examples
    --------
    >>> nonneg("noise_deg", 0, "CompassModel")
    0.0
    """
    v = finite(name, value, owner)
    if v < 0:
        raise ConfigError(f"{owner}.{name} must be >= 0, got {value!r}")
    return v


def positive(name: str, value, owner: str) -> float:
    """A finite number > 0, as float (see :func:`finite` for the parameters).

    Examples
    --------
    >>> positive("fs_hz", 0.0, "simulate")
    Traceback (most recent call last):
    ...
    gyrodrift.errors.ConfigError: simulate.fs_hz must be > 0, got 0.0
    """
    v = finite(name, value, owner)
    if v <= 0:
        raise ConfigError(f"{owner}.{name} must be > 0, got {value!r}")
    return v

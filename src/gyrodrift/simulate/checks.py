"""Validation of the numbers given to the simulator's models and to :func:`~gyrodrift.simulate.simulate`.

Each check returns the value as a float or raises :class:`~gyrodrift.errors.ConfigError`
naming the field ``name`` of ``owner`` (a class or function) as ``owner.name``.
"""

from __future__ import annotations

import math

from gyrodrift.errors import ConfigError

__all__ = ["finite", "nonneg", "positive"]


def finite(name: str, value, owner: str) -> float:
    """A finite real number (an int or float, not a bool), as float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{owner}.{name} must be a finite number, got {value!r}")
    return float(value)


def nonneg(name: str, value, owner: str) -> float:
    """A finite number >= 0, as float."""
    v = finite(name, value, owner)
    if v < 0:
        raise ConfigError(f"{owner}.{name} must be >= 0, got {value!r}")
    return v


def positive(name: str, value, owner: str) -> float:
    """A finite number > 0, as float."""
    v = finite(name, value, owner)
    if v <= 0:
        raise ConfigError(f"{owner}.{name} must be > 0, got {value!r}")
    return v

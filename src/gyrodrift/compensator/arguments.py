"""The checks of the Python API's arguments, run before any compiled code sees them (which
indexes its inputs unchecked): a wrong kind is an :class:`~gyrodrift.errors.ArgumentTypeError`,
a wrong shape or length a :class:`~gyrodrift.errors.LogFormatError`, each one line.
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from gyrodrift.compensator.config import CompensatorConfig
from gyrodrift.compensator.memory import OutputBuffers
from gyrodrift.errors import ArgumentTypeError, LogFormatError
from gyrodrift.estimators.base import DriftEstimator

__all__ = ["short", "shown", "check_source", "check_config", "check_estimator", "check_callable", "check_buffers",
           "column", "rows", "check_log", "frame_column"]


def short(value) -> str:
    """A value for a message: its repr, shortened and on one line."""
    text = " ".join(repr(value).split())
    return text if len(text) <= 40 else text[:37] + "..."


def shown(value) -> str:
    """A value for a message: its type and :func:`short` repr."""
    return f"{type(value).__name__} {short(value)}"


def check_source(source) -> str:
    """``source`` (the name in messages) as a str: a str or a path."""
    if isinstance(source, os.PathLike):
        return str(source)
    if not isinstance(source, str):
        raise ArgumentTypeError(f"source must be a str naming the data in messages, got {shown(source)}")
    return source


def check_config(config):
    """``config`` as a :class:`~gyrodrift.compensator.CompensatorConfig` (None: the defaults;
    its settings were checked when it was made, :mod:`gyrodrift.settings`)."""
    if config is None:
        return CompensatorConfig()
    if not isinstance(config, CompensatorConfig):
        raise ArgumentTypeError(
            f"config must be a CompensatorConfig (gyrodrift.config.load_config reads one from a TOML file) or None, "
            f"got {shown(config)}"
        )
    return config


def check_estimator(estimator) -> None:
    """Refuse an ``estimator`` that is neither None nor a drift estimator instance."""
    if estimator is None:
        return
    if isinstance(estimator, type) or not isinstance(estimator, DriftEstimator):
        raise ArgumentTypeError(
            "estimator must be a drift estimator instance (e.g. gyrodrift.compensator.build_estimator(config), or "
            f"an object with name, causal, params, cov, update, hold and drift) or None, got {shown(estimator)}"
        )


def check_callable(value, name: str) -> None:
    """Refuse a ``value`` that is neither None nor callable."""
    if value is not None and not callable(value):
        raise ArgumentTypeError(f"{name} must be a callable or None, got {shown(value)}")


def check_buffers(buffers) -> None:
    """Refuse ``buffers`` that are neither None nor :class:`~gyrodrift.compensator.OutputBuffers`."""
    if buffers is not None and not isinstance(buffers, OutputBuffers):
        raise ArgumentTypeError(f"buffers must be OutputBuffers or None, got {shown(buffers)}")


def _floats(value, name: str, source: str) -> np.ndarray:
    """``value`` as a float array, or a one-line error naming the argument ``name``."""
    if value is None:
        raise ArgumentTypeError(f"{source}: {name} must be an array of numbers, got None")
    if isinstance(value, (str, bytes, dict, set)):
        raise ArgumentTypeError(f"{source}: {name} must be an array of numbers, got {shown(value)}")
    try:
        if isinstance(value, (pd.Series, pd.Index, pd.api.extensions.ExtensionArray)):
            value = value.to_numpy(dtype=float, na_value=np.nan)
        arr = np.asarray(value)
        if arr.dtype.kind in "iuf":
            return arr.astype(float, copy=False)
        if arr.dtype.kind == "O":
            return arr.astype(float)
    except (TypeError, ValueError, OverflowError):
        pass
    else:
        raise ArgumentTypeError(f"{source}: {name} must be an array of numbers, got an array of {arr.dtype}")
    raise ArgumentTypeError(f"{source}: {name} must be an array of numbers, got {shown(value)}")


def column(value, name: str, source: str, n: int | None = None) -> np.ndarray:
    """A one-dimensional float array of ``n`` values (any length when ``n`` is None).

    Raises
    ------
    ArgumentTypeError
        ``value`` is not an array of numbers.
    LogFormatError
        It is not one-dimensional, or has another length than ``n``.
    """
    arr = _floats(value, name, source)
    if arr.ndim != 1:
        raise LogFormatError(f"{source}: {name} must be one-dimensional (one value per sample), got shape {arr.shape}")
    if n is not None and arr.size != n:
        raise LogFormatError(
            f"{source}: {name} has {arr.size} values but t_s has {n}: give every array one value per sample"
        )
    return arr


def rows(value, name: str, source: str, n: int, width: int) -> np.ndarray:
    """An (n, width) float array (``mag``, ``acc``: width 3; ``gyro_xy``: 2), or a one-line error."""
    arr = _floats(value, name, source)
    if arr.shape != (n, width):
        raise LogFormatError(
            f"{source}: {name} must have shape ({n}, {width}) (one row of {width} per sample), got shape {arr.shape}"
        )
    return arr


def check_log(log, source) -> None:
    """Refuse a ``log`` that is not a DataFrame, or whose column names repeat."""
    if not isinstance(log, pd.DataFrame):
        raise ArgumentTypeError(
            "log must be a pandas DataFrame with columns t, gyro_z, temp (gyrodrift.io.read_log reads one from a "
            f"file; pandas.DataFrame(...) makes one from a dict or a structured array), got {shown(log)}"
        )
    names = pd.Index(log.columns)
    if names.has_duplicates:
        twice = names[names.duplicated()][0]
        raise LogFormatError(f"{source}: column {twice!r} is given {int((names == twice).sum())} times; "
                             "give every column once")


def frame_column(log: pd.DataFrame, name: str, source: str) -> np.ndarray:
    """Column ``name`` of ``log`` as floats, or a :class:`LogFormatError` naming it."""
    col = log[name]
    try:
        return col.to_numpy(dtype=float, na_value=np.nan)
    except (TypeError, ValueError, OverflowError):
        bad = next((v for v in col.tolist() if not _is_number(v)), None)
        raise LogFormatError(f"{source}: column {name!r} holds values that are not numbers, e.g. {bad!r}; "
                             "give numbers (empty cells as NaN)") from None


def _is_number(value) -> bool:
    try:
        float(value)
    except (TypeError, ValueError, OverflowError):
        return False
    return True

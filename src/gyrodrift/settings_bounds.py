"""The range every setting must lie in, one check for Python, TOML and the command line.

The settings classes check the sign and the kind of their values; a finite value can
still be one the arithmetic cannot take (``compass_sigma_deg = 1e308`` squares to inf,
``p0_sd = 1e-300`` to a covariance of zeros, ``bin_s = 1e-300`` asks for 6e301 bins,
``innovation_window = 1e9`` for gigabytes). Here every number setting is bounded by
name, whatever class holds it:

* a number (float): 0, or a magnitude within :data:`NUMBER_RANGE` (1e-9 to 1e9: no
  setting in s, deg, degC or deg/s means anything outside), or inf where its class
  takes inf (``relock_s``), and above the larger minima of :data:`NUMBER_MINIMA`; a
  triple such as ``p0_sd`` element by element;
* a whole number: at most :data:`WHOLE_MAX`, and the smaller maxima of :data:`WHOLE_MAXIMA`;
* ``[temp_rate]``: ``window_s / bin_s`` at most :data:`MAX_TEMP_RATE_BINS` bins.

:func:`setting_problem` judges one value (the TOML loader, :mod:`gyrodrift.config`, and
the command line ask it as they read); :func:`check_settings` walks a whole
:class:`~gyrodrift.compensator.CompensatorConfig` (the Python API asks it before a
run, :mod:`gyrodrift._arguments`). Every refusal is a
:class:`~gyrodrift.errors.ConfigError` of one line naming the table and the key.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

from gyrodrift.errors import ConfigError

__all__ = ["NUMBER_RANGE", "NUMBER_MINIMA", "WHOLE_MAX", "WHOLE_MAXIMA", "MAX_TEMP_RATE_BINS", "setting_problem", "check_values",
           "check_table", "check_settings"]

#: Smallest and largest magnitude of a number setting other than 0 (and inf where allowed).
NUMBER_RANGE = (1e-9, 1e9)
#: Larger smallest magnitudes of number settings, by name: a gyro noise density below
#: 1e-6 deg/s/sqrt(Hz) (a hundredth of a navigation-grade gyro's) weights the drift
#: measurements so heavily that the least-squares estimators' normal equations turn singular.
NUMBER_MINIMA = {"gyro_noise_dps_rthz": 1e-6}
#: Largest whole-number setting.
WHOLE_MAX = 1_000_000
#: Smaller maxima of whole-number settings, by name: measurements stacked per update, and
#: the updates of the innovation window (each sizes memory the filter keeps and works on).
WHOLE_MAXIMA = {"stack_depth": 1000, "innovation_window": 10_000}
#: Largest number of temperature bins in the T' window (``window_s / bin_s``).
MAX_TEMP_RATE_BINS = 100_000


def _show(value) -> str:
    return repr(value) if not isinstance(value, float) or math.isfinite(value) else str(value)


def _clause(key: str, value) -> str | None:
    """What is wrong with one number for the setting ``key``, as a clause (None: nothing)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None  # not a number: the settings classes judge it
    if isinstance(value, numbers.Integral):
        top = WHOLE_MAXIMA.get(key, WHOLE_MAX)
        return f"is beyond {top:,}, the largest this setting takes" if abs(int(value)) > top else None
    x = float(value)
    lo, hi = NUMBER_RANGE
    if math.isnan(x) or math.isinf(x) or x == 0.0:
        return None  # NaN, inf and 0 are the settings classes' to judge
    if not lo <= abs(x) <= hi:
        return f"is outside the range of any setting (0, or a magnitude from {lo:g} to {hi:g})"
    if abs(x) < NUMBER_MINIMA.get(key, lo):
        return f"is below {NUMBER_MINIMA[key]:g}, the smallest this setting takes"
    return None


def _first_bad(key: str, value):
    """The first number of ``value`` (a number, or a tuple of them, nested) out of range,
    with its clause; None when there is none."""
    if isinstance(value, tuple):
        for item in value:
            bad = _first_bad(key, item)
            if bad is not None:
                return bad
        return None
    clause = _clause(key, value)
    return None if clause is None else (value, clause)


def setting_problem(key: str, value) -> str | None:
    """What is wrong with ``value`` for the setting ``key`` (None: nothing).

    Parameters
    ----------
    key : str
        The setting's name (the field of its class).
    value
        Its value, of the declared type: a number, a whole number or a tuple of them
        (anything else is not judged here).

    Returns
    -------
    str or None
        ``"<key> = <value> is outside ..."`` (for a tuple, the element out of range
        after a colon), one clause; or None.
    """
    bad = _first_bad(key, value)
    if bad is None:
        return None
    item, clause = bad
    if item is value:
        return f"{key} = {_show(value)} {clause}"
    return f"{key} = {_show(value)}: {_show(item)} {clause}"


def check_values(values: dict, where: str) -> None:
    """Refuse the first value of ``values`` (key -> value of its declared type) that
    :func:`setting_problem` finds out of range.

    Raises
    ------
    ConfigError
        ``<where>: <problem>``.
    """
    for key, value in values.items():
        problem = setting_problem(key, value)
        if problem is not None:
            raise ConfigError(f"{where}: {problem}")


def check_table(obj, where: str) -> None:
    """Refuse settings of one table that are out of range together: a T' window
    (``window_s``, ``bin_s``) of more than :data:`MAX_TEMP_RATE_BINS` bins.

    Raises
    ------
    ConfigError
        ``<where>: <problem>``.
    """
    window_s, bin_s = getattr(obj, "window_s", None), getattr(obj, "bin_s", None)
    if isinstance(window_s, numbers.Real) and isinstance(bin_s, numbers.Real) and bin_s > 0 and \
            math.isfinite(window_s) and window_s / bin_s > MAX_TEMP_RATE_BINS:
        raise ConfigError(f"{where}: window_s / bin_s = {window_s / bin_s:.3g} bins is beyond {MAX_TEMP_RATE_BINS:,}; "
                          "lengthen bin_s or shorten window_s")


def check_settings(config, where: str = "config") -> None:
    """Refuse settings outside their range anywhere in ``config`` (a settings dataclass,
    e.g. a :class:`~gyrodrift.compensator.CompensatorConfig`, and the tables it holds).

    Raises
    ------
    ConfigError
        ``<where> [<table>]: <problem>``, naming the first value out of range.
    """
    _check_tree(config, where)


def _check_tree(obj, where: str) -> None:
    values = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name, None)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            _check_tree(value, f"{where} [{f.name}]")
        else:
            values[f.name] = value
    check_values(values, where)
    check_table(obj, where)

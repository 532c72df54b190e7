"""Compensator settings from a TOML file (``gyrodrift compensate --config FILE``).

Top-level keys are the fields of :class:`~gyrodrift.compensator.CompensatorConfig`;
the tables ``[kalman]``, ``[gate]``, ``[temp_rate]``, ``[adaptive]`` and ``[fusion]``
hold the fields of :class:`~gyrodrift.estimators.KalmanConfig`,
:class:`~gyrodrift.gating.GateConfig`, :class:`~gyrodrift.model.TempRateConfig`,
:class:`~gyrodrift.estimators.AdaptiveConfig` and :class:`~gyrodrift.fusion.FusionConfig`.
Anything left out keeps its default; a ``[fusion]`` table changes the fused-heading
settings of the paper's filters, which start from the tolerant ones
(``CompensatorConfig.fusion_settings``, :meth:`~gyrodrift.fusion.FusionConfig.tolerant`)::

    update_interval_s = 10.0
    init_s = 30.0

    [kalman]
    fading = 1.2
    p0_sd = [0.05, 5.0, 5.0]   # a deg/s/degC, b deg, c deg/s

    [gate]
    turn_rate_dps = 2.0

    [adaptive]                 # the default estimator's model (AdaptiveConfig)
    disturbed_s = 600.0        # mean length of a magnetic disturbance, s
    turn_walks = [0.003, 0.03, 0.3, 3.0]   # deg/s/√s, slow turns to manoeuvres

    [fusion]                   # the fused-heading settings (B) of docs/results.md
    magnetic_gates = true
    bias_corr_s = 30.0
    relock_s = inf

Checks
------
The file is read as bytes and must be UTF-8 (a leading byte-order mark is allowed) and
at most :data:`MAX_FILE_BYTES` long. Every value is checked against the type its
setting declares before the settings classes check their ranges: a number setting
takes an integer or a float (not ``true``/``false``, not ``nan``), a whole-number
setting a 64-bit integer, a switch ``true`` or ``false``, a name a quoted string, and
a triple such as ``p0_sd`` a list of exactly three numbers. Unknown keys are refused.
The settings in drift-model units are also checked against physics: ``[kalman]``
``x0`` must lie within :data:`DRIFT_PARAM_BOUNDS` (``|a| <= 1`` deg/s/degC, ``|b| <=
1000`` deg, ``|c| <= 50`` deg/s; the bounds of a device profile, see
:mod:`gyrodrift.profile`), and the standard deviations ``p0_sd``, ``q_sd``, ``max_sd``
(and those on the diagonal of ``p0_cov``) within the same bounds. So are the
``[adaptive]`` settings in those units: the random walks ``slope_walk`` (of a),
``rate_walk`` (of b), ``drift_walk`` and ``drift_walk_temp`` (of c), the jump
``drift_jump_dps`` and the drift's rate ``drift_rate_dps2`` (at most c's bound per second);
its angles ``heading_sd0``, ``compass_error_deg``, ``disturbance_step_deg`` and the walks
``disturbance_walk`` and ``still_walk`` (deg per √s) are at most a turn, 360 deg (a larger
value is no angle, and its square can overflow). The settings class checks the rest (a
list such as ``turn_walks`` of exactly four positive numbers). Every number must also lie
in the range of :mod:`gyrodrift.settings_bounds` (0, or a magnitude from 1e-9 to 1e9; whole
numbers and the ``[temp_rate]`` window bounded too), so that no finite value reaches
arithmetic that cannot take it. Every problem is a :class:`~gyrodrift.errors.ConfigError`
of one line that names the file, the table and the key.
"""

from __future__ import annotations

import codecs
import dataclasses
import datetime as _dt
import json
import math
import sys
import types
import typing
from dataclasses import fields, replace
from functools import lru_cache
from pathlib import Path

from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError
from gyrodrift.estimators.base import DRIFT_BOUNDS_TEXT, DRIFT_PARAM_BOUNDS
from gyrodrift.settings_bounds import check_table, check_values

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "MAX_FILE_BYTES", "DRIFT_PARAM_BOUNDS", "load_config", "config_from_dict", "load_toml", "apply_settings",
    "read_utf8",
]

_TABLES = ("kalman", "gate", "temp_rate", "adaptive", "fusion")
#: Largest settings or profile file read, bytes (such files are a few hundred bytes).
MAX_FILE_BYTES = 1 << 20
_INT64 = (-(2**63), 2**63 - 1)
#: Per table: the settings that are triples (a, b, c) of drift-model values.
_DRIFT_TRIPLES = {"kalman": ("x0", "p0_sd", "q_sd", "max_sd")}
_A_MAX, _B_MAX, _C_MAX = DRIFT_PARAM_BOUNDS
#: Per table: single settings and their plausible largest magnitude, with its unit.
_BOUNDED = {
    "adaptive": {
        "slope_walk": (_A_MAX, "deg/s/degC per √degC"),
        "rate_walk": (_B_MAX, "deg/degC per √s"),
        "drift_walk": (_C_MAX, "deg/s per √s"),
        "drift_walk_temp": (_C_MAX, "deg/s per √degC"),
        "drift_jump_dps": (_C_MAX, "deg/s"),
        "drift_rate_dps2": (_C_MAX, "deg/s²"),
        "heading_sd0": (360.0, "deg"),
        "compass_error_deg": (360.0, "deg"),
        "disturbance_step_deg": (360.0, "deg"),
        "disturbance_walk": (360.0, "deg per √s"),
        "still_walk": (360.0, "deg per √s"),
    },
}


def _one_line(text) -> str:
    return " ".join(str(text).split())


def read_utf8(path, what: str) -> str:
    """The text of a small UTF-8 file, read as bytes; every problem is one line.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        What the file is, for the messages (``"settings file"``, ``"profile file"``).

    Returns
    -------
    str
        The text, without a leading UTF-8 byte-order mark.

    Raises
    ------
    ConfigError
        The file is missing or unreadable, larger than :data:`MAX_FILE_BYTES`, or not
        UTF-8 (the message gives the first bad byte and its offset). Each message
        starts with the path.
    """
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise ConfigError(f"{path}: {what} not found; check the path") from None
    except OSError as err:
        raise ConfigError(f"{path}: cannot read the {what} ({err.strerror or _one_line(err)})") from None
    if len(data) > MAX_FILE_BYTES:
        raise ConfigError(
            f"{path}: larger than {MAX_FILE_BYTES >> 10} KiB, too large for a {what}; check that the path names the "
            f"right file"
        )
    skip = len(codecs.BOM_UTF8) if data.startswith(codecs.BOM_UTF8) else 0
    try:
        return data[skip:].decode("utf-8")
    except UnicodeDecodeError as err:
        offset = skip + err.start
        raise ConfigError(
            f"{path}: the {what} is not UTF-8 text (byte 0x{data[offset]:02x} at offset {offset}); "
            "save it with UTF-8 encoding"
        ) from None


# --------------------------------------------------------------------------- schema


class _Mismatch(Exception):
    """A value does not have the declared type; ``expected`` says what it must be."""

    def __init__(self, expected: str) -> None:
        super().__init__(expected)
        self.expected = expected


def _show(value, limit: int = 60) -> str:
    """A value as it is written in TOML, on one line and at most about ``limit`` characters."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    elif isinstance(value, int):
        if abs(value) < 10**40:
            text = str(value)
        else:  # str() of a very long integer is refused by Python (and unreadable)
            sign = "a negative" if value < 0 else "an"
            text = f"{sign} integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    elif isinstance(value, str):
        text = json.dumps(value, ensure_ascii=False)
    elif isinstance(value, (_dt.date, _dt.time)):
        text = value.isoformat()
    elif isinstance(value, (list, tuple)):
        parts, size = [], 2
        for item in value:
            if size > limit:
                parts.append("...")
                break
            part = _show(item, max(8, limit - size))
            parts.append(part)
            size += len(part) + 2
        text = "[" + ", ".join(parts) + "]"
    elif isinstance(value, dict):
        text = "a table"
    elif value is None:
        text = "nothing"
    else:
        text = type(value).__name__
    return text if len(text) <= limit + 3 else text[:limit] + "..."


def _key(key) -> str:
    """A settings key for a message: bare when it is a plain name, else quoted with escapes."""
    return key if isinstance(key, str) and key.isidentifier() else repr(key)


_NOUNS = {float: ("a number", "numbers"), int: ("a whole number", "whole numbers"),
          bool: ("true or false", "true/false values"), str: ("text in quotes", "texts in quotes")}


def _describe(hint, plural: bool = False) -> str:
    """What a value of the declared type ``hint`` is, in words ("a list of 3 numbers")."""
    if hint in _NOUNS:
        return _NOUNS[hint][plural]
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_describe(a, plural) for a in args if a is not type(None))
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            inner = _describe(args[0], True)
            return f"lists of {inner}" if plural else f"a list of {inner}"
        if len(set(args)) == 1:
            inner = _describe(args[0], True)
            return f"lists of {len(args)} {inner}" if plural else f"a list of {len(args)} {inner}"
        inner = ", ".join(_describe(a) for a in args)
        return f"lists of ({inner})" if plural else f"a list of ({inner})"
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return "tables of settings" if plural else "a table of settings"
    return getattr(hint, "__name__", str(hint))


def _conform(value, hint):
    """``value`` converted to the declared type ``hint`` (an integer to float for a
    number, a list to a tuple), or :class:`_Mismatch`. Types this schema does not know
    pass unchanged: their settings class checks them."""
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _Mismatch(_describe(hint))
        try:
            number = float(value)
        except OverflowError:
            raise _Mismatch("a number within the range of a float") from None
        if math.isnan(number):
            raise _Mismatch("a number (not nan)")
        return number
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise _Mismatch(_describe(hint))
        if not _INT64[0] <= value <= _INT64[1]:
            raise _Mismatch("a whole number within the 64-bit range")
        return value
    if hint is bool or hint is str:
        if not isinstance(value, hint):
            raise _Mismatch(_describe(hint))
        return value
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        options = [a for a in args if a is not type(None)]
        if value is None and len(options) < len(args):
            return None
        for option in options:
            try:
                return _conform(value, option)
            except _Mismatch:
                continue
        raise _Mismatch(_describe(hint))
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise _Mismatch(_describe(hint))
        if len(args) == 2 and args[1] is Ellipsis:
            kinds = [args[0]] * len(value)
        elif len(value) != len(args):
            raise _Mismatch(_describe(hint))
        else:
            kinds = list(args)
        try:
            return tuple(_conform(v, k) for v, k in zip(value, kinds))
        except _Mismatch:
            raise _Mismatch(_describe(hint)) from None
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        if not isinstance(value, hint):
            raise _Mismatch(_describe(hint))
        return value
    return value


@lru_cache(maxsize=None)
def _declared_types(cls) -> dict:
    """Field name -> declared type of a settings dataclass (empty if the annotations
    cannot be resolved: the settings class then checks its values alone)."""
    try:
        return typing.get_type_hints(cls)
    except Exception:  # an annotation that names something not importable here
        return {}


def _within_drift_bounds(table: str):
    """A check for :func:`apply_settings`: the drift-model triples of ``table`` (and the
    variances of ``[kalman] p0_cov``) within :data:`DRIFT_PARAM_BOUNDS`, and the single
    settings of ``table`` that have a plausible largest value (module notes)."""
    unit = DRIFT_BOUNDS_TEXT

    def check(converted: dict, where: str) -> None:
        for key, (bound, what) in _BOUNDED.get(table, {}).items():
            v = converted.get(key)
            if isinstance(v, float) and abs(v) > bound:
                raise ConfigError(f"{where}: {key} = {_show(v)} is outside the plausible range (at most {bound:g} {what})")
        for key in _DRIFT_TRIPLES.get(table, ()):
            v = converted.get(key)
            if v is not None and any(abs(x) > b for x, b in zip(v, DRIFT_PARAM_BOUNDS)):
                raise ConfigError(f"{where}: {key} = {_show(v)} is outside the plausible drift model ({unit})")
        p0 = converted.get("p0_cov") if table == "kalman" else None
        if p0 is not None and len(p0) == 3 and all(len(row) == 3 for row in p0):
            if any(abs(p0[i][i]) > b * b for i, b in enumerate(DRIFT_PARAM_BOUNDS)):
                raise ConfigError(
                    f"{where}: p0_cov = {_show(p0)} has a variance outside the plausible drift model "
                    f"(standard deviations {unit})"
                )

    return check


def apply_settings(obj, values: dict, where: str, check=None):
    """Copy of a frozen settings dataclass with ``values`` replaced.

    Parameters
    ----------
    obj : dataclass instance
        The settings to start from (defaults, or settings already chosen).
    values : dict
        Setting name -> value, as read from TOML.
    where : str
        The file and table, for the messages (``"run.toml [kalman]"``).
    check : callable, optional
        ``check(converted, where)``, called with the values converted to their declared
        types before the settings class sees them; raises :class:`ConfigError`.

    Returns
    -------
    dataclass instance
        A new ``obj`` with the values, each converted to its declared type.

    Raises
    ------
    ConfigError
        ``values`` is not a table, a key is unknown, a value does not have the declared
        type (module notes), or the settings class refuses the values. One line that
        starts with ``where`` and names the key.
    """
    if not isinstance(values, dict):
        raise ConfigError(f"{where}: must be a table of settings, got {_show(values)}")
    known = {f.name for f in fields(obj) if f.init}
    unknown = sorted((k for k in values if k not in known), key=repr)
    if unknown:
        raise ConfigError(
            f"{where}: unknown setting(s) {', '.join(_key(k) for k in unknown)}; known: {', '.join(sorted(known))}"
        )
    hints = _declared_types(type(obj))
    converted = {}
    for key, value in values.items():
        hint = hints.get(key)
        try:
            converted[key] = value if hint is None else _conform(value, hint)
        except _Mismatch as bad:
            now = getattr(obj, key)
            example = "" if now is None or dataclasses.is_dataclass(now) else f", e.g. {key} = {_show(now)}"
            raise ConfigError(f"{where}: {key} = {_show(value)} is refused: give {bad.expected}{example}") from None
    if check is not None:
        check(converted, where)
    check_values(converted, where)  # every number within the range arithmetic takes (gyrodrift.settings_bounds)
    try:
        changed = replace(obj, **converted)
    except ConfigError as err:
        raise ConfigError(f"{where}: {_one_line(err)}") from None
    except (TypeError, ValueError, ArithmeticError) as err:  # a settings class that checks less than it should
        keys = ", ".join(_key(k) for k in converted)
        raise ConfigError(f"{where}: the values of {keys} are not accepted ({_one_line(err)})") from None
    check_table(changed, where)  # settings bounded together ([temp_rate] window)
    return changed


def config_from_dict(values: dict, *, where: str = "config", base: CompensatorConfig | None = None) -> CompensatorConfig:
    """Build a :class:`CompensatorConfig` from nested plain values (as read from TOML).

    Parameters
    ----------
    values : dict
        Top-level settings and the tables ``kalman``, ``gate``, ``temp_rate``,
        ``adaptive`` and ``fusion`` (module notes).
    where : str
        The source of the values, for the messages (usually the file name).
    base : CompensatorConfig, optional
        The settings the values change (default: the defaults).

    Returns
    -------
    CompensatorConfig

    Raises
    ------
    ConfigError
        One line naming ``where``, the table and the key (see :func:`apply_settings`).
    """
    if not isinstance(values, dict):
        raise ConfigError(f"{where}: must be a table of settings, got {_show(values)}")
    base = base or CompensatorConfig()
    top = {k: v for k, v in values.items() if k not in _TABLES}
    nested = {}
    for name in _TABLES:
        if name in values:
            if not isinstance(values[name], dict):
                raise ConfigError(f"{where}: [{name}] must be a table of settings, got {_show(values[name])}")
            if name == "fusion":  # settings given change those in force (the tolerant ones unless set)
                start = base.fusion_settings
            else:
                start = getattr(base, name)
            nested[name] = apply_settings(start, values[name], f"{where} [{name}]", _within_drift_bounds(name))
    return apply_settings(base, {**top, **nested}, where)


def load_toml(path) -> dict:
    """Read a TOML file as bytes and parse it.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    dict
        The tables and values, as :mod:`tomllib` gives them.

    Raises
    ------
    ConfigError
        Unreadable, too large, not UTF-8 (see :func:`read_utf8`) or not valid TOML;
        one line that starts with the path.
    """
    text = read_utf8(path, "settings file")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{path}: not valid TOML: {_one_line(err)}") from None
    except RecursionError:
        raise ConfigError(f"{path}: not valid TOML: arrays or tables nested too deeply") from None
    except ValueError as err:  # an integer beyond Python's digit limit for text
        what = "a number with too many digits" if "digits" in str(err) else _one_line(err)
        raise ConfigError(f"{path}: not valid TOML: {what}") from None


def load_config(path) -> CompensatorConfig:
    """Read a TOML settings file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    CompensatorConfig

    Raises
    ------
    ConfigError
        One line naming the file and, for a bad value, the table and the key
        (module notes).
    """
    return config_from_dict(load_toml(path), where=str(path))

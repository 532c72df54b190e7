"""Settings declared once: each field's unit and bounds as metadata (:func:`setting`), and one
validator (:func:`check`) that every route to a setting reaches: a Python construction, a TOML
file, a device profile and a command-line option give the same words for the same bad value,
``<key> = <value> <what is wrong>``. The rules: ``docs/settings-and-profiles.md`` ("The validator").
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import numbers
import types
import typing
from functools import lru_cache

import numpy as np

from gyrodrift.errors import ConfigError

__all__ = ["NUMBER_RANGE", "WHOLE_MAX", "DRIFT_PARAM_BOUNDS", "DRIFT_BOUNDS_TEXT", "Spec", "SettingError", "setting",
           "spec_of", "number_problem", "check", "check_values", "apply_settings", "show", "check_covariance"]

#: Smallest and largest magnitude of a number setting other than 0 (and inf where allowed).
NUMBER_RANGE = (1e-9, 1e9)
#: Largest whole-number setting (a setting may declare a smaller one).
WHOLE_MAX = 1_000_000
#: Largest plausible magnitude of the drift-model parameters a (deg/s/degC), b (deg/degC) and
#: c (deg/s), and of their standard deviations: ten times and more what MEMS data sheets give.
DRIFT_PARAM_BOUNDS = (1.0, 1000.0, 50.0)
#: :data:`DRIFT_PARAM_BOUNDS` in words, for messages.
DRIFT_BOUNDS_TEXT = "|a| <= {:g} deg/s/degC, |b| <= {:g} deg/degC, |c| <= {:g} deg/s".format(*DRIFT_PARAM_BOUNDS)
_INT64 = (-(2**63), 2**63 - 1)


@dataclasses.dataclass(frozen=True)
class Spec:
    """What a setting is (the metadata :func:`setting` gives its field).

    ``gt``, ``ge``, ``lt``, ``le`` bound every number (a list's element by element);
    ``most`` is its largest plausible magnitude; ``least`` a smallest magnitude other than
    0 above :data:`NUMBER_RANGE`'s; ``inf`` allows inf; ``choices`` are the texts a name
    takes (or a function that gives them); ``size`` is a list's length; ``whole_max`` the
    largest whole number; ``drift`` names the elements of a drift triple, each within
    :data:`DRIFT_PARAM_BOUNDS`; ``measured`` marks a value learned from data (its own
    bounds only); ``longest`` bounds a text; ``flag`` and ``help`` make its command-line
    option (:mod:`gyrodrift.cli.options`).
    """

    unit: str = ""
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    most: float | None = None
    least: float | None = None
    inf: bool = False
    choices: tuple | typing.Callable[[], tuple] = ()
    size: int | None = None
    whole_max: int = WHOLE_MAX
    drift: tuple | None = None
    measured: bool = False
    longest: int | None = None
    flag: str | None = None
    help: str = ""


_PLAIN = Spec()
_MISSING = dataclasses.MISSING


def setting(default=_MISSING, unit: str = "", *, factory=_MISSING, **spec):
    """A dataclass field with its :class:`Spec` (``unit`` and ``**spec``) as metadata; a
    ``default``, or a ``factory`` that makes one, or neither (a required field)."""
    meta = {"setting": Spec(unit=unit, **spec)}
    if factory is not _MISSING:
        return dataclasses.field(default_factory=factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def spec_of(field: dataclasses.Field) -> Spec:
    """The :class:`Spec` of a field (a plain one for a field declared without :func:`setting`)."""
    return field.metadata.get("setting", _PLAIN)


class SettingError(ConfigError):
    """A setting refused by :func:`check`; ``text`` is the message without its source."""

    def __init__(self, text: str, source: str = ""):
        super().__init__(f"{source}: {text}" if source else text)
        self.text = text


# --------------------------------------------------------------------------- showing values


def show(value, limit: int = 60) -> str:
    """A value as TOML writes it, on one line and at most about ``limit`` characters."""
    if isinstance(value, (bool, np.bool_)):
        text = "true" if value else "false"
    elif isinstance(value, numbers.Integral):
        value = int(value)
        if abs(value) < 10**40:
            text = str(value)
        else:  # str() of a very long integer is refused by Python (and unreadable)
            sign = "a negative" if value < 0 else "an"
            text = f"{sign} integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    elif isinstance(value, numbers.Real):
        value = float(value)
        text = "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    elif isinstance(value, str):
        text = json.dumps(value, ensure_ascii=False)
    elif isinstance(value, (_dt.date, _dt.time)):
        text = value.isoformat()
    elif isinstance(value, (list, tuple, np.ndarray)):
        parts, size = [], 2
        for item in list(value):
            if size > limit:
                parts.append("...")
                break
            part = show(item, max(8, limit - size))
            parts.append(part)
            size += len(part) + 2
        text = "[" + ", ".join(parts) + "]"
    elif isinstance(value, dict):
        text = "a table"
    elif value is None:
        text = "nothing"
    elif dataclasses.is_dataclass(value):
        text = f"a {type(value).__name__}"
    else:
        text = type(value).__name__
    return text if len(text) <= limit + 3 else text[:limit] + "..."


# --------------------------------------------------------------------------- types


class _Mismatch(Exception):
    """A value does not have the declared type; ``expected`` says what it must be."""

    def __init__(self, expected: str) -> None:
        super().__init__(expected)
        self.expected = expected


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
        return f"{hint.__name__}s" if plural else f"a {hint.__name__}"
    return getattr(hint, "__name__", str(hint))


def _conform(value, hint):
    """``value`` converted to the declared type ``hint`` (a whole number to a float for a
    number, a list or an array to a tuple), or :class:`_Mismatch`. Types not known here
    pass unchanged."""
    if hint is float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise _Mismatch(_describe(hint))
        try:
            number = float(value)
        except OverflowError:
            raise _Mismatch("a number within the range of a float") from None
        if math.isnan(number):
            raise _Mismatch("a number (not nan)")
        return number
    if hint is int:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
            raise _Mismatch(_describe(hint))
        if not _INT64[0] <= int(value) <= _INT64[1]:
            raise _Mismatch("a whole number within the 64-bit range")
        return int(value)
    if hint is bool or hint is str:
        if isinstance(value, np.bool_) and hint is bool:
            return bool(value)
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
        if isinstance(value, np.ndarray):
            value = value.tolist()
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
    if isinstance(hint, type) and dataclasses.is_dataclass(hint) and not isinstance(value, hint):
        raise _Mismatch(_describe(hint))
    return value


@lru_cache(maxsize=None)
def _declared(cls) -> dict:
    """Field name -> (declared type, :class:`Spec`, default) of a settings dataclass."""
    try:
        hints = typing.get_type_hints(cls)
    except Exception:  # an annotation that names something not importable here: no type check
        hints = {}
    out = {}
    for f in dataclasses.fields(cls):
        default = f.default if f.default is not _MISSING else None
        out[f.name] = (hints.get(f.name), spec_of(f), default)
    return out


# --------------------------------------------------------------------------- bounds


def _bound_clause(spec: Spec, x: float) -> str | None:
    """What is wrong with one number for ``spec``, as a clause (None: nothing)."""
    unit = f" {spec.unit}" if spec.unit else ""
    if math.isinf(x) and not spec.inf:
        return "must be a finite number"
    if spec.gt is not None and spec.lt is not None and not spec.gt < x < spec.lt:
        return f"must be between {spec.gt:g} and {spec.lt:g}{unit}"
    if spec.ge is not None and spec.le is not None and not spec.ge <= x <= spec.le:
        return f"must be within {spec.ge:g} to {spec.le:g}{unit}"
    for bound, ok, word in ((spec.gt, lambda b: x > b, ">"), (spec.ge, lambda b: x >= b, ">="),
                            (spec.lt, lambda b: x < b, "<"), (spec.le, lambda b: x <= b, "<=")):
        if bound is not None and not ok(bound):
            return "must be positive" if word == ">" and bound == 0 else f"must be {word} {bound:g}{unit}"
    if spec.most is not None and abs(x) > spec.most:
        return f"is outside the plausible range (at most {spec.most:g}{unit})"
    if spec.measured or x == 0.0 or math.isinf(x):
        return None
    lo, hi = NUMBER_RANGE
    if not lo <= abs(x) <= hi:
        return f"is outside the range of any setting (0, or a magnitude from {lo:g} to {hi:g})"
    if spec.least is not None and abs(x) < spec.least:
        return f"is below {spec.least:g}, the smallest this setting takes"
    return None


def _problem(key: str, value, spec: Spec) -> str | None:
    """What is wrong with a converted ``value`` of the setting ``key`` (None: nothing)."""
    if isinstance(value, str):
        choices = spec.choices() if callable(spec.choices) else spec.choices
        if choices and value not in choices:
            return f"{key} = {show(value)} must be one of {', '.join(map(show, choices))}"
        if spec.longest is not None and len(value) > spec.longest:
            return f"{key} = {show(value)} must be at most {spec.longest} characters"
        return None
    if isinstance(value, bool) or value is None or dataclasses.is_dataclass(value):
        return None
    if isinstance(value, int):
        top = spec.whole_max
        if abs(value) > top:
            return f"{key} = {show(value)} is beyond {top:,}, the largest this setting takes"
        clause = _bound_clause(dataclasses.replace(spec, measured=True), float(value))
        return None if clause is None else f"{key} = {show(value)} {clause}"
    if isinstance(value, float):
        clause = _bound_clause(spec, value)
        return None if clause is None else f"{key} = {show(value)} {clause}"
    if isinstance(value, tuple):
        if spec.size is not None and len(value) != spec.size:
            return f"{key} = {show(value)} must be a list of {spec.size} numbers"
        flat = [x for item in value for x in (item if isinstance(item, tuple) else (item,))]
        for i, x in enumerate(flat):
            if spec.drift is not None and abs(x) > DRIFT_PARAM_BOUNDS[i]:
                return (f"{key} = {show(value)}: {spec.drift[i]} = {x:g} is outside the plausible drift model "
                        f"({DRIFT_BOUNDS_TEXT})")
            clause = _bound_clause(spec, x) if isinstance(x, float) else None
            if clause is not None:
                return f"{key} = {show(value)}: {show(x)} {clause}"
    return None


def number_problem(key: str, value) -> str | None:
    """What is wrong with a number that is not a setting (a command-line option such as
    ``--fs-hz``): outside :data:`NUMBER_RANGE`, or not finite; None when nothing."""
    return _problem(key, float(value), _PLAIN)


def check_values(cls, values: dict) -> dict:
    """``values`` (name -> value) of the settings class ``cls`` converted to their declared
    types, each within its bounds (``docs/settings-and-profiles.md``).

    Raises
    ------
    SettingError
        ``<key> = <value> <what is wrong>`` for the first value refused.
    """
    declared = _declared(cls)
    out = {}
    for key, value in values.items():
        hint, spec, default = declared.get(key, (None, _PLAIN, None))
        try:
            converted = value if hint is None else _conform(value, hint)
        except _Mismatch as bad:
            plain = default is not None and not dataclasses.is_dataclass(default)
            example = f", e.g. {key} = {show(default)}" if plain else ""
            raise SettingError(f"{key} = {show(value)} is refused: give {bad.expected}{example}") from None
        problem = _problem(key, converted, spec)
        if problem is not None:
            raise SettingError(problem)
        out[key] = converted
    return out


def check(obj) -> None:
    """The validator of every settings class, called by its ``__post_init__``: each field
    converted to its declared type and within its bounds, then the class's
    ``_check_together()`` (settings bounded together), if it has one.

    Raises
    ------
    SettingError
        ``<Class>: <key> = <value> <what is wrong>``.
    """
    try:
        values = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj) if f.init}
        for key, value in check_values(type(obj), values).items():
            if value is not values[key]:
                object.__setattr__(obj, key, value)
        together = getattr(obj, "_check_together", None)
        if together is not None:
            together()
    except SettingError as err:
        raise SettingError(err.text, type(obj).__name__) from None


def check_covariance(key: str, cov, names=("a", "b", "c")) -> None:
    """Refuse a drift covariance (3x3) that is not symmetric (to 1e-6 of ``sqrt(P_ii P_jj)``)
    and positive definite (the smallest eigenvalue of its correlation matrix above 1e-12: no
    correlation of 1 to within rounding), or whose standard deviations leave
    :data:`DRIFT_PARAM_BOUNDS`; ``names`` name the elements in the message."""
    P = np.array(cov, dtype=float)
    not_pd = f"{key} is not positive definite (a variance is zero or negative, or a correlation is 1 or more)"
    var = np.diag(P)
    if not np.all(var > 0):
        raise SettingError(not_pd)
    sd = np.sqrt(var)
    for name, bound, s in zip(names, DRIFT_PARAM_BOUNDS, sd):
        if s > bound:
            raise SettingError(f"{key} gives {name} a standard deviation of {s:g}, outside the plausible drift model "
                               f"({DRIFT_BOUNDS_TEXT})")
    if not np.all(np.abs(P - P.T) <= 1e-6 * np.outer(sd, sd)):
        raise SettingError(f"{key} is not symmetric")
    corr = 0.5 * (P + P.T) / np.outer(sd, sd)  # scale-free: variances of 1e-12 and 1e3 side by side
    if not np.linalg.eigvalsh(corr).min() > 1e-12:
        raise SettingError(not_pd)


def _one_line(text) -> str:
    return " ".join(str(text).split())


def apply_settings(obj, values: dict, where: str):
    """A copy of the settings ``obj`` (a frozen dataclass) with ``values`` replaced, checked
    by :func:`check_values` and the class.

    Parameters
    ----------
    obj : dataclass instance
        The settings to start from.
    values : dict
        Setting name -> value, as read from TOML or an option.
    where : str
        Where the values come from, for the messages (``"run.toml [kalman]"``, ``"--fading"``).

    Raises
    ------
    ConfigError
        ``values`` is not a table, a key is unknown, or a value is refused: one line
        ``<where>: <key> = <value> <what is wrong>``.
    """
    if not isinstance(values, dict):
        raise ConfigError(f"{where}: must be a table of settings, got {show(values)}")
    known = {f.name for f in dataclasses.fields(obj) if f.init}
    unknown = sorted((k for k in values if k not in known), key=repr)
    if unknown:
        keys = ", ".join(k if isinstance(k, str) and k.isidentifier() else repr(k) for k in unknown)
        raise ConfigError(f"{where}: unknown setting(s) {keys}; known: {', '.join(sorted(known))}")
    try:
        converted = check_values(type(obj), values)
        changed = dataclasses.replace(obj, **converted)
        if not _checks_itself(type(obj)):
            check(changed)  # a class whose __post_init__ does not call check (the simulator's)
        return changed
    except SettingError as err:
        raise ConfigError(f"{where}: {err.text}") from None
    except ConfigError as err:
        raise ConfigError(f"{where}: {_one_line(err)}") from None
    except (TypeError, ValueError, ArithmeticError) as err:  # a class that checks less than it should
        keys = ", ".join(map(str, values))
        raise ConfigError(f"{where}: the values of {keys} are not accepted ({_one_line(err)})") from None


def _checks_itself(cls) -> bool:
    """Whether the class declares its fields with :func:`setting` (and so calls :func:`check`)."""
    return any("setting" in f.metadata for f in dataclasses.fields(cls))

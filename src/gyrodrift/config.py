"""Compensator settings from a TOML file (``gyrodrift compensate --config FILE``).

Top-level keys are the fields of :class:`~gyrodrift.compensator.CompensatorConfig`;
the tables ``[kalman]``, ``[gate]``, ``[temp_rate]``, ``[adaptive]`` and ``[fusion]``
hold the fields of :class:`~gyrodrift.estimators.KalmanConfig`,
:class:`~gyrodrift.gating.GateConfig`, :class:`~gyrodrift.model.TempRateConfig`,
:class:`~gyrodrift.estimators.AdaptiveConfig` and :class:`~gyrodrift.fusion.FusionConfig`.
Anything left out keeps its default; a ``[fusion]`` table changes the fused-heading
settings that suit the estimator (``CompensatorConfig.fusion_settings``)::

    update_interval_s = 10.0
    init_s = 30.0

    [kalman]
    fading = 1.2
    p0_sd = [0.05, 5.0, 5.0]   # a deg/s/degC, b deg, c deg/s

    [gate]
    turn_rate_dps = 2.0

    [fusion]                   # the fused-heading settings (B) of docs/results.md
    magnetic_gates = true
    bias_corr_s = 30.0
    relock_s = inf
"""

from __future__ import annotations

import sys
from dataclasses import fields, replace
from pathlib import Path

from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["load_config", "config_from_dict", "load_toml", "apply_settings"]

_TABLES = ("kalman", "gate", "temp_rate", "adaptive", "fusion")


def apply_settings(obj, values: dict, where: str):
    """Copy of a frozen settings dataclass with ``values`` replaced; errors name the setting."""
    known = {f.name for f in fields(obj)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise ConfigError(f"{where}: unknown setting(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    converted = {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}
    try:
        return replace(obj, **converted)
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from None
    except (TypeError, ValueError) as err:
        raise ConfigError(f"{where}: {err}") from None


def config_from_dict(values: dict, *, where: str = "config", base: CompensatorConfig | None = None) -> CompensatorConfig:
    """Build a :class:`CompensatorConfig` from nested plain values (as read from TOML)."""
    base = base or CompensatorConfig()
    top = {k: v for k, v in values.items() if k not in _TABLES}
    nested = {}
    for name in _TABLES:
        if name in values:
            if not isinstance(values[name], dict):
                raise ConfigError(f"{where}: [{name}] must be a table of settings")
            if name == "fusion":  # settings given change those that suit the estimator chosen
                start = apply_settings(base, {k: v for k, v in top.items() if k == "estimator"}, where).fusion_settings
            else:
                start = getattr(base, name)
            nested[name] = apply_settings(start, values[name], f"{where} [{name}]")
    return apply_settings(base, {**top, **nested}, where)


def load_toml(path) -> dict:
    """Read a TOML file; errors name the file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise ConfigError(f"{path}: cannot read the settings file ({err.strerror})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{path}: not valid TOML: {err}") from None


def load_config(path) -> CompensatorConfig:
    """Read a TOML settings file; errors name the file and the setting."""
    return config_from_dict(load_toml(path), where=str(path))

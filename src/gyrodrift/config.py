"""Compensator settings from a TOML file (``gyrodrift compensate --config FILE``).

Top-level keys are the fields of :class:`~gyrodrift.compensator.CompensatorConfig`, the
tables ``[kalman]``, ``[gate]``, ``[temp_rate]``, ``[adaptive]`` and ``[fusion]`` those of
its settings classes; every value goes through the validator of :mod:`gyrodrift.settings`.
An example and the checks: docs/settings-and-profiles.md, section "Settings files".
"""

from __future__ import annotations

import codecs
import sys
from pathlib import Path

from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError
from gyrodrift.settings import DRIFT_PARAM_BOUNDS, apply_settings, show

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "MAX_FILE_BYTES", "DRIFT_PARAM_BOUNDS", "load_config", "config_from_dict", "load_toml", "apply_settings",
    "read_utf8", "parse_problem", "TABLES",
]

#: The tables of a settings file: fields of :class:`CompensatorConfig` that hold settings classes.
TABLES = ("kalman", "gate", "temp_rate", "adaptive", "fusion")
#: Largest settings or profile file read, bytes (such files are a few hundred bytes).
MAX_FILE_BYTES = 1 << 20


def _one_line(text) -> str:
    return " ".join(str(text).split())


def parse_problem(err: ValueError) -> str:
    """Why a text did not parse, on one line: an integer beyond Python's digit limit, or the parser's words."""
    return "a number with too many digits" if "digits" in str(err) else _one_line(err)


def read_utf8(path, what: str) -> str:
    """The text of a small UTF-8 file (``what`` names it in the messages), read as bytes, without
    a leading byte-order mark; a missing, unreadable, too large (:data:`MAX_FILE_BYTES`) or
    non-UTF-8 file is a one-line :class:`ConfigError` starting with the path."""
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


def config_from_dict(values: dict, *, where: str = "config", base: CompensatorConfig | None = None) -> CompensatorConfig:
    """Build a :class:`CompensatorConfig` from nested plain values (as read from TOML).

    ``values`` holds top-level settings and the tables (:data:`TABLES`); ``where`` names their
    source in the messages; ``base`` is the settings they change (default: the defaults). A
    bad value is a one-line :class:`ConfigError` naming ``where``, the table and the key.
    """
    if not isinstance(values, dict):
        raise ConfigError(f"{where}: must be a table of settings, got {show(values)}")
    base = base or CompensatorConfig()
    top = {k: v for k, v in values.items() if k not in TABLES}
    nested = {}
    for name in TABLES:
        if name in values:
            if not isinstance(values[name], dict):
                raise ConfigError(f"{where}: [{name}] must be a table of settings, got {show(values[name])}")
            # a [fusion] table changes the settings in force (the tolerant ones unless set)
            start = base.fusion_settings if name == "fusion" else getattr(base, name)
            nested[name] = apply_settings(start, values[name], f"{where} [{name}]")
    return apply_settings(base, {**top, **nested}, where)


def load_toml(path) -> dict:
    """The tables and values of a TOML file, read as bytes (:func:`read_utf8`); a file that does
    not parse is a one-line :class:`ConfigError` starting with the path."""
    text = read_utf8(path, "settings file")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{path}: not valid TOML: {_one_line(err)}") from None
    except RecursionError:
        raise ConfigError(f"{path}: not valid TOML: arrays or tables nested too deeply") from None
    except ValueError as err:  # an integer beyond Python's digit limit for text
        raise ConfigError(f"{path}: not valid TOML: {parse_problem(err)}") from None


def load_config(path) -> CompensatorConfig:
    """Read a TOML settings file into a :class:`CompensatorConfig`; every problem is a one-line
    :class:`ConfigError` naming the file and, for a bad value, the table and the key."""
    return config_from_dict(load_toml(path), where=str(path))

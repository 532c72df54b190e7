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
at most :data:`MAX_FILE_BYTES` long. Unknown tables and keys are refused; every value goes
through the validator of the settings classes (:mod:`gyrodrift.settings`: its declared
type, unit and bounds), the same that judges a Python construction and a command-line
option. Every problem is a :class:`~gyrodrift.errors.ConfigError` of one line that names
the file, the table and the key.
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
    "read_utf8", "TABLES",
]

#: The tables of a settings file: fields of :class:`CompensatorConfig` that hold settings classes.
TABLES = ("kalman", "gate", "temp_rate", "adaptive", "fusion")
#: Largest settings or profile file read, bytes (such files are a few hundred bytes).
MAX_FILE_BYTES = 1 << 20


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

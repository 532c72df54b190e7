"""The exceptions gyrodrift raises for problems a user can fix."""

from __future__ import annotations

__all__ = ["GyroDriftError", "LogFormatError", "ConfigError", "ArgumentTypeError"]


class GyroDriftError(Exception):
    """A problem the user can fix; the command line prints it as one line and exits 2.

    The message names the file, row or column and says what to do.
    """


class LogFormatError(GyroDriftError, ValueError):
    """An input log does not follow the input contract."""


class ConfigError(GyroDriftError, ValueError):
    """An option or configuration value is invalid."""


class ArgumentTypeError(GyroDriftError, TypeError):
    """An argument of a Python function is of the wrong kind (e.g. a dict where a
    DataFrame is expected); the message says what is expected."""

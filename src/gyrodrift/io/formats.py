"""Which format a log is: from the ``fmt`` option, from the path, or from its first bytes.

:func:`log_format` chooses among all formats :func:`gyrodrift.io.read_log` reads,
:func:`table_format` between CSV and Parquet for the table readers and writers.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Mapping

from gyrodrift.errors import ConfigError
from gyrodrift.io.messages import one_line, option_error

__all__ = ["FORMATS", "READ_SUFFIXES", "WRITE_SUFFIXES", "table_format", "format_from_path", "log_format"]


#: Formats :func:`gyrodrift.io.read_log` accepts for ``fmt``.
FORMATS = ("csv", "parquet", "ulog", "ardupilot", "tlog", "rosbag")
#: File-name endings (lower case) and the table format each one means.
READ_SUFFIXES = {
    ".csv": "csv",
    ".csv.gz": "csv",
    ".txt": "csv",
    ".txt.gz": "csv",
    ".parquet": "parquet",
    ".pq": "parquet",
}
#: File-name endings (lower case) the table writers accept, and the format each one means.
WRITE_SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}
_TABLE_FORMATS = ("csv", "parquet")
#: File-name endings of the binary logs.
_ULOG_SUFFIXES = (".ulg",)
_ARDUPILOT_SUFFIXES = (".bin",)
_TLOG_SUFFIXES = (".tlog",)
_ROSBAG_SUFFIXES = (".bag", ".db3", ".mcap")
#: First bytes of the binary logs, to tell a file with another ending: a ULog header,
#: and the DataFlash FMT message that defines FMT (``0xA3 0x95``, type 128).
_MAGIC = ((b"ULog\x01\x12\x35", "ulog"), (b"\xa3\x95\x80", "ardupilot"))


def _sniff(path: Path) -> str | None:
    """"ulog" or "ardupilot" from the file's first bytes, else None (also when unreadable)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError:
        return None
    return next((fmt for magic, fmt in _MAGIC if head.startswith(magic)), None)


def _pipe_or_device(path: Path) -> bool:
    """True when ``path`` is a FIFO or a character device (``/dev/null``, a terminal)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)


def table_format(path: Path, fmt: str | None, suffixes: Mapping[str, str]) -> str:
    """Return "csv" or "parquet" from ``fmt`` or else from the file-name ending (a FIFO or
    a character device without a table ending: "csv")."""
    if fmt is not None:
        key = str(fmt).strip().lower()
        if key not in _TABLE_FORMATS:
            raise ConfigError(
                one_line(f"unknown table format {fmt!r}; use one of: {', '.join(_TABLE_FORMATS)}")
            )
        return key
    name = path.name.lower()
    for suffix in sorted(suffixes, key=len, reverse=True):
        if name.endswith(suffix):
            return suffixes[suffix]
    if _pipe_or_device(path):  # a FIFO or /dev/stdout-like device without an ending carries text: CSV
        return "csv"
    accepted = ", ".join(sorted(suffixes))
    raise option_error(str(path), f"cannot tell the table format from the file name (accepted endings: {accepted})",
                       "rename the file or give the format explicitly (csv or parquet)")


def format_from_path(path: Path) -> str | None:
    """"ulog", "ardupilot", "tlog" or "rosbag" from the path, "csv"/"parquet" for table endings, else None."""
    name = path.name.lower()
    if name.endswith(_ULOG_SUFFIXES):
        return "ulog"
    if name.endswith(_ARDUPILOT_SUFFIXES):
        return "ardupilot"
    if name.endswith(_TLOG_SUFFIXES):
        return "tlog"
    if name.endswith(_ROSBAG_SUFFIXES) or (path.is_dir() and (path / "metadata.yaml").is_file()):
        return "rosbag"
    for suffix, table_fmt in READ_SUFFIXES.items():
        if name.endswith(suffix):
            return table_fmt
    return None


def log_format(path: Path, fmt: str | None) -> str | None:
    """The format named by ``fmt``, by the path, or by the first bytes of a file with an
    ending no format uses (a ULog or DataFlash log); None: let the table reader decide."""
    if fmt is not None:
        key = str(fmt).strip().lower()
        if key not in FORMATS:
            raise ConfigError(one_line(f"unknown log format {fmt!r}; use one of: {', '.join(FORMATS)}"))
        return key
    found = format_from_path(path)
    if found is None and path.is_file():
        found = _sniff(path)
    if found is None and path.is_file():
        endings = sorted(READ_SUFFIXES) + list(_ULOG_SUFFIXES + _ARDUPILOT_SUFFIXES + _TLOG_SUFFIXES + _ROSBAG_SUFFIXES)
        raise option_error(str(path),
                           f"cannot tell the log format from the file name (accepted endings: {', '.join(endings)};"
                           " or a ROS 2 bag directory)",
                           f"rename the file or give the format explicitly ({', '.join(FORMATS)})")
    return found

"""The message style of every reader, and the errors of a whole file.

Every problem a user can fix is one line, ``<file>: <location>: <problem>; <what to do>``
(docs/log-formats.md, section "Messages"): :func:`message` builds it, :class:`Source`,
:func:`row_label` and :func:`cell_label` name the rows and cells.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Iterable, NamedTuple

from gyrodrift.errors import ConfigError, LogFormatError

__all__ = [
    "Source",
    "one_line",
    "message",
    "format_error",
    "show_text",
    "show_names",
    "physical_line",
    "row_label",
    "cell_label",
    "check_input_path",
    "read_log_bytes",
    "read_error",
    "empty_file_error",
    "no_data_rows_error",
    "optional_module",
    "log_error",
    "option_error",
]

_MAX_NAMES_SHOWN = 30
_MAX_TEXT_SHOWN = 40


class Source(NamedTuple):
    """Where a table came from: enough to name rows the way a user sees them."""

    name: str  #: the path as the user gave it
    fmt: str  #: "csv" or "parquet"
    #: CSV: maps the 1-based index of a non-empty line (header = 1) to the line an
    #: editor shows (called on error only); None for Parquet
    line_of: Callable[[int], int] | None
    #: index in the whole file of the frame's first data row (0 unless read in chunks)
    row0: int = 0

    def at(self, row0: int) -> "Source":
        """The same source for a frame whose first row is data row ``row0`` of the file."""
        return self._replace(row0=row0)


def one_line(text: str) -> str:
    """Collapse any line breaks so a message stays on one line."""
    return " ".join(str(text).split())


def message(name: str, problem: str, advice: str, where: str = "") -> str:
    """Build ``<file>: [<where>: ]<problem>; <advice>`` on one line."""
    head = f"{name}: {where}: " if where else f"{name}: "
    return one_line(f"{head}{problem}; {advice}")


def log_error(name: str, problem: str, advice: str, where: str = "") -> LogFormatError:
    """A :class:`LogFormatError` for the file ``name`` with the one-line :func:`message`."""
    return LogFormatError(message(name, problem, advice, where))


def option_error(name: str, problem: str, advice: str, where: str = "") -> ConfigError:
    """A :class:`ConfigError` (a bad option for the file ``name``) with the one-line :func:`message`."""
    return ConfigError(message(name, problem, advice, where))


def format_error(src: Source, problem: str, advice: str, where: str = "") -> LogFormatError:
    """Return a :class:`LogFormatError` for ``src`` with a one-line message."""
    return log_error(src.name, problem, advice, where)


def show_text(value: object) -> str:
    """Quote a cell's text for a message, shortened and without line breaks."""
    text = str(value)
    if len(text) > _MAX_TEXT_SHOWN:
        text = text[: _MAX_TEXT_SHOWN - 3] + "..."
    return repr(text)


def show_names(names) -> str:
    """List column names for a message (at most ``_MAX_NAMES_SHOWN`` of them)."""
    names = [repr(str(n)) for n in names]
    if not names:
        return "(none)"
    if len(names) > _MAX_NAMES_SHOWN:
        extra = len(names) - _MAX_NAMES_SHOWN
        names = names[:_MAX_NAMES_SHOWN] + [f"... ({extra} more)"]
    return ", ".join(names)


def physical_line(blocks: Iterable[bytes], nonempty_index: int) -> int:
    """The 1-based file line of the ``nonempty_index``-th non-empty line (pyarrow counts only
    those); ``blocks`` are the file's bytes in order, in pieces of any size."""
    count = 0
    line_no = 0
    carry = b""
    for block in blocks:
        lines = (carry + block).splitlines(keepends=True)
        # the last piece may be an unfinished line, or a "\r" whose "\n" is in the next block
        carry = lines.pop() if lines and (lines[-1].endswith(b"\r") or not lines[-1].endswith(b"\n")) else b""
        for line in lines:
            line_no += 1
            if line.rstrip(b"\r\n"):
                count += 1
                if count == nonempty_index:
                    return line_no
    if carry:
        line_no += 1
        if carry.rstrip(b"\r\n") and count + 1 == nonempty_index:
            return line_no
    return nonempty_index


def row_label(src: Source, row: int) -> str:
    """Name data row ``row`` of the frame (0-based; negative: rows before it) as the user
    sees it: ``line N`` (CSV) or ``data row N`` (Parquet), counted in the whole file."""
    row = src.row0 + row
    if src.fmt == "csv" and src.line_of is not None:
        # header is non-empty line 1, data row 0 is non-empty line 2
        return f"line {src.line_of(row + 2)}"
    return f"data row {row + 1}"


def cell_label(src: Source, row: int, column: str) -> str:
    """Name one cell: ``line N, column 'x'``."""
    return f"{row_label(src, row)}, column {column!r}"


def check_input_path(path: Path, kind: str = "a log file", advice: str = "give the path of a .csv or .parquet log") -> None:
    """Raise :class:`LogFormatError` if ``path`` is not an existing regular file: a folder
    ("is a directory, not ``kind``; ``advice``") or nothing at all."""
    if path.is_dir():
        raise LogFormatError(message(str(path), f"is a directory, not {kind}", advice))
    if not path.exists():
        raise LogFormatError(
            message(str(path), "input file does not exist", "check the path and the current directory")
        )


def read_log_bytes(path: Path, kind: str, advice: str, empty_advice: str, size: int = -1) -> bytes:
    """The bytes of a binary log (the first ``size`` of them; all when -1), or a one-line
    :class:`LogFormatError`: no such file (:func:`check_input_path`, with ``kind`` and
    ``advice``), one the system cannot read, an empty one (``empty_advice``)."""
    check_input_path(path, kind, advice)
    try:
        with open(path, "rb") as fh:
            data = fh.read(size)
    except OSError as exc:
        raise read_error(path, exc) from exc
    if not data:
        raise empty_file_error(str(path), empty_advice)
    return data


def read_error(path, exc: OSError) -> LogFormatError:
    """The error for an input file the operating system cannot read."""
    reason = exc.strerror or type(exc).__name__
    return LogFormatError(message(str(path), f"cannot read the input file ({reason})", "check that it is a readable file"))


def empty_file_error(name: str, advice: str) -> LogFormatError:
    """The error for a file with no content at all."""
    return LogFormatError(message(name, "file is empty", advice))


def no_data_rows_error(src: Source) -> LogFormatError:
    """The error for a table without data rows."""
    problem = "has a header row but no data rows" if src.fmt == "csv" else "has no data rows"
    return format_error(src, problem, "give a log with at least one data row")


def optional_module(name: str, what: str, package: str, extra: str):
    """``from parent import attr`` for the dotted ``name``, or a :class:`ConfigError`: "``what`` needs
    the optional package ``package``; install it with pip install 'gyrodrift[``extra``]'"."""
    parent, _, attr = name.rpartition(".")
    try:
        return getattr(__import__(parent, fromlist=[attr]), attr)
    except (ImportError, AttributeError) as exc:
        raise ConfigError(
            f"{what} needs the optional package {package}; install it with pip install 'gyrodrift[{extra}]'"
        ) from exc

"""The files a command reads and writes: never one for the other, and every output writable first.

:func:`check_paths` refuses outputs that name an input or each other and checks each output
(:func:`check_writable`) before any work; refusals are one-line
:class:`~gyrodrift.errors.ConfigError` naming the option and the path
(``docs/output_files.md``, input and output paths).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from gyrodrift.errors import ConfigError

__all__ = ["NAME_MAX", "PATH_MAX", "same_file", "check_path_length", "check_writable", "check_paths",
           "READ_OPTIONS", "WRITE_OPTIONS"]

#: Longest file name, bytes (common Linux and macOS file systems).
NAME_MAX = 255
#: Longest path the system takes, bytes.
PATH_MAX = 4096
#: Options of the command line that name files a command reads.
READ_OPTIONS = ("input", "prior", "profile", "config", "calibration")
#: Options that name files a command writes (not folders: ``batch`` and ``paper`` write into one).
WRITE_OPTIONS = ("output", "save_profile")
#: Commands whose ``-o`` is a folder.
_FOLDER_OUTPUTS = ("batch", "paper")
_FLAGS = {"input": "the input log", "prior": "--prior", "profile": "--profile", "config": "--config",
          "calibration": "--calibration", "output": "-o", "save_profile": "--save-profile"}


def same_file(a, b) -> bool:
    """True when paths ``a`` and ``b`` name one file (resolved path, or device and inode)."""
    try:
        if os.path.realpath(a) == os.path.realpath(b):
            return True
        return os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b)
    except (OSError, ValueError):  # a path the system cannot resolve is nobody's twin
        return False


def check_path_length(path, what: str) -> None:
    """Refuse a path with a file name longer than :data:`NAME_MAX` bytes, or longer than
    :data:`PATH_MAX` in all (the system would refuse it later, in the middle of the work)."""
    raw = os.fsencode(os.fspath(path))
    name = os.path.basename(raw.rstrip(b"/"))
    if len(name) > NAME_MAX:
        raise ConfigError(f"{_short(path)}: {what}: file name of {len(name)} bytes, longer than the {NAME_MAX} a file "
                          "system takes; choose a shorter name")
    if len(os.path.abspath(raw)) >= PATH_MAX:
        raise ConfigError(f"{_short(path)}: {what}: path of {len(os.path.abspath(raw))} bytes, longer than the "
                          f"{PATH_MAX} the system takes; choose a shorter path")


def _short(path) -> str:
    """A path for a message: at most about 120 characters (its end kept)."""
    text = os.fspath(path)
    text = text if isinstance(text, str) else os.fsdecode(text)
    return text if len(text) <= 120 else "..." + text[-117:]


def check_writable(path, what: str = "output") -> None:
    """Check, before any work, that ``path`` can be written as an output file (a
    :class:`ConfigError` naming ``what`` and the path otherwise; the rules: ``docs/output_files.md``)."""
    check_path_length(path, what)
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise ConfigError(f"{_short(path)}: {what}: cannot use this path ({_reason(exc)}); choose another") from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise ConfigError(f"{_short(path)}: {what} is a folder; give a file name")
    if st is not None and (stat.S_ISFIFO(st.st_mode) or stat.S_ISCHR(st.st_mode)):
        if not os.access(path, os.W_OK):
            raise ConfigError(f"{_short(path)}: {what}: no permission to write to it; choose another path")
        return
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{_short(path)}: {what} is {node_kind(st.st_mode)}, not a file; choose a file name")
    folder = Path(os.path.realpath(path)).parent
    if not folder.is_dir():
        raise ConfigError(f"{_short(path)}: {what}: folder {str(folder)!r} does not exist; create it first or "
                          "choose another path")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(f"{_short(path)}: {what}: no permission to write in folder {str(folder)!r}; choose "
                          "another path")


def node_kind(mode: int) -> str:
    """What a file-system node that is not a regular file is, in words ("a socket")."""
    for test, word in ((stat.S_ISSOCK, "a socket"), (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISDIR, "a folder")):
        if test(mode):
            return word
    return "not a regular file"


def _reason(exc: OSError) -> str:
    """Why the system refused a path, in words."""
    if exc.errno == errno.ENAMETOOLONG:
        return "name too long"
    if exc.errno == errno.ELOOP:
        return "a loop of symbolic links"
    return exc.strerror or str(exc)


def check_paths(command: str, args) -> None:
    """Refuse a command line whose outputs name its inputs or each other; check each output.

    ``args`` (an :class:`argparse.Namespace` of ``command``) has the attributes of
    :data:`READ_OPTIONS` and :data:`WRITE_OPTIONS` that name files (``-`` is not a file).
    """
    reads = _named(args, READ_OPTIONS)
    writes = [] if command in _FOLDER_OUTPUTS else _named(args, WRITE_OPTIONS)
    for option, path in writes:
        for other, source in reads:
            if same_file(path, source):
                raise ConfigError(
                    f"{_short(path)}: {_FLAGS[option]} is {_FLAGS[other]} {_short(source)!r} (the same file); "
                    f"the input is never overwritten: choose another {_FLAGS[option]}"
                )
    for k, (option, path) in enumerate(writes):
        for other, second in writes[k + 1:]:
            if same_file(path, second):
                raise ConfigError(f"{_short(path)}: {_FLAGS[option]} and {_FLAGS[other]} name the same file; give "
                                  "each its own")
    for option, path in writes:
        check_writable(path, _FLAGS[option])


def _named(args, options) -> list[tuple[str, Path]]:
    """The (option, path) pairs of ``args`` that name files."""
    found = []
    for option in options:
        value = getattr(args, option, None)
        if value is None or isinstance(value, bool) or str(value) in ("", "-"):
            continue
        found.append((option, Path(value)))
    return found

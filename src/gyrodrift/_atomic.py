"""Atomic output files: every file gyrodrift writes appears whole or not at all.

A file is written to a hidden temporary beside it (``.NAME.gyrodrift-tmp-HOST-PID-RANDOM``)
and moved onto its name in one step; a FIFO, a character device or a symbolic link is
written through. Naming, clean-up of stale temporaries and the node kinds:
``docs/output_files.md`` (atomic outputs).
"""

from __future__ import annotations

import hashlib
import os
import re
import secrets
import socket
import stat
import threading
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

from gyrodrift.errors import ConfigError

__all__ = ["atomic_output", "atomic_path", "write_bytes_atomic", "remove_stale_temporaries"]

_TAG = ".gyrodrift-tmp-"
_NAME_MAX = 255  # bytes of a file name on common file systems
# what follows NAME: the tag, host, a PID of up to 10 digits, random part and separators
_SUFFIX_BYTES = len(_TAG) + 8 + 1 + 10 + 1 + 12
_OWN_SUFFIX = re.compile(r"([0-9]{1,10})-[0-9a-f]{12}")


@lru_cache(maxsize=1)
def _host_tag() -> str:
    """Eight hex digits that tell this host's temporaries from another's."""
    return hashlib.blake2b(socket.gethostname().encode("utf-8", "surrogateescape"), digest_size=4).hexdigest()


def _prefix(path: Path) -> str:
    """``.NAME.gyrodrift-tmp-HOST-``: the start of every temporary of ``path`` on this host."""
    name = path.name
    while len(os.fsencode(name)) > _NAME_MAX - 1 - _SUFFIX_BYTES:
        name = name[:-1]
    return f".{name}{_TAG}{_host_tag()}-"


def _pid_alive(pid: int) -> bool:
    """False only when no process ``pid`` exists (POSIX); True when unsure."""
    if os.name != "posix" or pid <= 0:
        return True
    try:
        os.kill(pid, 0)  # signal 0: an existence check, nothing is sent
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):  # EPERM: it exists, another user's
        return True
    return True


def remove_stale_temporaries(path) -> list[Path]:
    """Remove the temporaries of the output ``path`` left by dead processes on this host; return them.

    A temporary whose process is alive (or a zombie not yet reaped), of another output or
    another host, or that cannot be removed, stays.
    """
    path = Path(path)
    prefix = _prefix(path)
    removed = []
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(prefix):
            continue
        match = _OWN_SUFFIX.fullmatch(entry.name[len(prefix):])
        if match is None or int(match[1]) == os.getpid() or _pid_alive(int(match[1])):
            continue
        try:
            if entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:  # removed meanwhile by another run, or not ours to remove
            continue
    return removed


def _create_temporary(path: Path) -> tuple[int, Path]:
    """Create the temporary of ``path`` (after removing stale ones); its descriptor and path.
    Problems with ``path`` are a :class:`ConfigError` naming it."""
    parent = path.parent
    if not parent.is_dir():
        raise ConfigError(f"{path}: output folder {str(parent)!r} does not exist; create it first or choose another path")
    if path.is_dir():
        raise ConfigError(f"{path}: output path is a folder; give a file name")
    remove_stale_temporaries(path)
    prefix = _prefix(path)
    while True:
        tmp = parent / f"{prefix}{os.getpid()}-{secrets.token_hex(6)}"
        try:
            # mode 0o666: the process umask decides, as for any newly created file
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
            return fd, tmp
        except FileExistsError:
            continue
        except OSError as exc:
            raise ConfigError(f"{path}: cannot write in {str(parent)!r} ({exc.strerror}); choose another path") from exc


@contextmanager
def _replacing(path: Path, tmp: Path):
    """Move ``tmp`` onto ``path`` when the block ends normally; remove it otherwise (an
    OS error becomes a :class:`ConfigError` naming ``path``)."""
    try:
        yield
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise ConfigError(f"{path}: writing failed ({exc.strerror or exc}); check disk space and permissions") from exc
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _destination(path: Path) -> tuple[Path, bool]:
    """The file to write for the output ``path``, and whether it is written through in
    place (a FIFO or a character device) rather than replaced (module notes)."""
    try:
        st = os.stat(path)  # through symbolic links
    except FileNotFoundError:
        st = None
    except OSError as exc:  # a name too long, a loop of links, no permission
        raise ConfigError(f"{path}: cannot write there ({exc.strerror or exc}); choose another path") from exc
    if st is not None and (stat.S_ISFIFO(st.st_mode) or stat.S_ISCHR(st.st_mode)):
        return path, True
    if st is not None and not (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode)):
        from gyrodrift._paths import node_kind

        raise ConfigError(f"{path}: output path is {node_kind(st.st_mode)}, not a file; choose a file name")
    if path.is_symlink():  # the file it names is replaced, the link kept (also a link to a file not made yet)
        return Path(os.path.realpath(path)), False
    return path, False


@contextmanager
def _through(path: Path):
    """A FIFO or character device opened for writing in place; OS errors become a
    :class:`ConfigError` naming it."""
    try:
        fh = open(path, "wb")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot write to it ({exc.strerror or exc}); choose another path") from exc
    try:
        with fh:
            yield fh
    except OSError as exc:
        raise ConfigError(f"{path}: writing failed ({exc.strerror or exc})") from exc


@contextmanager
def atomic_output(path):
    """Open a hidden temporary file beside ``path`` for binary writing; on success it is synced
    and moved onto ``path`` in one step (:func:`os.replace`).

    On any failure the temporary is removed and an existing ``path`` left untouched; a
    problem with the path is a :class:`ConfigError` naming it.
    """
    path, through = _destination(Path(path))
    if through:
        with _through(path) as fh:
            yield fh
        return
    fd, tmp = _create_temporary(path)
    with _replacing(path, tmp):
        with os.fdopen(fd, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())


@contextmanager
def atomic_path(path, *, sync_every_s: float | None = None):
    """:func:`atomic_output` for writers that open the file by its name (pyarrow's own files):
    yield the path of the temporary (created, empty), which the writer closes before the block
    ends. ``sync_every_s``: also sync what is written so far at that interval, in a thread.
    """
    path, through = _destination(Path(path))
    if through:  # the writer opens the FIFO or device itself
        yield path
        return
    fd, tmp = _create_temporary(path)
    with _replacing(path, tmp):
        try:
            with _Syncing(fd, sync_every_s):
                yield tmp
            os.fsync(fd)  # any descriptor of the file syncs what was written through another
        finally:
            os.close(fd)


class _Syncing:
    """Context manager: sync the file ``fd`` every ``interval_s`` seconds in a background
    thread while the block runs (nothing when ``interval_s`` is None)."""

    def __init__(self, fd: int, interval_s: float | None) -> None:
        self._fd, self._interval_s = fd, interval_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __enter__(self) -> "_Syncing":
        if self._interval_s is not None:
            self._thread = threading.Thread(target=self._run, name="gyrodrift-sync", daemon=True)
            self._thread.start()
        return self

    def _run(self) -> None:
        sync = getattr(os, "fdatasync", os.fsync)
        while not self._stop.wait(self._interval_s):
            try:
                sync(self._fd)
            except OSError:
                return  # the final sync reports the problem

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()


def write_bytes_atomic(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_output`)."""
    with atomic_output(path) as fh:
        fh.write(data)

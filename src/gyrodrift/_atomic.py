"""Atomic output files: every file gyrodrift writes appears whole or not at all."""

from __future__ import annotations

import os
import secrets
import threading
from contextlib import contextmanager
from pathlib import Path

from gyrodrift.errors import ConfigError

__all__ = ["atomic_output", "atomic_path", "write_bytes_atomic"]


def _create_temporary(path: Path) -> tuple[int, Path]:
    """Create a hidden temporary file beside ``path``; return its descriptor (open for
    writing) and its path. Problems with ``path`` are a :class:`ConfigError` naming it."""
    parent = path.parent
    if not parent.is_dir():
        raise ConfigError(f"{path}: output folder {str(parent)!r} does not exist; create it first or choose another path")
    if path.is_dir():
        raise ConfigError(f"{path}: output path is a folder; give a file name")
    while True:
        tmp = parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
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


@contextmanager
def atomic_output(path):
    """Open a hidden temporary file beside ``path`` for binary writing; on success it
    is synced and moved onto ``path`` in one step (:func:`os.replace`).

    A missing folder, a folder given as the path, or an OS error is a
    :class:`ConfigError` naming the path; on any failure the temporary file is
    removed and an existing ``path`` is left untouched.
    """
    path = Path(path)
    fd, tmp = _create_temporary(path)
    with _replacing(path, tmp):
        with os.fdopen(fd, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())


@contextmanager
def atomic_path(path, *, sync_every_s: float | None = None):
    """:func:`atomic_output` for writers that open the file by its name: yield the path
    of the hidden temporary file (created, empty).

    pyarrow's own files (:class:`pyarrow.OSFile`) write without holding Python's GIL,
    which a Python file object passed to pyarrow needs for every write. The writer must
    close its file before the block ends; the file is then synced and moved onto
    ``path``. Errors and clean-up as for :func:`atomic_output`.

    With ``sync_every_s``, a background thread also syncs what has been written so far
    at that interval, so that the disk writes overlap the writing instead of all waiting
    for the end (for a file written over seconds, e.g. by a pipeline).
    """
    path = Path(path)
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

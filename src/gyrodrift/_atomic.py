"""Atomic output files: every file gyrodrift writes appears whole or not at all."""

from __future__ import annotations

import os
import secrets
from contextlib import contextmanager
from pathlib import Path

from gyrodrift.errors import ConfigError

__all__ = ["atomic_output", "write_bytes_atomic"]


@contextmanager
def atomic_output(path):
    """Open a hidden temporary file beside ``path`` for binary writing; on success it
    is synced and moved onto ``path`` in one step (:func:`os.replace`).

    A missing folder, a folder given as the path, or an OS error is a
    :class:`ConfigError` naming the path; on any failure the temporary file is
    removed and an existing ``path`` is left untouched.
    """
    path = Path(path)
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
            break
        except FileExistsError:
            continue
        except OSError as exc:
            raise ConfigError(f"{path}: cannot write in {str(parent)!r} ({exc.strerror}); choose another path") from exc
    try:
        with os.fdopen(fd, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise ConfigError(f"{path}: writing failed ({exc.strerror or exc}); check disk space and permissions") from exc
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_bytes_atomic(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_output`)."""
    with atomic_output(path) as fh:
        fh.write(data)

"""Progress bars for long work: on a terminal only, silent in pipes, files and CI."""

from __future__ import annotations

import sys
from typing import Iterable

__all__ = ["progress_iter"]


def progress_iter(iterable: Iterable, total: int, desc: str, *, stream=None):
    """Yield from ``iterable``, showing a progress bar on ``stream`` (stderr) if it is a terminal.

    Uses tqdm when it is installed, else a one-line ``\\r`` bar that is erased at
    the end. Shows nothing when the stream is not a terminal (a pipe, a file, CI).
    """
    stream = sys.stderr if stream is None else stream
    try:
        tty = bool(stream.isatty())
    except (AttributeError, ValueError):
        tty = False
    if not tty:
        yield from iterable
        return
    try:
        from tqdm import tqdm
    except ImportError:
        tqdm = None
    if tqdm is not None:
        yield from tqdm(iterable, total=total, desc=desc, file=stream, leave=False)
        return
    width = 0

    def show(done: int) -> None:
        nonlocal width
        filled = int(24 * done / total) if total else 24
        line = f"\r{desc} [{'#' * filled}{'.' * (24 - filled)}] {done}/{total}"
        width = max(width, len(line))
        stream.write(line)
        stream.flush()

    show(0)
    try:
        for done, item in enumerate(iterable, 1):
            yield item
            show(done)
    finally:
        stream.write("\r" + " " * width + "\r")
        stream.flush()

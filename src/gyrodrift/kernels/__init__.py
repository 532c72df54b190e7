"""The equations of gyrodrift, written once, compiled with numba.

The streaming :class:`gyrodrift.Compensator`, :func:`gyrodrift.compensate` and the chunked
file path all call these functions, so they give the same bits by construction. The modules,
the on-disk cache and its digest of all their sources: ``docs/engine.md`` ("The kernels").
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

from numba import njit
from numba.core import event

__all__ = ["jit", "say_when_compiling"]

_HERE = Path(__file__).parent
_CACHE = _HERE / "__pycache__"


def _drop_stale_cache() -> None:
    """Empty numba's cache of this package when any of its sources changed since it was made."""
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in sorted(_HERE.glob("*.py")))).hexdigest()
    stamp = _CACHE / "sources.sha256"
    try:
        if stamp.read_text() == digest:
            return
    except OSError:
        pass
    try:
        for old in [*_CACHE.glob("*.nbi"), *_CACHE.glob("*.nbc")]:
            old.unlink()
        _CACHE.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:  # a read-only install: numba then caches elsewhere or not at all
        pass


_drop_stale_cache()


def jit(fn=None, *, inline: bool = False):
    """Compile ``fn`` with numba (nopython, cached on disk, releasing the GIL).

    No ``fastmath``: IEEE arithmetic in the order written. ``inline=True`` inlines the
    function into its callers at numba's IR level (small helpers called per row).
    """
    options = {"cache": True, "nogil": True}
    if inline:
        options["inline"] = "always"
    if fn is None:
        return njit(**options)
    return njit(**options)(fn)


class _SayWhenCompiling(event.Listener):
    """Listens to numba's compile events (``numba:compile``): one line at the first one
    after it is armed (:func:`say_when_compiling`)."""

    def __init__(self):
        self.armed = False
        self.stream = None
        self.registered = False

    def on_start(self, ev):
        if self.armed:
            self.armed = False
            print("gyrodrift: compiling the engine with numba (not in its cache; once, up to a minute; "
                  "python -m gyrodrift.kernels.warm compiles every path) ...",
                  file=self.stream or sys.stderr, flush=True)

    def on_end(self, ev):
        pass


_SAY = _SayWhenCompiling()


def say_when_compiling(stream=None) -> _SayWhenCompiling:
    """From now on in this process, print one line on ``stream`` (default: stderr, looked up
    when printing) the first time numba starts compiling: a function not in its cache, which
    pauses the command for seconds to a minute. Each call arms the line again (once per
    command when :func:`gyrodrift.cli.main` runs several in one process); one listener in all.
    Returns it (``.armed = False`` disarms it)."""
    if not _SAY.registered:
        event.register("numba:compile", _SAY)
        _SAY.registered = True
    _SAY.stream = stream
    _SAY.armed = True
    return _SAY

"""The equations of gyrodrift, written once, compiled with numba.

Every equation the compensator runs lives in this package, once: the streaming
:class:`gyrodrift.Compensator`, :func:`gyrodrift.compensate` and the chunked file path
all call the same functions, so they give the same bits by construction.

==================  ============================================================
module              what it holds
==================  ============================================================
:mod:`.layout`      the state and settings arrays: index names, reason codes
:mod:`.numeric`     angle wrapping, small-matrix algebra, the Kalman correction
                    (Joseph form) and the covariance cap
:mod:`.kalman`      the drift filters: eq. (10) with a fixed fading factor
                    (``stkf``, ``stkf-s1``, ``kf``) and the ``adaptive`` filter
:mod:`.drift`       eq. (2)/(5) and the T' estimate
:mod:`.aiding`      eqs. (4)–(6): compass and zero-rate measurements, the gates,
                    lock-out recovery, initialisation
:mod:`.fusion`      the fused heading (one-state Kalman filter)
:mod:`.loop`        the row loop: input checks, compensation, integration,
                    gating, interval decisions, fused heading
:mod:`.tilt`        the x and y axes: their row loop, aided by the gravity direction
:mod:`.evidence`    the default estimator's model (hypotheses weighed by evidence)
:mod:`.evloop`      its row loop
:mod:`.thermal`     the thermal calibration's polynomial (numpy, not compiled)
==================  ============================================================

The functions are cached on disk (``cache=True``): ``pip install .`` compiles every one
of them into the package (:mod:`.warm`, run by ``setup.py``), and a function missing from
the cache (an editable install, another numba or processor) is compiled on first use; with
``NUMBA_DISABLE_JIT=1`` the same source runs as plain Python (slow; for debugging,
and as an oracle in the tests). :func:`say_when_compiling` prints one line when numba
starts compiling, so a command line says why it pauses.

numba checks a cached function against its own file only, while the row loop inlines
functions of the other modules here: importing this package therefore compares a digest
of all their sources with the one the cache was made from, and empties the cache when
they differ.
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

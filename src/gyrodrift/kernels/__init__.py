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

The functions are compiled on first use and cached on disk (``cache=True``); with
``NUMBA_DISABLE_JIT=1`` the same source runs as plain Python (slow; for debugging,
and as an oracle in the tests). :func:`cached` says whether a compiled copy is on
disk, so a command line can say why the first run pauses.

numba checks a cached function against its own file only, while the row loop inlines
functions of the other modules here: importing this package therefore compares a digest
of all their sources with the one the cache was made from, and empties the cache when
they differ.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from numba import njit

__all__ = ["jit", "cached"]

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


def cached() -> bool:
    """True when the compiled row loops (heading axis, x/y axes) are in numba's cache next to
    this package (the first run after an install compiles them, about a minute)."""
    return any(_CACHE.glob("loop.run_chunk-*.nbi")) and any(_CACHE.glob("tilt.*.nbi"))

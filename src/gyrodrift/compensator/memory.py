"""Memory for the engine's output: fresh columns on 4-KB pages, faulted in by a helper thread, or
kept between calls (:class:`OutputBuffers`). Why: ``docs/engine.md`` ("Output memory").
"""

from __future__ import annotations

import sys
import threading

import numpy as np

from gyrodrift.errors import GyroDriftError
from gyrodrift.kernels.layout import N_CODES, N_OUT, O_TEMP_RATE, OC_GAP

__all__ = ["OutputBuffers", "Columns", "new_columns", "populate_in_background", "join"]


class Columns:
    """The output and scratch memory of one call for ``n`` rows: ``out`` (N_OUT float columns,
    ``n`` apart), ``codes`` (N_CODES int8 columns), and the scratch inputs ``g_held``,
    ``T_held``, ``h_wrapped`` (written only when a chunk needs them)."""

    def __init__(self, out: np.ndarray, codes: np.ndarray, g_held: np.ndarray, T_held: np.ndarray,
                 h_wrapped: np.ndarray, n: int):
        self.out, self.codes, self.g_held, self.T_held, self.h_wrapped, self.n = out, codes, g_held, T_held, h_wrapped, n

    def column(self, k: int) -> np.ndarray:
        """Float column ``k`` (a view)."""
        return self.out[k * self.n:(k + 1) * self.n]

    def code(self, k: int) -> np.ndarray:
        """int8 column ``k`` (a view)."""
        return self.codes[k * self.n:(k + 1) * self.n]


def new_columns(n: int) -> tuple[Columns, object]:
    """Fresh :class:`Columns` for ``n`` rows (codes zeroed), and the helper thread faulting
    their pages in (:func:`join` it after the kernels ran)."""
    out = small_pages(np.empty(N_OUT * n))
    codes = small_pages(np.zeros(N_CODES * n, dtype=np.int8))
    cols = Columns(out, codes, np.empty(n), np.empty(n), np.empty(n), n)
    views = [cols.code(OC_GAP), cols.column(O_TEMP_RATE)] + [cols.column(k) for k in range(N_OUT) if k != O_TEMP_RATE]
    return cols, populate_in_background(views, n)


class OutputBuffers:
    """Memory for the output columns of a whole-log call, kept from call to call.

    Code that compensates many logs in one process (a Monte Carlo, a sweep, a service) can
    pass one to every call as ``buffers=``: its pages are faulted in once, here, not at every
    call (``docs/engine.md``, "Output memory"). The table a call returns *views* this memory:
    the next call with the same buffers overwrites it; copy what must outlive it.

    Parameters
    ----------
    rows : int
        Largest number of rows of a call that will use these buffers.

    Examples
    --------
    >>> buffers = OutputBuffers(1_000)
    >>> buffers.rows
    1000
    """

    def __init__(self, rows: int):
        rows = int(rows)
        if rows < 1:
            raise GyroDriftError(f"OutputBuffers needs at least one row, not {rows}")
        self.rows = rows
        self._out = np.zeros(N_OUT * rows)
        self._codes = np.zeros(N_CODES * rows, dtype=np.int8)
        self._scratch = np.zeros(3 * rows)
        self.gated = np.zeros(rows, dtype=np.bool_)

    def take(self, n: int) -> Columns:
        """:class:`Columns` for the first ``n`` rows (the codes zeroed, as :func:`new_columns` gives them)."""
        if n > self.rows:
            raise GyroDriftError(
                f"the log has {n} rows but the OutputBuffers were made for {self.rows}: "
                f"make them with OutputBuffers({n}) or more, or leave buffers out"
            )
        codes = self._codes[:N_CODES * n]
        codes.fill(0)
        s = self._scratch
        return Columns(self._out[:N_OUT * n], codes, s[:n], s[n:2 * n], s[2 * n:3 * n], n)


# ------------------------------------------------------------ fresh memory: docs/engine.md, "Output memory"

#: ``madvise`` advice (Linux): fault pages in writable, keeping the contents (5.14); no huge pages.
_MADV_POPULATE_WRITE = 23
_MADV_NOHUGEPAGE = 15
#: Arrays smaller than this are left as numpy allocates them (malloc reuses such blocks).
_SMALL_PAGES_MIN_BYTES = 8 << 20
#: Below this many bytes in all the columns no helper thread is started.
_POPULATE_MIN_BYTES = 32 << 20
#: Rows populated at a time, in row order across the columns (ahead of the loop).
_POPULATE_ROWS = 1 << 19
_PAGE = 4096
_madvise = None


def _load_madvise():
    """libc's ``madvise`` through ctypes, or False where there is none (not Linux)."""
    global _madvise
    if _madvise is None:
        _madvise = False
        if sys.platform.startswith("linux"):
            try:
                import ctypes

                fn = ctypes.CDLL(None, use_errno=True).madvise
                fn.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int)
                fn.restype = ctypes.c_int
                _madvise = fn
            except (OSError, AttributeError):
                pass
    return _madvise


def _span(a, lo: int, hi: int) -> tuple[int, int]:
    """Address (rounded down to its page: the same mapping) and length of elements ``lo:hi``."""
    start = a.ctypes.data + lo * a.itemsize
    start -= start % _PAGE
    return start, a.ctypes.data + hi * a.itemsize - start


def small_pages(a: np.ndarray) -> np.ndarray:
    """``a`` (fresh, not yet written) on 4-KB pages when it is large; returns it."""
    if a.nbytes >= _SMALL_PAGES_MIN_BYTES and _load_madvise():
        _madvise(*_span(a, 0, a.size), _MADV_NOHUGEPAGE)  # a failure only leaves huge pages
    return a


def populate_in_background(columns, n: int):
    """Fault in the ``n`` rows of the fresh 1-d ``columns`` in a helper thread, in the order the
    kernels write them: the gap flags and T' (the first two, written by the checks and the T'
    kernel in turn), then the output columns in row order; returns the thread (for
    :func:`join`), or None when they are small or the system cannot (the kernels then fault
    the pages in themselves)."""
    if sum(c.nbytes for c in columns) < _POPULATE_MIN_BYTES or not _load_madvise():
        return None

    def populate(columns=columns):  # holds the columns until done
        for group in (columns[:2], columns[2:]):
            for lo in range(0, n, _POPULATE_ROWS):
                hi = min(lo + _POPULATE_ROWS, n)
                for c in group:
                    if _madvise(*_span(c, lo, hi), _MADV_POPULATE_WRITE) != 0:
                        return  # not supported (Linux < 5.14): the kernels fault the pages in themselves

    helper = threading.Thread(target=populate, name="gyrodrift-pages", daemon=True)
    helper.start()
    return helper


def join(helper) -> None:
    if helper is not None:
        helper.join()

"""Progress bars for long work: on a terminal only, silent in pipes, files and CI.

tqdm's bar when it is installed, else one drawn here (docs/command-line.md, section "Progress bars").
"""

from __future__ import annotations

import math
import sys
import time
from typing import Callable, Iterable

__all__ = ["progress_iter"]

#: Width of the built-in bar, characters between the brackets.
_BAR_CHARS = 24
#: Least time between two redraws of the built-in bar, s (the last one is always drawn).
_REDRAW_S = 0.2


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _amount_text(value: float) -> str:
    """A count with an SI prefix: ``950``, ``12.3k``, ``4.56M``."""
    for scale, prefix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if abs(value) >= scale:
            return f"{value / scale:.3g}{prefix}"
    return f"{value:.0f}" if float(value).is_integer() else f"{value:.3g}"


def _clock_text(seconds: float) -> str:
    """``m:ss``, or ``h:mm:ss`` from an hour; ``?`` when unknown."""
    if not math.isfinite(seconds) or seconds < 0:
        return "?"
    h, rest = divmod(int(round(seconds)), 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def _line(desc: str, done: float, total: float | None, elapsed_s: float, unit: str) -> str:
    """The built-in bar: ``desc [####....] done/total unit, rate unit/s, ETA m:ss``."""
    rate = done / elapsed_s if elapsed_s > 0 and done > 0 else math.nan
    if total:
        filled = min(_BAR_CHARS, int(_BAR_CHARS * done / total))
        eta = max(total - done, 0) / rate if math.isfinite(rate) else math.nan
        head = f"{desc} [{'#' * filled}{'.' * (_BAR_CHARS - filled)}] {_amount_text(done)}/{_amount_text(total)}"
        tail = f", ETA {_clock_text(eta)}"
    else:  # an unknown total: count and rate only
        head, tail = f"{desc} {_amount_text(done)}", ""
    rate_text = f"{_amount_text(rate)} {unit}/s" if math.isfinite(rate) else f"? {unit}/s"
    return f"{head} {unit}, {rate_text}{tail}"


def progress_iter(
    iterable: Iterable,
    total: float | None,
    desc: str,
    *,
    stream=None,
    unit: str = "it",
    size: Callable[[object], float] | None = None,
):
    """Yield from ``iterable``, showing a progress bar on ``stream`` (stderr) if it is a terminal.

    Parameters
    ----------
    iterable : iterable
        What to iterate; its items are yielded unchanged.
    total : float or None
        The amount the whole iteration does, in ``unit``; None when unknown.
    desc : str
        The bar's label.
    stream : file-like, optional
        Where to draw (default ``sys.stderr``); nothing is written off a terminal.
    unit : str
        What ``total`` counts (``"rows"``, ``"logs"``).
    size : callable, optional
        ``size(item)``: how far an item advances the bar (default 1; ``len`` for chunks of rows).
    """
    stream = sys.stderr if stream is None else stream
    if not _is_terminal(stream):
        yield from iterable
        return
    step = size or (lambda item: 1)
    try:
        from tqdm import tqdm
    except ImportError:
        tqdm = None
    if tqdm is not None:
        with tqdm(total=total, desc=desc, file=stream, leave=False, unit=unit, unit_scale=True,
                  dynamic_ncols=True) as bar:
            for item in iterable:
                yield item
                bar.update(step(item))
        return
    width, start, drawn = 0, time.monotonic(), -math.inf

    def show(done: float, *, last: bool = False) -> None:
        nonlocal width, drawn
        now = time.monotonic()
        if not last and now - drawn < _REDRAW_S:
            return
        drawn = now
        line = "\r" + _line(desc, done, total, now - start, unit)
        stream.write(line + " " * max(0, width - len(line)))  # blank what a longer line left
        width = max(width, len(line))
        stream.flush()

    done = 0.0
    show(done)
    try:
        for item in iterable:
            yield item
            done += step(item)
            show(done)
        show(done, last=True)
    finally:
        stream.write("\r" + " " * width + "\r")
        stream.flush()

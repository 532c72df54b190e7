"""Held compass values: a table that repeats the last compass sample on every row.

:func:`drop_held` empties the compass cells of rows that repeat the row before bit for bit,
when such repeats are common enough to be held values (docs/log-formats.md, section "Held
compass values"); :func:`held_note` says how many. This module imports no module of
gyrodrift.io, so that :mod:`gyrodrift.io.validate` can import it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.conventions import HEADING, MAG_COLS

__all__ = ["HELD_MIN_SHARE", "Held", "compass_groups", "drop_held", "held_note"]

#: Share of the rows with a compass value that must repeat the row before for a table to
#: be taken as holding its compass values (a compass slower than 90 % of the row rate).
HELD_MIN_SHARE = 0.1
_COUNTS = "counts"  #: key of ``Held.last`` holding (repeats, rows with a value) so far


class Held(NamedTuple):
    """What :func:`drop_held` did to one frame."""

    frame: pd.DataFrame  #: the frame, held compass cells empty
    dropped: int  #: rows whose compass values were dropped
    #: each group's values in the frame's last row, as read, and the counts so far (for the next frame)
    last: dict | None


def compass_groups(columns) -> list[tuple[str, ...]]:
    """The compass column groups :func:`drop_held` compares: ``heading`` and the complete
    magnetometer triple, those the table has."""
    groups = [(HEADING,)] if HEADING in columns else []
    if all(c in columns for c in MAG_COLS):
        groups.append(tuple(MAG_COLS))
    return groups


def drop_held(frame: pd.DataFrame, prev: dict | None = None) -> Held:
    """Empty the compass cells of rows that repeat the row before (see the module notes).

    ``frame`` holds float64 compass columns as read (before unit or frame conversions) and
    is not changed; ``prev`` is ``Held.last`` of the frame before it (rows read in chunks).
    Returns ``frame`` itself when no row was dropped.
    """
    groups = compass_groups(frame.columns)
    if not groups or len(frame) == 0:
        return Held(frame, 0, prev)
    held = np.ones(len(frame), dtype=bool)
    valued = np.zeros(len(frame), dtype=bool)
    last = {}
    for cols in groups:
        values = frame[list(cols)].to_numpy(dtype=np.float64)
        before = np.full((1, len(cols)), np.nan) if prev is None or cols not in prev else prev[cols][None, :]
        previous = np.concatenate((before, values[:-1]))
        present = np.isfinite(values).all(axis=1)
        held &= (values == previous).all(axis=1) | ~present
        valued |= present
        last[cols] = values[-1].copy()
    held &= valued
    repeats, rows = (prev or {}).get(_COUNTS, (0, 0))
    repeats, rows = repeats + int(held.sum()), rows + int(valued.sum())
    last[_COUNTS] = (repeats, rows)
    dropped = int(held.sum()) if repeats >= HELD_MIN_SHARE * rows else 0
    if not dropped:
        return Held(frame, 0, last)
    out = frame.copy(deep=False)  # columns are replaced, never changed in place
    for cols in groups:
        for col in cols:
            out[col] = np.where(held, np.nan, out[col].to_numpy(dtype=np.float64))
    return Held(out, dropped, last)


def held_note(name: str, dropped: int) -> str | None:
    """The note for ``dropped`` held compass rows of the file ``name`` (None for none)."""
    if not dropped:
        return None
    return (
        f"{name}: {dropped} compass samples repeated the row before bit for bit (held values, as in a table "
        "resampled onto the gyro rows) and were dropped: only new compass samples aid the gyro"
    )

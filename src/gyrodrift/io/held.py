"""Held compass values: a table that repeats the last compass sample on every row.

A log resampled onto the gyro's rows (a CSV exported from a ROS bag, say) often repeats
the latest compass sample on every row until the next one comes. Read as they are, the
repeats count as new measurements: the fused heading and the compass averages then weigh
each sample by how long it was held, and the same data read from the bag (one compass
sample per message, :func:`gyrodrift.io.align.on_following_rows`) give another result.

:func:`drop_held` empties (NaN) the compass cells of every row whose compass values are
bit for bit those of the row before: the ``heading`` and, when the table has all of
``mag_x, mag_y, mag_z``, the magnetometer triple, compared together (a row is held when
every one of these groups that has a value in the row equals the row before). The first
row of a run of equal values keeps them. A real compass repeats itself by chance when
its output is quantised and the unit is still (a heading stored to 0.001 deg with 0.5 deg
of noise: about 1 sample in 1500); a table resampled onto the gyro rows repeats most of
its samples (9 in 10 for a 10 Hz compass on 100 Hz rows). So the repeats count as held
values only when they are at least :data:`HELD_MIN_SHARE` of the rows with a compass
value (read in chunks: of the rows read so far); fewer, they are real samples and stay.
:func:`held_note` says how many values were dropped. This module imports no module of
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
    """The compass column groups of a table compared by :func:`drop_held`: ``heading`` and the
    magnetometer triple, those the table has (the triple only when complete)."""
    groups = [(HEADING,)] if HEADING in columns else []
    if all(c in columns for c in MAG_COLS):
        groups.append(tuple(MAG_COLS))
    return groups


def drop_held(frame: pd.DataFrame, prev: dict | None = None) -> Held:
    """Empty the compass cells of rows that repeat the row before (see the module notes).

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows with numeric (float64) compass columns, as read (before unit or frame
        conversions). Not changed.
    prev : dict, optional
        ``Held.last`` of the frame just before (rows read in chunks).

    Returns
    -------
    Held
        A new frame when rows were dropped (else ``frame`` itself), the count, and the
        values of the last row for the next frame.
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

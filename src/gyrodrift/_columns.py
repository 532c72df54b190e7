"""Columns: the input columns joined to an output table at once, and inputs as read-only floats.

:func:`join_input_columns` does what adding each input column in turn does
(:func:`gyrodrift.compensator.append_input_columns`) in one step, in time linear in the
columns (pandas copies its column index, and warns, at every insertion).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from gyrodrift.conventions import HEADING, T

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["join_input_columns", "read_only_floats"]


def read_only_floats(values) -> np.ndarray:
    """A float64, contiguous, read-only view of ``values`` (a copy only when needed): a compiled
    kernel takes its inputs read-only, one compiled version whatever the caller passes."""
    view = np.ascontiguousarray(values, dtype=float).view()
    view.flags.writeable = False
    return view


def join_input_columns(out: pd.DataFrame, log: pd.DataFrame) -> pd.DataFrame:
    """``out`` (its ``attrs`` kept) with every input column of ``log`` but ``t`` and ``heading`` after its own.

    A name the table already has becomes ``in_NAME`` (``in_in_NAME`` when that is taken too:
    no column is ever replaced). The columns are taken row for row, by position, keeping
    their types (a text column of empty cells stays text).
    """
    import pandas as pd  # here: the kernels' build imports this module (for attitude) without pandas

    taken = set(out.columns)
    positions, names = [], []
    for position, col in enumerate(log.columns):
        if col in (T, HEADING):
            continue
        name = col
        while name in taken:
            name = f"in_{name}"
        taken.add(name)
        positions.append(position)
        names.append(name)
    if not names:
        return out
    extra = log.iloc[:, positions].set_axis(names, axis=1).set_axis(out.index, axis=0)  # one selection, by position
    joined = pd.concat([out, extra], axis=1)
    joined.attrs = out.attrs
    return joined

"""The input columns joined to an output table at once, however many there are.

:func:`join_input_columns` does what adding each input column in turn does
(:func:`gyrodrift.compensator.append_input_columns`), in one step: a table with
thousands of pass-through columns is assembled in time linear in its columns, not
quadratic (pandas copies its column index, and warns, at every insertion).
"""

from __future__ import annotations

import pandas as pd

from gyrodrift.conventions import HEADING, T

__all__ = ["join_input_columns"]


def join_input_columns(out: pd.DataFrame, log: pd.DataFrame) -> pd.DataFrame:
    """``out`` with every input column of ``log`` but ``t`` and ``heading`` after its own.

    A column whose name the table already has is added as ``in_NAME`` (``in_in_NAME``
    when that is taken too, and so on: no column is ever replaced). The columns are
    taken row for row, by position, keeping their types (a text column of empty cells
    stays text).

    Parameters
    ----------
    out : DataFrame
        The output table (its ``attrs`` are kept).
    log : DataFrame
        The input rows, as many as ``out`` has.

    Returns
    -------
    DataFrame
        A new table: ``out``'s columns, then the input columns.
    """
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

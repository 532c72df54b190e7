"""Notes: what a log lacks and what gyrodrift does instead, one line each in ``attrs["notes"]``.

Which gaps get a note and how each is worded: docs/log-formats.md, section "Notes".
"""

from __future__ import annotations

from typing import MutableMapping

import pandas as pd

from gyrodrift.conventions import ACC_COLS, HEADING, MAG_COLS, TEMP
from gyrodrift.io.messages import one_line, show_names

__all__ = [
    "NOTES",
    "NO_COMPASS",
    "NO_TEMPERATURE_C",
    "no_compass_note",
    "no_temperature_note",
    "add_note",
    "TEMP_MEASURED",
    "TEMP_ABSENT",
    "TEMP_EMPTY",
    "compass_columns_with_values",
    "compass_form",
    "table_notes",
]

#: Key of the notes in ``frame.attrs``.
NOTES = "notes"
#: ``attrs["compass"]`` of a log without a compass.
NO_COMPASS = "none"
#: Temperature (degC) written in every row of a log without a usable gyro temperature.
NO_TEMPERATURE_C = 0.0

_NO_COMPASS_DOES = "the heading is relative to the first sample and the drift is learned from still periods only"
_NO_TEMPERATURE_DOES = f"temp set to {NO_TEMPERATURE_C:g} degC; the drift is modelled as a trend in elapsed time"


def no_compass_note(name: str, why: str) -> str:
    """``"<name>: no compass (<why>): <what is done instead>"``, on one line."""
    return one_line(f"{name}: no compass ({why}): {_NO_COMPASS_DOES}")


def no_temperature_note(name: str, why: str, advice: str = "") -> str:
    """``"<name>: no usable gyro temperature (<why>): <what is done instead>[; <advice>]"``, on one line."""
    tail = f"; {advice}" if advice else ""
    return one_line(f"{name}: no usable gyro temperature ({why}): {_NO_TEMPERATURE_DOES}{tail}")


def add_note(attrs: MutableMapping[str, object], note: str) -> None:
    """Append ``note`` to ``attrs["notes"]``, creating the list if there is none yet."""
    notes = attrs.get(NOTES)
    attrs[NOTES] = [*(notes or []), note]


#: The raw compass form: its columns, and its name in a note.
_MAG_FORM_COLS = MAG_COLS + ACC_COLS
_MAG_FORM = "mag_x..z with acc_x..z"
#: Where a table's temperature came from (:attr:`gyrodrift.io.validate.Normalised.temperature`).
TEMP_MEASURED, TEMP_ABSENT, TEMP_EMPTY = "measured", "absent", "empty"


def compass_columns_with_values(frame: pd.DataFrame) -> frozenset[str]:
    """The compass columns (``heading``, ``mag_*``, ``acc_*``) that hold at least one value."""
    return frozenset(c for c in (HEADING,) + _MAG_FORM_COLS if c in frame.columns and frame[c].notna().any())


def compass_form(with_values: frozenset[str]) -> str:
    """Return "heading", "mag", "both" or "none" (:data:`NO_COMPASS`): the compass forms holding data
    in ``with_values``, the compass columns with a value somewhere in the file (united over chunks)."""
    heading = HEADING in with_values
    mag = all(c in with_values for c in _MAG_FORM_COLS)
    if heading and mag:
        return "both"
    if heading:
        return "heading"
    if mag:
        return "mag"
    return NO_COMPASS


def _compass_gap(columns, with_values: frozenset[str]) -> str:
    """Why a table has no compass form: the words inside its note's parentheses."""
    head = f"{HEADING} column empty in every row" if HEADING in columns else f"no {HEADING} column"
    present = [c for c in _MAG_FORM_COLS if c in columns]
    if not present:
        return f"{head} nor {_MAG_FORM}" if HEADING not in columns else f"{head}, no {_MAG_FORM}"
    missing = [c for c in _MAG_FORM_COLS if c not in columns]
    empty = [c for c in present if c not in with_values]
    parts = ([f"missing: {', '.join(missing)}"] if missing else []) + (
        [f"empty in every row: {', '.join(empty)}"] if empty else []
    )
    return f"{head}, {_MAG_FORM} incomplete ({'; '.join(parts)})"


def table_notes(name: str, columns, with_values: frozenset[str], temperature: str) -> list[str]:
    """The notes of a table read whole or in chunks: no compass, then no temperature.

    ``columns`` are the table's columns as read, ``with_values`` the compass columns with a
    value somewhere in the file, ``temperature`` "measured", "absent" or "empty"
    (:attr:`gyrodrift.io.validate.Normalised.temperature`).
    """
    notes = []
    if compass_form(with_values) == NO_COMPASS:
        notes.append(no_compass_note(name, _compass_gap(columns, with_values)))
    if temperature == TEMP_ABSENT:
        notes.append(
            no_temperature_note(
                name,
                f"no {TEMP!r} column; columns found: {show_names([c for c in columns if c != TEMP])}",
                f"if the log has it under another name, map it with --map {TEMP}=NAME (column_map in Python)",
            )
        )
    elif temperature == TEMP_EMPTY:
        notes.append(no_temperature_note(name, f"column {TEMP!r} empty in every row"))
    return notes

"""Notes: what a log lacks and what gyrodrift does instead.

A log without a compass, or without a usable gyro temperature, is read, not refused;
the reader says so in one line per gap, kept in ``frame.attrs["notes"]`` (a list of
str; :class:`gyrodrift.io.chunked.LogChunks` keeps them in its ``notes`` attribute):

* **no compass** (no ``heading`` column nor a complete ``mag_*`` + ``acc_*`` form, or
  those columns empty in every row; in a ULog, DataFlash log or ROS bag, no magnetometer
  sample within the gyro record, or in a ULog or DataFlash log no accelerometer for the
  tilt): ``attrs["compass"]`` is ``"none"`` (:data:`NO_COMPASS`);
* **no usable gyro temperature** (no ``temp`` column, one empty in every row; in a
  ULog, DataFlash log or ROS bag, none logged, or logged as exactly 0 or NaN
  everywhere): ``temp`` is :data:`NO_TEMPERATURE_C` in every row, a temperature that
  never changes, so the compensator's drift model takes the elapsed time as its ``T``
  (``CompensatorConfig.temperature``, :class:`gyrodrift.model.ElapsedClock`).

Every note has the form ``<file>: <what is missing> (<why>): <what is done instead>``
(:func:`no_compass_note`, :func:`no_temperature_note`); :func:`add_note` appends one to
a frame's ``attrs``, keeping notes other code put there.
"""

from __future__ import annotations

from typing import MutableMapping

import pandas as pd

from gyrodrift.conventions import ACC_COLS, HEADING, MAG_COLS, TEMP
from gyrodrift.io.messages import show_names

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


def _one_line(text: str) -> str:
    """Collapse line breaks (a topic or column name may hold one). This module imports no
    other module of gyrodrift.io, so that :mod:`gyrodrift.io.validate` can import it."""
    return " ".join(text.split())


def no_compass_note(name: str, why: str) -> str:
    """The note for a log without a compass.

    Parameters
    ----------
    name : str
        The log, as the user gave it.
    why : str
        What is missing, e.g. ``"no heading column nor mag_x..z with acc_x..z"``.

    Returns
    -------
    str
        ``"<name>: no compass (<why>): the heading is relative to the first sample and
        the drift is learned from still periods only"``, on one line.
    """
    return _one_line(f"{name}: no compass ({why}): {_NO_COMPASS_DOES}")


def no_temperature_note(name: str, why: str, advice: str = "") -> str:
    """The note for a log without a usable gyro temperature.

    Parameters
    ----------
    name : str
        The log, as the user gave it.
    why : str
        What is missing, e.g. ``"column 'temp' empty in every row"``.
    advice : str, optional
        Appended after ``"; "``: how to give the temperature if the log has it.

    Returns
    -------
    str
        ``"<name>: no usable gyro temperature (<why>): temp set to 0 degC; the drift is
        modelled as a trend in elapsed time[; <advice>]"``, on one line.
    """
    tail = f"; {advice}" if advice else ""
    return _one_line(f"{name}: no usable gyro temperature ({why}): {_NO_TEMPERATURE_DOES}{tail}")


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
    """Return "heading", "mag", "both" or "none" (:data:`~gyrodrift.io.notes.NO_COMPASS`):
    the compass forms that hold data.

    ``with_values`` are the compass columns holding a value somewhere in the file
    (:func:`compass_columns_with_values`, united over chunks). The raw form needs all
    of ``mag_x, mag_y, mag_z, acc_x, acc_y, acc_z``.
    """
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
    """The notes of a table read whole or in chunks (see :mod:`gyrodrift.io.notes`).

    Parameters
    ----------
    name : str
        The file, as the user gave it.
    columns : sequence of str
        The columns of the table as read (``temp`` included when it was filled in).
    with_values : frozenset of str
        Compass columns holding a value somewhere in the file.
    temperature : {"measured", "absent", "empty"}
        :attr:`gyrodrift.io.validate.Normalised.temperature` of the file.

    Returns
    -------
    list of str
        A compass note when :func:`compass_form` is "none", then a temperature note
        when ``temperature`` is not "measured"; empty when the table lacks neither.
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

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

__all__ = [
    "NOTES",
    "NO_COMPASS",
    "NO_TEMPERATURE_C",
    "no_compass_note",
    "no_temperature_note",
    "add_note",
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

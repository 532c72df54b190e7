"""Checks and conversions shared by the table readers, whole or in chunks.

:func:`normalise_frame` brings the rows of a table into the input contract, step by step
as docs/log-formats.md, section "Tables: CSV and Parquet", lists; every step works row by
row, so the chunks of a file come out as the rows of the whole file.
"""

from __future__ import annotations

from typing import Callable, Mapping, NamedTuple

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pa_compute
import pyarrow.csv as pa_csv

from gyrodrift.conventions import (
    ACC_COLS,
    FRAMES,
    GYRO_UNITS,
    GYRO_X,
    GYRO_Y,
    GYRO_Z,
    HEADING,
    MAG_COLS,
    REF_HEADING,
    REQUIRED_COLS,
    T,
    TEMP,
    TRUE_BIAS_X,
    TRUE_BIAS_Y,
    TRUE_BIAS_Z,
    wrap_360,
)
from gyrodrift.errors import ConfigError
from gyrodrift.io.limits import GYRO_MAX_DPS, LIMITED_COLS, check_gyro_max_dps, first_outside, limit_of, outside_problem
from gyrodrift.io.messages import Source, cell_label, format_error, one_line, option_error, row_label, show_names, show_text
# the reader of stream.py takes these from here, with the checks
from gyrodrift.io.messages import check_input_path, no_data_rows_error, read_error  # noqa: F401
from gyrodrift.io.notes import NO_TEMPERATURE_C, TEMP_ABSENT, TEMP_EMPTY, TEMP_MEASURED, compass_columns_with_values
# the reader of stream.py takes these from here, with the checks
from gyrodrift.io.notes import compass_form, table_notes  # noqa: F401
from gyrodrift.io.held import drop_held
from gyrodrift.io.timebase import time_base_notes, time_scale

__all__ = [
    "NUMERIC_COLS",
    "check_column_map",
    "check_z_up",
    "Z_UP_SHARE",
    "TableOptions",
    "read_options",
    "table_to_frame",
    "apply_column_map",
    "convert_numeric",
    "first_value_rows",
    "Normalised",
    "normalise_frame",
]


#: Contract columns that must hold numbers (in file order of checking).
NUMERIC_COLS = (
    (T, GYRO_Z, GYRO_X, GYRO_Y, TEMP, HEADING)
    + MAG_COLS
    + ACC_COLS
    + (REF_HEADING, TRUE_BIAS_Z, TRUE_BIAS_X, TRUE_BIAS_Y)
)
#: Gyro rate columns (converted to deg/s).
_GYRO_COLS = (GYRO_X, GYRO_Y, GYRO_Z)
#: Columns whose sign flips from ROS FLU body axes to FRD (180 deg rotation about x).
_FLU_TO_FRD_FLIP = (GYRO_Y, GYRO_Z, TRUE_BIAS_Y, TRUE_BIAS_Z, MAG_COLS[1], MAG_COLS[2], ACC_COLS[1], ACC_COLS[2])
#: Columns holding a heading (deg, clockwise from north in NED).
_HEADING_COLS = (HEADING, REF_HEADING)
#: Cells pyarrow's CSV reader takes for "no value" (its defaults, for every column).
_CSV_NULL_VALUES = tuple(pa_csv.ConvertOptions().null_values)
#: Text that means "no value" in a numeric column stored as text (compared stripped and in
#: lower case); it includes every CSV null value, so a cell is empty whether the CSV reader
#: or the text conversion decides.
_NAN_TEXT = frozenset({"", "nan", "-nan", "na", "n/a", "null", "none", "#n/a"} | {v.lower() for v in _CSV_NULL_VALUES})


# ---------------------------------------------------------------------------
# option checks
# ---------------------------------------------------------------------------


def _gyro_scale(gyro_unit: str) -> tuple[str, float]:
    """Return the canonical gyro unit name and its multiplier to deg/s."""
    key = str(gyro_unit).strip().lower()
    if key not in GYRO_UNITS:
        raise ConfigError(
            one_line(f"unknown gyro unit {gyro_unit!r}; use one of: {', '.join(GYRO_UNITS)}")
        )
    return key, GYRO_UNITS[key]


def _frame_name(frame: str | None) -> str:
    """Return the canonical frame name (None: "ned", not stated), or raise :class:`ConfigError`."""
    if frame is None:
        return "ned"
    key = str(frame).strip().lower()
    if key not in FRAMES:
        raise ConfigError(one_line(f"unknown frame {frame!r}; use one of: {', '.join(FRAMES)}"))
    return key


def check_column_map(column_map: Mapping[str, str] | None) -> dict[str, str]:
    """Return ``column_map`` as a plain NEW -> OLD dict of strings."""
    if column_map is None:
        return {}
    if not isinstance(column_map, Mapping):
        raise ConfigError(
            f"column map must be a mapping NEW -> OLD, got {type(column_map).__name__}"
        )
    out = {}
    for new, old in column_map.items():
        if not isinstance(new, str) or not isinstance(old, str) or not new or not old:
            raise ConfigError(
                one_line(f"column map entry {new!r}={old!r} is invalid; use NEW=OLD column names")
            )
        out[new.strip()] = old.strip()
    olds = list(out.values())
    dup = sorted({o for o in olds if olds.count(o) > 1})
    if dup:
        raise ConfigError(
            one_line(f"column map renames column {dup[0]!r} twice; map each input column once")
        )
    return out


class TableOptions(NamedTuple):
    """The table options of :func:`gyrodrift.io.tabular.read_log`, checked."""

    gyro_unit: str  #: canonical unit name of the gyro columns in the file
    scale: float  #: multiplier from that unit to deg/s
    frame: str  #: "ned" or "enu"
    renames: dict[str, str]  #: column map NEW -> OLD
    time_unit: str | None = None  #: canonical unit of ``t`` in the file (None: s, not stated)
    time_scale: float = 1.0  #: multiplier from that unit to s
    #: plausible gyro full scale, deg/s (:mod:`gyrodrift.io.limits`)
    gyro_max_dps: float = GYRO_MAX_DPS
    #: False when the frame was not given: a table whose accelerometer shows z up is refused
    frame_stated: bool = True


def read_options(gyro_unit: str, frame: str | None, column_map: Mapping[str, str] | None,
                 time_unit: str | None = None, gyro_max_dps: float = GYRO_MAX_DPS) -> TableOptions:
    """Check the table options (raising :class:`ConfigError`) and return them canonical;
    ``frame`` None means NED/FRD, not stated (:func:`check_z_up` then applies)."""
    unit_name, scale = _gyro_scale(gyro_unit)
    frame_name = _frame_name(frame)
    return TableOptions(unit_name, scale, frame_name, check_column_map(column_map), *time_scale(time_unit),
                       check_gyro_max_dps(gyro_max_dps), frame is not None)


# ---------------------------------------------------------------------------
# file-level errors
# ---------------------------------------------------------------------------


def table_to_frame(table: pa.Table, src: Source) -> pd.DataFrame:
    """Convert to pandas, with column names stripped of spaces and checked for duplicates."""
    names = [str(n).strip() for n in table.column_names]
    seen = set()
    for col in names:
        if col in seen:
            where = f"line {src.line_of(1)}" if src.line_of is not None else ""  # the header line
            raise format_error(
                src,
                f"column {col!r} appears more than once in the header",
                "rename or remove the duplicate column",
                where=where,
            )
        seen.add(col)
    frame = table.rename_columns(names).to_pandas(ignore_metadata=True)
    return frame.reset_index(drop=True)


# ---------------------------------------------------------------------------
# column checks (each takes the frame and the source, returns nothing or a new frame)
# ---------------------------------------------------------------------------


def apply_column_map(frame: pd.DataFrame, column_map: dict[str, str], src: Source) -> pd.DataFrame:
    """Rename OLD -> NEW columns, refusing missing OLD names and duplicate results."""
    if not column_map:
        return frame
    found = list(frame.columns)
    for new, old in column_map.items():
        if old not in frame.columns:
            raise option_error(src.name, f"column map {new}={old}: there is no column {old!r};"
                               f" columns found: {show_names(found)}",
                               "fix the --map NEW=OLD option (column_map in Python)")
    renamed = [next((n for n, o in column_map.items() if o == c), c) for c in found]
    for col in set(renamed):
        if renamed.count(col) > 1:
            raise option_error(src.name, f"column map would give two columns named {col!r}",
                               "map each contract name from one input column only, or drop the other column")
    return frame.set_axis(renamed, axis=1)


def _check_required_columns(frame: pd.DataFrame, src: Source) -> None:
    """Raise if ``t`` or ``gyro_z`` is missing (naming ``temp`` too when it is missing as well)."""
    missing = [c for c in REQUIRED_COLS if c not in frame.columns]
    if any(c != TEMP for c in missing):
        raise format_error(
            src,
            f"missing required column(s) {show_names(missing)};"
            f" columns found: {show_names(frame.columns)}",
            "rename the matching input columns with --map NEW=OLD (e.g. --map gyro_z=gz;"
            " column_map={'gyro_z': 'gz'} in Python)",
        )


def _is_plain_numeric(series: pd.Series) -> bool:
    """True for integer/float (not boolean) dtypes, which convert to float64 safely."""
    return pd.api.types.is_numeric_dtype(series.dtype) and not pd.api.types.is_bool_dtype(series.dtype)


def _objects_to_numbers(values: pd.Series) -> tuple[np.ndarray | None, int | None]:
    """Convert object cells (numbers, text, ``Decimal``) one by one, slowly: ``(values, None)``,
    or ``(None, pos)`` with the first cell that is not a number."""
    out = np.empty(len(values), dtype=np.float64)
    for pos, cell in enumerate(values.astype(object)):
        if cell is None or (isinstance(cell, float) and np.isnan(cell)):
            out[pos] = np.nan
            continue
        if isinstance(cell, (bool, np.bool_)):
            return None, pos
        text = str(cell).strip()
        if text.lower() in _NAN_TEXT:
            out[pos] = np.nan
            continue
        try:
            out[pos] = float(cell) if not isinstance(cell, str) else float(text)
        except (TypeError, ValueError):
            return None, pos
    return out, None


_NAN_TEXT_ARRAY = pa.array(sorted(_NAN_TEXT), pa.string())


def _canonical_nan(values: np.ndarray) -> np.ndarray:
    """``values`` with every NaN as the one NaN numpy uses (not a sign or payload a
    parser may leave), so that equal cells give equal bits whichever path read them."""
    nan = np.isnan(values)
    return np.where(nan, np.nan, values) if nan.any() else values


def _parse_text_numbers(series: pd.Series) -> tuple[np.ndarray | None, int | None]:
    """Text cells to float64 with pyarrow's (the CSV reader's) parser, stripped, :data:`_NAN_TEXT` empty:
    ``(values, None)``, ``(None, first bad pos)``, or ``(None, None)`` when some cells are not text."""
    try:
        text = pa.array(series.astype(object), type=pa.string(), from_pandas=True)
    except (pa.ArrowInvalid, pa.ArrowTypeError):
        return None, None
    text = pa_compute.utf8_trim_whitespace(text)
    blank = pa_compute.is_in(pa_compute.utf8_lower(text), value_set=_NAN_TEXT_ARRAY)
    text = pa_compute.if_else(blank, pa.scalar(None, pa.string()), text)
    try:
        return pa_compute.cast(text, pa.float64()).to_numpy(zero_copy_only=False), None
    except pa.ArrowInvalid:
        pass
    lo, hi = 0, len(text)  # the first bad cell is in [lo, hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            pa_compute.cast(text.slice(lo, mid - lo), pa.float64())
            lo = mid
        except pa.ArrowInvalid:
            hi = mid
    return None, lo


def _numeric_column(series: pd.Series, col: str, src: Source) -> np.ndarray:
    """Return a contract column as float64, or raise naming the first non-number."""
    if isinstance(series.dtype, pd.CategoricalDtype):  # dictionary-encoded Parquet column
        series = series.astype(object)
    if _is_plain_numeric(series):
        return _canonical_nan(series.to_numpy(dtype=np.float64, na_value=np.nan))
    if series.isna().all():
        return np.full(len(series), np.nan)
    if pd.api.types.is_string_dtype(series.dtype) or series.dtype == object:
        values, pos = _parse_text_numbers(series)
        if values is not None:
            return _canonical_nan(values)
        if pos is None:  # cells that are not all text (e.g. Decimal objects)
            values, pos = _objects_to_numbers(series)
            if values is not None:
                return _canonical_nan(values)
    else:
        # booleans, dates, timestamps, nested values: report the first non-empty cell
        pos = int(np.flatnonzero(series.notna().to_numpy())[0])
    raise format_error(
        src,
        f"{show_text(series.iloc[pos])} is not a number",
        f"column {col!r} must hold numbers only: fix the value or leave the cell empty",
        where=cell_label(src, pos, col),
    )


def convert_numeric(frame: pd.DataFrame, src: Source) -> pd.DataFrame:
    """Convert every numeric contract column to float64 and reject inf values."""
    out = frame.copy(deep=False)  # columns are replaced, never changed in place
    for col in NUMERIC_COLS:
        if col not in out.columns:
            continue
        values = _numeric_column(out[col], col, src)
        infinite = np.flatnonzero(np.isinf(values))
        if infinite.size:
            pos = int(infinite[0])
            raise format_error(
                src,
                f"value {float(values[pos])!r} is not finite",
                "replace it with a number or leave the cell empty",
                where=cell_label(src, pos, col),
            )
        out[col] = values
    return out


def _first_value_pos(values: np.ndarray) -> int | None:
    """Position of the first non-NaN value, or None if all are NaN."""
    idx = np.flatnonzero(~np.isnan(values))
    return int(idx[0]) if idx.size else None


def first_value_rows(frame: pd.DataFrame) -> dict[str, int | None]:
    """Row of the first value (None: none) of each required column the frame has, after
    conversion."""
    return {col: _first_value_pos(frame[col].to_numpy()) for col in REQUIRED_COLS if col in frame.columns}


def _check_required_values(first: Mapping[str, int | None], src: Source) -> None:
    """Reject an entirely empty ``t`` or ``gyro_z`` and leading empty gyro_z/temp cells;
    ``first`` maps each required column to the file row of its first value (None: none)."""
    for col in (T, GYRO_Z):
        if first[col] is None:
            raise format_error(
                src,
                f"required column {col!r} is empty in every row",
                "check the file, or map the right input column with --map NEW=OLD (column_map in Python)",
            )
    for col in (GYRO_Z, TEMP):
        pos = first.get(col)
        if pos is not None and pos > 0:
            raise format_error(
                src,
                f"the first data row has no {col} value (the first one is on {row_label(src, pos)})",
                f"drop the leading rows without {col} data",
                where=cell_label(src, 0, col),
            )


def _check_time(frame: pd.DataFrame, src: Source, prev_t_s: float | None = None) -> None:
    """Reject empty time stamps and times that do not strictly increase, also from ``prev_t_s``,
    the time of the row just before the frame (chunked reading)."""
    t = frame[T].to_numpy()
    empty = np.flatnonzero(np.isnan(t))
    if empty.size:
        pos = int(empty[0])
        raise format_error(
            src,
            "time is empty",
            "every row needs a time stamp in seconds: fill in t or drop the row",
            where=cell_label(src, pos, T),
        )
    before = 0 if prev_t_s is None else 1
    t_all = t if prev_t_s is None else np.concatenate(([prev_t_s], t))
    bad = np.flatnonzero(~(np.diff(t_all) > 0.0))
    if bad.size:
        pos = int(bad[0]) + 1 - before  # row in the frame; pos - 1 may be the row before it
        repeated = t_all[pos + before] == t_all[pos - 1 + before]
        raise format_error(
            src,
            f"time is not strictly increasing: t={float(t[pos])!r} follows t={float(t_all[pos - 1 + before])!r}"
            f" on {row_label(src, pos - 1)}",
            ("remove the row if it repeats a sample; if the two are distinct samples stamped by a clock "
             "coarser than the sample rate, give each its own time (spread a run of equal times evenly up to "
             "the next)") if repeated else "sort the log by time",
            where=cell_label(src, pos, T),
        )


def _check_limits(frame: pd.DataFrame, src: Source, opts: "TableOptions") -> None:
    """Reject values outside their plausible range (:mod:`gyrodrift.io.limits`), gyro rates in the file's unit."""
    for col in LIMITED_COLS:
        if col not in frame.columns:
            continue
        limit = limit_of(col, opts.gyro_max_dps, opts.scale, opts.gyro_unit)
        pos = first_outside(frame[col].to_numpy(), limit)
        if pos is not None:
            value = frame[col].iloc[pos]
            advice = limit.advice + (" and map the right one with --map NEW=OLD (column_map in Python)" if col == TEMP else "")
            raise format_error(src, outside_problem(col, value, limit), advice, where=cell_label(src, pos, col))


# ---------------------------------------------------------------------------
# unit and frame conversion (pure: frame in, new frame out)
# ---------------------------------------------------------------------------


#: Median share of the specific force along +z beyond which a table is taken as z up (a tilt under 26 deg).
Z_UP_SHARE = 0.9


def check_z_up(frame: pd.DataFrame, src: Source) -> None:
    """Refuse a table read as NED/FRD whose accelerometer says its z axis points up (the median of
    ``acc_z / |acc|`` above :data:`Z_UP_SHARE`), naming ``--frame enu``."""
    if not all(c in frame.columns for c in ACC_COLS):
        return
    acc = frame[list(ACC_COLS)].to_numpy(dtype=np.float64)
    acc = acc[np.all(np.isfinite(acc), axis=1)]
    norm = np.linalg.norm(acc, axis=1)
    acc, norm = acc[norm > 0], norm[norm > 0]
    if not norm.size:
        return
    share = float(np.median(acc[:, 2] / norm))
    if share > Z_UP_SHARE:
        raise format_error(
            src, f"the accelerometer reads {share:.2f} of its magnitude along +z (median): the z axis points up "
            "(ENU/FLU, as ROS logs), while the input contract is FRD (a level unit reads acc_z = -1 g)",
            "pass --frame enu to convert it (frame='enu' in Python), or --frame ned if the unit lay upside down",
            where="column 'acc_z'")


def _to_contract_frame(frame: pd.DataFrame, opts: TableOptions) -> pd.DataFrame:
    """A new frame: gyro columns (and ``true_bias_*``) times ``opts.scale`` (to deg/s); for ENU/FLU
    the headings ``90 - yaw`` and the y and z axes flipped; headings wrapped to [0, 360)."""
    out = frame.copy(deep=False)  # columns are replaced, never changed in place
    if opts.scale != 1.0:
        for col in _GYRO_COLS + (TRUE_BIAS_X, TRUE_BIAS_Y, TRUE_BIAS_Z):
            if col in out.columns:
                out[col] = out[col] * opts.scale
    if opts.frame == "enu":
        for col in _HEADING_COLS:
            if col in out.columns:
                out[col] = wrap_360(90.0 - out[col].to_numpy())
        for col in _FLU_TO_FRD_FLIP:
            if col in out.columns:
                out[col] = -out[col]
    for col in _HEADING_COLS:
        if col in out.columns:
            out[col] = wrap_360(out[col].to_numpy())
    return out


# ---------------------------------------------------------------------------
# one frame: checks and conversions shared by the whole-file and the chunked reader
# ---------------------------------------------------------------------------


class Normalised(NamedTuple):
    """A frame brought into the input contract by :func:`normalise_frame`."""

    frame: pd.DataFrame  #: the rows, in contract units and frames
    with_values: frozenset[str]  #: compass columns holding a value in this frame (for :func:`compass_form`)
    #: "measured"; "absent" (no ``temp`` column) or "empty" (``temp`` empty in every row
    #: of the file): then ``temp`` is :data:`~gyrodrift.io.notes.NO_TEMPERATURE_C` in every row
    temperature: str
    notes: tuple[str, ...] = ()  #: notes of the first frame about the whole file (a low sample rate)
    held: int = 0  #: rows whose held compass values were emptied (:mod:`gyrodrift.io.held`)
    last_compass: dict | None = None  #: ``prev_compass`` of the next frame


def normalise_frame(
    frame: pd.DataFrame,
    src: Source,
    opts: TableOptions,
    *,
    prev_t_s: float | None = None,
    first_values: Callable[[pd.DataFrame], Mapping[str, int | None]] | None = first_value_rows,
    temp_empty: bool = False,
    prev_compass: dict | None = None,
) -> Normalised:
    """Check a frame of a table and bring it into the input contract.

    The whole file or one chunk of it goes through here (docs/log-formats.md, section
    "Tables: CSV and Parquet"). A table without a usable temperature gets ``temp`` =
    :data:`~gyrodrift.io.notes.NO_TEMPERATURE_C` in every row, in place of the empty column
    or added last; held compass values are emptied.

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows as read (:func:`table_to_frame`).
    src : Source
        Where the rows are; ``src.row0`` is the file row of the frame's first row.
    opts : TableOptions
    prev_t_s : float, optional
        Time (s) of the file row just before the frame.
    first_values : callable, optional
        Gives the file row of the first value of each required column
        (:func:`first_value_rows`); None skips those checks (later chunks).
    temp_empty : bool, default False
        Later chunks: the first chunk found ``temp`` empty in every row of the file.
    prev_compass : dict, optional
        ``last_compass`` of the frame before (chunks).

    Returns
    -------
    Normalised
    """
    df = apply_column_map(frame, opts.renames, src)
    _check_required_columns(df, src)
    df = convert_numeric(df, src)
    if first_values is not None:
        first = first_values(df)
        _check_required_values(first, src)
        temp_empty = TEMP in first and first[TEMP] is None
    _check_time(df, src, prev_t_s)
    if first_values is not None and not opts.frame_stated:
        check_z_up(df, src)
    notes = time_base_notes(df[T].to_numpy(), opts.time_unit, src.name) if first_values is not None else ()
    df, held, last_compass = drop_held(df, prev_compass)
    if opts.time_scale != 1.0:
        df[T] = df[T].to_numpy() * opts.time_scale  # df is a new frame (convert_numeric)
    if TEMP not in df.columns:
        temperature = TEMP_ABSENT
    elif temp_empty:
        temperature = TEMP_EMPTY
    else:
        temperature = TEMP_MEASURED
    _check_limits(df, src, opts)
    with_values = compass_columns_with_values(df)
    df = _to_contract_frame(df, opts)
    if temperature != TEMP_MEASURED:
        df[TEMP] = np.full(len(df), NO_TEMPERATURE_C)  # df is a new frame (_to_contract_frame)
    return Normalised(df, with_values, temperature, notes, held, last_compass)

"""CSV cells a spreadsheet would run as a formula, made text: every CSV writer applies this.

Text cells and column names that start like a formula get a leading ``'``; numbers are
never changed (docs/log-formats.md, section "Writing tables"): :func:`formula_safe_table`
for the Arrow tables the CSV writers print, :func:`formula_safe_frame` for pandas.
"""

from __future__ import annotations

import pandas as pd
import pyarrow as pa
import pyarrow.compute as pa_compute

__all__ = ["FORMULA_STARTS", "formula_safe_text", "formula_safe_table", "formula_safe_frame"]

#: First characters that make a spreadsheet read a cell as a formula (OWASP's CSV injection list).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
_PATTERN = "^[=+@\t\r-]"
_QUOTE = "'"


def formula_safe_text(text):
    """``text`` with a leading ``'`` if it starts like a formula; anything else unchanged."""
    if isinstance(text, str) and text.startswith(FORMULA_STARTS):
        return _QUOTE + text
    return text


def _is_text(arrow_type: pa.DataType) -> bool:
    return pa.types.is_string(arrow_type) or pa.types.is_large_string(arrow_type)


def _safe_strings(values):
    """A text array with its formula-like values quoted; None when none is."""
    hits = pa_compute.match_substring_regex(values, _PATTERN)
    if not pa_compute.any(hits).as_py():
        return None
    quoted = pa_compute.binary_join_element_wise(pa.scalar(_QUOTE, values.type), values,
                                                 pa.scalar("", values.type))
    return pa_compute.if_else(hits, quoted, values)


def _safe_column(column: pa.ChunkedArray) -> pa.ChunkedArray | None:
    """``column`` with its formula-like text cells quoted; None when it has none (or no text).
    A dictionary column (a categorical) is checked on its dictionary values only."""
    if pa.types.is_dictionary(column.type) and _is_text(column.type.value_type):
        chunks, changed = [], False
        for chunk in column.chunks:
            safe = _safe_strings(chunk.dictionary)
            changed = changed or safe is not None
            chunks.append(chunk if safe is None else pa.DictionaryArray.from_arrays(chunk.indices, safe))
        return pa.chunked_array(chunks, column.type) if changed else None
    if _is_text(column.type):
        return _safe_strings(column)
    return None


def _holds_text(arrow_type: pa.DataType) -> bool:
    """True for a text column, or a dictionary (categorical) column of text."""
    if pa.types.is_dictionary(arrow_type):
        arrow_type = arrow_type.value_type
    return _is_text(arrow_type)


def formula_safe_table(table: pa.Table) -> pa.Table:
    """``table`` with formula-like text cells and column names quoted (module notes).
    Only its text columns are looked at, and the table is rebuilt once if any changes."""
    columns, changed = None, False
    for i, field in enumerate(table.schema):
        if not _holds_text(field.type):
            continue
        safe = _safe_column(table.column(i))
        if safe is not None:
            columns = columns if columns is not None else list(table.columns)
            columns[i], changed = safe, True
    names = [formula_safe_text(n) for n in table.column_names]
    if changed:
        return pa.Table.from_arrays(columns, names=names)
    return table.rename_columns(names) if names != table.column_names else table


def formula_safe_frame(df: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``df`` with formula-like text cells and column names quoted; number
    columns are left as they are (module notes)."""
    safe = df.copy()
    for i in range(safe.shape[1]):
        col = safe.iloc[:, i]
        if isinstance(col.dtype, pd.CategoricalDtype):
            if any(formula_safe_text(c) is not c for c in col.cat.categories):
                safe.isetitem(i, col.astype(object).map(formula_safe_text))
        elif col.dtype == object or pd.api.types.is_string_dtype(col.dtype):
            safe.isetitem(i, col.map(formula_safe_text))
    return safe.set_axis([formula_safe_text(c) for c in safe.columns], axis=1)

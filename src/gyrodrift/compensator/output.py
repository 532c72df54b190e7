"""What the compensator gives back: one row (:class:`CompensatedSample`) or a table
(:func:`output_frame`; its columns: :func:`gyrodrift.compensate`, its ``attrs``: :func:`with_attrs`).
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from gyrodrift import gating
from gyrodrift.conventions import ACC_COLS, GYRO_Z, HEADING, MAG_COLS, TEMP, T
from gyrodrift.errors import LogFormatError
from gyrodrift.kernels.layout import UNOBSERVABLE_NAMES
from gyrodrift.samples import CompensatedSample

__all__ = ["CompensatedSample", "UNOBSERVABLE", "MEASUREMENT_COLUMNS", "output_frame", "with_attrs",
           "check_input_columns", "append_input_columns", "updated_column", "LEGACY_UPDATED"]

#: Every value of the ``unobservable`` column, in a fixed order (its categories; the kernels'
#: codes index it).
UNOBSERVABLE = UNOBSERVABLE_NAMES

#: Columns of ``attrs["measurements"]``: time (s), drift measurement m (deg/s), interval
#: means of T (degC) and T' (degC/s), variance r ((deg/s)²).
MEASUREMENT_COLUMNS = ("t", "m", "temp", "temp_rate", "r")


def output_frame(cols: dict, gated: np.ndarray | None = None) -> pd.DataFrame:
    """The output table from the columns of :meth:`gyrodrift.compensator.ChunkEngine.feed`
    (``reason`` and ``unobs``: the codes of ``gate_reason`` and ``unobservable``). No
    column is copied; ``gated`` (bool, one per row) receives the ``gated`` column if given."""
    reason_code = cols["reason"]
    return pd.DataFrame(
        {
            "t": cols["t"],
            "rate_z": cols["rate_z"],
            "bias_z": cols["bias_z"],
            "heading": cols["heading"],
            "a": cols["a"],
            "b": cols["b"],
            "c": cols["c"],
            "updated": cols["updated"],
            "gated": np.not_equal(reason_code, 0, out=gated).view(np.int8),  # bool and int8 share one byte
            # codes made by the kernels are in range: no validation pass over the rows
            "gate_reason": pd.Categorical.from_codes(reason_code, categories=list(gating.REASONS), validate=False),
            "temp_rate": cols["temp_rate"],
            "compass_heading": cols["compass_heading"],
            "unobservable": pd.Categorical.from_codes(cols["unobs"], categories=list(UNOBSERVABLE), validate=False),
            "bias_sd": cols["bias_sd"],
            "heading_fused": cols["heading_fused"],
            "heading_fused_sd": cols["heading_fused_sd"],
            "heading_sd": cols["heading_sd"],
        },
        copy=False,
    )


#: The name of the ``updated`` column in output tables written before it was renamed.
LEGACY_UPDATED = "update"


def updated_column(out: pd.DataFrame, what: str = "output table") -> pd.Series:
    """The ``updated`` column of an output table (1 where the filter took a measurement), or the
    ``update`` column of a table written under that earlier name, with a :class:`FutureWarning`;
    ``what`` names the table in messages. A :class:`LogFormatError` when it has neither."""
    if "updated" in out.columns:
        return out["updated"]
    if LEGACY_UPDATED in out.columns:
        warnings.warn(f"{what}: column {LEGACY_UPDATED!r} read as 'updated' (its name in output tables "
                      "written before gyrodrift renamed it)", FutureWarning, stacklevel=3)
        return out[LEGACY_UPDATED]
    raise LogFormatError(f"{what} needs the column updated, which the table lacks")


def with_attrs(out: pd.DataFrame, accepted: np.ndarray, est, notes=(), regressor: str = "temperature",
               engine=None) -> pd.DataFrame:
    """``out`` with its ``attrs``: the accepted measurements ``(M, 5)``, the estimator's name,
    final parameters and covariance, ``notes``: what could not be learned or was done
    instead (one-line sentences), and ``drift_regressor``: what the model's ``T`` was
    (``"temperature"``, or ``"clock"``: the elapsed time, :class:`gyrodrift.model.ElapsedClock`);
    with the default estimator's ``engine``, its epoch history (``epochs``) and reference
    temperature (``temp_ref_c``), for the smoother (:mod:`gyrodrift.smooth`)."""
    out.attrs["measurements"] = pd.DataFrame(np.asarray(accepted, dtype=float).reshape(-1, 5),
                                             columns=list(MEASUREMENT_COLUMNS))
    out.attrs["estimator"] = est.name
    out.attrs["final_params"] = est.params
    out.attrs["final_cov"] = est.cov
    out.attrs["notes"] = list(notes)
    out.attrs["drift_regressor"] = regressor
    if engine is not None and hasattr(engine, "epochs"):
        out.attrs["epochs"] = engine.epochs()
        out.attrs["temp_ref_c"] = engine.temp_ref_c
    return out


def check_input_columns(log: pd.DataFrame, source: str) -> bool:
    """Check a log (or chunk) has the contract's required columns; return whether the raw
    magnetometer form (``mag_*`` and ``acc_*``) is complete. A log may have no compass at
    all (no ``heading`` either): its heading is then relative and its drift is learned
    from still periods only."""
    missing = [c for c in (T, GYRO_Z, TEMP) if c not in log.columns]
    if missing:
        raise LogFormatError(f"{source}: missing required column(s) {', '.join(missing)}")
    return all(c in log.columns for c in MAG_COLS + ACC_COLS)


def append_input_columns(out: pd.DataFrame, log: pd.DataFrame) -> pd.DataFrame:
    """Add every input column but ``t`` and ``heading`` to the output (``in_NAME`` where the
    output already has ``NAME``), row for row."""
    for col in log.columns:
        if col in (T, HEADING):
            continue
        name = col if col not in out.columns else f"in_{col}"
        out[name] = log[col].array  # by position; keeps the column's type (a text column of empty cells stays text)
    return out

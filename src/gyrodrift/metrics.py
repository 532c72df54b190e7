"""Accuracy of a compensated log against a reference heading or the true drift."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from gyrodrift.conventions import REF_HEADING, TRUE_BIAS_Z, wrap_180

__all__ = ["heading_error_deg", "raw_heading_deg", "Accuracy", "accuracy"]


def heading_error_deg(heading_deg, ref_heading_deg) -> np.ndarray:
    """Heading minus reference, deg, wrapped to [-180, 180).

    >>> float(heading_error_deg(1.0, 359.0))
    2.0
    """
    return wrap_180(np.asarray(heading_deg, dtype=float) - np.asarray(ref_heading_deg, dtype=float))


def raw_heading_deg(t_s, gyro_z_dps, start_deg: float) -> np.ndarray:
    """Heading integrated (trapezoid rule) from the uncompensated gyro, deg (unwrapped)."""
    t_s = np.asarray(t_s, dtype=float)
    g = np.asarray(gyro_z_dps, dtype=float)
    inc = 0.5 * (g[1:] + g[:-1]) * np.diff(t_s)
    return start_deg + np.r_[0.0, np.cumsum(inc)]


@dataclass(frozen=True)
class Accuracy:
    """Errors of one run; None where the log has no reference for it.

    Heading errors in deg (against ``ref_heading``), bias errors in deg/s
    (against ``true_bias_z``), for the raw gyro and the compensated one.
    """

    heading_rms_raw: float | None
    heading_rms: float | None
    heading_max_raw: float | None
    heading_max: float | None
    bias_rms_raw: float | None
    bias_rms: float | None


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def accuracy(out: pd.DataFrame) -> Accuracy:
    """Accuracy of a :func:`gyrodrift.compensate.compensate` output table.

    The raw-gyro heading starts at the same heading as the compensated one; the raw
    bias error is the whole drift (no compensation).
    """
    h_rms_raw = h_rms = h_max_raw = h_max = b_rms_raw = b_rms = None
    if REF_HEADING in out.columns:
        ok = out[REF_HEADING].notna().to_numpy()
        raw = raw_heading_deg(out["t"], out["gyro_z"], float(out["heading"].iloc[0]))
        e_raw = heading_error_deg(raw, out[REF_HEADING])[ok]
        e = heading_error_deg(out["heading"], out[REF_HEADING])[ok]
        h_rms_raw, h_rms = _rms(e_raw), _rms(e)
        h_max_raw, h_max = float(np.max(np.abs(e_raw))), float(np.max(np.abs(e)))
    if TRUE_BIAS_Z in out.columns:
        truth = out[TRUE_BIAS_Z].to_numpy(float)
        b_rms_raw = _rms(truth)
        b_rms = _rms(out["bias_z"].to_numpy(float) - truth)
    return Accuracy(h_rms_raw, h_rms, h_max_raw, h_max, b_rms_raw, b_rms)

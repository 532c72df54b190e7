"""A whole log at once: :func:`compensate` (a DataFrame) and :func:`compensate_arrays`."""

from __future__ import annotations

import numpy as np
import pandas as pd

from gyrodrift._columns import join_input_columns
from gyrodrift.compensator.arguments import (
    check_buffers,
    check_callable,
    check_config,
    check_estimator,
    check_log,
    check_source,
    column,
    frame_column,
    rows,
)
from gyrodrift.compensator.config import CompensatorConfig
from gyrodrift.compensator.intake import Intake, MagFit, WholeLog
from gyrodrift.compensator.memory import OutputBuffers
from gyrodrift.compensator.output import check_input_columns, with_attrs
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, HEADING, MAG_COLS, TEMP, T
from gyrodrift.errors import LogFormatError
from gyrodrift.io.limits import GYRO_MAX_DPS, check_columns, check_gyro_max_dps
from gyrodrift.io.timebase import check_time_base
from gyrodrift.model import temperature_is_flat

__all__ = ["compensate", "compensate_arrays"]

#: Rows per chunk when a progress display is asked for.
PROGRESS_ROWS = 1 << 20


#: Rows whose time steps are checked against the plausible sample rate of a file (the first
#: chunk, as the chunked file reader checks it).
TIME_BASE_ROWS = 250_000


def _check_rate(t: np.ndarray, source: str) -> None:
    """Refuse strictly increasing times whose median step gives a sample rate above that of
    a plausible file (:func:`gyrodrift.io.timebase.check_time_base`); other times are the
    engine's to judge."""
    if t.size < 2:
        return
    with np.errstate(over="ignore", invalid="ignore"):  # times of any size: the engine refuses them
        if not (np.diff(t) > 0).all():
            return
        rate = check_time_base(t, "s")
    if rate.problem:
        raise LogFormatError(f"{source}: t_s: {rate.problem}; give the times in seconds")


def compensate_arrays(
    t_s,
    gyro_z_dps,
    temp_c,
    heading_deg=None,
    mag=None,
    acc=None,
    config: CompensatorConfig | None = None,
    *,
    estimator=None,
    source: str = "arrays",
    progress=None,
    buffers: OutputBuffers | None = None,
    gyro_max_dps: float = GYRO_MAX_DPS,
    gyro_xy=None,
    gyro_unit: str | None = None,
    declination: tuple[float, str] | None = None,
) -> pd.DataFrame:
    """Compensate a whole log given as arrays; see :func:`compensate` for the output.

    Parameters
    ----------
    t_s, gyro_z_dps, temp_c : (N,) array_like
        Time (s, strictly increasing), raw heading-axis rate (deg/s), temperature (degC).
        NaN in gyro or temperature holds the previous value (``gap``).
    heading_deg : (N,) array_like, optional
        Compass heading, deg clockwise from north; NaN = no sample.
    mag, acc : (N, 3) array_like, optional
        Raw FRD magnetometer and accelerometer (compass when ``heading_deg`` is
        None or NaN; field-anomaly gate).
    config : CompensatorConfig, optional
    estimator : DriftEstimator, optional
        A fresh estimator instance to use instead of ``config.estimator``.
    source : str
        Name used in error messages (the file name).
    progress : callable, optional
        ``progress(iterable, total)`` wraps the loop over chunks of
        :data:`PROGRESS_ROWS` rows (e.g. a progress bar); it must yield the same items.
    buffers : OutputBuffers, optional
        Memory for the output columns, kept between calls (see :class:`OutputBuffers`):
        the returned table then views it, and the next call with the same buffers
        overwrites it.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro, deg/s.
    gyro_xy : (N, 2) array_like, optional
        Raw ``gyro_x``, ``gyro_y`` (deg/s, FRD): with ``acc``, the x and y axes are
        compensated too (:mod:`gyrodrift.triad`); with ``mag`` and ``acc``, the compass is
        tilt-compensated with the gyro-aided gravity (``config.tilt``, :mod:`gyrodrift.attitude`).
    gyro_unit : str, optional
        The unit the gyro was read in, for the advice of the unit check's note
        (:mod:`gyrodrift.gyro_units`).
    declination : (float, str), optional
        The magnetic declination the log's autopilot used, deg east, and where it is from
        (e.g. ``(11.88, "COMPASS_DEC=0.2074")``): added to the compass when
        ``config.declination_deg`` is None.

    Raises
    ------
    LogFormatError
        No samples; arrays of another shape than given above, or of unequal lengths; a median
        time step above the plausible sample rate of a file (:data:`gyrodrift.io.timebase.MAX_RATE_HZ`);
        a first sample without gyro or temperature; a value outside its plausible range
        (:mod:`gyrodrift.io.limits`; the gyro's is ``gyro_max_dps``), naming the row.
    ArgumentTypeError
        An argument of the wrong kind, saying what is expected (a :class:`TypeError` too).
    """
    source = check_source(source)
    cfg = check_config(config)
    check_estimator(estimator)
    check_callable(progress, "progress")
    check_buffers(buffers)
    # one length for every array before the compiled code, which indexes them unchecked
    t = column(t_s, "t_s", source)
    n = t.size
    g = column(gyro_z_dps, "gyro_z_dps", source, n)
    T_in = column(temp_c, "temp_c", source, n)
    heading_deg = None if heading_deg is None else column(heading_deg, "heading_deg", source, n)
    mag = None if mag is None else rows(mag, "mag", source, n, 3)
    acc = None if acc is None else rows(acc, "acc", source, n, 3)
    gyro_xy = None if gyro_xy is None else rows(gyro_xy, "gyro_xy", source, n, 2)
    if n == 0:
        raise LogFormatError(f"{source}: the log has no samples")
    _check_rate(t[:TIME_BASE_ROWS], source)
    if not (np.isfinite(g[0]) and np.isfinite(T_in[0])):
        raise LogFormatError(f"{source}: the first sample needs gyro_z and temp values")
    check_columns(source, {TEMP: T_in, GYRO_Z: g, HEADING: heading_deg, "mag": mag, "acc": acc},
                  check_gyro_max_dps(gyro_max_dps))
    fit = MagFit(cfg, source) if cfg.mag_calibration and mag is not None and acc is not None else None
    if fit is not None:
        fit.add(t, g, mag, acc, gyro_xy)
    whole = WholeLog(temp_flat=temperature_is_flat(T_in), magcal=None if fit is None else fit.fit(),
                     declination=declination)
    intake = Intake(cfg, source, estimator=estimator, whole=whole, gyro_unit=gyro_unit)
    step = n if progress is None else PROGRESS_ROWS
    if n <= step:  # one piece, in the buffers when given
        cols = intake.feed(t, g, T_in, heading_deg, mag, acc, gyro_xy, buffers)
        if cols is not None:
            return _with_attrs(intake.frame(cols, None if buffers is None else buffers.gated[:n]), intake)
        parts = []
    else:
        starts = range(0, n, step)
        parts = [intake.feed(*(None if a is None else a[lo:lo + step] for a in (t, g, T_in, heading_deg, mag, acc,
                                                                                gyro_xy)))
                 for lo in progress(starts, len(starts))]
    parts = [p for p in (*parts, intake.flush()) if p is not None]  # flush: a log shorter than the init window
    return _with_attrs(intake.frame({k: np.concatenate([p[k] for p in parts]) for k in parts[0]}), intake)


def _with_attrs(out: pd.DataFrame, intake: Intake) -> pd.DataFrame:
    """``out`` with the run's attributes (:func:`with_attrs`); ``attrs["compass"]`` "none" when
    the magnetometer read no field and no heading was given (a log without compass)."""
    engine = intake.engine
    out = with_attrs(out, engine.finish(), intake.estimator, intake.notes, engine.regressor, engine)
    if intake.compass_dead:
        out.attrs["compass"] = "none"
    return out


def compensate(
    log: pd.DataFrame,
    config: CompensatorConfig | None = None,
    *,
    estimator=None,
    source: str | None = None,
    progress=None,
    gyro_max_dps: float = GYRO_MAX_DPS,
) -> pd.DataFrame:
    """Compensate a log in the input contract; return the output table.

    Parameters
    ----------
    log : DataFrame
        Columns ``t`` (s), ``gyro_z`` (deg/s), ``temp`` (degC) and a compass:
        ``heading`` (deg) or ``mag_x..z`` + ``acc_x..z`` (see
        :mod:`gyrodrift.conventions`). As returned by :func:`gyrodrift.io.read_log`.
    config : CompensatorConfig, optional
    estimator : DriftEstimator, optional
        A fresh estimator instance overriding ``config.estimator``.
    source : str, optional
        Name for error messages; defaults to ``log.attrs["source"]``.
    progress : callable, optional
        See :func:`compensate_arrays`.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s; a log with a larger rate, or
        another value outside its plausible range (:mod:`gyrodrift.io.limits`), raises
        :class:`~gyrodrift.errors.LogFormatError` naming the row and column.

    Returns
    -------
    DataFrame
        ``t, rate_z, bias_z, heading, a, b, c, updated, gated, gate_reason`` (the output
        contract), then ``temp_rate`` (T', degC/s), ``compass_heading`` (deg, the
        compass used; empty where there was no sample), ``unobservable`` (``a``, ``b``
        or ``a+b``: drift parameters the data have not yet determined, e.g. while the
        temperature is flat; empty when all are), ``bias_sd`` (deg/s, the filter's
        standard deviation of ``bias_z``), ``heading_fused``, ``heading_fused_sd``,
        ``heading_sd`` (deg; :mod:`gyrodrift.fusion`) and every other input column (the
        input ``heading`` is ``compass_heading``). When the log has ``gyro_x``,
        ``gyro_y`` and ``acc_x..z``, ``rate_x, rate_y, bias_x, bias_y`` (deg/s) and
        ``tilt_gated`` come before the input columns (:mod:`gyrodrift.triad`).
        ``attrs["notes"]`` has the log's notes, the compensator's, and one when the gyro
        unit looks wrong against the compass (:mod:`gyrodrift.gyro_units`).

    Raises
    ------
    ArgumentTypeError
        ``log`` is not a DataFrame, or another argument is of the wrong kind (see
        :func:`compensate_arrays`); a :class:`TypeError` too.
    LogFormatError
        A column name given twice, a required column missing, a number column holding
        text, or what :func:`compensate_arrays` refuses.
    """
    check_log(log, "log")
    source = check_source(source or log.attrs.get("source", "log"))
    check_config(config)
    has_mag = check_input_columns(log, source)
    numbers = {c: frame_column(log, c, source) for c in (T, GYRO_Z, TEMP, HEADING, GYRO_X, GYRO_Y, *MAG_COLS, *ACC_COLS)
               if c in log.columns}
    check_columns(source, {c: numbers[c] for c in (GYRO_X, GYRO_Y) if c in numbers}, check_gyro_max_dps(gyro_max_dps))
    out = compensate_arrays(
        numbers[T],
        numbers[GYRO_Z],
        numbers[TEMP],
        heading_deg=numbers.get(HEADING),
        mag=np.column_stack([numbers[c] for c in MAG_COLS]) if has_mag else None,
        acc=np.column_stack([numbers[c] for c in ACC_COLS]) if set(ACC_COLS) <= set(numbers) else None,
        config=config,
        estimator=estimator,
        source=source,
        progress=progress,
        gyro_max_dps=gyro_max_dps,
        gyro_xy=np.column_stack([numbers[GYRO_X], numbers[GYRO_Y]]) if {GYRO_X, GYRO_Y} <= set(numbers) else None,
        gyro_unit=log.attrs.get("gyro_unit"),
        declination=getattr(log.attrs.get("onboard"), "declination", None),
    )
    out.attrs["notes"] = [*log.attrs.get("notes", ()), *out.attrs["notes"]]
    return join_input_columns(out, log)  # the input columns at once (a wide log: thousands of them)

"""The streaming compensator: samples in, compensated rows out (:class:`Compensator`)."""

from __future__ import annotations

import math
import numbers
from collections import deque
from dataclasses import replace

import numpy as np

from gyrodrift import gating
from gyrodrift.compensator.arguments import check_config, check_estimator, check_source, short, shown
from gyrodrift.compensator.config import CompensatorConfig
from gyrodrift.compensator.engine import CODE_COLUMNS, FLOAT_COLUMNS
from gyrodrift.compensator.intake import Intake, optional_float
from gyrodrift.compensator.output import UNOBSERVABLE, CompensatedSample
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, HEADING, MAG_COLS, TEMP
from gyrodrift.errors import GyroDriftError
from gyrodrift.io.limits import GYRO_MAX_DPS, check_gyro_max_dps, limit_of, outside_problem
from gyrodrift.io.timebase import TimeBaseWatch, time_scale
from gyrodrift.kernels import layout as L
from gyrodrift.triad import TRIAD_COLUMNS

__all__ = ["Compensator"]

_REASONS = gating.REASONS


class Compensator:
    """Streaming compensator: feed samples in time order, get compensated rows back.

    :meth:`push` returns a list of :class:`CompensatedSample`, one row per sample from the
    first. While the initialisation window fills (``init_s``) the rows are *provisional*
    (``gate_reason`` ``init``); from its end on they are those of :func:`gyrodrift.compensate`
    on the same data, bit for bit. ``provisional=False`` holds the window's rows back and
    returns them at once when it ends (every row then equals the batch's); :meth:`flush` gives
    the rows still held when the samples end first.

    The first sample decides the x and y axes (``gyro_x_dps``, ``gyro_y_dps`` and ``acc``);
    ``scale_factor`` (a :class:`gyrodrift.scale_factor.ScaleFactorConfig`) adds the online scale
    factor (``sf``, ``sf_sd``, ``rate_sf``, ``heading_sf``; NaN without it), the default model's
    own scale factor then held exact (:meth:`CompensatorConfig.without_scale_factor`). ``gyro_max_dps``
    (deg/s) bounds the gyro as a log's rows are bounded; ``gyro_unit`` is the unit the rates
    were read in (for the gyro-unit note), ``time_unit`` that of the times pushed (``"s"``,
    ``"ms"``, ``"us"``, ``"ns"``). What each does, and what the front end of a stream leaves
    out: ``docs/streaming.md`` ("The Compensator object").

    Examples
    --------
    >>> comp = Compensator(CompensatorConfig(init_s=3.0, update_interval_s=1.0))
    >>> out = []
    >>> for i in range(500):
    ...     out += comp.push(i * 0.01, gyro_z_dps=0.2, temp_c=30.0, heading_deg=90.0)
    >>> round(out[-1].bias_z, 3), round(out[-1].heading_fused, 3)
    (0.2, 90.0)

    A noiseless gyro cannot tell stillness from a steady turn by its noise; the still compass
    tells them apart, and the gyro-alone heading holds:

    >>> round(out[-1].heading, 1)
    90.0
    """

    def __init__(self, config: CompensatorConfig | None = None, *, estimator=None, source: str = "stream",
                 scale_factor=None, gyro_max_dps: float = GYRO_MAX_DPS, provisional: bool = True,
                 time_unit: str | None = None, gyro_unit: str | None = None):
        self.config = check_config(config)
        if scale_factor is not None:  # the tracker estimates the whole scale factor
            self.config = self.config.without_scale_factor()
        check_estimator(estimator)
        self.source = source = check_source(source)
        self._gyro_max_dps = check_gyro_max_dps(gyro_max_dps)
        unit, self._time_scale = time_scale(time_unit)
        self._time_div: float | None = None  # judge_times_as: the times judged are t_s / this
        self._time_decided = False  # the Intake's time-base watch has judged all it judges
        self._limits = _limits(self._gyro_max_dps)
        # the ranges push checks plain floats against before the full check (_checked_sample)
        self._ranges = tuple(v for name in (GYRO_Z, TEMP, HEADING) for v in _range(self._limits[name]))
        # "auto" takes the temperature: a stream has no whole log to look at
        # times judged as compensate_arrays judges its own (gyrodrift.io.timebase), in their unit
        self._intake = Intake(self.config, source, estimator=estimator, gyro_unit=gyro_unit, record=False,
                              time_unit=unit or "s")
        self._provisional = bool(provisional)
        self._n_provisional = 0  # rows of the init window already emitted as provisional
        self._prev: tuple[float, float, float] | None = None  # t, gyro, temp of the last sample
        self._held_T: deque[float] = deque()  # temperature of the rows not yet output (scale factor)
        self._sf = None  # ScaleFactorTracker when a scale factor was asked for
        if scale_factor is not None:
            from gyrodrift.scale_factor import CompensatedSFSample, ScaleFactorTracker

            self._sf = ScaleFactorTracker(scale_factor, source=source)
            self._sf_sample = CompensatedSFSample

    def temperature_absent(self) -> None:
        """Say, before the first sample, that the stream has no temperature (its ``temp_c``
        will be None or NaN): with ``config.temperature = "auto"`` the drift model's ``T``
        becomes the elapsed time, as for a log whose temperature never changes
        (:func:`gyrodrift.compensator.uses_clock`). ``"measured"`` keeps a constant
        temperature (a bias); ``"clock"`` has the clock already."""
        if self._prev is not None:
            raise GyroDriftError(f"{self.source}: temperature_absent() must come before the first sample")
        self._intake.temperature_absent()

    @property
    def _engine(self):
        return self._intake.engine

    @property
    def _clock(self) -> bool:
        return self._intake.engine.regressor == "clock"

    # -- public state
    @property
    def initialised(self) -> bool:
        return self._engine.initialised

    @property
    def regressor(self) -> str:
        """What the drift model's ``T`` is: ``"temperature"`` or ``"clock"`` (the elapsed time)."""
        return self._engine.regressor

    @property
    def scale_factor(self):
        """The :class:`gyrodrift.scale_factor.ScaleFactorTracker` (its ``params``, ``cov``,
        ``n_updates``), or None without ``scale_factor``."""
        return self._sf

    @property
    def estimator(self):
        """The drift estimator (updated in place as samples come)."""
        return self._intake.estimator

    @property
    def params(self) -> np.ndarray:
        """[a (deg/s/degC), b (deg/degC), c (deg/s)] now in force."""
        return self._intake.estimator.params

    @property
    def cov(self) -> np.ndarray:
        """Covariance of :attr:`params`."""
        return self._intake.estimator.cov

    def push(self, t_s, gyro_z_dps, temp_c, heading_deg=math.nan, mag=None, acc=None, gyro_x_dps=None,
             gyro_y_dps=None):
        """Add one sample; return the rows that became available.

        Parameters
        ----------
        t_s : float
            Sample time, s, or in ``time_unit`` (strictly increasing).
        gyro_z_dps : float
            Raw heading-axis rate, deg/s (NED: positive = heading increases).
            NaN: hold the previous value (the interval is refused as ``gap``).
        temp_c : float or None
            Gyro temperature, degC (NaN: hold the previous value). With
            ``config.temperature = "clock"`` it is not used and may be None.
        heading_deg : float, optional
            Compass heading, deg clockwise from magnetic north; NaN = no sample.
        mag, acc : 3-sequences, optional
            Raw FRD magnetometer and accelerometer: the compass when ``heading_deg`` is NaN (its
            tilt gyro-aided with ``config.tilt`` ``"gyro"`` and ``gyro_x_dps``, ``gyro_y_dps`` on
            the first sample) and the field-anomaly check; ``acc`` also aids the x and y axes.
        gyro_x_dps, gyro_y_dps : float, optional
            Raw roll- and pitch-axis rates, deg/s (FRD; NaN: hold). Given with ``acc`` on
            the first sample, every row gets ``rate_x, rate_y, bias_x, bias_y`` and
            ``tilt_gated``; later samples without them hold the last values.

        Raises
        ------
        GyroDriftError
            An argument that is not a number (``mag``, ``acc``: three numbers; None where
            optional) or is outside its plausible range as a log's cell (:mod:`gyrodrift.io.limits`;
            NaN holds), naming it; a time that is not finite or does not increase, or a sample
            rate above 100 kHz. The refused sample is not taken: the compensator stays as it was.
        """
        if temp_c is None and self._clock:
            temp_c = math.nan
        g_lo, g_hi, T_lo, T_hi, h_lo, h_hi = self._ranges
        if not (type(t_s) is float and type(gyro_z_dps) is float and type(temp_c) is float
                and type(heading_deg) is float and mag is None and acc is None and gyro_x_dps is None
                and gyro_y_dps is None and (g_lo <= gyro_z_dps <= g_hi or gyro_z_dps != gyro_z_dps)
                and (T_lo <= temp_c <= T_hi or temp_c != temp_c)
                and (h_lo <= heading_deg <= h_hi or heading_deg != heading_deg)):
            # anything but the plain floats in their ranges (NaN: no value) the common sample gives
            t_s, gyro_z_dps, temp_c, heading_deg, mag, acc, gyro_x_dps, gyro_y_dps = _checked_sample(
                self.source, self._limits, t_s, gyro_z_dps, temp_c, heading_deg, mag, acc, gyro_x_dps, gyro_y_dps)
        g, T = gyro_z_dps, temp_c
        if not math.isfinite(t_s):
            raise GyroDriftError(f"{self.source}: sample time must be a finite number of seconds, got {t_s!r}")
        t_raw, t_s = t_s, t_s * self._time_scale
        if self._prev is not None and not t_s > self._prev[0]:
            raise GyroDriftError(f"{self.source}: time must increase: got t={t_s!r} after t={self._prev[0]!r}")
        intake = self._intake
        if not self._time_decided:
            self._judge_time_base(intake.time_stamp(t_raw if self._time_div is None else t_s / self._time_div))
            self._time_decided = intake.time_base.decided
        if self._prev is None:
            if self._clock and not math.isfinite(T):
                T = temp_c = 0.0  # not used by the drift model; the x/y axes and scale factor take it as constant
            if not (math.isfinite(g) and math.isfinite(T)):
                raise GyroDriftError(f"{self.source}: the first sample needs gyro_z and temp values")
        elif not math.isfinite(T):
            T = self._prev[2]
        self._prev = (t_s, g, T)
        down, rate = intake.row_body(t_s, g, acc, gyro_x_dps, gyro_y_dps)
        heading, norm, dip, tilt_diff = intake.row_compass(t_s, rate, heading_deg, mag, acc, down)
        xy, engine = intake.xy, intake.engine
        if xy is not None:
            ax = (math.nan,) * 3 if acc is None else acc
        if self._sf is not None:
            self._held_T.append(T)
        if engine._held is None:  # initialised (ChunkEngine.initialised, without the property's call): floats in, floats out
            out, codes, compass = engine.feed_row(t_s, rate, float(temp_c), heading, norm, dip, tilt_diff)
            intake.rate_z_row(out)  # the heading rate of a tilted body went in: rate_z is gyro_z - bias_z
            row = self._sample(t_s, out, codes, compass)
            if xy is not None:
                values = xy.feed_row(t_s, optional_float(gyro_x_dps), optional_float(gyro_y_dps), float(temp_c), row.temp_rate, ax,
                                     row.rate_z)
                for name, value in zip(TRIAD_COLUMNS, values):
                    object.__setattr__(row, name, value)  # the sample was made for this push and is not shared yet
            return [row]
        if xy is not None:  # the x/y inputs wait with the row in the engine's init window
            self._intake.hold_xy(t_s, optional_float(gyro_x_dps), optional_float(gyro_y_dps), float(temp_c), ax)
        cols = engine.window_row(t_s, rate, float(temp_c), heading, norm, dip, tilt_diff)
        if cols is None:
            if not self._provisional:
                return []
            self._n_provisional += 1
            row = engine.provisional()
            intake.rate_z_row(row[1], held=True)
            return [self._provisional_row(row)]
        return self._released(cols)

    def flush(self) -> list[CompensatedSample]:
        """The rows held back while the init window fills, when the samples end before it does
        (a short log, ``provisional=False``): compensated from what they give (the window ends
        at the last sample). Empty when no row is held, and with provisional rows (every
        sample already has its row; the window is still closed, so samples pushed afterwards
        come out one by one, as after a complete window).

        Raises
        ------
        GyroDriftError
            The samples were too few for their sample rate to be judged as they came, and
            it is above 100 kHz (:class:`gyrodrift.io.timebase.TimeBaseWatch`).
        """
        self._judge_time_base(self._intake.time_end())
        return self._released(self._engine.flush())

    def judge_times_as(self, time_unit: str | None) -> None:
        """Judge the times pushed (seconds) as those of a file read with ``time_unit`` that
        were converted to seconds: ``None`` for text without a stated unit, whose guesses of
        another unit (epoch or whole-number milliseconds) then apply too. ``gyrodrift stream``
        calls it for the text it reads. Before the first sample.

        Raises
        ------
        ConfigError
            An unknown unit.
        """
        if self._prev is not None:
            raise GyroDriftError(f"{self.source}: judge_times_as() must come before the first sample")
        unit, scale = time_scale(time_unit)
        self._intake.time_base = TimeBaseWatch(unit)
        self._time_div = scale

    def _judge_time_base(self, found) -> None:
        """Refuse a time base a file is refused for (the error carries what was found as
        ``time_base``)."""
        if found is not None:
            error = GyroDriftError(f"{self.source}: t_s: {found.problem}; {found.advice}")
            error.time_base = found
            raise error

    @property
    def compass_dead(self) -> bool:
        """True when magnetometer samples came, none read a field and no heading was given:
        the stream has no compass (:class:`gyrodrift.compass.DeadField`)."""
        return self._intake.compass_dead

    @property
    def notes(self) -> list[str]:
        """What could not be learned or was done instead (one-line sentences)."""
        return self._intake.notes

    def _released(self, cols: dict | None) -> list[CompensatedSample]:
        """The rows of the engine's output columns, less those already emitted as provisional
        (the x/y axes and the scale factor still take every row, in order)."""
        skip, self._n_provisional = self._n_provisional, 0
        if cols is None or not skip:
            return self._rows(cols)
        if self._intake.xy is None and self._sf is None:  # only the rows not yet out are made
            return self._rows({k: v[skip:] for k, v in cols.items()})
        return self._rows(cols)[skip:]

    def _provisional_row(self, row: tuple) -> CompensatedSample:
        """The provisional row of a sample of the init window (:meth:`ChunkEngine.provisional`):
        heading axis only, the x/y and scale-factor fields NaN."""
        if self._sf is None:
            return _new_sample(*row)
        return self._sf_sample(*self._values(*row))

    def _rows(self, cols: dict | None) -> list[CompensatedSample]:
        """The samples of the engine's output columns (none for None)."""
        cols = self._intake.with_xy(cols)
        rows = [self._sample(*row) for row in _engine_rows(cols)]
        if cols is None or self._intake.xy is None:
            return rows
        return [replace(r, rate_x=float(cols["rate_x"][i]), rate_y=float(cols["rate_y"][i]),
                        bias_x=float(cols["bias_x"][i]), bias_y=float(cols["bias_y"][i]),
                        tilt_gated=int(cols["tilt_gated"][i])) for i, r in enumerate(rows)]

    def _sample(self, t: float, out, codes, compass: float) -> CompensatedSample:
        """One output row from the engine's float outputs and codes (layout order)."""
        if self._sf is None:
            return _new_sample(t, out, codes, compass)
        values = self._values(t, out, codes, compass)
        sf = self._sf.push(t, out[L.O_RATE], self._held_T.popleft(), compass, values[9])
        return self._sf_sample(*values, sf=sf.sf, sf_sd=sf.sf_sd, rate_sf=sf.rate_sf, heading_sf=sf.heading_sf)

    @staticmethod
    def _values(t: float, out, codes, compass: float) -> tuple:
        """The fields of :class:`CompensatedSample` from the engine's float outputs and codes."""
        return tuple(vars(_new_sample(t, out, codes, compass)).values())


def _engine_rows(cols: dict | None):
    """(t, float outputs, codes, compass heading) of each row of the engine's output columns
    (none for None), the outputs and codes in the order of :mod:`gyrodrift.kernels.layout`."""
    if cols is None:
        return ()
    return zip(cols["t"].tolist(), zip(*(cols[k].tolist() for k in FLOAT_COLUMNS)),
               zip(*(cols[k].tolist() for k in CODE_COLUMNS)), cols["compass_heading"].tolist())


def _new_sample(t: float, out, codes, compass: float, new=object.__new__, cls=CompensatedSample,
                setattr=object.__setattr__, reasons=_REASONS, unobservable=UNOBSERVABLE, O_RATE=L.O_RATE,
                O_BIAS=L.O_BIAS, O_HEADING=L.O_HEADING, O_A=L.O_A, O_B=L.O_B, O_C=L.O_C, O_TEMP_RATE=L.O_TEMP_RATE,
                O_BIAS_SD=L.O_BIAS_SD, O_FUSED=L.O_FUSED, O_FUSED_SD=L.O_FUSED_SD, O_HEADING_SD=L.O_HEADING_SD,
                OC_UPDATE=L.OC_UPDATE, OC_REASON=L.OC_REASON, OC_UNOBS=L.OC_UNOBS) -> CompensatedSample:
    """``CompensatedSample(*Compensator._values(t, out, codes, compass))`` made without the
    frozen dataclass's ``__init__`` (one ``object.__setattr__`` per field) and without the
    tuple: its fields set at once (the layout's indices bound as defaults). The same sample
    (fields, ``==``, ``repr``, ``asdict``); the fields left out are read from their class
    defaults until set."""
    reason = reasons[codes[OC_REASON]]
    sample = new(cls)
    setattr(sample, "__dict__", {
        "t": t, "rate_z": out[O_RATE], "bias_z": out[O_BIAS], "heading": out[O_HEADING], "a": out[O_A],
        "b": out[O_B], "c": out[O_C], "updated": codes[OC_UPDATE], "gated": int(reason != ""),
        "gate_reason": reason, "temp_rate": out[O_TEMP_RATE], "compass_heading": compass,
        "unobservable": unobservable[codes[OC_UNOBS]], "bias_sd": out[O_BIAS_SD], "heading_fused": out[O_FUSED],
        "heading_fused_sd": out[O_FUSED_SD], "heading_sd": out[O_HEADING_SD]})
    return sample


def _limits(gyro_max_dps: float) -> dict:
    """The plausible range of every checked input column (:mod:`gyrodrift.io.limits`), by name,
    and the three ranges of ``MAG_COLS`` and of ``ACC_COLS`` (:func:`_range`) under those tuples."""
    names = ("", GYRO_Z, TEMP, HEADING, GYRO_X, GYRO_Y, *MAG_COLS, *ACC_COLS)
    limits = {name: limit_of(name, gyro_max_dps) for name in names}
    for columns in (MAG_COLS, ACC_COLS):  # a triple's three ranges, for _triple's common case
        limits[columns] = tuple(_range(limits[c]) for c in columns)
    return limits


def _range(limit) -> tuple[float, float]:
    """The plausible range of a :func:`_limits` entry (any float without one)."""
    return (-math.inf, math.inf) if limit is None else (limit.lo, limit.hi)


def _number(source: str, arg: str, value, column: str, limits: dict) -> float:
    """``value`` as a float within the plausible range of ``column`` (``limits`` from
    :func:`_limits`; NaN passes), or a :class:`GyroDriftError` naming the argument ``arg``."""
    if isinstance(value, float):  # the common case (numpy's float64 too), without the generic checks
        x = float(value)
    elif isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise GyroDriftError(f"{source}: {arg} must be a number, got {shown(value)}")
    else:
        try:
            x = float(value)
        except (OverflowError, ValueError):
            raise GyroDriftError(f"{source}: {arg} = {short(value)} is not a float (too large)") from None
    limit = limits[column]
    if limit is not None and not limit.lo <= x <= limit.hi and not math.isnan(x):
        raise GyroDriftError(f"{source}: {arg}: {outside_problem(column, x, limit)}; {limit.advice}")
    return x


def _triple(source: str, arg: str, value, columns: tuple[str, ...], limits: dict) -> tuple | None:
    """``mag`` or ``acc``: None, or three checked floats."""
    if value is None:
        return None
    if type(value) in (tuple, list) and len(value) == 3:  # the common sample: three floats in range (NaN: none)
        x, y, z = value
        if isinstance(x, float) and isinstance(y, float) and isinstance(z, float):  # numpy's float64 too
            x, y, z = float(x), float(y), float(z)
            (xlo, xhi), (ylo, yhi), (zlo, zhi) = limits[columns]
            if (xlo <= x <= xhi or x != x) and (ylo <= y <= yhi or y != y) and (zlo <= z <= zhi or z != z):
                return x, y, z
    try:
        items = list(value) if not isinstance(value, (str, bytes)) else None
    except TypeError:
        items = None
    if items is None or len(items) != 3:
        raise GyroDriftError(f"{source}: {arg} must be three numbers (x, y, z) or None, got {short(value)}")
    return tuple(_number(source, f"{arg}[{k}]", v, c, limits) for k, (v, c) in enumerate(zip(items, columns)))


def _checked_sample(source: str, limits: dict, t_s, gyro_z_dps, temp_c, heading_deg, mag, acc, gyro_x_dps,
                    gyro_y_dps) -> tuple:
    """The arguments of :meth:`Compensator.push` checked and as floats (``heading_deg``
    None: NaN; ``mag``, ``acc``, ``gyro_x_dps``, ``gyro_y_dps`` stay None when None);
    ``limits`` from :func:`_limits`."""
    return (
        _number(source, "t_s", t_s, "", limits),
        _number(source, "gyro_z_dps", gyro_z_dps, GYRO_Z, limits),
        _number(source, "temp_c", temp_c, TEMP, limits),
        math.nan if heading_deg is None else _number(source, "heading_deg", heading_deg, HEADING, limits),
        None if mag is None else _triple(source, "mag", mag, MAG_COLS, limits),
        None if acc is None else _triple(source, "acc", acc, ACC_COLS, limits),
        None if gyro_x_dps is None else _number(source, "gyro_x_dps", gyro_x_dps, GYRO_X, limits),
        None if gyro_y_dps is None else _number(source, "gyro_y_dps", gyro_y_dps, GYRO_Y, limits),
    )

"""The front end of every entry point, written once (:class:`Intake`): dead magnetometer samples,
the gyro-aided tilt and the heading rate of a tilted body, the tilt and calibration of a raw
compass, the compass columns, the engine, the x and y axes, the gyro-unit check, the time base of
rows that come one by one, and the notes. Its stages and
:class:`WholeLog`: ``docs/engine.md`` ("The front end").
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import pandas as pd

from gyrodrift.attitude import GravityFilter, RawTilt, accel_down, propagate
from gyrodrift.compass import DeadField, compass_columns
from gyrodrift.compensator.config import build_estimator, clock_config, uses_clock, with_declination
from gyrodrift.compensator.engine import compiled
from gyrodrift.compensator.model_engine import make_engine
from gyrodrift.compensator.output import output_frame
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, HEADING, MAG_COLS, TEMP, T
from gyrodrift.gyro_units import GyroUnitCheck
from gyrodrift.io.timebase import TimeBase, TimeBaseWatch
from gyrodrift.kernels import layout as L
from gyrodrift.kernels.compass import row as compass_row
from gyrodrift.kernels.integrate import trapezoid
from gyrodrift.magcal import MagSamples, uncalibrated_note
from gyrodrift.triad import TRIAD_COLUMNS

__all__ = ["Intake", "WholeLog", "MagFit", "survey", "needs_survey", "chunk_arrays", "optional_float"]

#: Rows taken one by one (:meth:`Intake.row_compass`) given to the gyro-unit check at a time.
UNIT_ROWS = 4096


@dataclass(frozen=True)
class WholeLog:
    """What the front end takes from the whole log before its first row: whether its
    temperature never changes (None: not known), its magnetometer calibration (None: not
    fitted), its rows (None: not counted) and the declination its autopilot used (None:
    not known)."""

    temp_flat: bool | None = None
    magcal: object = None
    rows: int | None = None
    declination: tuple[float, str] | None = None  # the autopilot's, deg east, and its parameter


def chunk_arrays(log) -> tuple:
    """The arguments of :meth:`Intake.feed` from a chunk of a log (a DataFrame in the input
    contract): ``t, gyro_z, temp`` and, None where the chunk lacks them, ``heading``, the
    magnetometer, the accelerometer and ``gyro_x, gyro_y``."""
    def get(names):
        return log[list(names)].to_numpy(float) if set(names) <= set(log.columns) else None

    return (log[T].to_numpy(float), log[GYRO_Z].to_numpy(float), log[TEMP].to_numpy(float),
            log[HEADING].to_numpy(float) if HEADING in log.columns else None, get(MAG_COLS), get(ACC_COLS),
            get((GYRO_X, GYRO_Y)))


def needs_survey(config, first) -> bool:
    """Whether a log read in chunks must be read once before it is compensated, decided on
    its ``first`` chunk (a DataFrame): for the magnetometer calibration of a raw compass, or
    when ``temperature="auto"`` would take the clock for the first chunk's temperature alone."""
    if config.mag_calibration and all(c in first.columns for c in (*MAG_COLS, *ACC_COLS)):
        return True
    return config.temperature == "auto" and uses_clock(config, first[TEMP].to_numpy(float))


class MagFit:
    """The magnetometer calibration of a whole log (:func:`gyrodrift.magcal.fit`), its rows
    added in order (:meth:`add`) with the tilt :class:`Intake` uses and, where the log has
    ``gyro_x``, ``gyro_y`` and that tilt is the accelerometer's, also with the gyro-aided
    gravity: the fit uses the one whose calibrated field is the more constant in the world
    (:func:`gyrodrift.magcal.inconsistency`; ``docs/heading_and_axes.md``, magnetometer
    calibration)."""

    def __init__(self, config, source: str):
        from gyrodrift import magcal

        self.config, self.source = config, source
        self.samples = magcal.MagSamples()
        self.by_gravity: magcal.MagSamples | None = None  # the same rows with the gyro-aided gravity's down
        self.tilt: RawTilt | None = None
        self._gravity: GravityFilter | None = None  # the gyro-aided gravity, with gyro_x, gyro_y
        self._last: tuple[float, float, float] | None = None  # time, gyro and its integral at the last row

    def add(self, t, g, mag, acc, gyro_xy=None) -> None:
        """Rows with a raw compass, in order (with the raw gyro's trapezoid integral to each,
        carried across chunks; an empty gyro cell holds the last value)."""
        if self.tilt is None:
            from gyrodrift import magcal

            self.tilt = RawTilt(self.config.tilt, gyro_xy is not None, self.source)
            self._gravity = GravityFilter() if self.tilt.gyro_xy else None
            if self.tilt.gyro_xy and not self.tilt.uses_gyro:
                self.by_gravity = magcal.MagSamples()
        down = gravity = None
        if self._gravity is not None:
            gxy = np.asarray(gyro_xy, dtype=float)
            gravity = self._gravity.feed(t, gxy[:, 0], gxy[:, 1], g, acc)
            down = gravity if self.tilt.uses_gyro else None
        t = np.asarray(t, dtype=float)
        turned = np.zeros(0)
        if t.size:  # empty cells held from the last finite value (the last chunk's, or 0 before any)
            g = pd.Series(np.asarray(g, dtype=float)).ffill().fillna(0.0 if self._last is None else self._last[1])
            g = g.to_numpy()
            if self._last is None:
                turned = trapezoid(t, g)
            else:
                turned = self._last[2] + trapezoid(np.r_[self._last[0], t], np.r_[self._last[1], g])[1:]
            self._last = (float(t[-1]), float(g[-1]), float(turned[-1]))
        mag = DeadField().mask(mag)
        self.samples.add(mag, accel_down(acc) if down is None else down, t, turned)
        if self.by_gravity is not None:
            self.by_gravity.add(mag, gravity, t, turned)

    def fit(self):
        """The :class:`gyrodrift.magcal.MagCalibration` to apply (with ``mag_calibration =
        "auto"``, one only where the magnetometer looks uncalibrated), or None when no row was added."""
        from gyrodrift import magcal

        if self.tilt is None:
            return None
        samples, tilt = self.samples, None
        fitted = magcal.fit(*samples.arrays())  # each sample set fitted once
        if self.by_gravity is not None:
            by_gravity = magcal.fit(*self.by_gravity.arrays())
            if magcal.inconsistency(self.by_gravity, by_gravity) < magcal.inconsistency(samples, fitted):
                samples, fitted, tilt = self.by_gravity, by_gravity, "the gyro-aided gravity's tilt"
        cal = magcal.auto_calibration(samples, fitted) if self.config.mag_calibration == "auto" else fitted
        return cal if tilt is None or not cal.ok else dataclasses.replace(cal, tilt=tilt)


def survey(chunks, config, source: str) -> WholeLog:
    """One reading of a whole log in chunks (DataFrames) for what :class:`WholeLog` holds:
    the magnetometer calibration when ``config.mag_calibration`` asks for it and whether the
    temperature changes."""
    fit = MagFit(config, source) if config.mag_calibration else None
    temp_lo, temp_hi, rows = math.inf, -math.inf, 0
    for log in chunks:
        rows += len(log)
        temp = log[TEMP].to_numpy(float)
        temp = temp[np.isfinite(temp)]
        if temp.size:
            temp_lo, temp_hi = min(temp_lo, float(temp.min())), max(temp_hi, float(temp.max()))
        if fit is None and temp_lo < temp_hi:  # all that was needed is known
            return WholeLog(temp_flat=False)
        t, g, _, _, mag, acc, gyro_xy = chunk_arrays(log)
        if fit is not None and mag is not None and acc is not None:
            fit.add(t, g, mag, acc, gyro_xy)
    return WholeLog(temp_flat=not temp_lo < temp_hi, magcal=None if fit is None else fit.fit(), rows=rows)


class Intake:
    """The front end of one log (``docs/engine.md``): chunks (:meth:`feed`) or rows (:meth:`row_compass`).

    Parameters
    ----------
    config : CompensatorConfig
    source : str
        Name for notes and error messages.
    estimator : DriftEstimator, optional
        A fresh estimator to use instead of one built from ``config``.
    whole : WholeLog, optional
    gyro_unit : str, optional
        The unit the gyro was read in, for the unit check's advice.
    record : bool
        Keep the default engine's epoch history (for the smoother).
    time_unit : str or None
        The canonical unit of the time stamps given to :meth:`time_stamp` (None: seconds,
        not stated), as for a file.

    Attributes
    ----------
    engine, estimator
        The engine (built once) and its estimator.
    xy : TriadCompensator or None
        The x and y axes, once the first rows had their inputs.
    """

    def __init__(self, config, source: str = "log", *, estimator=None, whole: WholeLog | None = None,
                 gyro_unit: str | None = None, record: bool = True, time_unit: str | None = "s"):
        whole = whole or WholeLog()
        self.config = with_declination(config, whole.declination)
        self._declination_note = None if config.declination_deg is not None or whole.declination is None else (
            f"{source}: the compass is turned to true north, like the autopilot's heading, by the declination it "
            f"used, {whole.declination[0]:+.2f} deg ({whole.declination[1]}); --declination 0 keeps magnetic north")
        self.source = source
        self._cal = whole.magcal
        self._given = estimator
        self._record = record
        self._tilt: RawTilt | None = None
        self._raw_seen = False  # a raw compass sample came: the tilt note (and the stream's calibration note)
        self._dead = DeadField()
        # a raw compass's samples, for the note of a magnetometer that needs calibrating
        # (none where the whole log's fit decided: mag_calibration true, or "auto" in a batch run)
        self._survey = None if config.mag_calibration is True or self._cal is not None else MagSamples()
        self._survey_rows: list[tuple] = []  # rows taken one by one, not yet in the survey
        self._survey_note: tuple[int, str | None] | None = None  # (samples seen, note) once judged
        self._heading_seen = False  # a heading with a value: a compass even when the magnetometer is dead
        self.units = GyroUnitCheck(source, gyro_unit)
        self._unit_rows: list[tuple] = []  # (t, gyro, heading) of rows not yet given to the unit check
        self.time_base = TimeBaseWatch(time_unit)
        self._time_note: str | None = None
        self._time_ended = False
        self.xy = None
        self._xy_decided = False
        self._xy_in: deque = deque()  # x/y inputs of the rows not yet out of the engine
        self._gravity: GravityFilter | None = None  # the gyro-aided tilt (first rows with gyro_x, gyro_y)
        self._gravity_row = None  # rows taken one by one: the filter's kernel and its one-row arrays
        self._rate_from_tilt = False  # the engine takes the heading rate of the tilted body, not gyro_z
        self._added: deque = deque()  # what the heading rate added to gyro_z, rows not yet out of the engine
        self._last_added = 0.0  # ... on the last row with a finite gyro_z (a NaN row holds it, as the engine does)
        self._start(uses_clock(config, whole.temp_flat))

    def _start(self, clock: bool) -> None:
        """The estimator (unless one was given) and the engine, its ``T`` the elapsed time or not."""
        cfg = clock_config(self.config) if clock else self.config
        self.estimator = self._given if self._given is not None else build_estimator(cfg)
        self.engine = make_engine(cfg, self.estimator, self.source, clock=clock, record=self._record)

    def temperature_absent(self) -> None:
        """The log has no temperature: with ``temperature="auto"`` the drift model's ``T``
        becomes the elapsed time (before the first row)."""
        if self.engine.regressor == "temperature" and self.config.temperature == "auto":
            self._start(True)

    @property
    def compass_dead(self) -> bool:
        """True when magnetometer samples came, none read a field and no heading was given."""
        return self._dead.none_usable() and not self._heading_seen

    @property
    def notes(self) -> list[str]:
        """What the front end and the engine could not learn or did instead (one-line sentences)."""
        raw = []
        if self._raw_seen:
            raw.append(self._tilt.note())
            mode = self.config.mag_calibration
            if mode is True:  # no calibration without the whole log: a stream has none
                raw.append(self._cal.note(self.source) if self._cal is not None else f"{self.source}: magnetometer "
                           "not calibrated: a stream does not see the whole log the fit needs (mag_calibration)")
            elif self._cal is not None:  # "auto" over the whole log: a note where it calibrated
                raw.append(self._cal.note(self.source) if self._cal.ok else None)
            else:  # off, or "auto" in a stream
                raw.append(self._uncalibrated())
        self._check_unit_rows()
        return [*filter(None, [self._time_note, self._dead.note(self.source, self._heading_seen), self._declination_note,
                               self._heading_rate_note()]),
                *filter(None, raw),
                *self.engine.notes,
                *filter(None, [self.units.note()])]

    def _heading_rate_note(self) -> str | None:
        """What the heading integrates, where the log has the x/y gyros (``heading_rate = "auto"``)."""
        if not self._rate_from_tilt:
            return None
        if self._gravity.accepted_s > 0.0:
            return (f"{self.source}: the heading integrates the rate of the tilted body's heading (gyro_y, gyro_z and "
                    "the gyro-aided tilt), taken in as the x/y gyros' offsets were learned; heading_rate = 'gyro_z' "
                    "integrates gyro_z alone")
        return (f"{self.source}: the heading integrates gyro_z alone: the x/y gyros' offsets were never learned (the "
                "accelerometer was never taken along the tilt), so the tilt is not known well enough")

    # ------------------------------------------------------------------ chunks
    def compass(self, t, heading=None, mag=None, acc=None, down=None):
        """Heading (deg, NaN = no sample), field strength and dip (None without a raw
        compass) and the difference of its two tilts' headings (:func:`tilt_difference`;
        None without the gyro-aided gravity) of these rows: the stages before the engine
        (``docs/engine.md``, "The front end"). ``down``: the gyro-aided gravity of these
        rows (:meth:`body`), the raw compass's tilt with ``config.tilt`` ``"gyro"``."""
        n = len(t)
        if heading is not None and not self._heading_seen:
            self._heading_seen = bool(np.isfinite(heading).any())
        if mag is None or acc is None:  # the engine wraps the heading itself
            return (np.full(n, np.nan) if heading is None else np.asarray(heading, dtype=float)), None, None, None
        mag = self._dead.mask(mag)
        self._raw_seen = True
        if self._tilt is None:
            self._tilt = RawTilt(self.config.tilt, self._gravity is not None, self.source)
        gravity = down
        down = down if self._tilt.uses_gyro else None
        if self._survey is not None:
            self._survey.add(mag, accel_down(acc) if down is None else down)
        if self.config.mag_calibration and self._cal is not None:
            mag = self._cal.apply(mag)
        given = None if heading is None else np.isfinite(heading)
        heading, norm, dip = compass_columns(n, heading, mag, acc, down)
        tilt_diff = None
        if gravity is not None:  # the heading by the other tilt; a heading given has no tilt known
            other = compass_columns(n, None, mag, acc, gravity if down is None else None)[0]
            tilt_diff = tilt_difference(heading, other) if down is None else tilt_difference(other, heading)
            if given is not None:
                tilt_diff[given] = math.nan
        return heading, norm, dip, tilt_diff

    def body(self, t, g, acc=None, gyro_xy=None) -> tuple[np.ndarray | None, np.ndarray]:
        """The gyro-aided gravity (n, 3; None without the filter) and the heading rate (deg/s)
        of these rows: ``g`` itself unless :attr:`config` ``heading_rate`` is ``"auto"`` and the
        first rows had ``gyro_xy`` and ``acc`` (:func:`gyrodrift.attitude.propagate`). The
        first rows decide (:meth:`_decide_body`)."""
        if not self._xy_decided:
            self._decide_body(gyro_xy is not None, acc is not None)
        if self._gravity is None:
            return None, g
        n = len(t)
        gxy = np.full((n, 2), np.nan) if gyro_xy is None else np.asarray(gyro_xy, dtype=float)
        down, rate = self._gravity.run(t, gxy[:, 0], gxy[:, 1], g, np.full((n, 3), np.nan) if acc is None else acc)
        if not self._rate_from_tilt:
            return down, g
        added = rate - np.asarray(g, dtype=float)
        held = ~np.isfinite(added)
        if held.any():  # NaN gyro_z: the engine holds the rate, and rate_z keeps the last row's addition
            added = pd.Series(np.where(held, np.nan, added)).ffill().fillna(self._last_added).to_numpy()
        if n:
            self._last_added = float(added[-1])
        self._added.append((added,))
        return down, rate

    def feed(self, t, g, T, heading=None, mag=None, acc=None, gyro_xy=None, buffers=None) -> dict | None:
        """Add rows (a whole log or a chunk); return the output columns of the rows that
        became available (:meth:`ChunkEngine.feed`, with the x/y columns when the first rows
        had ``gyro_xy`` and ``acc``), or None while the init window fills.

        ``t, g, T, heading``: (n,) arrays; ``mag``, ``acc``: (n, 3) raw FRD magnetometer and
        accelerometer (the compass when both are given; ``acc`` the x/y axes' tilt);
        ``gyro_xy``: (n, 2) raw ``gyro_x``, ``gyro_y``. The engine takes the heading rate of
        :meth:`body`; ``rate_z`` comes out as ``gyro_z - bias_z`` (:meth:`with_xy`)."""
        down, rate = self.body(t, g, acc, gyro_xy)
        heading, norm, dip, tilt_diff = self.compass(t, heading, mag, acc, down)
        if self.xy is not None:
            gxy = np.asarray(gyro_xy, dtype=float)
            self._xy_in.append((np.asarray(t, dtype=float), gxy[:, 0], gxy[:, 1], np.asarray(T, dtype=float),
                                np.asarray(acc, dtype=float)))
        cols = self.engine.feed(t, rate, T, heading, norm, dip, tilt_diff, buffers)
        self.units.add(t, rate, heading)  # on times the engine took (finite, increasing)
        return self.with_xy(cols)

    def flush(self) -> dict | None:
        """The rows still held when the log ends inside the init window (:meth:`ChunkEngine.flush`)."""
        return self.with_xy(self.engine.flush())

    def _decide_body(self, gyro_xy: bool, acc: bool) -> None:
        """Decided on the first rows: the x/y axes when they have ``gyro_x``, ``gyro_y`` and the
        accelerometer; the gyro-aided gravity when they have the x/y gyros and the accelerometer
        or the raw compass's tilt asks for it; the heading rate from it with ``heading_rate``
        ``"auto"``."""
        self._xy_decided = True
        if gyro_xy and acc:
            from gyrodrift.triad import TriadCompensator

            self.xy = TriadCompensator(self.config)
        if gyro_xy and (acc or self.config.tilt == "gyro"):
            self._gravity = GravityFilter()
            self._rate_from_tilt = self.config.heading_rate == "auto"

    def row_body(self, t: float, g: float, acc, gx, gy) -> tuple[tuple | None, float]:
        """:meth:`body` of one row (floats; ``acc`` a triple or None, ``gx``, ``gy`` floats or
        None): the gyro-aided gravity (a triple, or None) and the heading rate."""
        if not self._xy_decided:
            self._decide_body(gx is not None and gy is not None, acc is not None)
        if self._gravity is None:
            return None, g
        r = self._gravity_row
        if r is None:  # one-row arrays; the first row runs through numba's dispatcher
            r = self._gravity_row = [propagate, (np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros((1, 3)),
                                                 self._gravity.state, np.zeros((1, 3)), np.zeros(1))]
        fn, args = r
        args[0][0], args[1][0], args[2][0], args[3][0] = t, optional_float(gx), optional_float(gy), g
        args[4][0] = math.nan if acc is None else acc
        fn(*args)
        if fn is propagate:  # then the compiled function for these arrays (engine.compiled)
            r[0] = compiled(propagate, args)
        down = args[6][0]
        if not self._rate_from_tilt:
            return down, g
        rate = float(args[7][0])
        if math.isfinite(rate - g):
            self._last_added = rate - g
        self._added.append((np.array([self._last_added]),))
        return down, rate

    def hold_xy(self, t: float, gx: float, gy: float, T: float, acc) -> None:
        """Keep the x/y inputs of one row until the engine gives it back (:meth:`with_xy`)."""
        self._xy_in.append((np.array([t]), np.array([gx]), np.array([gy]), np.array([T]), np.array([acc], dtype=float)))

    @property
    def rate_from_tilt(self) -> bool:
        """The engine takes the heading rate of a tilted body (:meth:`body`), not gyro_z."""
        return self._rate_from_tilt

    def rate_z_row(self, out: list, held: bool = False) -> None:
        """``rate_z`` of one row's outputs (a list in the order of :mod:`gyrodrift.kernels.layout`,
        in place) less what the heading rate added to gyro_z: of the next row out of the
        engine, or with ``held`` of the last row taken (a provisional row). Nothing unless
        :attr:`rate_from_tilt`."""
        if self._rate_from_tilt:
            out[L.O_RATE] -= self._last_added if held else float(_take(self._added, 1)[0][0])

    def with_xy(self, cols: dict | None) -> dict | None:
        """``cols`` with ``rate_z`` less what the heading rate added to gyro_z (in place:
        ``gyro_z - bias_z``) and the x/y columns of its rows (the inputs held since they came in)."""
        if cols is None:
            return cols
        if self._rate_from_tilt:
            cols["rate_z"] -= _take(self._added, len(cols["t"]))[0]
        if self.xy is None:
            return cols
        t, gx, gy, T, acc = _take(self._xy_in, len(cols["t"]))
        return {**cols, **self.xy.feed(t, gx, gy, T, cols["temp_rate"], acc, cols["rate_z"])}

    @staticmethod
    def frame(cols: dict, gated=None):
        """The output table of :meth:`feed`'s columns (:func:`output_frame`, then the x/y columns)."""
        out = output_frame(cols, gated)
        for name in TRIAD_COLUMNS:
            if name in cols:
                out[name] = cols[name]
        return out

    # ------------------------------------------------------------------ rows
    def time_stamp(self, t_raw: float) -> TimeBase | None:
        """Judge the time base with the next time stamp (in :attr:`time_base`'s unit) until it
        is decided: returns what is found when the time stamps cannot be in that unit (the
        caller refuses the row; the stamp is not taken), else None; a note of a low sample
        rate goes to :attr:`notes`."""
        return self._time_found(self.time_base.add(t_raw))

    def time_end(self) -> TimeBase | None:
        """At the end of the rows: :meth:`time_stamp`'s judgement of rows too few to be judged
        as they came (once: None when called again)."""
        if self._time_ended:
            return None
        self._time_ended = True
        return self._time_found(self.time_base.end())

    def _time_found(self, found: TimeBase | None) -> TimeBase | None:
        if found is not None and not found.problem:
            self._time_note = f"{self.source}: {found.note}"
            return None
        return found

    def row_compass(self, t: float, rate: float, heading: float, mag, acc,
                    down) -> tuple[float, float, float, float]:
        """Heading, field strength, dip and the two tilts' difference (:func:`tilt_difference`)
        of one row (floats; ``mag``, ``acc`` triples or None; ``rate`` and ``down`` from
        :meth:`row_body`, which comes first): the stages of
        :meth:`compass`, without the calibration (a stream does not see the whole log). The
        row goes to the gyro-unit check as :meth:`feed`'s rows do (:data:`UNIT_ROWS` at a time,
        and the rest before :attr:`notes`): the row must be one the engine takes."""
        compass = self._row_compass(heading, mag, acc, down)
        rows = self._unit_rows
        rows.append((t, rate, compass[0]))
        if len(rows) >= UNIT_ROWS:
            self._check_unit_rows()
        return compass

    def _check_unit_rows(self) -> None:
        """The rows taken one by one since the last call, to the gyro-unit check (in order)."""
        if self._unit_rows:
            t, g, heading = (np.array(v, dtype=float) for v in zip(*self._unit_rows))
            self._unit_rows = []
            self.units.add(t, g, heading)

    def _survey_flush(self) -> None:
        """The raw compass rows taken one by one since the last call, to the survey (in order)."""
        if self._survey_rows:
            rows = np.array(self._survey_rows, dtype=float)
            self._survey_rows = []
            down = rows[:, 3:6]
            accel = rows[:, 6] == 0.0
            down[accel] = accel_down(down[accel])
            self._survey.add(rows[:, :3], down)

    def _uncalibrated(self) -> str | None:
        """The note of a magnetometer that needs calibrating (:func:`gyrodrift.magcal.uncalibrated_note`),
        judged again only when more samples came."""
        self._survey_flush()
        if self._survey_note is None or self._survey_note[0] != self._survey.seen:
            mode = "auto" if self.config.mag_calibration == "auto" else False
            self._survey_note = (self._survey.seen, uncalibrated_note(self._survey, self.source, mode))
        return self._survey_note[1]

    def _row_compass(self, heading, mag, acc, down) -> tuple[float, float, float, float]:
        if self._tilt is None:
            self._tilt = RawTilt(self.config.tilt, self._gravity is not None, self.source)
        gravity = down
        if not self._tilt.uses_gyro:
            down = None
        if mag is not None and acc is not None:
            self._raw_seen = True
        if mag is not None and not self._dead.sample(*mag):
            mag = None  # a sample without a field is no compass sample
        self._heading_seen = self._heading_seen or math.isfinite(heading)
        if mag is None or (acc is None and down is None):
            return heading, math.nan, math.nan, math.nan
        mx, my, mz = mag
        fx, fy, fz = acc if down is None else (-down[0], -down[1], -down[2])
        if not math.isfinite(mx + my + mz + fx + fy + fz):  # each at most 1e8: a sum overflows only with an inf
            return heading, math.nan, math.nan, math.nan
        if self._survey is not None and acc is not None:  # as the chunks' rows (compass() needs acc)
            # the accelerometer's down vector is taken at the flush, over many rows at once
            self._survey_rows.append((mx, my, mz, *(acc if down is None else down), 0.0 if down is None else 1.0))
            if len(self._survey_rows) >= UNIT_ROWS:
                self._survey_flush()
        from_mag, norm, dip = compass_row(float(mx), float(my), float(mz), float(fx), float(fy), float(fz))
        if math.isfinite(heading):  # a heading given is the compass, and its tilt is not known
            return heading, norm, dip, math.nan
        tilt_diff = math.nan
        if gravity is not None and acc is not None:  # as tilt_difference: the other tilt's heading
            gx, gy, gz = acc if down is not None else (-gravity[0], -gravity[1], -gravity[2])
            other = compass_row(float(mx), float(my), float(mz), float(gx), float(gy), float(gz))[0]
            diff = (from_mag - other if down is None else other - from_mag) + 180.0
            tilt_diff = diff % 360.0 - 180.0
        return from_mag, norm, dip, tilt_diff


def _take(queue: deque, n: int) -> tuple:
    """The next ``n`` rows of a queue of tuples of arrays (one tuple per chunk), joined."""
    parts = []
    while n:
        part = queue.popleft()
        if len(part[0]) > n:  # the rest of this chunk comes out later
            queue.appendleft(tuple(v[n:] for v in part))
            part = tuple(v[:n] for v in part)
        parts.append(part)
        n -= len(part[0])
    return tuple(np.concatenate(v) if len(parts) > 1 else v[0] for v in zip(*parts))


def tilt_difference(by_acc, by_gravity):
    """The difference (deg, within ±180) of a raw compass sample's headings (deg) tilted by the
    accelerometer and by the gyro-aided gravity: the size of its tilt error. Where the two
    agree the tilt is known; where one of them errs (the specific force of a banked turn, of
    braking and cornering, or a gravity the gyro has not yet learned) the heading errs by about
    their difference, and which one is right the pair alone cannot say (``docs/model.md``,
    "The compass's tilt"). NaN where either is missing."""
    diff = np.asarray(by_acc, dtype=float) - np.asarray(by_gravity, dtype=float)
    with np.errstate(invalid="ignore"):
        return (diff + 180.0) % 360.0 - 180.0


def optional_float(v) -> float:
    """A float from an optional number (None: NaN)."""
    return math.nan if v is None else float(v)

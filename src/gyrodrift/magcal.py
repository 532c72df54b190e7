"""Hard- and soft-iron calibration of a raw magnetometer from the log itself, when it turns enough.

``m_cal = s ⊙ (m - o)`` fitted so that ``|m_cal|`` and its vertical part are constant; used only
when the headings cover enough and the fit is good, and by default (``mag_calibration =
"auto"``) only where the magnetometer looks uncalibrated (:func:`looks_uncalibrated`). Not
causal. The model and the acceptance: ``docs/heading_and_axes.md`` (magnetometer calibration).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "MIN_COVERAGE_DEG", "MAX_RESIDUAL", "MAX_SCALE_RATIO", "MIN_TILT_SPREAD_DEG", "UNCALIBRATED_DEG", "MagCalibration",
    "MagSamples", "Uncalibrated", "fit", "looks_uncalibrated", "uncalibrated_note", "auto_calibration", "ADVICE",
    "LOOKS_CALIBRATED", "AGREE_WINDOW_S", "AGREE_RATIO", "turn_error_deg", "agrees_better", "inconsistency",
]

#: Least heading coverage of the calibrated field for the fit to be used, deg.
MIN_COVERAGE_DEG = 270.0
#: Largest relative RMS residual of |m_cal| = F for the fit to be used.
MAX_RESIDUAL = 0.05
#: Below this spread of the down vector (largest angle from its mean, deg) the log is taken
#: as level: o_z and s_z are not fitted (kept 0 and 1).
MIN_TILT_SPREAD_DEG = 15.0
#: Largest plausible ratio of two axes' scales (y or z against x, either way): a magnetometer's
#: axes and the soft iron around it do not make them differ by more. A fit beyond it has taken
#: something else for a scale (a vehicle's acceleration for tilt, :func:`fit`).
MAX_SCALE_RATIO = 4.0 / 3.0
#: Samples :class:`MagSamples` keeps at most.
CAPACITY = 8192
#: A magnetometer whose fit from the log moves its heading by more than this (RMS over the kept
#: samples, deg) is said to need calibrating (:func:`looks_uncalibrated`).
UNCALIBRATED_DEG = 3.0
#: ``why`` of the calibration ``"auto"`` does not apply: the magnetometer looks calibrated.
LOOKS_CALIBRATED = "it looks calibrated"


@dataclass(frozen=True)
class MagCalibration:
    """The outcome of :func:`fit`: ``ok`` with ``offset`` (input unit), ``scale`` (x, y, z),
    ``residual`` (relative RMS of eq. 2), ``coverage_deg`` and, where it was applied because the
    magnetometer looked uncalibrated, ``said`` (why); or not ``ok`` and ``why``."""

    ok: bool
    offset: tuple = (0.0, 0.0, 0.0)
    scale: tuple = (1.0, 1.0, 1.0)
    residual: float = math.nan
    coverage_deg: float = 0.0
    why: str = ""
    said: str = ""
    tilt: str = ""  # the down vectors it was fitted with, where not the compass's own tilt

    def apply(self, mag) -> np.ndarray:
        """Eq. (1) on (n, 3) raw samples (unchanged when not ``ok``)."""
        mag = np.asarray(mag, dtype=float)
        if not self.ok:
            return mag
        return (mag - np.asarray(self.offset)) * np.asarray(self.scale)

    def note(self, source: str) -> str:
        """One line for ``attrs["notes"]``."""
        if self.ok:
            o = ", ".join(f"{v:.3g}" for v in self.offset)
            s = ", ".join(f"{v:.4f}" for v in self.scale)
            why = f"; {self.said}" if self.said else ""
            tilt = f", fitted with {self.tilt}" if self.tilt else ""
            return (f"{source}: magnetometer calibrated from the log (hard iron ({o}), scales ({s}); fit residual "
                    f"{100 * self.residual:.2f} % of the field, heading coverage {self.coverage_deg:.0f} deg{tilt}){why}")
        return f"{source}: magnetometer not calibrated: {self.why}"


class MagSamples:
    """A bounded, evenly thinned set of (mag, down) samples in row order, with their times and
    the raw gyro's integral to them where given (NaN otherwise); the same rows however the log is
    cut into chunks (every ``stride``-th finite sample, the stride doubling when full)."""

    def __init__(self, capacity: int = CAPACITY):
        self.capacity = int(capacity)
        self.stride = 1
        self.seen = 0
        self.rows: list[np.ndarray] = []
        self.n = 0

    def add(self, mag, down, t=None, turned=None) -> None:
        """Take the rows of a chunk with a finite field and down vector (``t``, s, and
        ``turned``, the raw gyro's integral to each row, deg, where given)."""
        mag = np.asarray(mag, dtype=float).reshape(-1, 3)
        extra = np.full((mag.shape[0], 2), np.nan)
        if t is not None and turned is not None:
            extra[:, 0], extra[:, 1] = t, turned
        both = np.hstack([mag, np.asarray(down, dtype=float).reshape(-1, 3), extra])
        both = both[np.isfinite(both[:, :6]).all(axis=1)]
        index = self.seen + np.arange(both.shape[0])
        self.seen += both.shape[0]
        keep = both[index % self.stride == 0]
        self.rows.append(keep)
        self.n += keep.shape[0]
        while self.n > self.capacity:  # thin: keep every other kept row (those on the doubled stride)
            allrows = np.concatenate(self.rows)
            first = allrows[::2]
            self.rows, self.n = [first], first.shape[0]
            self.stride *= 2

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The kept (n, 3) fields and down vectors."""
        allrows = self._all()
        return allrows[:, :3], allrows[:, 3:6]

    def turns(self) -> tuple[np.ndarray, np.ndarray]:
        """The kept samples' times (s) and the raw gyro's integral to them (deg; NaN: not given)."""
        allrows = self._all()
        return allrows[:, 6], allrows[:, 7]

    def _all(self) -> np.ndarray:
        return np.concatenate(self.rows) if self.rows else np.zeros((0, 8))


def _coverage_deg(mag_cal: np.ndarray, down: np.ndarray) -> float:
    """Degrees of heading (10° sectors) the tilt-compensated, calibrated field covers."""
    from gyrodrift.compass import tilt_compensated_heading

    heading = tilt_compensated_heading(*mag_cal.T, *(-down).T)
    sectors = np.unique(np.floor(heading[np.isfinite(heading)] / 10.0).astype(int) % 36)
    return 10.0 * sectors.size


def _start(mag, down) -> np.ndarray:
    """:func:`fit`'s starting point [o, s_y, s_z, F, V]: the midpoint of the field's range with
    o_z 0, unit scales, and the median strength and vertical part about that offset."""
    o0 = 0.5 * (mag.max(axis=0) + mag.min(axis=0))
    o0[2] = 0.0
    F0 = float(np.median(np.linalg.norm(mag - o0, axis=1)))
    V0 = float(np.median(np.sum((mag - o0) * down, axis=1)))
    return np.array([*o0, 1.0, 1.0, F0, V0])


def _solve(mag, down, start, free) -> tuple[np.ndarray, bool]:
    """Least squares of :func:`fit`'s residuals (relative to the starting strength) over the
    parameters ``free`` (of o, s_y, s_z, F, V), the others at ``start``: the seven parameters
    and whether the solver converged."""
    from scipy.optimize import least_squares  # here: scipy costs 0.4 s at start-up

    F0 = start[5]

    def full(q):
        p = start.copy()
        p[free] = q
        return p

    def residuals(q):
        p = full(q)
        mc = (mag - p[0:3]) * np.array([1.0, p[3], p[4]])
        return np.concatenate([np.linalg.norm(mc, axis=1) - p[5], np.sum(mc * down, axis=1) - p[6]]) / F0

    sol = least_squares(residuals, start[free], method="lm")
    return full(sol.x), bool(sol.success)


def _converged(x, success: bool) -> bool:
    """The solver converged to finite parameters."""
    return success and bool(np.all(np.isfinite(x)))


def _plausible_scales(x) -> bool:
    """The y and z scales within :data:`MAX_SCALE_RATIO` of x's, either way."""
    return bool(np.all((x[3:5] >= 1.0 / MAX_SCALE_RATIO) & (x[3:5] <= MAX_SCALE_RATIO)))


def fit(mag, down) -> MagCalibration:
    """Fit ``m_cal = s ⊙ (m - o)``, ``|m_cal| = F``, ``m_cal · d = V`` to the raw fields ``mag``
    (n, 3; any unit) and down unit vectors ``down`` (n, 3; body FRD) of the same rows.

    o_z and s_z are fitted when the down vector turns by :data:`MIN_TILT_SPREAD_DEG` or more. Where
    that fit does not converge or gives a scale beyond :data:`MAX_SCALE_RATIO`, it is solved again
    with s_z at 1: on a car the accelerometer's down vector turns by tens of degrees with braking
    and cornering while the car stays level, and s_z is what takes that tilt."""
    mag, down = np.asarray(mag, dtype=float), np.asarray(down, dtype=float)
    if mag.shape[0] < 100:
        return MagCalibration(False, why=f"{mag.shape[0]} magnetometer samples, fewer than 100")
    mean_down = down.mean(axis=0) / np.linalg.norm(down.mean(axis=0))
    spread = float(np.degrees(np.arccos(np.clip(down @ mean_down, -1.0, 1.0))).max())
    free = np.ones(7, dtype=bool)
    if spread < MIN_TILT_SPREAD_DEG:  # o_z and s_z undetermined: kept at 0 and 1
        free[[2, 4]] = False
    start = _start(mag, down)
    x, success = _solve(mag, down, start, free)
    if free[4] and not (_converged(x, success) and _plausible_scales(x)):
        free[4] = False
        x, success = _solve(mag, down, start, free)
    o, s, F = x[0:3], np.array([1.0, x[3], x[4]]), x[5]
    mc = (mag - o) * s
    resid = float(np.sqrt(np.mean((np.linalg.norm(mc, axis=1) - F) ** 2)) / abs(F))
    cover = _coverage_deg(mc, down)
    result = dict(offset=tuple(float(v) for v in o), scale=tuple(float(v) for v in s), residual=resid,
                  coverage_deg=cover)
    if cover <= MIN_COVERAGE_DEG:
        return MagCalibration(False, **result, why=f"the log turns through {cover:.0f} deg of heading, "
                                                     f"not more than {MIN_COVERAGE_DEG:.0f}")
    if not _converged(x, success):
        return MagCalibration(False, **result, why="the fit did not converge")
    if not _plausible_scales(x):
        scales = ", ".join(f"{v:.3g}" for v in s)
        return MagCalibration(False, **result, why=f"the fit's axis scales ({scales}) differ by more than a factor "
                                                     f"{MAX_SCALE_RATIO:.3g}, more than a magnetometer's do")
    if resid > MAX_RESIDUAL:
        return MagCalibration(False, **result, why=f"the fit leaves {100 * resid:.1f} % of the field, more than "
                                                     f"{100 * MAX_RESIDUAL:.0f} %")
    return MagCalibration(True, **result)


def inconsistency(samples: "MagSamples", cal: "MagCalibration | None" = None) -> float:
    """How far the field of ``samples``, calibrated by its :func:`fit`, is from constant in
    the world: the relative RMS of both parts the fit makes constant, its strength and its
    vertical part along the samples' down vectors (``sqrt(norm² + vertical²)``, fractions of the
    strength; NaN without a fit). A down vector that is the platform's true tilt leaves the
    vertical part constant; one that leans with the platform's accelerations does not, however
    the fit moves the offsets (a car's fit with the accelerometer's down takes a z offset of most
    of the vertical field, which no rotation about the vertical can show, to hide its leaning).
    ``cal``: that fit, when the caller has it."""
    mag, down = samples.arrays()
    if mag.shape[0] < 100:
        return math.nan
    cal = fit(mag, down) if cal is None else cal
    if not np.all(np.isfinite(cal.offset)):
        return math.nan
    mc = (mag - np.asarray(cal.offset)) * np.asarray(cal.scale)
    strength = np.linalg.norm(mc, axis=1)
    F = float(np.median(strength))
    vertical = np.sum(mc * down, axis=1)
    if not F > 0.0:
        return math.nan
    return float(math.hypot(np.std(strength), np.std(vertical)) / F)


@dataclass(frozen=True)
class Uncalibrated:
    """The evidence that a magnetometer needs calibrating (:func:`looks_uncalibrated`): the raw
    field strength's relative RMS scatter, the fit from the log that explains it, and how far
    that fit moves the tilt-compensated heading (RMS and largest, deg)."""

    scatter: float
    cal: MagCalibration
    moved_rms_deg: float
    moved_max_deg: float

    def said(self) -> str:
        """The evidence in words."""
        o = ", ".join(f"{v:.3g}" for v in self.cal.offset)
        return (f"its field strength scatters by {100 * self.scatter:.1f} % (RMS), and a fit from this log (hard iron "
                f"({o})) leaves {100 * self.cal.residual:.2f} % and moves its heading by {self.moved_rms_deg:.0f} deg "
                f"RMS, up to {self.moved_max_deg:.0f} deg")


def _headings(mag, down, cal: MagCalibration) -> tuple[np.ndarray, np.ndarray]:
    """The tilt-compensated headings (deg) of the raw fields ``mag`` and of them calibrated by ``cal``."""
    from gyrodrift.compass import tilt_compensated_heading

    return (tilt_compensated_heading(*mag.T, *(-down).T),
            tilt_compensated_heading(*cal.apply(mag).T, *(-down).T))


def looks_uncalibrated(mag, down, cal: MagCalibration | None = None) -> Uncalibrated | None:
    """Whether the raw fields ``mag`` (n, 3) with their down vectors ``down`` look uncalibrated:
    their strength scatters by more than :data:`MAX_RESIDUAL` (relative RMS about its median: a
    calibrated field's is constant), the fit from the log itself (:func:`fit`, when it holds)
    explains that scatter (leaves less than a third of it), and the fit moves the
    tilt-compensated heading by more than :data:`UNCALIBRATED_DEG` RMS. The compass then errs
    with the heading by that much, and the default model can take that for drift or for a
    disturbance. None when not (a field disturbed in places scatters too, but no fit explains it).
    ``cal``: that fit, where it is already made."""
    from gyrodrift.conventions import wrap_180

    mag, down = np.asarray(mag, dtype=float), np.asarray(down, dtype=float)
    strength = np.linalg.norm(mag, axis=1)
    if strength.size == 0:
        return None
    scatter = float(np.sqrt(np.mean((strength / np.median(strength) - 1.0) ** 2)))
    if not scatter > MAX_RESIDUAL:
        return None
    cal = fit(mag, down) if cal is None else cal
    if not cal.ok or not cal.residual < scatter / 3.0:
        return None
    before, after = _headings(mag, down, cal)
    moved = np.abs(np.asarray(wrap_180(after - before), dtype=float))
    moved = moved[np.isfinite(moved)]
    rms = float(np.sqrt(np.mean(moved**2))) if moved.size else 0.0
    if not rms > UNCALIBRATED_DEG:
        return None
    return Uncalibrated(scatter, cal, rms, float(moved.max()))


#: Window over which the compass less the gyro's integral is taken as a straight line (the
#: drift), s; what is left is the compass's error that changes as the platform turns, and noise.
AGREE_WINDOW_S = 30.0
#: A fit from the log is applied where it leaves at most this share of that error (RMS).
AGREE_RATIO = 0.5


def turn_error_deg(t, turned, heading) -> float:
    """RMS (deg) of ``heading - turned`` (the compass less the raw gyro's integral, unwrapped)
    about a least-squares line in each :data:`AGREE_WINDOW_S` window of at least 10 samples:
    the compass's error that changes within a window (with the platform's heading, for a
    deviation) and its noise; the gyro's drift is a line. NaN without such a window."""
    from gyrodrift.conventions import wrap_180

    t, turned, heading = (np.asarray(v, dtype=float) for v in (t, turned, heading))
    ok = np.isfinite(t) & np.isfinite(turned) & np.isfinite(heading)
    t, d = t[ok], np.asarray(wrap_180(heading[ok] - turned[ok]), dtype=float)
    if t.size < 10:
        return math.nan
    d = np.degrees(np.unwrap(np.radians(d)))
    k = np.floor((t - t[0]) / AGREE_WINDOW_S).astype(np.int64)
    ss, n = 0.0, 0
    for w in np.unique(k):
        m = k == w
        if m.sum() < 10:
            continue
        u = t[m] - t[m].mean()
        y = d[m] - d[m].mean()
        suu = float(u @ u)
        r = y - (float(u @ y) / suu) * u if suu > 0.0 else y
        ss += float(r @ r)
        n += int(m.sum())
    return math.sqrt(ss / n) if n else math.nan


def agrees_better(samples: "MagSamples", cal: MagCalibration) -> tuple[float, float] | None:
    """The compass's turn error (:func:`turn_error_deg`) raw and with ``cal`` applied, where the
    raw one is above :data:`UNCALIBRATED_DEG` and the fit leaves at most :data:`AGREE_RATIO` of
    it; None otherwise, or where it cannot be judged: without the gyro's integral, or with fewer
    than 10 kept samples in every window (a compass slower than 1/3 Hz, or a log longer than
    3.4–6.8 h, whose samples :class:`MagSamples` has thinned to between half its capacity and
    all of it)."""
    if not cal.ok:
        return None
    t, turned = samples.turns()
    before, after = _headings(*samples.arrays(), cal)
    raw, fitted = turn_error_deg(t, turned, before), turn_error_deg(t, turned, after)
    if not (fitted <= AGREE_RATIO * raw and raw > UNCALIBRATED_DEG):
        return None
    return raw, fitted


#: What a note of a magnetometer that looks uncalibrated advises, by ``mag_calibration``: off
#: (False), or ``"auto"`` in a stream, which cannot calibrate.
ADVICE = {
    False: "set mag_calibration = \"auto\" (the default) or true (--config) to calibrate it from the log, or "
           "calibrate the magnetometer",
    "auto": "a stream cannot calibrate it (the fit needs the whole log): compensate the whole log, which does "
            "(mag_calibration = \"auto\"), or calibrate the magnetometer",
}


def uncalibrated_note(samples: MagSamples, source: str, mode=False) -> str | None:
    """A note for a log compensated without the calibration when its magnetometer looks
    uncalibrated (:func:`looks_uncalibrated` on the kept ``samples``), with the advice for the
    ``mag_calibration`` in force (``mode``: False or ``"auto"``, :data:`ADVICE`); None otherwise."""
    found = looks_uncalibrated(*samples.arrays())
    if found is None:
        return None
    return (f"{source}: the magnetometer looks uncalibrated: {found.said()}, an error the drift estimate can absorb; "
            f"{ADVICE[mode]}")


def auto_calibration(samples: MagSamples, cal: MagCalibration | None = None) -> MagCalibration:
    """The calibration ``mag_calibration = "auto"`` applies: the fit from the log when the
    magnetometer looks uncalibrated (:func:`looks_uncalibrated`), or when the fit makes its
    heading agree with the gyro's turns (:func:`agrees_better`: a deviation with the heading shows
    there even where the field's strength hardly scatters), its note saying why; else none (not
    ``ok``, ``why`` :data:`LOOKS_CALIBRATED`, which needs no note). ``cal``: the samples'
    :func:`fit`, when the caller has it."""
    cal = fit(*samples.arrays()) if cal is None else cal
    found = looks_uncalibrated(*samples.arrays(), cal)
    if found is None:
        agree = agrees_better(samples, cal)
        if agree is None:
            return MagCalibration(False, why=LOOKS_CALIBRATED)
        return dataclasses.replace(cal, said=(
            f"its heading agreed with the gyro's turns to {agree[0]:.1f} deg RMS within {AGREE_WINDOW_S:.0f} s, "
            f"and to {agree[1]:.1f} deg with the fit"))
    return dataclasses.replace(found.cal, said=(
        f"it looked uncalibrated: its field strength scattered by {100 * found.scatter:.1f} % (RMS), and the fit "
        f"moves its heading by {found.moved_rms_deg:.0f} deg RMS, up to {found.moved_max_deg:.0f} deg"))

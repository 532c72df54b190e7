"""Compass heading from a body-frame magnetometer and accelerometer (FRD, specific force).

Roll and pitch come from the gravity direction, the field is rotated to the level frame and
its horizontal part gives the heading (deg, clockwise from magnetic north): the paper's
compass (Section 2). The functions are vectorised, unit-agnostic and pure; a magnetometer
sample counts only when it reads a field (:func:`usable_field`, :class:`DeadField`). See
docs/conventions.md, section "The compass".
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.conventions import wrap_360
from gyrodrift.io.notes import no_compass_note
from gyrodrift.kernels import compass as compass_kernel

__all__ = ["MIN_FIELD", "roll_pitch_deg", "tilt_compensated_heading", "field_norm_dip", "compass_columns",
           "usable_field", "DeadField"]

#: Weakest field strength a magnetometer sample must read to be a compass sample, in the
#: sample's own unit (docs/conventions.md, section "The compass").
MIN_FIELD = 1e-9


def roll_pitch_deg(acc_x, acc_y, acc_z):
    """Roll and pitch (deg) from specific force in the FRD body frame.

    Parameters
    ----------
    acc_x, acc_y, acc_z : array_like
        Specific force, any unit (g or m/s²). Level and still: (0, 0, -1 g).

    Returns
    -------
    roll_deg, pitch_deg : ndarray
        Roll (right wing down positive) and pitch (nose up positive), deg.

    Examples
    --------
    >>> [round(float(v), 3) for v in roll_pitch_deg(0.0, -0.5, -0.866025)]
    [30.0, 0.0]
    """
    fx, fy, fz = (np.asarray(v, dtype=float) for v in (acc_x, acc_y, acc_z))
    roll = np.arctan2(-fy, -fz)
    pitch = np.arctan2(fx, np.hypot(fy, fz))
    return np.degrees(roll), np.degrees(pitch)


def _components(*values):
    """The arguments broadcast against each other, as new contiguous 1-d float64 arrays (the
    kernel's one signature), and their common shape."""
    arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values))
    return [np.array(a, dtype=float).ravel() for a in arrays], arrays[0].shape


def _compass(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z):
    """Heading, field strength and dip of every sample (:func:`gyrodrift.kernels.compass.rows`)."""
    parts, shape = _components(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z)
    heading, norm, dip = (np.empty(parts[0].size) for _ in range(3))
    compass_kernel.rows(*parts, heading, norm, dip)
    return heading.reshape(shape), norm.reshape(shape), dip.reshape(shape)


def tilt_compensated_heading(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z):
    """Magnetic heading (deg, clockwise from magnetic north, [0, 360)).

    Parameters
    ----------
    mag_x, mag_y, mag_z : array_like
        Magnetic field in the FRD body frame, any one unit. NaN gives NaN.
    acc_x, acc_y, acc_z : array_like
        Specific force in the FRD body frame, g or m/s².

    Returns
    -------
    ndarray
        Heading, deg in [0, 360).

    Examples
    --------
    Level, nose pointing east: the field's horizontal part lies along -y.

    >>> float(tilt_compensated_heading(0.0, -0.2, 0.4, 0.0, 0.0, -1.0))
    90.0
    """
    return _compass(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z)[0]


def field_norm_dip(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z):
    """Field strength (input unit) and dip angle (deg, positive = field points down)."""
    return _compass(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z)[1:]


def compass_columns(n: int, heading_deg=None, mag=None, acc=None, down=None):
    """The compass of every row of a log: heading (deg in [0, 360), NaN = no sample), field
    strength and dip (NaN without a raw magnetometer).

    Parameters
    ----------
    n : int
        Number of rows.
    heading_deg : (n,) array_like, optional
        A given compass heading, deg; NaN = no sample.
    mag, acc : (n, 3) array_like, optional
        Raw FRD magnetometer and accelerometer: the heading where ``heading_deg`` has none.
    down : (n, 3) array_like, optional
        A gravity direction (unit vector down, body FRD) to tilt-compensate with instead of
        the accelerometer's (:mod:`gyrodrift.attitude`).

    Returns
    -------
    heading_deg, norm, dip_deg : (n,) ndarray
    """
    heading = np.full(n, np.nan) if heading_deg is None else np.asarray(heading_deg, dtype=float).copy()
    norm = np.full(n, np.nan)
    dip = np.full(n, np.nan)
    if mag is not None and acc is not None:
        mag = np.asarray(mag, dtype=float)
        acc = np.asarray(acc, dtype=float) if down is None else -np.asarray(down, dtype=float)
        from_mag, norm, dip = _compass(*mag.T, *acc.T)
        heading = np.where(np.isfinite(heading), heading, from_mag)
    with np.errstate(invalid="ignore"):
        heading = np.where(np.isfinite(heading), wrap_360(heading), np.nan)
    return heading, norm, dip


def usable_field(mag) -> np.ndarray:
    """Which magnetometer samples ((n, 3), any unit) read a field: finite components and a
    strength of at least :data:`MIN_FIELD`; (n,) bool."""
    mag = np.asarray(mag, dtype=float).reshape(-1, 3)
    with np.errstate(over="ignore", invalid="ignore"):
        strength = np.sqrt(np.einsum("ij,ij->i", mag, mag))
    return np.isfinite(strength) & (strength >= MIN_FIELD)


class DeadField:
    """The magnetometer samples that read no field (:func:`usable_field`), emptied and counted over a
    whole log, chunk by chunk (:meth:`mask`) or sample by sample (:meth:`sample`); a row whose
    three components are all NaN is no sample."""

    def __init__(self) -> None:
        self.samples = 0  #: magnetometer samples seen
        self.dead = 0  #: of those, the ones that read no field

    def mask(self, mag) -> np.ndarray:
        """``mag`` ((n, 3)) with its dead samples NaN (a copy when there is one), counted."""
        mag = np.asarray(mag, dtype=float)
        present = ~np.isnan(mag).all(axis=1)
        dead = present & ~usable_field(mag)
        self.samples += int(np.count_nonzero(present))
        n_dead = int(np.count_nonzero(dead))
        if n_dead:
            self.dead += n_dead
            mag = mag.copy()
            mag[dead] = math.nan
        return mag

    def sample(self, x: float, y: float, z: float) -> bool:
        """Count one sample (floats); whether it reads a field (all NaN: no sample, False)."""
        if math.isnan(x) and math.isnan(y) and math.isnan(z):
            return False
        self.samples += 1
        strength = math.sqrt(x * x + y * y + z * z)  # a square beyond the float range is inf: dead
        if math.isfinite(strength) and strength >= MIN_FIELD:
            return True
        self.dead += 1
        return False

    def none_usable(self) -> bool:
        """True when there were samples and none read a field."""
        return self.samples > 0 and self.dead == self.samples

    def note(self, source: str, other_compass: bool) -> str | None:
        """One line on the dead samples (None without any); a "no compass" note
        (:func:`gyrodrift.io.notes.no_compass_note`) when no sample read a field and
        ``other_compass`` (a ``heading`` column with values) is False."""
        if not self.dead:
            return None
        what = (f"{self.dead} of {self.samples} magnetometer samples read no field (zero, NaN or weaker than "
                f"{MIN_FIELD:g} in the file's unit)")
        if self.none_usable() and not other_compass:
            return no_compass_note(source, f"the magnetometer is dead or unplugged: {what}")
        return f"{source}: {what}; they are not compass samples: check the magnetometer and its wiring"

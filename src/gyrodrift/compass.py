"""Compass heading from a body-frame magnetometer and accelerometer.

Body frame FRD (x forward, y right, z down); the accelerometer gives specific force,
so a level, still unit reads ``acc = (0, 0, -1 g)``. Roll and pitch come from the
gravity direction, the magnetic field is rotated back to the local level frame and
its horizontal part gives the heading (deg, clockwise from magnetic north). All
functions are vectorised, unit-agnostic (only ratios are used) and pure.

The tilt estimate assumes the accelerometer sees gravity only: linear acceleration
(braking, cornering) tilts the computed heading. That is the compass the paper uses
(Section 2); the gating of :mod:`gyrodrift.gating` refuses aiding while turning.
"""

from __future__ import annotations

import numpy as np

from gyrodrift.conventions import wrap_360

__all__ = ["roll_pitch_deg", "tilt_compensated_heading", "field_norm_dip", "compass_columns"]


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


def _level_field(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z):
    """Magnetic field rotated into the local level frame: (north-ish, east-ish, down)."""
    mx, my, mz = (np.asarray(v, dtype=float) for v in (mag_x, mag_y, mag_z))
    roll_deg, pitch_deg = roll_pitch_deg(acc_x, acc_y, acc_z)
    phi, theta = np.radians(roll_deg), np.radians(pitch_deg)
    sphi, cphi, sth, cth = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    # Undo roll (about x), then pitch (about y): horizontal x, y and vertical z parts.
    horiz_x = mx * cth + (my * sphi + mz * cphi) * sth
    horiz_y = my * cphi - mz * sphi
    vert = -mx * sth + (my * sphi + mz * cphi) * cth
    return horiz_x, horiz_y, vert


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
    hx, hy, _ = _level_field(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z)
    return wrap_360(np.degrees(np.arctan2(-hy, hx)))


def field_norm_dip(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z):
    """Field strength (input unit) and dip angle (deg, positive = field points down).

    A change in either while the heading is used flags magnetic interference
    (:mod:`gyrodrift.gating`): the Earth's field has a fixed strength and dip at one place.
    """
    hx, hy, vert = _level_field(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z)
    horiz = np.hypot(hx, hy)
    return np.sqrt(horiz**2 + vert**2), np.degrees(np.arctan2(vert, horiz))


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
        Raw FRD magnetometer and accelerometer: a tilt-compensated heading where
        ``heading_deg`` has none, and the field strength and dip of every row.
    down : (n, 3) array_like, optional
        The gravity direction (a unit vector pointing down, body FRD) to tilt-compensate
        with instead of the accelerometer's (:mod:`gyrodrift.attitude`); the heading and
        field use ``-down`` as the specific force.

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
        with np.errstate(invalid="ignore"):
            norm, dip = field_norm_dip(*mag.T, *acc.T)
            from_mag = tilt_compensated_heading(*mag.T, *acc.T)
        heading = np.where(np.isfinite(heading), heading, from_mag)
    with np.errstate(invalid="ignore"):
        heading = np.where(np.isfinite(heading), wrap_360(heading), np.nan)
    return heading, norm, dip

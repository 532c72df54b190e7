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

__all__ = ["roll_pitch_deg", "tilt_compensated_heading", "field_norm_dip"]


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
    heading = np.degrees(np.arctan2(-hy, hx))
    heading = np.mod(heading, 360.0)
    return np.where(heading >= 360.0, heading - 360.0, heading)


def field_norm_dip(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z):
    """Field strength (input unit) and dip angle (deg, positive = field points down).

    A change in either while the heading is used flags magnetic interference
    (:mod:`gyrodrift.gating`): the Earth's field has a fixed strength and dip at one place.
    """
    hx, hy, vert = _level_field(mag_x, mag_y, mag_z, acc_x, acc_y, acc_z)
    horiz = np.hypot(hx, hy)
    return np.sqrt(horiz**2 + vert**2), np.degrees(np.arctan2(vert, horiz))

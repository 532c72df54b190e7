"""The compass of a raw magnetometer: the field levelled with the accelerometer's roll and
pitch, and its heading, strength and dip (``docs/conventions.md``, "The compass").

:func:`row` is one sample, :func:`rows` many; both are the same arithmetic, so a streamed
sample's compass is the batch's to the bit (:func:`gyrodrift.compass.compass_columns` and
:class:`gyrodrift.compensator.intake.Intake` call them).
"""

from __future__ import annotations

import math

from gyrodrift.kernels import jit
from gyrodrift.kernels.numeric import wrap360

__all__ = ["level_field", "row", "rows"]


@jit(inline=True)
def level_field(mx, my, mz, fx, fy, fz):
    """The field ``m`` (FRD body frame, any unit) in the local level frame, with the roll
    ``atan2(−f_y, −f_z)`` and pitch ``atan2(f_x, √(f_y² + f_z²))`` of the specific force ``f``
    (FRD, any unit; level and still: (0, 0, −1 g)): undo the roll about x, then the pitch
    about y. Returns (north-ish, east-ish, down) parts."""
    phi = math.atan2(-fy, -fz)
    theta = math.atan2(fx, math.hypot(fy, fz))
    sphi, cphi, sth, cth = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
    yz = my * sphi + mz * cphi
    return mx * cth + yz * sth, my * cphi - mz * sphi, -mx * sth + yz * cth


@jit(inline=True)
def row(mx, my, mz, fx, fy, fz):
    """Heading (deg clockwise from magnetic north, [0, 360)), field strength (the input's
    unit) and dip (deg, positive: the field points down) of one sample; NaN in, NaN out."""
    hx, hy, vert = level_field(mx, my, mz, fx, fy, fz)
    horiz = math.hypot(hx, hy)
    heading = wrap360(math.degrees(math.atan2(-hy, hx)))
    return heading, math.sqrt(horiz * horiz + vert * vert), math.degrees(math.atan2(vert, horiz))


@jit
def rows(mx, my, mz, fx, fy, fz, heading, norm, dip):
    """:func:`row` of every element of the 1-d component arrays, into ``heading``, ``norm``
    and ``dip``."""
    for i in range(mx.size):
        heading[i], norm[i], dip[i] = row(mx[i], my[i], mz[i], fx[i], fy[i], fz[i])

"""Board and sensor rotations of PX4 and ArduPilot: their enum numbers as matrices.

``v_body = R @ v_board`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (:func:`euler_matrix`); each
table entry is its (roll, pitch, yaw) in degrees. A number is always read with its autopilot.
Sources and the custom rotations: ``docs/heading_and_axes.md`` (board rotations).
"""

from __future__ import annotations

import math
import re
from typing import Mapping

import numpy as np

from gyrodrift.errors import ConfigError

__all__ = [
    "PX4_ROTATIONS", "ARDUPILOT_ROTATIONS", "ARDUPILOT_CUSTOM", "AUTOPILOTS", "euler_matrix", "rotation_matrix",
    "rotation_name", "parse_rotation",
]

#: PX4 ``enum Rotation``: number -> (name, (roll, pitch, yaw) deg), from ``rot_lookup``.
PX4_ROTATIONS: dict[int, tuple[str, tuple[float, float, float]]] = {
    0: ("NONE", (0, 0, 0)), 1: ("YAW_45", (0, 0, 45)), 2: ("YAW_90", (0, 0, 90)), 3: ("YAW_135", (0, 0, 135)),
    4: ("YAW_180", (0, 0, 180)), 5: ("YAW_225", (0, 0, 225)), 6: ("YAW_270", (0, 0, 270)),
    7: ("YAW_315", (0, 0, 315)), 8: ("ROLL_180", (180, 0, 0)), 9: ("ROLL_180_YAW_45", (180, 0, 45)),
    10: ("ROLL_180_YAW_90", (180, 0, 90)), 11: ("ROLL_180_YAW_135", (180, 0, 135)),
    12: ("PITCH_180", (0, 180, 0)), 13: ("ROLL_180_YAW_225", (180, 0, 225)),
    14: ("ROLL_180_YAW_270", (180, 0, 270)), 15: ("ROLL_180_YAW_315", (180, 0, 315)),
    16: ("ROLL_90", (90, 0, 0)), 17: ("ROLL_90_YAW_45", (90, 0, 45)), 18: ("ROLL_90_YAW_90", (90, 0, 90)),
    19: ("ROLL_90_YAW_135", (90, 0, 135)), 20: ("ROLL_270", (270, 0, 0)), 21: ("ROLL_270_YAW_45", (270, 0, 45)),
    22: ("ROLL_270_YAW_90", (270, 0, 90)), 23: ("ROLL_270_YAW_135", (270, 0, 135)),
    24: ("PITCH_90", (0, 90, 0)), 25: ("PITCH_270", (0, 270, 0)), 26: ("PITCH_180_YAW_90", (0, 180, 90)),
    27: ("PITCH_180_YAW_270", (0, 180, 270)), 28: ("ROLL_90_PITCH_90", (90, 90, 0)),
    29: ("ROLL_180_PITCH_90", (180, 90, 0)), 30: ("ROLL_270_PITCH_90", (270, 90, 0)),
    31: ("ROLL_90_PITCH_180", (90, 180, 0)), 32: ("ROLL_270_PITCH_180", (270, 180, 0)),
    33: ("ROLL_90_PITCH_270", (90, 270, 0)), 34: ("ROLL_180_PITCH_270", (180, 270, 0)),
    35: ("ROLL_270_PITCH_270", (270, 270, 0)), 36: ("ROLL_90_PITCH_180_YAW_90", (90, 180, 90)),
    37: ("ROLL_90_YAW_270", (90, 0, 270)), 38: ("ROLL_90_PITCH_68_YAW_293", (90, 68, 293)),
    39: ("PITCH_315", (0, 315, 0)), 40: ("ROLL_90_PITCH_315", (90, 315, 0)),
    41: ("ROLL_270_YAW_180", (270, 0, 180)), 42: ("ROLL_270_YAW_270", (270, 0, 270)),
    43: ("PITCH_90_YAW_180", (0, 90, 180)), 44: ("PITCH_9_YAW_180", (0, 9, 180)), 45: ("PITCH_45", (0, 45, 0)),
    46: ("ROLL_270_YAW_225", (270, 0, 225)), 47: ("ROLL_270_YAW_315", (270, 0, 315)),
}  # fmt: skip

#: ArduPilot ``enum Rotation`` without the custom ones: number -> (name, (roll, pitch, yaw) deg).
ARDUPILOT_ROTATIONS: dict[int, tuple[str, tuple[float, float, float]]] = {
    **{k: PX4_ROTATIONS[k] for k in range(38)},
    38: ("ROLL_90_PITCH_68_YAW_293", (90, 68.8, 293.3)), 39: ("PITCH_315", (0, 315, 0)),
    40: ("ROLL_90_PITCH_315", (90, 315, 0)), 41: ("PITCH_7", (0, 7, 0)), 42: ("ROLL_45", (45, 0, 0)),
    43: ("ROLL_315", (315, 0, 0)),
}  # fmt: skip

#: ArduPilot's custom rotations: number -> the parameters holding roll, pitch, yaw (deg).
ARDUPILOT_CUSTOM: dict[int, tuple[str, str, str]] = {
    100: ("AHRS_CUSTOM_ROLL", "AHRS_CUSTOM_PIT", "AHRS_CUSTOM_YAW"),
    101: ("CUST_ROT1_ROLL", "CUST_ROT1_PITCH", "CUST_ROT1_YAW"),
    102: ("CUST_ROT2_ROLL", "CUST_ROT2_PITCH", "CUST_ROT2_YAW"),
}

#: The parameter that holds the board rotation, per autopilot.
AUTOPILOTS = {"px4": "SENS_BOARD_ROT", "ardupilot": "AHRS_ORIENTATION"}


def euler_matrix(roll_deg: float, pitch_deg: float, yaw_deg: float) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` (angles in degrees): ``v_body = R @ v_board``."""
    r, p, y = (math.radians(float(a)) for a in (roll_deg, pitch_deg, yaw_deg))
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(r), -math.sin(r)], [0.0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0.0, math.sin(p)], [0.0, 1.0, 0.0], [-math.sin(p), 0.0, math.cos(p)]])
    rz = np.array([[math.cos(y), -math.sin(y), 0.0], [math.sin(y), math.cos(y), 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


def _table(autopilot: str) -> dict:
    if autopilot not in AUTOPILOTS:
        raise ConfigError(f"unknown autopilot {autopilot!r}; use one of: {', '.join(AUTOPILOTS)}")
    return PX4_ROTATIONS if autopilot == "px4" else ARDUPILOT_ROTATIONS


def _numbers(autopilot: str) -> str:
    """The valid numbers of ``autopilot``, for messages."""
    table = _table(autopilot)
    extra = ", 100..102 (custom)" if autopilot == "ardupilot" else ""
    return f"0..{max(table)}{extra}"


def rotation_name(autopilot: str, number: int) -> str:
    """``"8 (ROLL_180)"``: the number with the enum's name (``"CUSTOM"`` for ArduPilot 100..102)."""
    if autopilot == "ardupilot" and number in ARDUPILOT_CUSTOM:
        return f"{number} (CUSTOM)"
    entry = _table(autopilot).get(number)
    return f"{number} ({entry[0]})" if entry else str(number)


def rotation_matrix(autopilot: str, number, params: Mapping[str, float] | None = None,
                    where: str = "") -> np.ndarray:
    """The matrix ``R`` (``v_body = R @ v_board``) of rotation ``number`` of ``autopilot`` ("px4", "ardupilot").

    ``params`` holds the angles of ArduPilot's custom rotations (100..102); ``where`` names the
    number's source in the message. A number the autopilot does not define, or a custom
    rotation whose angles are not in ``params``, is a :class:`ConfigError`.
    """
    table = _table(autopilot)
    label = where or AUTOPILOTS[autopilot]
    if isinstance(number, float) and number.is_integer():
        number = int(number)
    if isinstance(number, bool) or not isinstance(number, (int, np.integer)):
        raise ConfigError(f"{label}: rotation {number!r} is not a whole number; use {_numbers(autopilot)}")
    number = int(number)
    if autopilot == "ardupilot" and number in ARDUPILOT_CUSTOM:
        names = ARDUPILOT_CUSTOM[number]
        missing = [n for n in names if params is None or n not in params]
        if missing:
            raise ConfigError(f"{label} = {number} is a custom rotation but {', '.join(missing)} are not known; "
                              "give the angles instead, e.g. --board-rotation 180,0,225 (roll,pitch,yaw deg)")
        return euler_matrix(*(float(params[n]) for n in names))
    if number not in table:
        raise ConfigError(f"{label} = {number} is not a rotation {autopilot} defines ({_numbers(autopilot)})")
    return euler_matrix(*table[number][1])


def parse_rotation(text: str, autopilot: str) -> tuple[np.ndarray, str]:
    """``--board-rotation``: a rotation number of ``autopilot`` or ``roll,pitch,yaw`` (deg); ``R`` and a description."""
    body = str(text).strip()
    if re.fullmatch(r"[+-]?\d+", body):
        number = int(body)
        return rotation_matrix(autopilot, number, where="--board-rotation"), \
            f"--board-rotation {rotation_name(autopilot, number)}"
    parts = [p.strip() for p in body.split(",")]
    try:
        angles = [float(p) for p in parts]
    except ValueError:
        angles = []
    if len(angles) != 3 or not all(map(math.isfinite, angles)):
        raise ConfigError(f"--board-rotation expects a {autopilot} rotation number ({_numbers(autopilot)}) or "
                          f"roll,pitch,yaw in degrees, got {text!r}")
    return euler_matrix(*angles), f"--board-rotation roll {angles[0]:g}, pitch {angles[1]:g}, yaw {angles[2]:g} deg"

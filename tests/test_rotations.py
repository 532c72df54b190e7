"""Board rotations of PX4 and ArduPilot (gyrodrift.rotations), every enum number.

Checked three ways: every matrix is a proper rotation; the angles of every entry agree
with its enum name (parsed here: ROLL_90_PITCH_180_YAW_90 -> 90, 180, 90); and a set of
entries moves a vector as the autopilots' hand-written per-axis formulas do (PX4
``rotate_3f``, ArduPilot ``Vector3::rotate``), worked out here by hand.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from gyrodrift.errors import ConfigError
from gyrodrift.rotations import (
    ARDUPILOT_CUSTOM,
    ARDUPILOT_ROTATIONS,
    PX4_ROTATIONS,
    euler_matrix,
    parse_rotation,
    rotation_matrix,
    rotation_name,
)

ALL = [("px4", n) for n in PX4_ROTATIONS] + [("ardupilot", n) for n in ARDUPILOT_ROTATIONS]


def angles_from_name(name: str) -> tuple[float, float, float]:
    found = dict(re.findall(r"(ROLL|PITCH|YAW)_(\d+)", name))
    return tuple(float(found.get(k, 0)) for k in ("ROLL", "PITCH", "YAW"))


def test_the_tables_hold_every_number_the_autopilots_define():
    assert sorted(PX4_ROTATIONS) == list(range(48))  # ROTATION_MAX = 48
    assert sorted(ARDUPILOT_ROTATIONS) == list(range(44))  # ROTATION_MAX = 44
    assert sorted(ARDUPILOT_CUSTOM) == [100, 101, 102]


@pytest.mark.parametrize("autopilot, number", ALL)
def test_every_rotation_is_proper_and_matches_its_name(autopilot, number):
    R = rotation_matrix(autopilot, number)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    name = (PX4_ROTATIONS if autopilot == "px4" else ARDUPILOT_ROTATIONS)[number][0]
    by_name = euler_matrix(*angles_from_name(name))
    tol = 0.03 if number == 38 and autopilot == "ardupilot" else 1e-12  # 68.8/293.3 named 68/293
    np.testing.assert_allclose(R, by_name, atol=tol)


V = np.array([1.0, 2.0, 3.0])
S = math.sqrt(0.5)
c7, s7 = math.cos(math.radians(7)), math.sin(math.radians(7))
# (autopilot, number, V rotated), each worked out from the autopilot's per-axis formula
BY_HAND = [
    ("px4", 0, (1, 2, 3)), ("px4", 2, (-2, 1, 3)),  # YAW_90: x = -y, y = x
    ("px4", 1, (S * (1 - 2), S * (1 + 2), 3)),  # YAW_45
    ("px4", 4, (-1, -2, 3)), ("px4", 6, (2, -1, 3)),  # YAW_180, YAW_270
    ("px4", 8, (1, -2, -3)), ("px4", 12, (-1, 2, -3)),  # ROLL_180, PITCH_180
    ("px4", 10, (2, 1, -3)), ("px4", 14, (-2, -1, -3)),  # ROLL_180_YAW_90, ROLL_180_YAW_270
    ("px4", 16, (1, -3, 2)), ("px4", 20, (1, 3, -2)),  # ROLL_90: y = -z, z = y; ROLL_270
    ("px4", 18, (3, 1, 2)), ("px4", 22, (-3, 1, -2)),  # ROLL_90_YAW_90, ROLL_270_YAW_90
    ("px4", 24, (3, 2, -1)), ("px4", 25, (-3, 2, 1)),  # PITCH_90: x = z, z = -x; PITCH_270
    ("px4", 26, (-2, -1, -3)), ("px4", 27, (2, 1, -3)),  # PITCH_180_YAW_90/270
    ("px4", 28, (2, -3, -1)), ("px4", 29, (-3, -2, -1)), ("px4", 30, (-2, 3, -1)),
    ("px4", 31, (-1, -3, -2)), ("px4", 32, (-1, 3, 2)), ("px4", 33, (-2, -3, 1)),
    ("px4", 34, (3, -2, 1)), ("px4", 35, (2, 3, 1)), ("px4", 36, (3, -1, -2)), ("px4", 37, (-3, -1, 2)),
    ("px4", 39, (S * (1 - 3), 2, S * (1 + 3))),  # PITCH_315
    ("px4", 40, (S * (1 - 2), -3, S * (1 + 2))),  # ROLL_90_PITCH_315
    ("px4", 38, (0.146371 + 0.362280 * 2 - 0.920505 * 3, -0.344827 - 0.853477 * 2 - 0.390731 * 3,
                 -0.927184 + 0.374607 * 2)),  # rotate_3f's matrix for (90, 68, 293)
    ("ardupilot", 8, (1, -2, -3)), ("ardupilot", 41, (c7 * 1 + s7 * 3, 2, -s7 * 1 + c7 * 3)),  # PITCH_7
    ("ardupilot", 42, (1, S * (2 - 3), S * (2 + 3))), ("ardupilot", 43, (1, S * (2 + 3), S * (3 - 2))),
    ("ardupilot", 38, (0.143039 + 0.368776 * 2 - 0.918446 * 3, -0.332133 - 0.856289 * 2 - 0.395546 * 3,
                       -0.932324 + 0.361625 * 2)),  # Vector3::rotate's matrix
]  # fmt: skip


@pytest.mark.parametrize("autopilot, number, expected", BY_HAND)
def test_rotations_move_a_vector_as_the_autopilots_formulas(autopilot, number, expected):
    np.testing.assert_allclose(rotation_matrix(autopilot, number) @ V, expected, atol=5e-6)


def test_the_autopilots_differ_only_where_their_lists_do():
    for n in range(41):
        same = np.allclose(rotation_matrix("px4", n), rotation_matrix("ardupilot", n), atol=1e-12)
        assert same == (n != 38), n
    assert not np.allclose(rotation_matrix("px4", 41), rotation_matrix("ardupilot", 41))


def test_custom_rotations_read_their_angles_from_parameters():
    params = {"CUST_ROT1_ROLL": 180.0, "CUST_ROT1_PITCH": 0.0, "CUST_ROT1_YAW": 225.0}
    np.testing.assert_allclose(rotation_matrix("ardupilot", 101, params), rotation_matrix("ardupilot", 13))
    old = {"AHRS_CUSTOM_ROLL": 90.0, "AHRS_CUSTOM_PIT": 0.0, "AHRS_CUSTOM_YAW": 0.0}
    np.testing.assert_allclose(rotation_matrix("ardupilot", 100, old), rotation_matrix("ardupilot", 16))
    with pytest.raises(ConfigError, match="CUST_ROT2_ROLL.*--board-rotation"):
        rotation_matrix("ardupilot", 102, params, where="x.bin: AHRS_ORIENTATION")
    assert rotation_name("ardupilot", 101) == "101 (CUSTOM)" and rotation_name("px4", 8) == "8 (ROLL_180)"


@pytest.mark.parametrize("autopilot, number", [("px4", 48), ("px4", 100), ("ardupilot", 44), ("ardupilot", -1)])
def test_numbers_no_autopilot_defines_are_refused(autopilot, number):
    with pytest.raises(ConfigError, match="is not a rotation"):
        rotation_matrix(autopilot, number)


def test_board_rotation_option():
    R, how = parse_rotation("8", "ardupilot")
    np.testing.assert_allclose(R, np.diag([1.0, -1.0, -1.0]), atol=1e-15)
    assert how == "--board-rotation 8 (ROLL_180)"
    R, how = parse_rotation("0, 0, 90", "px4")
    np.testing.assert_allclose(R, rotation_matrix("px4", 2), atol=1e-15)
    for bad in ("roll", "1,2", "48", "nan,0,0"):
        with pytest.raises(ConfigError, match="--board-rotation"):
            parse_rotation(bad, "px4")

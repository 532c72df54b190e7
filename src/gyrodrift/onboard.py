"""What the autopilot did to a log's gyro rates, and what its thermal calibration does.

:class:`Onboard` records a gyro's board rotation, identity and the thermal correction its
logged rates hold; :class:`ThermalCorrection` evaluates PX4's or ArduPilot's correction as
the autopilot does (in 32-bit floats on request). The autopilots' rules, with their sources:
docs/autopilot-files.md, sections "What the autopilot did to the rates", "PX4" and "ArduPilot".
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.rotations import euler_matrix, rotation_matrix, rotation_name

__all__ = [
    "ThermalCorrection", "Onboard", "px4_correction", "px4_slots", "ardupilot_correction", "ardupilot_onboard",
    "px4_onboard", "px4_sensor_rotation", "uint32", "ARDUPILOT_TREF_C", "ARDUPILOT_SCALE",
]

#: ArduPilot's fixed reference temperature, degC, and the scale of its stored coefficients.
ARDUPILOT_TREF_C = 35.0
ARDUPILOT_SCALE = 1.0e6
_ORDER = 3
#: ArduPilot's INS_GYRn_CALTEMP before any gyro calibration, degC.
_NO_CALTEMP_C = -300.0


def uint32(value) -> int:
    """A device id as PX4 compares it: the 32 bits of an int32 parameter, unsigned."""
    return int(value) & 0xFFFFFFFF


@dataclass(frozen=True)
class ThermalCorrection:
    """An autopilot's thermal correction of one gyro, in its sensor axes."""

    coeffs: tuple  #: ``coeffs[k][axis]``: coefficient of ``(T - temp_ref_c)**k``, rad/s per degC**k
    temp_ref_c: float  #: reference temperature, degC
    temp_min_c: float  #: clip range, degC
    temp_max_c: float
    cal_temp_c: float | None  #: ArduPilot: the temperature whose polynomial value is added back (PX4: None)
    names: str  #: the parameters it comes from, e.g. "TC_G0_* (TC_G_ENABLE=1)"

    def offset_rad_s(self, temp_c, *, float32: bool = False) -> np.ndarray:
        """What the autopilot subtracts at ``temp_c`` (degC): (n, 3), rad/s, sensor axes;
        ``float32`` evaluates in 32-bit floats as the autopilots do."""
        kind = np.float32 if float32 else np.float64
        temp = np.atleast_1d(np.asarray(temp_c, dtype=np.float64)).astype(kind)
        c = np.asarray(self.coeffs, dtype=np.float64).astype(kind)
        lo, hi, ref = (kind(v) for v in (self.temp_min_c, self.temp_max_c, self.temp_ref_c))

        def poly(t):
            d = (np.minimum(np.maximum(t, lo), hi) - ref)[:, None]
            if self.cal_temp_c is None:  # PX4: X0 + X1 d + X2 d^2 + X3 d^3
                d2 = d * d
                return c[0] + c[1] * d + c[2] * d2 + c[3] * (d2 * d)
            return ((c[3] * d + c[2]) * d + c[1]) * d + c[0]  # ArduPilot's polynomial_eval (c[0] = 0)

        out = poly(temp)
        if self.cal_temp_c is not None:
            out = out - poly(np.array([self.cal_temp_c], dtype=kind))
        return out.astype(np.float64)

    def offset_dps(self, temp_c, rotation=None, *, float32: bool = False) -> np.ndarray:
        """The offset in deg/s, turned to the body frame by ``rotation`` (``v_body = R v_sensor``)."""
        off = np.degrees(self.offset_rad_s(temp_c, float32=float32))
        return off if rotation is None else off @ np.asarray(rotation, dtype=float).T


def _need(params: Mapping, names, where: str, what: str) -> list[float]:
    missing = [n for n in names if n not in params]
    if missing:
        raise ConfigError(f"{where}: {what}, but {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''} "
                          "not found")
    values = [float(params[n]) for n in names]
    bad = [n for n, v in zip(names, values) if not math.isfinite(v)]
    if bad:
        raise ConfigError(f"{where}: {what}, but {bad[0]} is not a finite number")
    return values


def px4_slots(params: Mapping) -> list[int]:
    """The ``TC_G{i}`` slots a parameter set holds (those with a ``TC_G{i}_ID``)."""
    return sorted({int(m.group(1)) for n in params if (m := re.fullmatch(r"TC_G(\d)_ID", n))})


def px4_correction(params: Mapping, device_id: int | None, *, slot: int | None = None,
                   where: str = "parameters") -> tuple[ThermalCorrection | None, str]:
    """PX4's gyro thermal correction of the gyro with ``device_id`` (docs/autopilot-files.md,
    section "PX4"): the correction, or None and why PX4 applies none.

    With ``device_id`` None (unknown, e.g. a CSV log) slot ``slot`` is taken as the one that
    applies. A slot that applies but lacks a parameter is a :class:`ConfigError` naming ``where``.
    """
    enable = params.get("TC_G_ENABLE")
    if enable is None or int(enable) != 1:
        return None, f"TC_G_ENABLE is {'not set' if enable is None else int(enable)}, not 1"
    slots = px4_slots(params)
    if device_id is None:
        if slot is None or slot not in slots:
            return None, f"no TC_G{slot if slot is not None else ''} slot (slots: {slots or 'none'})"
        chosen = slot
    else:
        matching = [i for i in slots if uint32(params[f"TC_G{i}_ID"]) == uint32(device_id)]
        if not matching:
            ids = ", ".join(f"TC_G{i}_ID={uint32(params[f'TC_G{i}_ID'])}" for i in slots) or "no TC_G slot"
            return None, f"no TC_G slot holds the gyro's device id {uint32(device_id)} ({ids})"
        chosen = matching[0]
    g = f"TC_G{chosen}_"
    what = f"TC_G_ENABLE=1 and {g}ID applies"
    t_ref, t_min, t_max = _need(params, [g + "TREF", g + "TMIN", g + "TMAX"], where, what)
    names = [f"{g}X{k}_{a}" for k in range(_ORDER + 1) for a in range(3)]
    values = np.array(_need(params, names, where, what)).reshape(_ORDER + 1, 3)
    coeffs = tuple(tuple(float(v) for v in row) for row in values)
    return ThermalCorrection(coeffs, t_ref, t_min, t_max, None, f"{g}* (TC_G_ENABLE=1)"), ""


def ardupilot_correction(params: Mapping, imu: int, *, where: str = "parameters",
                         ) -> tuple[ThermalCorrection | None, str]:
    """ArduPilot's gyro temperature correction of IMU ``imu`` (0 = ``INS_TCAL1``): the correction,
    or None and why ArduPilot applies none; a :class:`ConfigError` when ``ENABLE`` is 1 but a
    coefficient or the range is missing (docs/autopilot-files.md, section "ArduPilot")."""
    p = f"INS_TCAL{imu + 1}_"
    enable = params.get(p + "ENABLE")
    if enable is None or int(enable) != 1:
        return None, f"{p}ENABLE is {'not set' if enable is None else int(enable)}, not 1"
    what = f"{p}ENABLE=1"
    t_min, t_max = _need(params, [p + "TMIN", p + "TMAX"], where, what)
    names = [f"{p}GYR{k}_{'XYZ'[a]}" for k in range(1, _ORDER + 1) for a in range(3)]
    stored = np.array(_need(params, names, where, what)).reshape(_ORDER, 3) / ARDUPILOT_SCALE
    coeffs = ((0.0, 0.0, 0.0), *(tuple(float(v) for v in row) for row in stored))
    cal_temp = float(params.get(f"INS_GYR{imu + 1}_CALTEMP", _NO_CALTEMP_C))
    return ThermalCorrection(coeffs, ARDUPILOT_TREF_C, t_min, t_max, cal_temp, f"{p}* ({p}ENABLE=1)"), ""


@dataclass(frozen=True)
class Onboard:
    """What the autopilot did to the gyro rates of a log (docs/autopilot-files.md)."""

    autopilot: str  #: "px4" or "ardupilot"
    instance: int  #: PX4 ``sensor_gyro`` instance (its ``TC_G`` slot), ArduPilot IMU (0 = ``INS_TCAL1``)
    device_id: int | None  #: PX4 ``sensor_gyro.device_id``; ArduPilot ``INS_GYR_ID`` (``INS_GYR2_ID`` ...)
    rotation: tuple | None  #: ``R`` with ``v_body = R @ v_sensor``; None when unusable
    rotation_text: str  #: where ``R`` comes from, e.g. "AHRS_ORIENTATION=8 (ROLL_180)"
    correction: ThermalCorrection | None = None  #: the thermal correction the logged rates hold
    correction_problem: str = ""  #: why that correction cannot be undone ("" when it can or there is none)
    rotation_problem: str = ""  #: why ``rotation`` is None ("" otherwise)
    system_id: int | None = None  #: the vehicle's MAVLink system id
    #: the magnetic declination the autopilot used, deg east, and its parameter (None: not in the log)
    declination: tuple[float, str] | None = None

    @property
    def matrix(self) -> np.ndarray | None:
        """``rotation`` as a 3x3 array (None without one)."""
        return None if self.rotation is None else np.array(self.rotation, dtype=float)

    @property
    def gyro_name(self) -> str:
        """The gyro, e.g. ``"IMU 0"`` or ``"sensor_gyro 1 (device id 2424842)"``."""
        gyro = f"sensor_gyro {self.instance}" if self.autopilot == "px4" else f"IMU {self.instance}"
        return gyro + (f" (device id {self.device_id})" if self.device_id else "")


def _system_id(params: Mapping, name: str) -> int | None:
    value = params.get(name)
    return int(value) if value is not None and 1 <= int(value) <= 255 else None


def _as_tuple(matrix: np.ndarray) -> tuple:
    return tuple(tuple(float(v) for v in row) for row in np.asarray(matrix, dtype=float))


def _declination(params: Mapping, name: str, to_deg: float) -> tuple[float, str] | None:
    """The declination parameter ``name`` in degrees (its value times ``to_deg``) and its
    name, or None where the log does not have it or it is 0 (not set)."""
    value = params.get(name)
    if value is None or not math.isfinite(float(value)) or float(value) == 0.0:
        return None
    deg = float(value) * to_deg
    return (deg, f"{name}={float(value):g}") if abs(deg) <= 180.0 else None


def _changed(changed, names) -> list[str]:
    return sorted(n for n in names if n in changed)


def _moved(where: str, name: str) -> str:
    """Why the rotation is unusable: its parameter ``name`` changed during the log."""
    return f"{where}: {name} changed during the log; cut the log where it is constant or give --board-rotation"


def _held_correction(find, changed: list[str], temperature: bool, where: str, enabled: str, sensor: str,
                     off: str) -> tuple[ThermalCorrection | None, str]:
    """The correction the logged rates hold (``find()``) and why it cannot be undone ("" when it
    can): a parameter missing, one of ``changed`` changed during the log, or no temperature."""
    correction, problem = None, ""
    try:
        correction, _ = find()
    except ConfigError as exc:
        problem = f"{exc}: the correction the log's rates hold cannot be undone"
    if changed:
        problem = f"{where}: {sorted(changed)[0]} changed during the log, so the correction its rates hold changed: " \
                  "cut the log where it is constant, or record the run again with the setting fixed"
    elif correction is not None and not temperature:
        problem = f"{where}: {enabled} but the log has no {sensor} temperature: the correction its rates hold " \
                  f"cannot be undone; record the run with {off}"
    return correction, problem


def ardupilot_onboard(params: Mapping, instance: int, *, changed=(), temperature: bool = True,
                      where: str = "log") -> Onboard:
    """:class:`Onboard` of IMU ``instance`` of an ArduPilot log (rates after ``INS_TCALn`` and
    ``AHRS_ORIENTATION``), from its ``params`` (the last value of each), the parameters
    ``changed`` during the log and whether it holds the IMU's ``temperature``."""
    number = int(params.get("AHRS_ORIENTATION", 0))
    rotation, rotation_problem = None, ""
    try:
        rotation = _as_tuple(rotation_matrix("ardupilot", number, params, where=f"{where}: AHRS_ORIENTATION"))
    except ConfigError as exc:
        rotation_problem = str(exc)
    moved = _changed(changed, ["AHRS_ORIENTATION", "CUST_ROT1_ROLL", "CUST_ROT1_PITCH", "CUST_ROT1_YAW",
                               "CUST_ROT2_ROLL", "CUST_ROT2_PITCH", "CUST_ROT2_YAW"])
    if moved and not rotation_problem:
        rotation, rotation_problem = None, _moved(where, moved[0])
    text = f"AHRS_ORIENTATION={rotation_name('ardupilot', number)}" + ("" if "AHRS_ORIENTATION" in params
                                                                       else " (not in the log: 0 taken)")
    dev_name = "INS_GYR_ID" if instance == 0 else f"INS_GYR{instance + 1}_ID"
    device = uint32(params[dev_name]) if dev_name in params else None
    p = f"INS_TCAL{instance + 1}_"
    tcal = [n for n in changed if n.startswith(p) or n == f"INS_GYR{instance + 1}_CALTEMP"]
    correction, problem = _held_correction(lambda: ardupilot_correction(params, instance, where=where), tcal,
                                           temperature, where, f"{p}ENABLE=1", "IMU", "INS_TCAL disabled")
    return Onboard("ardupilot", instance, device, rotation, text, correction, problem, rotation_problem,
                   _system_id(params, "SYSID_THISMAV"), _declination(params, "COMPASS_DEC", math.degrees(1.0)))


def px4_sensor_rotation(params: Mapping, kind: str, device: int | None, *, where: str = "log"
                        ) -> tuple[np.ndarray, str]:
    """PX4's rotation from a sensor's frame to the body frame, and its description.

    ``kind`` is "GYRO", "ACC" or "MAG" (``CAL_<kind>n_ID``); ``device`` the sensor's device id
    (docs/autopilot-files.md, section "What the autopilot did to the rates"). A rotation
    number PX4 does not define is a :class:`ConfigError`.
    """
    slot = None
    if device is not None:
        slot = next((n for n in range(4) if uint32(params.get(f"CAL_{kind}{n}_ID", 0)) == uint32(device)), None)
    own = int(params.get(f"CAL_{kind}{slot}_ROT", -1)) if slot is not None else -1
    if own >= 0:
        param = f"CAL_{kind}{slot}_ROT"
        return rotation_matrix("px4", own, where=f"{where}: parameter {param}"), \
            f"{param}={rotation_name('px4', own)}"
    board = int(params.get("SENS_BOARD_ROT", 0))
    trims = [float(params.get(f"SENS_BOARD_{a}_OFF", 0.0)) for a in "XYZ"]
    matrix = euler_matrix(*trims) @ rotation_matrix("px4", board, where=f"{where}: parameter SENS_BOARD_ROT")
    how = f"SENS_BOARD_ROT={rotation_name('px4', board)}"
    return matrix, how + (" and the SENS_BOARD_*_OFF level trims" if any(trims) else "")


def px4_onboard(params: Mapping, instance: int, device_id: int | None, rotation: np.ndarray, rotation_text: str,
                *, corrected: bool, changed=(), temperature: bool = True, where: str = "log") -> Onboard:
    """:class:`Onboard` of ``sensor_gyro`` instance ``instance`` of a PX4 log.

    ``rotation`` is the sensor-to-body rotation the reader applied, ``rotation_text`` where it
    comes from; ``corrected`` is True for PX4's corrected rates (``sensor_combined``), False
    for raw ``sensor_gyro``; ``changed`` the parameters that changed during the log and
    ``temperature`` whether it holds the gyro's temperature.
    """
    correction, problem = None, ""
    if corrected:
        tc = [n for n in changed if n.startswith("TC_G")]
        correction, problem = _held_correction(lambda: px4_correction(params, device_id, slot=instance, where=where),
                                               tc, temperature, where, "TC_G_ENABLE=1", "gyro", "TC_G_ENABLE=0")
    moved = sorted(n for n in changed if n.startswith("SENS_BOARD_") or re.fullmatch(r"CAL_GYRO\d_ROT", n))
    rotation_problem = _moved(where, moved[0]) if moved else ""
    return Onboard("px4", instance, device_id, None if moved else _as_tuple(rotation), rotation_text, correction,
                   problem, rotation_problem, _system_id(params, "MAV_SYS_ID"), _declination(params, "EKF2_MAG_DECL", 1.0))


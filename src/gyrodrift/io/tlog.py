"""Read MAVLink telemetry logs (``.tlog``) into the gyrodrift input contract (needs pymavlink).

The framing is walked here and only the messages used are decoded. Which messages give
which column, and how reboots and damage are handled: docs/log-formats.md, section
"MAVLink telemetry logs".
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.errors import ConfigError
from gyrodrift.io.align import (
    Stream, binary_log_frame, check_reader_options, check_temperature, describe_rate, increasing, interp_held,
    last_values, no_instance, on_following_rows, read_summary, reference_heading,
)
from gyrodrift.io.limits import GYRO_MAX_DPS
from gyrodrift.io.messages import log_error, optional_module, read_log_bytes
from gyrodrift.onboard import ardupilot_onboard, px4_onboard, px4_sensor_rotation

__all__ = ["read_tlog", "read_tlog_imus", "REBOOT_S"]

#: A vehicle clock that goes back by more than this (s) is a reboot.
REBOOT_S = 5.0
_MIN_IMU_SAMPLES = 2
_ARDUPILOT, _PX4 = 3, 12  # MAV_AUTOPILOT
_GCS_TYPE = 6  # MAV_TYPE_GCS
_V1, _V2 = 0xFE, 0xFD
#: Arrival times outside 2000..2100 (µs since 1970) are no tlog record: resynchronise.
_STAMP_RANGE_US = (946_684_800_000_000, 4_102_444_800_000_000)
_MG_TO_MPS2 = 9.80665e-3
_IMU_NAMES = {_ARDUPILOT: ("RAW_IMU", "SCALED_IMU2", "SCALED_IMU3")}
_OTHER_IMU_NAMES = ("SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3")
_WANTED = ("HEARTBEAT", "PARAM_VALUE", "RAW_IMU", "SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3", "SCALED_PRESSURE",
           "ATTITUDE")
#: MAV_PARAM_TYPE of the integers and the struct code of their bytes (PX4's bytewise encoding).
_INT_TYPES = {1: "<B", 2: "<b", 3: "<H", 4: "<h", 5: "<I", 6: "<i"}


class _Packets(NamedTuple):
    """What the walk over a tlog found."""

    messages: dict  #: message name -> list of (arrival s, decoded message)
    autopilot: int | None  #: MAV_AUTOPILOT of the vehicle
    system: int | None  #: its system id
    skipped: int  #: bytes of no tlog record
    bad: int  #: packets of a wanted message whose checksum or length failed


def _frame_length(data: bytes, pos: int) -> int:
    """Length of the MAVLink packet starting at ``pos`` (0: no packet starts there)."""
    if pos + 2 > len(data):
        return 0
    magic, length = data[pos], data[pos + 1]
    if magic == _V1:
        return 8 + length
    if magic == _V2 and pos + 3 <= len(data):
        return 12 + length + (13 if data[pos + 2] & 0x01 else 0)
    return 0


def _record_at(data: bytes, pos: int) -> int:
    """Length of the tlog record (stamp + packet) at ``pos``, 0 when none starts there."""
    if pos + 8 > len(data):
        return 0
    stamp = struct.unpack_from(">Q", data, pos)[0]
    size = _frame_length(data, pos + 8)
    if not (_STAMP_RANGE_US[0] <= stamp < _STAMP_RANGE_US[1]) or size == 0 or pos + 8 + size > len(data):
        return 0
    return 8 + size


def _walk(data: bytes, dialect) -> _Packets:
    """Decode the wanted messages of every record, resynchronising over corrupt bytes."""
    ids = {getattr(dialect, f"MAVLINK_MSG_ID_{n}"): n for n in _WANTED}
    mav = dialect.MAVLink(None)
    mav.robust_parsing = True
    found: dict[str, list] = {n: [] for n in _WANTED}
    pos, skipped, bad = 0, 0, 0
    autopilot = system = None
    while pos < len(data):
        size = _record_at(data, pos)
        if size == 0:
            pos, skipped = pos + 1, skipped + 1
            continue
        start = pos + 8
        v2 = data[start] == _V2
        msg_id = int.from_bytes(data[start + 7:start + 10], "little") if v2 else data[start + 5]
        src_system, src_comp = (data[start + 5], data[start + 6]) if v2 else (data[start + 3], data[start + 4])
        name = ids.get(msg_id)
        if name is not None:
            try:
                msg = mav.decode(bytearray(data[start:pos + size]))
            except Exception:  # a third-party decoder on untrusted bytes: a bad checksum or length
                msg = None
            if msg is None:
                bad += 1
            elif name == "HEARTBEAT" and system is None and src_comp == 1 and msg.type != _GCS_TYPE:
                autopilot, system = int(msg.autopilot), src_system
            if msg is not None and (system is None or src_system == system):
                found[name].append((struct.unpack_from(">Q", data, pos)[0] * 1e-6, src_system, msg))
        pos += size
    if system is not None:  # packets seen before the first heartbeat: keep the vehicle's only
        found = {n: [m for m in v if m[1] == system] for n, v in found.items()}
    return _Packets({n: [(a, m) for a, _, m in v] for n, v in found.items()}, autopilot, system, skipped, bad)


def _params(packets: _Packets) -> tuple[dict, set]:
    """``PARAM_VALUE`` name -> the last value, and the names received with more than one value."""
    return last_values(_param_value(packets.autopilot, msg) for _, msg in packets.messages["PARAM_VALUE"])


def _param_value(autopilot: int | None, msg) -> tuple[str, float]:
    """Name and value of a ``PARAM_VALUE``, a PX4 integer decoded from the float's bytes."""
    value = float(msg.param_value)
    code = _INT_TYPES.get(int(msg.param_type))
    if autopilot == _PX4 and code is not None:  # bytewise: the float's bytes hold the integer
        value = float(struct.unpack_from(code, struct.pack("<f", value))[0])
    return str(msg.param_id).split("\0", 1)[0], value


def _vehicle_time(msg) -> float:
    return msg.time_usec * 1e-6 if hasattr(msg, "time_usec") else msg.time_boot_ms * 1e-3


def _boots(imu_rows: list) -> list[tuple[float, float]]:
    """The vehicle's boots: ranges of ``arrival - vehicle clock`` (s) of the IMU messages,
    split where the sorted offsets jump by more than :data:`REBOOT_S`."""
    offsets = np.sort([arrival - _vehicle_time(msg) for arrival, msg in imu_rows])
    cuts = np.flatnonzero(np.diff(offsets) > REBOOT_S)
    starts, ends = np.r_[0, cuts + 1], np.r_[cuts, offsets.size - 1]
    return [(float(offsets[a]), float(offsets[b])) for a, b in zip(starts, ends)]


def _imu_names(autopilot: int | None) -> tuple[str, ...]:
    return _IMU_NAMES.get(autopilot, _OTHER_IMU_NAMES)


def _rows(packets: _Packets, name: str, boot) -> list:
    """The messages ``name`` of one boot (:func:`_boots`)."""
    lo, hi = boot[0] - 0.5 * REBOOT_S, boot[1] + 0.5 * REBOOT_S
    return [m for a, m in packets.messages[name] if lo <= a - _vehicle_time(m) <= hi]


def _imu_stream(msgs: list, label: str) -> Stream:
    """Gyro (deg/s), acc (m/s²), mag (gauss) and temperature (cdegC, 0: none) as one stream of 10 columns."""
    t = np.array([_vehicle_time(m) for m in msgs], dtype=np.float64)
    fields = np.array([[m.xgyro, m.ygyro, m.zgyro, m.xacc, m.yacc, m.zacc, m.xmag, m.ymag, m.zmag,
                        getattr(m, "temperature", 0) or 0] for m in msgs], dtype=np.float64).reshape(-1, 10)
    values = np.column_stack([np.degrees(fields[:, :3] * 1e-3), fields[:, 3:6] * _MG_TO_MPS2, fields[:, 6:9] * 1e-3,
                              fields[:, 9]])
    return Stream(label, t, values)


def _temperature(imu: Stream, pressure: list) -> tuple[Stream | None, str]:
    """The IMU's own temperature, else the barometer's (degC); None and why there is none."""
    imu_temp = imu.values[:, 9]
    if np.any(imu_temp != 0.0):
        ok = imu_temp != 0.0
        return Stream(f"{imu.label}.temperature", imu.t[ok], imu_temp[ok] * 0.01), ""
    temps = [(m.time_boot_ms * 1e-3, m.temperature * 0.01) for m in pressure if m.temperature != 0]
    if temps:
        t, v = np.array(temps).T
        return Stream("SCALED_PRESSURE.temperature (the barometer's, on the board)", t, v), ""
    return None, f"{imu.label} has no temperature and there is no SCALED_PRESSURE message"


def _onboard(autopilot, params, changed, instance: int, has_temp: bool, name: str):
    """:class:`gyrodrift.onboard.Onboard` of the IMU (None for an autopilot not known here)."""
    if autopilot == _ARDUPILOT:
        return ardupilot_onboard(params, instance, changed=changed, temperature=has_temp, where=name)
    if autopilot == _PX4:
        device = params.get(f"CAL_GYRO{instance}_ID")
        device = int(device) & 0xFFFFFFFF if device else None
        try:
            rotation, how = px4_sensor_rotation(params, "GYRO", device, where=name)
        except ConfigError:
            return None
        return px4_onboard(params, instance, device, rotation, how, corrected=True, changed=changed,
                           temperature=has_temp, where=name)
    return None


def _open(path) -> tuple[str, _Packets]:
    dialect = optional_module("pymavlink.dialects.v20.ardupilotmega", "reading MAVLink telemetry logs (.tlog)",
                              "pymavlink", "ardupilot")
    path = Path(path)
    name = str(path)
    data = read_log_bytes(path, "a telemetry log", "give the path of a .tlog file",
                          "give a .tlog recorded by a ground station")
    packets = _walk(data, dialect)
    if not any(packets.messages[n] for n in ("RAW_IMU", "SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3")):
        what = "no MAVLink packets" if packets.skipped and not any(packets.messages.values()) else "no IMU messages"
        raise log_error(name, f"{what} (RAW_IMU or SCALED_IMU*) found", "give a .tlog recorded with the "
                        "IMU stream on (Mission Planner: SRn_RAW_SENS; QGroundControl: the vehicle's "
                        "SCALED_IMU rate)")
    return name, packets


def read_tlog_imus(path, *, mag_instance: int | None = None, reference: bool = True,
                   gyro_max_dps: float = GYRO_MAX_DPS, instances=None) -> list[pd.DataFrame]:
    """Every IMU of a telemetry log (or the ``instances`` listed), each as :func:`read_tlog` reads
    one, in instance order."""
    gyro_max_dps = check_reader_options(instances, mag_instance, gyro_max_dps)
    name, packets = _open(path)
    names = _imu_names(packets.autopilot)
    present = [k for k, n in enumerate(names) if packets.messages[n]]
    if instances is None:
        instances = present
    for k in (*instances, *([mag_instance] if mag_instance is not None else [])):
        if k not in present:
            raise no_instance(name, "IMU", k, present, "instance")
    params, changed = _params(packets)
    return [_read(packets, params, changed, name, k, mag_instance, reference, gyro_max_dps) for k in instances]


def read_tlog(path, *, instance: int = 0, mag_instance: int | None = None, reference: bool = True,
              gyro_max_dps: float = GYRO_MAX_DPS) -> pd.DataFrame:
    """Read a MAVLink telemetry log (``.tlog``) into the gyrodrift input contract.

    See docs/log-formats.md, section "MAVLink telemetry logs", for the messages each
    column comes from.

    Parameters
    ----------
    path : str or os.PathLike
    instance : int, default 0
        IMU instance (ArduPilot: ``RAW_IMU`` 0, ``SCALED_IMU2`` 1, ``SCALED_IMU3`` 2).
    mag_instance : int, optional
        The IMU message whose magnetometer is the compass (default: ``instance``'s).
    reference : bool, default True
        Add ``ref_heading`` (deg) from ``ATTITUDE.yaw``.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        One row per IMU sample, ``t`` on the vehicle's clock; ``attrs`` as
        docs/log-formats.md, section "Alignment", with ``format`` "tlog" and ``onboard``
        (ArduPilot and PX4).

    Raises
    ------
    LogFormatError
        Missing, empty or unreadable file; no IMU message; fewer than 2 IMU samples; an
        implausible value.
    ConfigError
        pymavlink is not installed; ``instance`` or ``mag_instance`` not in the log.
    """
    return read_tlog_imus(path, mag_instance=mag_instance, reference=reference, gyro_max_dps=gyro_max_dps,
                          instances=[instance])[0]


def _read(packets: _Packets, params, changed, name: str, instance: int, mag_instance, reference: bool,
          gyro_max_dps: float) -> pd.DataFrame:
    names = _imu_names(packets.autopilot)
    boots = _boots(packets.messages[names[instance]])
    counts = [len(_rows(packets, names[instance], boot)) for boot in boots]
    boot = boots[int(np.argmax(counts))]
    gyro, dropped = increasing(_imu_stream(_rows(packets, names[instance], boot), names[instance]))
    if gyro.t.size < _MIN_IMU_SAMPLES:
        raise log_error(name, f"too few IMU samples ({gyro.t.size}) in {names[instance]}",
                        f"give a log with at least {_MIN_IMU_SAMPLES} IMU samples")
    t = gyro.t
    temp, no_temp_why = _temperature(gyro, _rows(packets, "SCALED_PRESSURE", boot))
    if temp is not None:
        temp = increasing(temp)[0]
        check_temperature(name, temp.label, temp.values)
    compass = gyro if mag_instance is None or mag_instance == instance else \
        increasing(_imu_stream(_rows(packets, names[mag_instance], boot), names[mag_instance]))[0]
    mag = Stream(compass.label, compass.t, compass.values[:, 6:9])
    mag_ok = np.any(mag.values != 0.0, axis=1)
    mag = Stream(mag.label, mag.t[mag_ok], mag.values[mag_ok])
    mag_on_rows, mag_rows = on_following_rows(t, mag.t, mag.values) if mag.t.size else (None, 0)
    no_compass_why = "" if mag_rows else f"the magnetometer of {mag.label} reads 0 in every sample"
    att = _rows(packets, "ATTITUDE", boot) if reference else []
    ref = Stream("ATTITUDE", np.array([m.time_boot_ms * 1e-3 for m in att]), np.degrees([m.yaw for m in att])) \
        if att else None
    ref_heading, extra = reference_heading(ref, t, reference, "ATTITUDE.yaw", "no ATTITUDE messages, so no ref_heading")
    if len(boots) > 1:
        extra.append(f"the vehicle rebooted {len(boots) - 1} time(s) during the log: the boot with the most "
                     f"{names[instance]} samples is read")
    if dropped:
        extra.append(f"{dropped} IMU samples with a repeated time stamp dropped")
    if packets.skipped:
        extra.append(f"{packets.skipped} bytes that are no tlog record skipped")
    if packets.bad:
        extra.append(f"{packets.bad} packets with a bad checksum dropped")
    onboard = _onboard(packets.autopilot, params, changed, instance, temp is not None, name)
    compass_part = f"compass: mag from {mag.label} (on {mag_rows} rows)" if mag_rows else "no compass"
    summary = read_summary(name, t, f"gyro {describe_rate(t)} from {names[instance]}", temp, [compass_part], extra,
                           temp_rate=False)
    topics = {"gyro": names[instance], "temp": temp.label if temp is not None else None,
              "mag": mag.label if mag_rows else None, "acc": names[instance],
              "ref_heading": "ATTITUDE" if ref_heading is not None else None}
    return binary_log_frame(
        name, "tlog", t, gyro.values[:, :3], interp_held(temp.t, temp.values, t) if temp is not None else None,
        mag_on_rows if mag_rows else None, gyro.values[:, 3:6], ref_heading, topics=topics, summary=summary,
        no_compass_why=no_compass_why, no_temp_why=no_temp_why, gyro_max_dps=gyro_max_dps, onboard=onboard)

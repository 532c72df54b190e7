"""Read MAVLink telemetry logs (``.tlog``) into the gyrodrift input contract.

A ``.tlog`` is what a ground station (Mission Planner, QGroundControl, MAVProxy) records
of the telemetry link: each MAVLink packet as received, after the time it arrived (8
bytes, big-endian, µs since 1970). The IMU messages come at the stream rate the ground
station asked for, 1 to 10 Hz, irregularly (packets are lost, or late); for many users it
is the only record of a warm-up. Needs the optional package pymavlink (``pip install
'gyrodrift[ardupilot]'``), whose ``ardupilotmega`` dialect decodes the packets; the
framing is walked here, so that only the messages used are decoded, a corrupt stretch is
skipped and counted, and a packet whose checksum fails is dropped and counted.

Which messages give which column (MAVLink ``common.xml``; ArduPilot ``GCS_Common.cpp``)
-------------------------------------------------------------------------------------
Only the packets of the vehicle's autopilot are read: the system of the first
``HEARTBEAT`` from a component that is not a ground station, component 1
(``MAV_COMP_ID_AUTOPILOT1``). Its ``autopilot`` field says whose numbering applies.

``t`` (s)
    The vehicle's own clock of the IMU message (``time_boot_ms`` ms, or ``time_usec``
    µs for ``RAW_IMU``), not the arrival time. Packets that arrive out of order are
    sorted; a reboot (the vehicle clock's offset from the arrival time moving by more
    than :data:`REBOOT_S`) splits the log, and only the boot with the most IMU samples
    is read (the summary says so).
``gyro_x``, ``gyro_y``, ``gyro_z`` (deg/s, body FRD), ``acc_*`` (m/s²), ``mag_*`` (gauss)
    IMU instance ``instance``: ArduPilot (``MAV_AUTOPILOT_ARDUPILOTMEGA``) sends IMU 0 as
    ``RAW_IMU``, IMU 1 as ``SCALED_IMU2``, IMU 2 as ``SCALED_IMU3``, all in mrad/s, mG and
    mgauss, in the body frame after its calibration, ``INS_TCAL`` correction and
    ``AHRS_ORIENTATION``, as the DataFlash ``IMU`` message
    (:class:`gyrodrift.onboard.Onboard` as for a ``.bin``); other autopilots send
    ``SCALED_IMU``, ``SCALED_IMU2``, ``SCALED_IMU3`` (``RAW_IMU`` is raw counts there, and
    not read). The magnetometer of the same message is the compass (``mag_instance``:
    that of another IMU message); one that reads 0 in every sample is none.
``temp`` (degC)
    The IMU message's ``temperature`` (cdegC; a MAVLink 2 extension, 0 meaning "not
    provided"), else the first barometer's, ``SCALED_PRESSURE.temperature`` (cdegC), the
    board's temperature near the IMU (the summary says which), interpolated onto the
    IMU samples. None of them: ``temp`` is 0 and a note says so (:mod:`gyrodrift.io.notes`).
``ref_heading`` (deg, [0, 360)), with ``reference=True``
    ``ATTITUDE.yaw`` (rad) interpolated in unwrapped form onto the IMU samples.

Parameters come from the ``PARAM_VALUE`` messages the ground station received (the last
value of each; PX4 sends integers bytewise in the float, ``MAV_PROTOCOL_CAPABILITY_
PARAM_ENCODE_BYTEWISE``, decoded here). Errors are one line, ``<file>: <problem>; <what
to do>``, as in :mod:`gyrodrift.io.validate`.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io.align import (
    Stream,
    check_temperature,
    binary_log_frame,
    describe_rate,
    increasing,
    interp_heading,
    interp_held,
    on_following_rows,
)
from gyrodrift.io.ardupilot import _check_instance  # the same rule for both MAVLink logs
from gyrodrift.io.limits import GYRO_MAX_DPS, check_gyro_max_dps
from gyrodrift.io.notes import NO_TEMPERATURE_C
from gyrodrift.io.messages import message, read_log_bytes
from gyrodrift.onboard import ardupilot_onboard, px4_onboard, px4_sensor_rotation

__all__ = ["read_tlog", "read_tlog_imus", "REBOOT_S"]

_INSTALL = "pip install 'gyrodrift[ardupilot]'"
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


def _import_dialect():
    try:
        from pymavlink.dialects.v20 import ardupilotmega
    except ImportError as exc:
        raise ConfigError(
            f"reading MAVLink telemetry logs (.tlog) needs the optional package pymavlink; install it with {_INSTALL}"
        ) from exc
    return ardupilotmega


def _read_bytes(path: Path) -> bytes:
    return read_log_bytes(path, "a telemetry log", "give the path of a .tlog file", "give a .tlog recorded by a ground station")


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
    values: dict[str, float] = {}
    seen: dict[str, set] = {}
    for _, msg in packets.messages["PARAM_VALUE"]:
        name = str(msg.param_id).split("\0", 1)[0]
        value = float(msg.param_value)
        code = _INT_TYPES.get(int(msg.param_type))
        if packets.autopilot == _PX4 and code is not None:  # bytewise: the float's bytes hold the integer
            raw = struct.pack("<f", value)
            value = float(struct.unpack_from(code, raw)[0])
        values[name] = value
        seen.setdefault(name, set()).add(value)
    return values, {n for n, v in seen.items() if len(v) > 1}


def _vehicle_time(msg) -> float:
    return msg.time_usec * 1e-6 if hasattr(msg, "time_usec") else msg.time_boot_ms * 1e-3


def _boots(imu_rows: list) -> list[tuple[float, float]]:
    """The vehicle's boots: ranges of ``arrival - vehicle clock`` (s) of the IMU messages.

    Within a boot that difference is the clock's offset plus the link's delay; a reboot
    moves it by the time the vehicle was up, so gaps wider than :data:`REBOOT_S` between
    the sorted differences separate the boots (a late packet of one boot still falls in
    its own range)."""
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
    dialect = _import_dialect()
    path = Path(path)
    name = str(path)
    packets = _walk(_read_bytes(path), dialect)
    if not any(packets.messages[n] for n in ("RAW_IMU", "SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3")):
        what = "no MAVLink packets" if packets.skipped and not any(packets.messages.values()) else "no IMU messages"
        raise LogFormatError(message(name, f"{what} (RAW_IMU or SCALED_IMU*) found", "give a .tlog recorded with the "
                                     "IMU stream on (Mission Planner: SRn_RAW_SENS; QGroundControl: the vehicle's "
                                     "SCALED_IMU rate)"))
    return name, packets


def read_tlog(path, *, instance: int = 0, mag_instance: int | None = None, reference: bool = True,
              gyro_max_dps: float = GYRO_MAX_DPS) -> pd.DataFrame:
    """Read a MAVLink telemetry log (``.tlog``) into the gyrodrift input contract.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.tlog`` file.
    instance : int, default 0
        IMU instance (module notes: ArduPilot ``RAW_IMU`` 0, ``SCALED_IMU2`` 1,
        ``SCALED_IMU3`` 2).
    mag_instance : int, optional
        The IMU message whose magnetometer is the compass (default: ``instance``'s).
    reference : bool, default True
        Add ``ref_heading`` (deg) from ``ATTITUDE.yaw``.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        One row per IMU sample: ``t`` (s, the vehicle's clock, strictly increasing),
        ``gyro_z``, ``gyro_x``, ``gyro_y`` (deg/s, body FRD), ``temp`` (degC),
        ``mag_*`` (gauss; no columns without a compass), ``acc_*`` (m/s²) and, with
        ``reference``, ``ref_heading`` (deg). ``df.attrs``: ``source``, ``format``
        ("tlog"), ``gyro_unit``, ``frame``, ``compass``, ``mag_unit``, ``acc_unit``,
        ``topics``, ``summary``, ``onboard`` (:class:`gyrodrift.onboard.Onboard`, for
        ArduPilot and PX4) and ``notes`` when the log lacks a compass or a temperature.

    Raises
    ------
    LogFormatError
        Missing, empty or unreadable file; no IMU message; fewer than 2 IMU samples; an
        implausible value.
    ConfigError
        pymavlink is not installed; ``instance`` or ``mag_instance`` not in the log.
    """
    _check_instance(instance, "instance")
    return _read_instances(path, [instance], mag_instance, reference, gyro_max_dps)[0]


def read_tlog_imus(path, *, mag_instance: int | None = None, reference: bool = True,
                   gyro_max_dps: float = GYRO_MAX_DPS) -> list[pd.DataFrame]:
    """Every IMU of a telemetry log, each read as :func:`read_tlog` reads one, in instance order."""
    return _read_instances(path, None, mag_instance, reference, gyro_max_dps)


def _read_instances(path, instances, mag_instance, reference, gyro_max_dps) -> list[pd.DataFrame]:
    _check_instance(mag_instance, "mag_instance", allow_none=True)
    gyro_max_dps = check_gyro_max_dps(gyro_max_dps)
    name, packets = _open(path)
    names = _imu_names(packets.autopilot)
    present = [k for k, n in enumerate(names) if packets.messages[n]]
    if instances is None:
        instances = present
    for k in (*instances, *([mag_instance] if mag_instance is not None else [])):
        if k not in present:
            raise ConfigError(message(name, f"there is no IMU instance {k}; instances present: "
                                      f"{', '.join(map(str, present))}", "choose one of them (instance=N)"))
    params, changed = _params(packets)
    return [_read(packets, params, changed, name, k, mag_instance, reference, gyro_max_dps) for k in instances]


def _read(packets: _Packets, params, changed, name: str, instance: int, mag_instance, reference: bool,
          gyro_max_dps: float) -> pd.DataFrame:
    names = _imu_names(packets.autopilot)
    boots = _boots(packets.messages[names[instance]])
    counts = [len(_rows(packets, names[instance], boot)) for boot in boots]
    boot = boots[int(np.argmax(counts))]
    gyro, dropped = increasing(_imu_stream(_rows(packets, names[instance], boot), names[instance]))
    if gyro.t.size < _MIN_IMU_SAMPLES:
        raise LogFormatError(message(name, f"too few IMU samples ({gyro.t.size}) in {names[instance]}",
                                     f"give a log with at least {_MIN_IMU_SAMPLES} IMU samples"))
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
    extra = []
    ref_heading = None
    if reference:
        att = _rows(packets, "ATTITUDE", boot)
        if att:
            ref = increasing(Stream("ATTITUDE", np.array([m.time_boot_ms * 1e-3 for m in att]),
                                    np.degrees([m.yaw for m in att])))[0]
            ref_heading = interp_heading(ref.t, ref.values, t)
            extra.append("ref_heading from ATTITUDE.yaw")
        else:
            extra.append("no ATTITUDE messages, so no ref_heading")
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
    parts = [f"{Path(name).name}: {t[-1] - t[0]:.1f} s of data from t={t[0]:.3f} s, {t.size} rows",
             f"gyro {describe_rate(t)} from {names[instance]}",
             f"temperature {np.min(temp.values):.1f}..{np.max(temp.values):.1f} degC from {temp.label}"
             if temp is not None else f"no gyro temperature (temp set to {NO_TEMPERATURE_C:g} degC)",
             f"compass: mag from {mag.label} (on {mag_rows} rows)" if mag_rows else "no compass"]
    topics = {"gyro": names[instance], "temp": temp.label if temp is not None else None,
              "mag": mag.label if mag_rows else None, "acc": names[instance],
              "ref_heading": "ATTITUDE" if ref_heading is not None else None}
    return binary_log_frame(
        name, "tlog", t, gyro.values[:, :3], interp_held(temp.t, temp.values, t) if temp is not None else None,
        mag_on_rows if mag_rows else None, gyro.values[:, 3:6], ref_heading, topics=topics,
        summary="; ".join(parts + extra), no_compass_why=no_compass_why, no_temp_why=no_temp_why,
        gyro_max_dps=gyro_max_dps, onboard=onboard)


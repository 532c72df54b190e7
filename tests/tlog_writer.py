"""A small MAVLink telemetry log (``.tlog``) writer for the tests.

A ``.tlog`` is what a ground station records: every MAVLink packet it receives, after the
time it arrived (uint64, big-endian, µs since 1970). The packets are encoded here with
pymavlink's ``ardupilotmega`` dialect (MAVLink 2); this module only lays out the records,
picks which messages go in and when, and can damage the file as a radio link does.

:func:`write_heating_tlog` turns a still heating run (body rates in deg/s) into what an
ArduPilot vehicle sends at telemetry rates: ``HEARTBEAT``, ``PARAM_VALUE`` for the given
parameters, ``RAW_IMU`` (IMU 0) and ``SCALED_IMU2`` (IMU 1; mrad/s, mG, mgauss,
temperature in cdegC), ``SCALED_PRESSURE`` (the barometer's temperature) and ``ATTITUDE``,
at irregular intervals of 0.1 to 1 s, some packets late (out of order) or lost.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

EPOCH_US = 1_700_000_000_000_000  #: arrival time of the first record, µs since 1970


def _mav(system: int = 1, component: int = 1):
    from pymavlink.dialects.v20 import ardupilotmega

    return ardupilotmega.MAVLink(None, srcSystem=system, srcComponent=component)


def record(arrival_us: int, packet: bytes) -> bytes:
    """One tlog record."""
    return struct.pack(">Q", int(arrival_us)) + packet


def param_float(value, param_type: int, bytewise: bool) -> float:
    """``PARAM_VALUE.param_value``: a cast (ArduPilot), or the integer's bytes in the float (PX4)."""
    if bytewise and param_type == 6:
        return struct.unpack("<f", struct.pack("<i", int(value)))[0]
    return float(value)


def write_heating_tlog(path: Path, t_s, temp_c, rates_dps, *, params=None, autopilot: int = 3,
                       imu_temperature: bool = True, seed: int = 0, late: float = 0.05, lost: float = 0.05,
                       second_imu: bool = True, garbage: bool = False, boot_s: float = 100.0,
                       acc_g=(0.0, 0.0, -1.0), mag_mgauss=(200.0, -50.0, 400.0)) -> Path:
    """Write a still heating run as a ground station records an ArduPilot (or PX4) vehicle.

    Parameters
    ----------
    path : pathlib.Path
    t_s, temp_c : array_like
        Sample times (s since boot minus ``boot_s``) and IMU temperature (degC).
    rates_dps : array_like
        Body rates (n, 3), deg/s; stored as whole mrad/s.
    params : dict, optional
        Parameters sent as ``PARAM_VALUE`` (int32 type for whole numbers).
    autopilot : int
        ``HEARTBEAT.autopilot``: 3 ArduPilot (``RAW_IMU``), 12 PX4 (``SCALED_IMU``, bytewise
        integer parameters).
    imu_temperature : bool
        Fill the IMU messages' temperature (else 0: "not provided").
    late, lost : float
        Share of IMU packets that arrive 1.5 s late, and that are lost.
    second_imu : bool
        Also send ``SCALED_IMU2`` (0.3 deg/s more on every axis, 2 degC warmer).
    garbage : bool
        Insert stray bytes and a packet with a broken checksum.
    """
    rng = np.random.default_rng(seed)
    t = np.asarray(t_s, dtype=float)
    temp = np.asarray(temp_c, dtype=float)
    rates = np.asarray(rates_dps, dtype=float)
    mav, gcs, other = _mav(), _mav(255, 190), _mav(2, 1)
    out: list[tuple[float, bytes]] = []
    arrival0 = EPOCH_US - int(round((t[0] + boot_s) * 1e6))

    def send(vehicle_s: float, msg, src=mav, delay_s: float = 0.0) -> None:
        out.append((arrival0 + (vehicle_s + boot_s + delay_s) * 1e6, msg.pack(src)))

    send(t[0] - 1.0, gcs.heartbeat_encode(6, 8, 0, 0, 0, 3), gcs)  # the ground station first
    send(t[0] - 0.9, mav.heartbeat_encode(2, autopilot, 81, 0, 3, 3))
    for i, (name, value) in enumerate((params or {}).items()):
        kind = 6 if float(value).is_integer() else 9
        send(t[0] - 0.8 + 0.001 * i, mav.param_value_encode(name.encode(), param_float(value, kind, autopilot == 12),
                                                             kind, len(params), i))
    first = "RAW_IMU" if autopilot == 3 else "SCALED_IMU"
    for k in range(t.size):
        ms = int(round((t[k] + boot_s) * 1e3))
        if rng.random() >= lost:
            for inst in range(2 if second_imu else 1):
                g = np.round(np.radians(rates[k] + 0.3 * inst) * 1e3).astype(int)
                a = np.round(np.asarray(acc_g) * 1e3).astype(int)
                m = np.round(np.asarray(mag_mgauss)).astype(int)
                cdeg = int(round((temp[k] + 2.0 * inst) * 100)) if imu_temperature else 0
                if inst == 0 and first == "RAW_IMU":
                    msg = mav.raw_imu_encode(int(round((t[k] + boot_s) * 1e6)), *a, *g, *m, 0, cdeg)
                elif inst == 0:
                    msg = mav.scaled_imu_encode(ms, *a, *g, *m, cdeg)
                else:
                    msg = mav.scaled_imu2_encode(ms, *a, *g, *m, cdeg)
                send(t[k], msg, delay_s=1.5 if rng.random() < late else 0.0)
        send(t[k] + 0.001, mav.scaled_pressure_encode(ms, 1000.0, 0.0, int(round(temp[k] * 100)) - 150))
        send(t[k] + 0.002, mav.attitude_encode(ms, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
        if k % 50 == 0:
            send(t[k] + 0.003, gcs.heartbeat_encode(6, 8, 0, 0, 0, 3), gcs)
            send(t[k] + 0.004, other.raw_imu_encode(0, 0, 0, -1000, 999, 999, 999, 0, 0, 0), other)  # another vehicle
    out.sort(key=lambda r: r[0])
    broken = next((k for k in range(len(out) // 2, len(out)) if out[k][1][7] in (26, 27)), None) if garbage else None
    blob = bytearray()
    for k, (arrival, packet) in enumerate(out):
        if garbage and k == len(out) // 3:
            blob += b"\x00\x17garbage\xfe"
        if k == broken:  # an IMU packet with a payload byte flipped: its checksum fails
            packet = packet[:12] + bytes([packet[12] ^ 0xFF]) + packet[13:]
        blob += record(arrival, packet)
    Path(path).write_bytes(bytes(blob))
    return Path(path)

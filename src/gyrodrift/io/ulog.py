"""Read PX4 ULog flight logs (``.ulg``) into the gyrodrift input contract (needs pyulog).

Which topic gives which column, how raw sensor topics are rotated to the body frame and
what is checked: docs/log-formats.md, section "PX4 ULog".
"""

from __future__ import annotations

import contextlib
import io
import struct
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io.align import (
    Stream, binary_log_frame, check_reader_options, check_temperature, compass_on_rows, compass_parts, increasing,
    interp_held, measured_temperature, median_rate_hz, no_instance, read_summary, reference_heading, yaw_deg,
)
from gyrodrift.io.limits import GYRO_MAX_DPS
from gyrodrift.io.messages import log_error, one_line, optional_module, read_log_bytes
from gyrodrift.onboard import px4_onboard, px4_sensor_rotation

__all__ = ["read_ulog", "read_ulog_gyros", "FASTER"]

#: ``sensor_combined`` (or ``vehicle_magnetometer``) replaces the per-instance topic
#: when its median sample rate is at least this many times higher.
FASTER = 4.0

_MAGIC = b"ULog\x01\x12\x35"
_FILE_HEADER_SIZE = 16
_MSG_HEADER_SIZE = 3
#: ULog message types of the header (definitions) section: flags, format, info,
#: info multiple, parameter, parameter default.
_DEFINITION_TYPES = frozenset(b"BFIMPQ")
#: Message types that start the data section: add subscription, logging, tagged logging.
_DATA_START_TYPES = frozenset(b"ALC")
#: Known data-section message types.
_DATA_TYPES = frozenset(b"ARDLCSOIMPQ")
#: pyulog treats larger unknown messages as corruption.
_MAX_UNKNOWN_SIZE = 10000
_MIN_GYRO_SAMPLES = 2
#: Accelerometer time offset in sensor_combined that means "no sample".
_RELATIVE_TIMESTAMP_INVALID = 2**31 - 1
_TOPICS = ("sensor_combined", "sensor_gyro", "sensor_accel", "sensor_mag", "vehicle_magnetometer", "vehicle_attitude",
           "sensor_selection")
_GYRO_COMBINED = ("gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]")
_ACC_COMBINED = ("accelerometer_m_s2[0]", "accelerometer_m_s2[1]", "accelerometer_m_s2[2]")
_XYZ = ("x", "y", "z")
_MAG_VEHICLE = ("magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]")
_QUAT = ("q[0]", "q[1]", "q[2]", "q[3]")

# ---------------------------------------------------------------------------
# file checks and parsing
# ---------------------------------------------------------------------------


def _truncated(name: str, start: int, total: int, in_header: bool) -> LogFormatError:
    """The error for a message that runs past the end of the file."""
    if in_header:
        return log_error(name, f"the file ends inside the ULog header section (message at byte {start}, file size"
                         f" {total} bytes): the file is truncated", "copy the complete .ulg from the vehicle again")
    return log_error(name, f"the file is truncated: its last message starts at byte {start} but the file ends at byte"
                     f" {total}", "copy the complete .ulg from the vehicle again, or keep only the complete messages"
                     f" (the first {start} bytes, e.g. head -c {start})")


def _check_framing(data: bytes, name: str) -> bool:
    """Walk the message chain, refusing non-ULog, truncated or header-only files; True when the data
    section holds a corrupt stretch (pyulog skips it)."""
    if len(data) < _FILE_HEADER_SIZE or not data.startswith(_MAGIC):
        raise log_error(name, "is not a ULog file (it does not start with the ULog header bytes)",
                        "give a PX4 .ulg flight log, or name the right format")
    total = len(data)
    pos = _FILE_HEADER_SIZE
    in_header = True
    while pos < total:
        if pos + _MSG_HEADER_SIZE > total:
            raise _truncated(name, pos, total, in_header)
        size, kind = struct.unpack_from("<HB", data, pos)
        if in_header and kind in _DATA_START_TYPES:
            in_header = False
        known = _DEFINITION_TYPES if in_header else _DATA_TYPES
        if kind not in known and (kind == 0 or size == 0 or size > _MAX_UNKNOWN_SIZE):
            if in_header:
                raise log_error(name, f"the ULog header section is corrupt at byte {pos}",
                                "copy the .ulg from the vehicle again; this file cannot be read")
            return True
        if pos + _MSG_HEADER_SIZE + size > total:
            raise _truncated(name, pos, total, in_header)
        pos += _MSG_HEADER_SIZE + size
    if in_header:
        raise log_error(name, "holds only the ULog header, no logged data", "give a log that recorded data")
    return False


def _parse(ulog_class, data: bytes, name: str):
    """Parse the bytes with pyulog (the topics used only); any failure is one LogFormatError."""
    try:
        # pyulog prints warnings to stdout; keep them out of gyrodrift's output
        with contextlib.redirect_stdout(io.StringIO()):
            return ulog_class(io.BytesIO(data), message_name_filter_list=list(_TOPICS))
    except Exception as exc:  # any failure of a third-party parser on an untrusted file
        raise log_error(name, f"cannot be parsed as a ULog file ({one_line(str(exc))})",
                        "check that it is a complete PX4 .ulg log") from exc


# ---------------------------------------------------------------------------
# topic access
# ---------------------------------------------------------------------------


def _instances(ulog, topic: str) -> dict[int, Any]:
    """All logged instances of ``topic``: multi_id -> pyulog dataset."""
    return {d.multi_id: d for d in ulog.data_list if d.name == topic}


def _label(topic: str, instance: int) -> str:
    return f"{topic} instance {instance}"


def _fields(ds, names, name: str, where: str) -> np.ndarray:
    """Stack fields of a dataset as float64 columns, shape (n, len(names))."""
    missing = [f for f in names if f not in ds.data]
    if missing:
        raise log_error(name, f"field(s) {', '.join(missing)} missing; fields found: {', '.join(sorted(ds.data))}",
                        "this PX4 version logs the topic differently; convert the log to CSV in the input contract",
                        where=where)
    return np.column_stack([np.asarray(ds.data[f], dtype=np.float64) for f in names])


def _time_s(ds) -> np.ndarray:
    """Sample times (s): ``timestamp_sample`` if logged, else ``timestamp`` (both µs)."""
    key = "timestamp_sample" if "timestamp_sample" in ds.data else "timestamp"
    return np.asarray(ds.data[key], dtype=np.float64) * 1e-6


def _device_id(ds) -> int | None:
    """The dataset's ``device_id`` (first sample), or None if not logged."""
    if "device_id" not in ds.data or len(ds.data["device_id"]) == 0:
        return None
    return int(ds.data["device_id"][0]) & 0xFFFFFFFF


def _selected_ids(ulog, field: str) -> set[int]:
    """Non-zero device ids in ``sensor_selection.<field>`` over the whole log."""
    sel = _instances(ulog, "sensor_selection").get(0)
    if sel is None or field not in sel.data:
        return set()
    return {int(v) & 0xFFFFFFFF for v in sel.data[field] if int(v) != 0}


def _pick_instance(ulog, topic: str, instance: int, name: str, option: str):
    """Dataset of ``topic`` instance ``instance``; missing topic or instance raises."""
    found = _instances(ulog, topic)
    if not found:
        raise log_error(name, f"no '{topic}' topic in the log",
                        f"log '{topic}' (PX4 logger profile) or convert the log to CSV")
    if instance not in found:
        raise no_instance(name, topic, instance, found, option)
    return found[instance]


def _same_chip(ulog, topic: str, device: int | None, instance: int):
    """(multi_id, dataset) of ``topic`` with ``device_id`` == ``device``; without device ids,
    instance ``instance``; dataset None when there is none."""
    found = _instances(ulog, topic)
    if device is not None:
        for multi_id in sorted(found):
            if _device_id(found[multi_id]) == device:
                return multi_id, found[multi_id]
        if any(_device_id(d) is not None for d in found.values()):
            return None, None
    return instance, found.get(instance)


def _board_to_body(params: dict, kind: str, device: int | None, name: str) -> tuple[np.ndarray, str]:
    """:func:`gyrodrift.onboard.px4_sensor_rotation`, an unknown rotation a :class:`LogFormatError`."""
    try:
        return px4_sensor_rotation(params, kind, device, where=name)
    except ConfigError as exc:
        raise log_error(name, f"{exc}".split(": ", 1)[1], "use the calibrated topics (sensor_combined, "
                        "vehicle_magnetometer) or convert the log to CSV") from None


# ---------------------------------------------------------------------------
# streams (docs/log-formats.md, section "PX4 ULog")
# ---------------------------------------------------------------------------


def _combined_is_instance(ulog, device: int | None, instance: int) -> bool:
    """True if ``sensor_combined`` carries gyro ``instance`` for the whole log."""
    ids = _selected_ids(ulog, "gyro_device_id")
    if not ids or device is None:
        return instance == 0
    return ids == {device}


def _combined_only(ulog, instance: int) -> bool:
    """True for a log whose IMU is in ``sensor_combined`` alone (no ``sensor_gyro``: an older PX4
    logger, whose ``sensor_combined`` also carries the magnetometer, or a profile that left it out)."""
    combined = _instances(ulog, "sensor_combined").get(0)
    return (instance == 0 and not _instances(ulog, "sensor_gyro") and combined is not None
            and all(f in combined.data for f in _GYRO_COMBINED))


def _gyro_stream(ulog, instance: int, name: str) -> Stream:
    """Rates (rad/s, body FRD) from sensor_combined or sensor_gyro."""
    if _combined_only(ulog, instance):
        combined = _instances(ulog, "sensor_combined")[0]
        return Stream("sensor_combined", np.asarray(combined.data["timestamp"], dtype=np.float64) * 1e-6,
                      _fields(combined, _GYRO_COMBINED, name, "sensor_combined"))
    gyro = _pick_instance(ulog, "sensor_gyro", instance, name, "instance")
    device = _device_id(gyro)
    t_gyro = _time_s(gyro)
    combined = _instances(ulog, "sensor_combined").get(0)
    if (
        combined is not None
        and len(combined.data["timestamp"]) >= _MIN_GYRO_SAMPLES
        and all(f in combined.data for f in _GYRO_COMBINED)
        and _combined_is_instance(ulog, device, instance)
    ):
        t_comb = np.asarray(combined.data["timestamp"], dtype=np.float64) * 1e-6
        if median_rate_hz(t_comb) >= FASTER * median_rate_hz(t_gyro):
            return Stream("sensor_combined", t_comb, _fields(combined, _GYRO_COMBINED, name, "sensor_combined"))
    label = _label("sensor_gyro", instance)
    rot, how = _board_to_body(ulog.initial_parameters, "GYRO", device, name)
    rates = _fields(gyro, _XYZ, name, label) @ rot.T
    return Stream(f"{label} rotated to the body frame by {how}", t_gyro, rates)


def _temperature_stream(ulog, instance: int) -> tuple[Stream | None, str]:
    """Gyro temperature (degC) from sensor_gyro, else sensor_accel of the same chip; or None and why."""
    if _combined_only(ulog, instance):
        return None, "no sensor_gyro topic: the gyro is sensor_combined's, which carries no gyro temperature"
    gyro = _instances(ulog, "sensor_gyro")[instance]
    device = _device_id(gyro)
    candidates = [(_label("sensor_gyro", instance), gyro)]
    acc_id, acc = _same_chip(ulog, "sensor_accel", device, instance)
    if acc is not None:
        candidates.append((_label("sensor_accel", acc_id), acc))
    reasons = []
    for label, ds in candidates:
        if "temperature" not in ds.data:
            reasons.append(f"{label} has no temperature field")
            continue
        stream, why = measured_temperature(label, _time_s(ds), np.asarray(ds.data["temperature"], dtype=np.float64))
        if stream is not None:
            return stream, ""
        reasons.append(why)
    if len(candidates) == 1:
        reasons.append("no sensor_accel of the same chip")
    for other, ds in sorted(_instances(ulog, "sensor_gyro").items()):
        temp = np.asarray(ds.data.get("temperature", []), dtype=np.float64)
        if other != instance and np.isfinite(temp).any() and np.nanmax(np.abs(temp)) > 0.0:
            reasons.append(f"{_label('sensor_gyro', other)} logs one: instance={other} (--instance {other}) reads"
                           " that gyro")
            break
    return None, ", ".join(reasons)


def _acc_stream(ulog, instance: int, name: str) -> Stream | None:
    """Specific force (m/s², body FRD) from sensor_combined, else the gyro chip's sensor_accel."""
    combined = _instances(ulog, "sensor_combined").get(0)
    if combined is not None and all(f in combined.data for f in _ACC_COMBINED):
        t = np.asarray(combined.data["timestamp"], dtype=np.float64)
        rel = combined.data.get("accelerometer_timestamp_relative")
        if rel is not None:
            rel = np.asarray(rel, dtype=np.float64)
            t = np.where(rel == _RELATIVE_TIMESTAMP_INVALID, np.nan, t + rel)
        values = _fields(combined, _ACC_COMBINED, name, "sensor_combined")
        return Stream("sensor_combined", t * 1e-6, values)
    if _combined_only(ulog, instance):
        return None
    device = _device_id(_instances(ulog, "sensor_gyro")[instance])
    acc_id, acc = _same_chip(ulog, "sensor_accel", device, instance)
    if acc is None:
        return None
    label = _label("sensor_accel", acc_id)
    rot, how = _board_to_body(ulog.initial_parameters, "ACC", _device_id(acc), name)
    return Stream(f"{label} rotated by {how}", _time_s(acc), _fields(acc, _XYZ, name, label) @ rot.T)


def _sensor_mag_stream(ulog, ds, instance: int, name: str) -> Stream:
    """Raw sensor_mag (gauss) rotated to the body frame."""
    label = _label("sensor_mag", instance)
    rot, how = _board_to_body(ulog.initial_parameters, "MAG", _device_id(ds), name)
    return Stream(f"{label} rotated by {how}", _time_s(ds), _fields(ds, _XYZ, name, label) @ rot.T)


def _mag_stream(ulog, mag_instance: int | None, name: str) -> Stream | None:
    """Magnetometer (gauss, body FRD); None without sensor_mag, vehicle_magnetometer and ``mag_instance``."""
    if mag_instance is not None:
        ds = _pick_instance(ulog, "sensor_mag", mag_instance, name, "mag_instance")
        return _sensor_mag_stream(ulog, ds, mag_instance, name)
    mags = _instances(ulog, "sensor_mag")
    chosen = 0 if 0 in mags else (min(mags) if mags else None)
    selected = _selected_ids(ulog, "mag_device_id")
    if len(selected) == 1:
        wanted = selected.pop()
        chosen = next((k for k in sorted(mags) if _device_id(mags[k]) == wanted), chosen)
    device = _device_id(mags[chosen]) if chosen is not None else None
    vm_id, vehicle = _same_chip(ulog, "vehicle_magnetometer", device, 0)
    if vehicle is not None and all(f in vehicle.data for f in _MAG_VEHICLE):
        t_vehicle = _time_s(vehicle)
        if chosen is None or median_rate_hz(t_vehicle) >= FASTER * median_rate_hz(_time_s(mags[chosen])):
            label = _label("vehicle_magnetometer", vm_id)
            return Stream(label, t_vehicle, _fields(vehicle, _MAG_VEHICLE, name, label))
    if chosen is None:
        return _combined_mag_stream(ulog, name)
    return _sensor_mag_stream(ulog, mags[chosen], chosen, name)


def _combined_mag_stream(ulog, name: str) -> Stream | None:
    """An older PX4 log's magnetometer (gauss, body FRD, calibrated) from sensor_combined: each
    sample once, at its own time (the row's time plus ``magnetometer_timestamp_relative``; the
    rows between samples hold the last one). None without those fields."""
    combined = _instances(ulog, "sensor_combined").get(0)
    if combined is None or not all(f in combined.data for f in _MAG_VEHICLE + ("magnetometer_timestamp_relative",)):
        return None
    rel = np.asarray(combined.data["magnetometer_timestamp_relative"], dtype=np.float64)
    t = np.asarray(combined.data["timestamp"], dtype=np.float64) + rel
    fresh = (rel != _RELATIVE_TIMESTAMP_INVALID) & np.isfinite(t)
    fresh[1:] &= t[1:] != t[:-1]
    if not fresh.any():
        return None
    return Stream("sensor_combined", t[fresh] * 1e-6, _fields(combined, _MAG_VEHICLE, name, "sensor_combined")[fresh])


def _reference_stream(ulog, name: str) -> Stream | None:
    """Heading (deg) from vehicle_attitude, or None if the topic is missing."""
    att = _instances(ulog, "vehicle_attitude").get(0)
    if att is None:
        return None
    q = _fields(att, _QUAT, name, "vehicle_attitude")
    return Stream("vehicle_attitude", _time_s(att), yaw_deg(q[:, 0], q[:, 1], q[:, 2], q[:, 3]))


# ---------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------


def read_ulog_gyros(path, *, mag_instance: int | None = None, reference: bool = True,
                    gyro_max_dps: float = GYRO_MAX_DPS, instances=None) -> list[pd.DataFrame]:
    """Every ``sensor_gyro`` instance of a ULog (or the ``instances`` listed), each as
    :func:`read_ulog` reads one, in instance order; the file is parsed once."""
    gyro_max_dps = check_reader_options(instances, mag_instance, gyro_max_dps)
    ulog_class = optional_module("pyulog.ULog", "reading PX4 ULog files", "pyulog", "ulog")
    path = Path(path)
    name = str(path)
    data = read_log_bytes(path, "a ULog file", "give the path of a .ulg log", "give a PX4 .ulg log")
    corrupt = _check_framing(data, name)
    ulog = _parse(ulog_class, data, name)
    if instances is None:
        instances = sorted(_instances(ulog, "sensor_gyro")) or [0]
    return [_read(ulog, name, corrupt, k, mag_instance, reference, gyro_max_dps) for k in instances]


def read_ulog(path, *, instance: int = 0, mag_instance: int | None = None, reference: bool = True,
              gyro_max_dps: float = GYRO_MAX_DPS) -> pd.DataFrame:
    """Read a PX4 ULog (``.ulg``) into the gyrodrift input contract.

    See docs/log-formats.md, section "PX4 ULog", for the topics each column comes from.

    Parameters
    ----------
    path : str or os.PathLike
    instance : int, default 0
        ``sensor_gyro`` multi-instance (the IMU chip) whose rate and temperature are used.
    mag_instance : int, optional
        ``sensor_mag`` multi-instance of the compass; default the magnetometer PX4 selected.
    reference : bool, default True
        Add ``ref_heading`` (deg) from ``vehicle_attitude`` when the log has it.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        One row per gyro sample; ``attrs`` as docs/log-formats.md, section "Alignment",
        with ``format`` "ulog" and ``onboard`` (:class:`gyrodrift.onboard.Onboard`).

    Raises
    ------
    LogFormatError
        A missing, non-ULog or corrupt file; a missing topic or field; fewer than 2 gyro
        samples; an implausible value; an unsupported sensor rotation.
    ConfigError
        pyulog is not installed; a bad or absent ``instance`` or ``mag_instance``.
    """
    return read_ulog_gyros(path, mag_instance=mag_instance, reference=reference, gyro_max_dps=gyro_max_dps,
                           instances=[instance])[0]


def _changed_parameters(ulog) -> set[str]:
    """Parameters whose value changed during the log (``ulog.changed_parameters``)."""
    initial = ulog.initial_parameters
    return {n for _, n, v in getattr(ulog, "changed_parameters", []) if initial.get(n) != v}


def _onboard(ulog, instance: int, gyro: Stream, temp, name: str):
    """:class:`gyrodrift.onboard.Onboard` of the gyro ``instance`` whose rates ``gyro`` holds."""
    params = ulog.initial_parameters
    gyros = _instances(ulog, "sensor_gyro")
    device = _device_id(gyros[instance]) if instance in gyros else None
    try:
        rotation, how, problem = *_board_to_body(params, "GYRO", device, name), ""
    except LogFormatError as exc:  # the rates came from sensor_combined: only a calibration needs it
        rotation, how, problem = np.eye(3), "", str(exc)
    onboard = px4_onboard(params, instance, device, rotation, how, corrected=gyro.label == "sensor_combined",
                          changed=_changed_parameters(ulog), temperature=temp is not None, where=name)
    return replace(onboard, rotation=None, rotation_problem=problem) if problem else onboard


def _read(ulog, name: str, corrupt: bool, instance: int, mag_instance: int | None, reference: bool,
          gyro_max_dps: float) -> pd.DataFrame:
    """The body of :func:`read_ulog` on a parsed log."""
    gyro, dropped = increasing(_gyro_stream(ulog, instance, name))
    if gyro.t.size < _MIN_GYRO_SAMPLES:
        raise log_error(name, f"too few gyro samples ({gyro.t.size}) in {gyro.label}",
                        f"give a log with at least {_MIN_GYRO_SAMPLES} gyro samples")
    temp, no_temp_why = _temperature_stream(ulog, instance)
    if temp is not None:
        temp, _ = increasing(temp)
        check_temperature(name, temp.label, temp.values)
    acc, mag = _acc_stream(ulog, instance, name), _mag_stream(ulog, mag_instance, name)
    acc = increasing(acc)[0] if acc is not None else None
    mag = increasing(mag)[0] if mag is not None else None
    t = gyro.t
    mag_on_rows, mag_rows, no_compass_why = compass_on_rows(
        t, mag, acc, "no sensor_mag nor vehicle_magnetometer topic in the log",
        "no accelerometer for the tilt, neither sensor_combined.accelerometer_m_s2 nor a sensor_accel of the gyro's"
        " chip")
    ref = _reference_stream(ulog, name) if reference else None
    ref_heading, extra = reference_heading(ref, t, reference, "vehicle_attitude",
                                           "no vehicle_attitude, so no ref_heading")
    if dropped:
        extra.append(f"{dropped} gyro samples with a repeated time stamp dropped")
    if corrupt or ulog.file_corruption:
        extra.append("the file holds a corrupt stretch that pyulog skipped")
    if gyro.label == "sensor_combined" and int(ulog.initial_parameters.get("TC_G_ENABLE", 0)) == 1:
        extra.append("PX4 thermal gyro compensation was on (TC_G_ENABLE=1)")
    acc_label = acc.label if acc is not None else None
    topics = {"gyro": gyro.label, "temp": temp.label if temp is not None else None,
              "mag": mag.label if mag_rows else None, "acc": acc_label,
              "ref_heading": ref.label if ref is not None else None}
    summary = read_summary(name, t, f"gyro {median_rate_hz(t):.3g} Hz from {gyro.label}", temp,
                           compass_parts(mag, mag_rows, acc_label), extra)
    return binary_log_frame(
        name, "ulog", t, np.degrees(gyro.values), interp_held(temp.t, temp.values, t) if temp is not None else None,
        mag_on_rows, interp_held(acc.t, acc.values, t) if acc is not None else None, ref_heading, topics=topics,
        summary=summary, no_compass_why=no_compass_why, no_temp_why=no_temp_why, gyro_max_dps=gyro_max_dps,
        onboard=_onboard(ulog, instance, gyro, temp, name))

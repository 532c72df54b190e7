"""Read ArduPilot DataFlash logs (``.bin``) into the gyrodrift input contract (needs pymavlink).

pymavlink indexes the messages; the fields used are decoded here with numpy. Which
message gives which column, and how a damaged file is read: docs/log-formats.md,
section "ArduPilot DataFlash".
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.io.align import (
    Stream, binary_log_frame, check_reader_options, check_temperature, compass_on_rows, compass_parts, increasing,
    interp_held, last_values, measured_temperature, median_rate_hz, no_instance, read_summary, reference_heading,
)
from gyrodrift.io.limits import GYRO_MAX_DPS
from gyrodrift.io.messages import log_error, one_line, optional_module, read_log_bytes
from gyrodrift.onboard import ardupilot_onboard

__all__ = ["read_ardupilot", "read_ardupilot_imus", "MAGIC"]

#: Every DataFlash log starts with the FMT message (type 128) that defines FMT itself.
MAGIC = b"\xa3\x95\x80"
_HEADER_BYTES = 3
_MIN_GYRO_SAMPLES = 2
#: Messages decoded per step when gathering bytes (bounds the index array's memory).
_GATHER_ROWS = 65536
#: DataFlash format characters: numpy type and the multiplier pymavlink applies.
_FIELD_TYPES = {
    "b": ("<i1", None), "B": ("<u1", None), "M": ("<u1", None), "h": ("<i2", None), "H": ("<u2", None),
    "i": ("<i4", None), "I": ("<u4", None), "q": ("<i8", None), "Q": ("<u8", None), "f": ("<f4", None),
    "d": ("<f8", None), "g": ("<f2", None), "n": ("S4", None), "N": ("S16", None), "Z": ("S64", None),
    "a": ("(32,)<i2", None), "c": ("<i2", 100.0), "C": ("<u2", 100.0), "e": ("<i4", 100.0),
    "E": ("<u4", 100.0), "L": ("<i4", 1e7),
}  # fmt: skip
_IMU_TYPES = ("IMU", "IMU2", "IMU3")
_MAG_TYPES = ("MAG", "MAG2", "MAG3")
_GYRO_FIELDS = ("GyrX", "GyrY", "GyrZ")
_ACC_FIELDS = ("AccX", "AccY", "AccZ")
_MAG_FIELDS = ("MagX", "MagY", "MagZ")
_MGAUSS_PER_GAUSS = 1000.0


class _Source(NamedTuple):
    """The messages of one sensor instance: their label and decoded fields."""

    label: str  #: e.g. "IMU instance 0" or "IMU2"
    fields: dict  #: field name -> float64 array (only the fields asked for)
    t: np.ndarray  #: time (s)


# ---------------------------------------------------------------------------
# file checks and parsing
# ---------------------------------------------------------------------------


def _check_file(path: Path) -> None:
    """Raise a one-line :class:`LogFormatError` unless ``path`` starts like a DataFlash log."""
    name = str(path)
    head = read_log_bytes(path, "a DataFlash log", "give the path of a .bin log", "give an ArduPilot .bin log", len(MAGIC))
    if head != MAGIC:
        raise log_error(name, "is not an ArduPilot DataFlash log (it does not start with a FMT message, bytes A3 95 80)",
                        "give a binary .bin log (from the SD card or downloaded over MAVLink), or name the right"
                        " format")


def _open(dfreader, path: Path):
    """Index the log with pymavlink (its wall-clock time base skipped); a failure is one LogFormatError."""

    class IndexOnly(dfreader.DFReader_binary):
        def init_clock(self):
            self._rewind(keep_messages=True)

    try:
        # pymavlink prints about skipped bytes; keep that out of gyrodrift's output
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            return IndexOnly(str(path), zero_time_base=True)
    except Exception as exc:  # any failure of a third-party parser on an untrusted file
        raise log_error(str(path), f"cannot be parsed as a DataFlash log ({one_line(str(exc)) or type(exc).__name__})",
                        "check that it is a complete ArduPilot .bin log") from exc


def _dtype(fmt, name: str) -> tuple[np.dtype, dict]:
    """Numpy record type of a message type's body, and its fields' multipliers."""
    names, types, scales = [], [], {}
    for char, column in zip(fmt.format, fmt.columns):
        if char not in _FIELD_TYPES:
            raise log_error(name, f"format character {char!r} of field {column} is not a DataFlash type",
                            "the log is corrupt or from an unsupported logger", where=f"message {fmt.name}")
        numpy_type, scale = _FIELD_TYPES[char]
        names.append(column)
        types.append(numpy_type)
        if scale is not None:
            scales[column] = scale
    dtype = np.dtype({"names": names, "formats": types})
    if dtype.itemsize != fmt.len - _HEADER_BYTES:
        raise log_error(name, f"its FMT states {fmt.len} bytes but the format {fmt.format!r} packs"
                        f" {dtype.itemsize + _HEADER_BYTES}", "the log is corrupt; download it again",
                        where=f"message {fmt.name}")
    return dtype, scales


def _complete(reader, type_id: int) -> np.ndarray:
    """Start offsets of the messages of ``type_id`` that end within the file."""
    offsets = np.asarray(reader.offsets[type_id], dtype=np.int64)
    return offsets[offsets + reader.formats[type_id].len <= reader.data_len]


def _records(reader, name: str, type_name: str) -> tuple[np.ndarray, dict] | None:
    """The complete messages ``type_name`` as raw records, and their fields' multipliers; None if undefined."""
    type_id = getattr(reader, "name_to_id", {}).get(type_name)
    if type_id is None or type_id not in reader.formats:
        return None
    fmt = reader.formats[type_id]
    dtype, scales = _dtype(fmt, name)
    offsets = _complete(reader, type_id) + _HEADER_BYTES
    data = np.frombuffer(reader.data_map, dtype=np.uint8)
    span = np.arange(dtype.itemsize)
    raw = np.empty((offsets.size, dtype.itemsize), dtype=np.uint8)
    for start in range(0, offsets.size, _GATHER_ROWS):
        part = offsets[start : start + _GATHER_ROWS]
        raw[start : start + part.size] = data[part[:, None] + span]
    return raw.view(dtype)[:, 0], scales


def _decode(reader, name: str, type_name: str, wanted) -> dict | None:
    """Fields ``wanted`` of every complete message ``type_name``, float64 and scaled; None if undefined."""
    found = _records(reader, name, type_name)
    if found is None:
        return None
    records, scales = found
    out = {}
    for field in wanted:
        if field in records.dtype.names:
            values = records[field].astype(np.float64)
            out[field] = values / scales[field] if field in scales else values
    return out


def _params(reader, name: str) -> tuple[dict[str, float], set[str]]:
    """``PARM``: name -> the last logged value, and the names logged with more than one value."""
    found = _records(reader, name, "PARM")
    if found is None or not {"Name", "Value"} <= set(found[0].dtype.names):
        return {}, set()
    records = found[0]
    names = [n.split(b"\0", 1)[0].decode("ascii", "replace") for n in records["Name"]]
    return last_values(zip(names, records["Value"].astype(np.float64).tolist()))


def _time_s(fields: dict) -> np.ndarray | None:
    """Message times (s) from ``TimeUS`` (µs) or, in old logs, ``TimeMS`` (ms)."""
    if "TimeUS" in fields:
        return fields["TimeUS"] * 1e-6
    if "TimeMS" in fields:
        return fields["TimeMS"] * 1e-3
    return None


def _sources(reader, name: str, types, wanted) -> dict[int, _Source]:
    """Every logged instance of a sensor: instance number -> its messages (field ``I``, or a type each)."""
    found: dict[int, _Source] = {}
    for number, type_name in enumerate(types):
        fields = _decode(reader, name, type_name, ("TimeUS", "TimeMS", "I", *wanted))
        if fields is None or not fields:
            continue
        t = _time_s(fields)
        if t is None and _px4log(reader):
            raise log_error(name, "is a PX4 .px4log (PX4's log format before ULog): its messages are timed by"
                            " TIME.StartTime, not by a field of their own, and gyrodrift does not read it",
                            "convert it to CSV in the input contract (gyro_z, temp, t; e.g. with px4tools or"
                            " sdlog2_dump.py)")
        if t is None:
            raise log_error(name, "has no TimeUS nor TimeMS field", "convert the log to CSV in the input contract",
                            where=f"message {type_name}")
        if "I" not in fields:
            if t.size:
                found.setdefault(number, _Source(type_name, fields, t))
            continue
        for instance in np.unique(fields["I"]).astype(int):
            keep = fields["I"] == instance
            picked = {k: v[keep] for k, v in fields.items()}
            found.setdefault(int(instance), _Source(f"{type_name} instance {instance}", picked, t[keep]))
    return found


def _px4log(reader) -> bool:
    """True for a PX4 .px4log: the DataFlash framing, its time in ``TIME.StartTime`` messages."""
    type_id = getattr(reader, "name_to_id", {}).get("TIME")
    return type_id is not None and type_id in reader.formats and "StartTime" in reader.formats[type_id].columns


def _pick(found: dict[int, _Source], kind: str, instance: int, name: str, option: str) -> _Source:
    """The source of ``instance``; a missing sensor or instance raises, listing those present."""
    if not found:
        raise log_error(name, f"no {kind} messages in the log", f"enable {kind} logging (LOG_BITMASK) or convert the"
                        " log to CSV in the input contract")
    if instance not in found:
        raise no_instance(name, kind, instance, found, option)
    return found[instance]


def _stack(source: _Source, fields, name: str = "") -> np.ndarray | None:
    """Fields as columns (n, k); None if any is missing, or with ``name`` (the file) an error."""
    if all(f in source.fields for f in fields):
        return np.column_stack([source.fields[f] for f in fields])
    if not name:
        return None
    raise log_error(name, f"field(s) {', '.join(fields)} missing; fields found: {', '.join(sorted(source.fields))}",
                    "convert the log to CSV in the input contract", where=source.label)


# ---------------------------------------------------------------------------
# streams
# ---------------------------------------------------------------------------


#: The IMU's temperature field (degC): ``T``, or ``Temp`` in ArduPilot's logs before about 2016.
_TEMP_FIELDS = ("T", "Temp")


def _temperature(imu: _Source) -> tuple[Stream | None, str]:
    """``IMU.T`` or ``IMU.Temp`` (degC), or None and why it is not usable (for the note)."""
    for field in _TEMP_FIELDS:
        if field in imu.fields:
            return measured_temperature(imu.label, imu.t, imu.fields[field])
    return None, f"{imu.label} has no temperature field ({' or '.join(_TEMP_FIELDS)})"


def _mag_stream(reader, params: dict, mag_instance: int | None, name: str) -> tuple[Stream | None, int]:
    """Magnetometer (gauss, body FRD) and the unhealthy samples dropped; None without MAG messages."""
    found = _sources(reader, name, _MAG_TYPES, (*_MAG_FIELDS, "Health"))
    if mag_instance is None:
        if not found:
            return None, 0
        primary = params.get("COMPASS_PRIMARY")
        mag_instance = int(primary) if primary is not None and int(primary) in found else min(found)
    mag = _pick(found, "MAG", mag_instance, name, "mag_instance")
    values = _stack(mag, _MAG_FIELDS, name)
    healthy = mag.fields["Health"] != 0 if "Health" in mag.fields else np.ones(mag.t.size, dtype=bool)
    stream = Stream(mag.label, mag.t[healthy], values[healthy] / _MGAUSS_PER_GAUSS)
    return stream, int(np.count_nonzero(~healthy))


def _reference(reader, name: str) -> Stream | None:
    """``ATT.Yaw`` (deg), or None if the log has no ATT messages with a yaw."""
    att = _decode(reader, name, "ATT", ("TimeUS", "TimeMS", "Yaw"))
    if not att or "Yaw" not in att or _time_s(att) is None or att["Yaw"].size == 0:
        return None
    return Stream("ATT", _time_s(att), att["Yaw"])


def _damage(reader) -> tuple[int, int]:
    """Bytes that are no message (skipped by pymavlink), and bytes of an incomplete last message."""
    starts, ends = [], []
    for type_id, offsets in enumerate(reader.offsets):
        if len(offsets) and type_id in reader.formats:
            complete = _complete(reader, type_id)
            starts.append(complete)
            ends.append(complete + reader.formats[type_id].len)
    start, end = np.concatenate(starts or [[0]]), np.concatenate(ends or [[0]])
    order = np.argsort(start, kind="stable")
    start, end = start[order], end[order]
    gaps = start[1:] - end[:-1]
    skipped = int(start[0]) + int(np.sum(gaps[gaps > 0]))
    last = int(end[-1])
    tail = reader.data_len - last
    head = bytes(reader.data_map[last : last + _HEADER_BYTES])
    if tail and head[:2] == MAGIC[:2] and len(head) == _HEADER_BYTES and head[2] in reader.formats \
            and reader.formats[head[2]].len > tail:
        return skipped, tail
    return skipped + tail, 0


# ---------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------


def read_ardupilot_imus(path, *, mag_instance: int | None = None, reference: bool = True,
                        gyro_max_dps: float = GYRO_MAX_DPS, instances=None) -> list[pd.DataFrame]:
    """Every IMU of a DataFlash log (or the ``instances`` listed), each as :func:`read_ardupilot`
    reads one, in instance order; the file is opened once."""
    gyro_max_dps = check_reader_options(instances, mag_instance, gyro_max_dps)
    dfreader = optional_module("pymavlink.DFReader", "reading ArduPilot DataFlash logs", "pymavlink", "ardupilot")
    path = Path(path)
    name = str(path)
    _check_file(path)
    reader = _open(dfreader, path)
    try:
        if instances is None:
            instances = sorted(_sources(reader, name, _IMU_TYPES, ())) or [0]
        return [_read(reader, name, k, mag_instance, reference, gyro_max_dps) for k in instances]
    finally:
        with contextlib.suppress(Exception):
            reader.close()


def read_ardupilot(path, *, instance: int = 0, mag_instance: int | None = None, reference: bool = True,
                   gyro_max_dps: float = GYRO_MAX_DPS) -> pd.DataFrame:
    """Read an ArduPilot DataFlash log (``.bin``) into the gyrodrift input contract.

    See docs/log-formats.md, section "ArduPilot DataFlash", for the messages each column
    comes from.

    Parameters
    ----------
    path : str or os.PathLike
    instance : int, default 0
        IMU instance (``IMU.I``, or 0/1/2 for ``IMU``/``IMU2``/``IMU3``).
    mag_instance : int, optional
        Compass instance (``MAG.I``, or ``MAG``/``MAG2``/``MAG3``); default
        ``COMPASS_PRIMARY`` when logged, else the lowest instance.
    reference : bool, default True
        Add ``ref_heading`` (deg) from ``ATT.Yaw`` when the log has it.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        One row per IMU sample; ``attrs`` as docs/log-formats.md, section "Alignment",
        with ``format`` "ardupilot" and ``onboard`` (:class:`gyrodrift.onboard.Onboard`).

    Raises
    ------
    LogFormatError
        A missing, empty, non-DataFlash or unparsable file; no IMU messages or gyro
        fields; fewer than 2 IMU samples; an implausible value; a corrupt message definition.
    ConfigError
        pymavlink is not installed; a bad or absent ``instance`` or ``mag_instance``.
    """
    return read_ardupilot_imus(path, mag_instance=mag_instance, reference=reference, gyro_max_dps=gyro_max_dps,
                               instances=[instance])[0]


def _read(reader, name: str, instance: int, mag_instance: int | None, reference: bool,
          gyro_max_dps: float) -> pd.DataFrame:
    """The body of :func:`read_ardupilot` on an open pymavlink reader."""
    skipped, partial = _damage(reader)
    imus = _sources(reader, name, _IMU_TYPES, (*_GYRO_FIELDS, *_ACC_FIELDS, *_TEMP_FIELDS))
    if not imus and partial:
        raise log_error(name, f"the file is truncated: it ends inside a message at byte {reader.data_len}, before"
                        " any IMU sample", "copy the complete .bin from the vehicle again")
    imu = _pick(imus, "IMU", instance, name, "instance")
    rates = _stack(imu, _GYRO_FIELDS, name)
    acc_values = _stack(imu, _ACC_FIELDS)
    columns = rates if acc_values is None else np.column_stack([rates, acc_values])
    gyro, dropped = increasing(Stream(imu.label, imu.t, columns))
    if gyro.t.size < _MIN_GYRO_SAMPLES:
        raise log_error(name, f"too few gyro samples ({gyro.t.size}) in {imu.label}",
                        f"give a log with at least {_MIN_GYRO_SAMPLES} IMU samples")
    t = gyro.t
    temp, no_temp_why = _temperature(imu)
    temp_on_rows = None
    if temp is not None:
        temp, _ = increasing(temp)
        check_temperature(name, temp.label, temp.values)
        temp_on_rows = interp_held(temp.t, temp.values, t)  # the same messages: the values themselves
    params, changed = _params(reader, name)
    mag, unhealthy = _mag_stream(reader, params, mag_instance, name)
    mag = increasing(mag)[0] if mag is not None else None
    acc = gyro.values[:, 3:6] if acc_values is not None else None
    mag_on_rows, mag_rows, no_compass_why = compass_on_rows(
        t, mag, acc, "no MAG messages in the log", "no accelerometer fields AccX, AccY, AccZ in the IMU messages for"
        " the tilt", empty=f"no healthy sample of {mag.label}" if mag is not None else "")
    ref = _reference(reader, name) if reference else None
    ref_heading, extra = reference_heading(ref, t, reference, "ATT.Yaw", "no ATT messages, so no ref_heading")
    if dropped:
        extra.append(f"{dropped} IMU samples with a repeated time stamp dropped")
    if unhealthy:
        extra.append(f"{unhealthy} unhealthy {mag.label} samples dropped")
    if skipped:
        extra.append(f"{skipped} bytes that are no message skipped")
    if partial:
        extra.append(f"the file ends inside a message ({partial} bytes at the end ignored)")
    onboard = ardupilot_onboard(params, instance, changed=changed, temperature=temp is not None, where=name)
    if int(params.get(f"INS_TCAL{instance + 1}_ENABLE", 0)) == 1:
        extra.append(f"ArduPilot's gyro temperature calibration was on (INS_TCAL{instance + 1}_ENABLE=1)")
    acc_label = imu.label if acc is not None else None
    topics = {"gyro": imu.label, "temp": temp.label if temp is not None else None,
              "mag": mag.label if mag_rows else None, "acc": acc_label,
              "ref_heading": ref.label if ref is not None else None}
    summary = read_summary(name, t, f"gyro {median_rate_hz(t):.3g} Hz from {imu.label}", temp,
                           compass_parts(mag, mag_rows, acc_label), extra, temp_rate=False)
    return binary_log_frame(
        name, "ardupilot", t, np.degrees(gyro.values[:, :3]), temp_on_rows if temp is not None else None, mag_on_rows,
        acc, ref_heading, topics=topics, summary=summary, no_compass_why=no_compass_why, no_temp_why=no_temp_why,
        gyro_max_dps=gyro_max_dps, onboard=onboard)

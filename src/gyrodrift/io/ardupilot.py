"""Read ArduPilot DataFlash logs (``.bin``) into the gyrodrift input contract.

Needs the optional package pymavlink: ``pip install 'gyrodrift[ardupilot]'``.
pymavlink's ``DFReader_binary`` parses the ``FMT`` definitions and indexes where every
message starts; the fields used here are then decoded from those places with numpy,
type by type (one array per field, the same values pymavlink's messages give,
``c``/``C``/``e``/``E``/``L`` fields scaled as pymavlink scales them).

Which messages give which column
--------------------------------
``t``
    ``IMU.TimeUS`` (µs since boot; ``TimeMS``, ms, in old logs) of the chosen IMU,
    in seconds, kept absolute (not shifted to 0).
``gyro_x``, ``gyro_y``, ``gyro_z`` (deg/s, body FRD)
    ``IMU.GyrX, GyrY, GyrZ`` (rad/s). ArduPilot logs the rates of each IMU after its
    calibration and the board rotation (``AHRS_ORIENTATION``), in the vehicle body
    frame FRD, so only the unit changes. IMU instance ``instance``: the messages
    ``IMU`` whose field ``I`` equals it (current logs) or, in older logs without
    ``I``, the types ``IMU`` (0), ``IMU2`` (1), ``IMU3`` (2).
``temp`` (degC)
    ``IMU.T`` of the same IMU (same message, no interpolation). A temperature that
    is exactly 0 in every sample (or NaN), or no ``T`` field, counts as "not
    measured": ``temp`` is 0 in every row and a note says so (:mod:`gyrodrift.io.notes`).
``acc_x``, ``acc_y``, ``acc_z`` (m/s², specific force, body FRD)
    ``IMU.AccX, AccY, AccZ`` of the same IMU (level and still: ``acc_z`` ≈ −9.81).
``mag_x``, ``mag_y``, ``mag_z`` (gauss, body FRD)
    ``MAG.MagX, MagY, MagZ`` (milligauss, corrected and rotated to the body frame by
    ArduPilot) of compass ``mag_instance`` (``MAG.I``, or ``MAG``/``MAG2``/``MAG3``);
    default the ``COMPASS_PRIMARY`` parameter when the log has it and that compass,
    else the lowest instance logged. Samples flagged unhealthy (``Health`` 0) are
    dropped. Each sample goes on the row of the first gyro sample at or after it;
    the other rows are NaN. No columns, compass "none" and a note when the log has
    no ``MAG`` messages, no accelerometer fields, or no sample within the gyro record.
``ref_heading`` (deg, [0, 360)), with ``reference=True``
    ``ATT.Yaw`` (deg, NED, clockwise from north) interpolated in unwrapped form onto
    the gyro rows, NaN outside the attitude record. For evaluation only.

A file that ends inside a message (the logger stopped mid-write) is read up to its
last complete message, and stretches of bytes that are no message (pymavlink skips
them) are counted; the summary says so in both cases. Errors are one line,
``<file>: [<message>: ]<problem>; <what to do>``, as in :mod:`gyrodrift.io.validate`.
"""

from __future__ import annotations

import contextlib
import io
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
    median_rate_hz,
    on_following_rows,
)
from gyrodrift.io.limits import GYRO_MAX_DPS, check_gyro_max_dps
from gyrodrift.io.notes import NO_TEMPERATURE_C
from gyrodrift.io.messages import message, one_line, read_log_bytes
from gyrodrift.onboard import ardupilot_onboard

__all__ = ["read_ardupilot", "read_ardupilot_imus", "MAGIC"]

_INSTALL = "pip install 'gyrodrift[ardupilot]'"
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


def _import_dfreader():
    """Return pymavlink's ``DFReader`` module, or raise :class:`ConfigError` naming the extra."""
    try:
        from pymavlink import DFReader
    except ImportError as exc:
        raise ConfigError(
            f"reading ArduPilot DataFlash logs needs the optional package pymavlink; install it with {_INSTALL}"
        ) from exc
    return DFReader


def _check_file(path: Path) -> None:
    """Raise a one-line :class:`LogFormatError` unless ``path`` starts like a DataFlash log."""
    name = str(path)
    head = read_log_bytes(path, "a DataFlash log", "give the path of a .bin log", "give an ArduPilot .bin log", len(MAGIC))
    if head != MAGIC:
        raise LogFormatError(
            message(
                name,
                "is not an ArduPilot DataFlash log (it does not start with a FMT message, bytes A3 95 80)",
                "give a binary .bin log (from the SD card or downloaded over MAVLink), or name the right format",
            )
        )


def _open(dfreader, path: Path):
    """Index the log with pymavlink; any failure of the parser becomes one LogFormatError.

    pymavlink's reader also works out a wall-clock time base when it opens a log,
    which in a log without GPS time reads every message in Python (about half a
    minute for 80 MB). The times used here are the messages' own ``TimeUS``, so that
    step is left out: ``init_clock`` only rewinds.
    """

    class IndexOnly(dfreader.DFReader_binary):
        def init_clock(self):
            self._rewind(keep_messages=True)

    try:
        # pymavlink prints about skipped bytes; keep that out of gyrodrift's output
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            return IndexOnly(str(path), zero_time_base=True)
    except Exception as exc:  # any failure of a third-party parser on an untrusted file
        raise LogFormatError(
            message(str(path), f"cannot be parsed as a DataFlash log ({one_line(str(exc)) or type(exc).__name__})",
                    "check that it is a complete ArduPilot .bin log")
        ) from exc


def _dtype(fmt, name: str) -> tuple[np.dtype, dict]:
    """Numpy record type of a message type's body, and its fields' multipliers."""
    names, types, scales = [], [], {}
    for char, column in zip(fmt.format, fmt.columns):
        if char not in _FIELD_TYPES:
            raise LogFormatError(
                message(name, f"format character {char!r} of field {column} is not a DataFlash type",
                        "the log is corrupt or from an unsupported logger", where=f"message {fmt.name}")
            )
        numpy_type, scale = _FIELD_TYPES[char]
        names.append(column)
        types.append(numpy_type)
        if scale is not None:
            scales[column] = scale
    dtype = np.dtype({"names": names, "formats": types})
    if dtype.itemsize != fmt.len - _HEADER_BYTES:
        raise LogFormatError(
            message(name, f"its FMT states {fmt.len} bytes but the format {fmt.format!r} packs"
                    f" {dtype.itemsize + _HEADER_BYTES}", "the log is corrupt; download it again",
                    where=f"message {fmt.name}")
        )
    return dtype, scales


def _complete(reader, type_id: int) -> np.ndarray:
    """Start offsets of the messages of ``type_id`` that end within the file."""
    offsets = np.asarray(reader.offsets[type_id], dtype=np.int64)
    return offsets[offsets + reader.formats[type_id].len <= reader.data_len]


def _records(reader, name: str, type_name: str) -> tuple[np.ndarray, dict] | None:
    """Every complete message ``type_name`` as a numpy record array (raw field values),
    and the multipliers of its scaled fields; None if the log defines no such type."""
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
    """Fields ``wanted`` (those present) of every complete message ``type_name``, as float64.

    Returns None if the log defines no such type. Scaled fields are divided by their
    factor (100 for ``c``/``C``/``e``/``E``, 1e7 for ``L``), as pymavlink does.
    """
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
    """The ``PARM`` messages: parameter name -> value (the last logged value wins), and the
    names logged with more than one value (changed during the log)."""
    found = _records(reader, name, "PARM")
    if found is None or not {"Name", "Value"} <= set(found[0].dtype.names):
        return {}, set()
    records = found[0]
    names = [n.split(b"\0", 1)[0].decode("ascii", "replace") for n in records["Name"]]
    values = records["Value"].astype(np.float64).tolist()
    seen: dict[str, set] = {}
    for key, value in zip(names, values):
        seen.setdefault(key, set()).add(value)
    return dict(zip(names, values)), {k for k, v in seen.items() if len(v) > 1}


def _time_s(fields: dict) -> np.ndarray | None:
    """Message times (s) from ``TimeUS`` (µs) or, in old logs, ``TimeMS`` (ms)."""
    if "TimeUS" in fields:
        return fields["TimeUS"] * 1e-6
    if "TimeMS" in fields:
        return fields["TimeMS"] * 1e-3
    return None


def _sources(reader, name: str, types, wanted) -> dict[int, _Source]:
    """Every logged instance of a sensor: instance number -> its messages.

    Current logs have one type (``IMU``) with an instance field ``I``; older ones a
    type per instance (``IMU``, ``IMU2``, ``IMU3``: instances 0, 1, 2).
    """
    found: dict[int, _Source] = {}
    for number, type_name in enumerate(types):
        fields = _decode(reader, name, type_name, ("TimeUS", "TimeMS", "I", *wanted))
        if fields is None or not fields:
            continue
        t = _time_s(fields)
        if t is None:
            raise LogFormatError(
                message(name, "has no TimeUS nor TimeMS field", "convert the log to CSV in the input contract",
                        where=f"message {type_name}")
            )
        if "I" not in fields:
            if t.size:
                found.setdefault(number, _Source(type_name, fields, t))
            continue
        for instance in np.unique(fields["I"]).astype(int):
            keep = fields["I"] == instance
            picked = {k: v[keep] for k, v in fields.items()}
            found.setdefault(int(instance), _Source(f"{type_name} instance {instance}", picked, t[keep]))
    return found


def _pick(found: dict[int, _Source], kind: str, instance: int, name: str, option: str) -> _Source:
    """The source of ``instance``; a missing sensor or instance raises, listing those present."""
    if not found:
        raise LogFormatError(
            message(name, f"no {kind} messages in the log", f"enable {kind} logging (LOG_BITMASK) or convert the"
                    " log to CSV in the input contract")
        )
    if instance not in found:
        present = ", ".join(str(k) for k in sorted(found))
        raise ConfigError(
            message(name, f"there is no {kind} instance {instance}; instances present: {present}",
                    f"choose one of them ({option}=N)")
        )
    return found[instance]


def _stack(source: _Source, fields) -> np.ndarray | None:
    """Fields as columns (n, k); None if any is missing."""
    if not all(f in source.fields for f in fields):
        return None
    return np.column_stack([source.fields[f] for f in fields])


# ---------------------------------------------------------------------------
# streams
# ---------------------------------------------------------------------------


def _temperature(imu: _Source) -> tuple[Stream | None, str]:
    """``IMU.T`` (degC), or None and why it is not usable (for the note)."""
    if "T" not in imu.fields:
        return None, f"{imu.label} has no temperature field T"
    temp = imu.fields["T"]
    ok = np.isfinite(temp)
    if ok.any() and np.any(temp[ok] != 0.0):
        return Stream(imu.label, imu.t[ok], temp[ok]), ""
    what = f"{NO_TEMPERATURE_C:g} degC" if ok.any() else "NaN"
    return None, f"{imu.label} logs {what} in all {temp.size} samples"


def _mag_stream(reader, params: dict, mag_instance: int | None, name: str) -> tuple[Stream | None, int]:
    """Magnetometer (gauss, body FRD) by the rule in the module doc, and the number of
    unhealthy samples dropped; None if the log has no MAG messages (no instance named)."""
    found = _sources(reader, name, _MAG_TYPES, (*_MAG_FIELDS, "Health"))
    if mag_instance is None:
        if not found:
            return None, 0
        primary = params.get("COMPASS_PRIMARY")
        mag_instance = int(primary) if primary is not None and int(primary) in found else min(found)
    mag = _pick(found, "MAG", mag_instance, name, "mag_instance")
    values = _stack(mag, _MAG_FIELDS)
    if values is None:
        raise LogFormatError(
            message(name, f"field(s) MagX, MagY, MagZ missing; fields found: {', '.join(sorted(mag.fields))}",
                    "convert the log to CSV in the input contract", where=mag.label)
        )
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


def _check_instance(value, option: str, allow_none: bool = False) -> None:
    """Raise :class:`ConfigError` unless ``value`` is a non-negative int (or None if allowed)."""
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ConfigError(one_line(f"{option} must be a non-negative integer, got {value!r}"))


def _compass(t: np.ndarray, mag: Stream | None, acc) -> tuple[np.ndarray | None, int, str]:
    """The magnetometer samples on the gyro rows (None: no compass), the number of rows
    that got one, and why there is no compass (``""`` when there is one)."""
    if mag is None:
        return None, 0, "no MAG messages in the log"
    if acc is None:
        return None, 0, "no accelerometer fields AccX, AccY, AccZ in the IMU messages for the tilt"
    if mag.t.size == 0:
        return None, 0, f"no healthy sample of {mag.label}"
    on_rows, rows = on_following_rows(t, mag.t, mag.values)
    if rows == 0:
        return None, 0, f"no sample of {mag.label} falls within the gyro record, t = {t[0]:.3f}..{t[-1]:.3f} s"
    return on_rows, rows, ""


def _summary(name: str, t, imu: _Source, temp: Stream | None, mag: Stream | None, mag_rows: int,
             has_acc: bool, extra: list[str]) -> str:
    """One human line describing what was read (``mag_rows`` 0: no compass)."""
    parts = [
        f"{Path(name).name}: {t[-1] - t[0]:.1f} s of data from t={t[0]:.3f} s, {t.size} rows",
        f"gyro {median_rate_hz(t):.3g} Hz from {imu.label}",
    ]
    if temp is not None:
        parts.append(f"temperature {np.min(temp.values):.1f}..{np.max(temp.values):.1f} degC from {temp.label}")
    else:
        parts.append(f"no gyro temperature (temp set to {NO_TEMPERATURE_C:g} degC)")
    if mag_rows:
        parts.append(f"compass: mag from {mag.label} ({describe_rate(mag.t)}, on {mag_rows} rows) + acc from"
                     f" {imu.label}")
    else:
        parts += ["no compass"] + ([f"acc from {imu.label}"] if has_acc else [])
    return "; ".join(parts + extra)


def read_ardupilot(path, *, instance: int = 0, mag_instance: int | None = None, reference: bool = True,
                   gyro_max_dps: float = GYRO_MAX_DPS) -> pd.DataFrame:
    """Read an ArduPilot DataFlash log (``.bin``) into the gyrodrift input contract.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.bin`` file.
    instance : int, default 0
        IMU instance (``IMU.I``, or 0/1/2 for ``IMU``/``IMU2``/``IMU3``) whose rate,
        temperature and acceleration are used.
    mag_instance : int, optional
        Compass instance (``MAG.I``, or ``MAG``/``MAG2``/``MAG3``). Default:
        ``COMPASS_PRIMARY`` when logged, else the lowest instance in the log.
    reference : bool, default True
        Add ``ref_heading`` (deg) from ``ATT.Yaw`` when the log has it.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s; a larger rate (a corrupt record)
        is refused, as are the other implausible values of :mod:`gyrodrift.io.limits`.

    Returns
    -------
    pandas.DataFrame
        One row per IMU sample: ``t`` (s, absolute, strictly increasing), ``gyro_z``,
        ``gyro_x``, ``gyro_y`` (deg/s, body FRD; ``gyro_z`` > 0 = heading increasing),
        ``temp`` (degC; 0 in every row without a measured temperature), ``mag_x``,
        ``mag_y``, ``mag_z`` (gauss, body FRD, NaN on rows without a new sample; no
        columns without a compass), ``acc_x``, ``acc_y``, ``acc_z`` (m/s², specific
        force, body FRD) and, with ``reference``, ``ref_heading`` (deg, [0, 360)).
        ``df.attrs``: ``source``, ``format`` ("ardupilot"), ``gyro_unit`` ("deg/s"),
        ``frame`` ("ned"), ``compass`` ("mag", or "none"), ``mag_unit`` ("gauss", with
        the mag columns), ``acc_unit`` ("m/s^2", with the acc columns), ``topics``
        (column group -> message used, None for a group without data), ``summary``
        (one line), ``onboard`` (:class:`gyrodrift.onboard.Onboard`: the board rotation
        ``AHRS_ORIENTATION``, the IMU and the ``INS_TCAL`` correction its rates hold)
        and, when the log has no compass or no measured temperature, ``notes`` (one line
        each, :mod:`gyrodrift.io.notes`).

    Raises
    ------
    LogFormatError
        Missing, empty or non-DataFlash file; one pymavlink cannot parse; no IMU
        messages or no gyro fields; fewer than 2 IMU samples; an implausible
        temperature; a message definition that does not add up.
    ConfigError
        pymavlink is not installed; ``instance`` or ``mag_instance`` is not a
        non-negative integer or not in the log (the message lists those present).

    Notes
    -----
    Samples with a repeated time stamp are dropped (the first is kept) and counted in
    the summary; see the module documentation for the message rules.
    """
    _check_instance(instance, "instance")
    return _read_instances(path, [instance], mag_instance, reference, gyro_max_dps)[0]


def read_ardupilot_imus(path, *, mag_instance: int | None = None, reference: bool = True,
                        gyro_max_dps: float = GYRO_MAX_DPS) -> list[pd.DataFrame]:
    """Every IMU of a DataFlash log, each read as :func:`read_ardupilot` reads one, in
    instance order (``attrs["onboard"].instance``).

    Raises
    ------
    LogFormatError, ConfigError
        As :func:`read_ardupilot`.
    """
    return _read_instances(path, None, mag_instance, reference, gyro_max_dps)


def _read_instances(path, instances, mag_instance, reference, gyro_max_dps) -> list[pd.DataFrame]:
    """The IMU ``instances`` of the log at ``path`` (None: all), the file opened once."""
    _check_instance(mag_instance, "mag_instance", allow_none=True)
    gyro_max_dps = check_gyro_max_dps(gyro_max_dps)
    dfreader = _import_dfreader()
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


def _read(reader, name: str, instance: int, mag_instance: int | None, reference: bool,
          gyro_max_dps: float) -> pd.DataFrame:
    """The body of :func:`read_ardupilot` on an open pymavlink reader."""
    skipped, partial = _damage(reader)
    imus = _sources(reader, name, _IMU_TYPES, (*_GYRO_FIELDS, *_ACC_FIELDS, "T"))
    if not imus and partial:
        raise LogFormatError(
            message(name, f"the file is truncated: it ends inside a message at byte {reader.data_len}, before"
                    " any IMU sample", "copy the complete .bin from the vehicle again")
        )
    imu = _pick(imus, "IMU", instance, name, "instance")
    rates = _stack(imu, _GYRO_FIELDS)
    if rates is None:
        raise LogFormatError(
            message(name, f"field(s) GyrX, GyrY, GyrZ missing; fields found: {', '.join(sorted(imu.fields))}",
                    "convert the log to CSV in the input contract", where=imu.label)
        )
    acc_values = _stack(imu, _ACC_FIELDS)
    columns = rates if acc_values is None else np.column_stack([rates, acc_values])
    gyro, dropped = increasing(Stream(imu.label, imu.t, columns))
    if gyro.t.size < _MIN_GYRO_SAMPLES:
        raise LogFormatError(
            message(name, f"too few gyro samples ({gyro.t.size}) in {imu.label}",
                    f"give a log with at least {_MIN_GYRO_SAMPLES} IMU samples")
        )
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
    mag_on_rows, mag_rows, no_compass_why = _compass(t, mag, acc)

    extra = []
    ref = _reference(reader, name) if reference else None
    ref_heading = None
    if ref is not None:
        ref, _ = increasing(ref)
        ref_heading = interp_heading(ref.t, ref.values, t)
        extra.append("ref_heading from ATT.Yaw")
    elif reference:
        extra.append("no ATT messages, so no ref_heading")
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

    topics = {"gyro": imu.label, "temp": temp.label if temp is not None else None,
              "mag": mag.label if mag_rows else None, "acc": imu.label if acc is not None else None,
              "ref_heading": ref.label if ref is not None else None}
    return binary_log_frame(
        name, "ardupilot", t, np.degrees(gyro.values[:, :3]), temp_on_rows if temp is not None else None, mag_on_rows,
        acc, ref_heading, topics=topics, summary=_summary(name, t, imu, temp, mag, mag_rows, acc is not None, extra),
        no_compass_why=no_compass_why, no_temp_why=no_temp_why, gyro_max_dps=gyro_max_dps, onboard=onboard)

"""A small PX4 ULog (``.ulg``) writer for the tests.

Written for gyrodrift from PX4's description of the format ("ULog File Format" in the PX4
user guide; no code taken from elsewhere): a 16-byte header (``ULog``, the bytes
``01 12 35``, a version byte, the start time in µs as uint64), then messages of a
uint16 payload size, a uint8 type and the payload, little-endian:

* ``B`` flag bits: 8 compatible and 8 incompatible flag bytes, 3 uint64 offsets;
* ``F`` format: ``name:type field;type field;...`` (the first field ``uint64_t timestamp``);
* ``P`` parameter: a uint8 key length, the key ``int32_t NAME`` or ``float NAME``, the value;
* ``A`` add subscription (starts the data section): uint8 multi id, uint16 message id, the name;
* ``D`` data: uint16 message id, then the fields packed as the format says.

:func:`write_ulog` writes topics given as numpy structured arrays.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

_TYPES = {"uint64_t": "<u8", "int64_t": "<i8", "uint32_t": "<u4", "int32_t": "<i4", "uint16_t": "<u2",
          "int16_t": "<i2", "uint8_t": "u1", "int8_t": "i1", "float": "<f4", "double": "<f8", "bool": "u1"}


def _message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def topic_dtype(fields) -> np.dtype:
    """Numpy record type of ``[(ulog type, name), ...]`` (``float[3] name`` for arrays)."""
    out = []
    for kind, name in fields:
        if "[" in kind:
            base, n = kind[:-1].split("[")
            out += [(f"{name}[{i}]", _TYPES[base]) for i in range(int(n))]
        else:
            out.append((name, _TYPES[kind]))
    return np.dtype(out)


def write_ulog(path: Path, topics: dict, params: dict | None = None, start_us: int = 1_000_000) -> Path:
    """Write a ULog.

    Parameters
    ----------
    path : pathlib.Path
    topics : dict
        ``{(name, multi_id): (fields, records)}``: ``fields`` a list of ``(ulog type,
        field name)`` starting with ``("uint64_t", "timestamp")``, ``records`` a numpy
        array of :func:`topic_dtype` of them.
    params : dict, optional
        Parameter name -> int (written int32) or float (float32).
    """
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", start_us))
    out += _message(b"B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    formats = {}
    for (name, _), (fields, _) in topics.items():
        formats[name] = fields
    for name, fields in formats.items():
        out += _message(b"F", (name + ":" + "".join(f"{k} {n};" for k, n in fields)).encode())
    for key, value in (params or {}).items():
        kind, packed = ("int32_t", struct.pack("<i", value)) if isinstance(value, (int, np.integer)) \
            else ("float", struct.pack("<f", value))
        tag = f"{kind} {key}".encode()
        out += _message(b"P", bytes([len(tag)]) + tag + packed)
    rows = []
    for msg_id, ((name, multi), (fields, records)) in enumerate(topics.items()):
        out += _message(b"A", struct.pack("<BH", multi, msg_id) + name.encode())
        body = records.astype(topic_dtype(fields)).tobytes()
        size = topic_dtype(fields).itemsize
        for i, ts in enumerate(records["timestamp"]):
            rows.append((int(ts), msg_id, body[i * size:(i + 1) * size]))
    rows.sort(key=lambda r: (r[0], r[1]))
    for _, msg_id, payload in rows:
        out += _message(b"D", struct.pack("<H", msg_id) + payload)
    Path(path).write_bytes(bytes(out))
    return Path(path)


SENSOR_GYRO = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"), ("uint32_t", "device_id"),
               ("float", "x"), ("float", "y"), ("float", "z"), ("float", "temperature")]
SENSOR_ACCEL = SENSOR_GYRO
SENSOR_COMBINED = [("uint64_t", "timestamp"), ("float[3]", "gyro_rad"), ("uint32_t", "gyro_integral_dt"),
                   ("int32_t", "accelerometer_timestamp_relative"), ("float[3]", "accelerometer_m_s2")]


def records(fields, **columns) -> np.ndarray:
    """A record array of ``fields`` filled from ``columns`` (arrays of equal length; an
    array field ``gyro_rad`` takes an (n, 3) array)."""
    n = len(next(iter(columns.values())))
    rec = np.zeros(n, dtype=topic_dtype(fields))
    for name, values in columns.items():
        values = np.asarray(values)
        if values.ndim == 2:
            for i in range(values.shape[1]):
                rec[f"{name}[{i}]"] = values[:, i]
        else:
            rec[name] = values
    return rec

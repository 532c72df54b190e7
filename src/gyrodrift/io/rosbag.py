"""Read ROS 1 and ROS 2 bags into the gyrodrift input contract (needs rosbags, not ROS).

Messages and columns, times, the FLU/ENU to FRD/NED conversion and how topics are
chosen: docs/log-formats.md, section "ROS bags".
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.conventions import wrap_360
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io.align import (
    Stream, binary_log_frame, check_temperature, compass_on_rows, compass_parts, increasing, interp_held,
    measured_temperature, median_rate_hz, read_summary, yaw_deg,
)
from gyrodrift.io.limits import GYRO_MAX_DPS, check_gyro_max_dps
from gyrodrift.io.messages import log_error, one_line, option_error, optional_module

__all__ = ["read_rosbag", "ROS2_SUFFIXES"]

_IMU = "sensor_msgs/msg/Imu"
_TEMPERATURE = "sensor_msgs/msg/Temperature"
_MAGNETIC_FIELD = "sensor_msgs/msg/MagneticField"
#: Single-file ROS 2 storage formats.
ROS2_SUFFIXES = (".db3", ".mcap")
#: FLU -> FRD (and ENU -> NED for vectors): x stays, y and z change sign.
_FLU_TO_FRD = np.array([1.0, -1.0, -1.0])
_MIN_IMU_SAMPLES = 2
_MAX_TOPICS_SHOWN = 20


class _Role(NamedTuple):
    """One message type the reader uses: its type name, option and purpose."""

    msgtype: str
    option: str
    purpose: str
    advice: str
    required: bool  #: False: a bag without such a topic is read without it (with a note)


_ROLES = (
    _Role(_IMU, "imu_topic", "the gyro rate", "record the IMU driver's sensor_msgs/Imu topic", True),
    _Role(
        _TEMPERATURE,
        "temp_topic",
        "the gyro temperature",
        "record the IMU driver's temperature topic (sensor_msgs/Temperature)",
        False,
    ),
    _Role(
        _MAGNETIC_FIELD,
        "mag_topic",
        "the compass",
        "record the magnetometer topic (sensor_msgs/MagneticField)",
        False,
    ),
)


# ---------------------------------------------------------------------------
# opening the bag
# ---------------------------------------------------------------------------


def _import_rosbags():
    """rosbags' ``AnyReader`` and the typestore of ROS 2 bags that do not embed their message definitions."""
    what = "reading ROS bags"
    any_reader = optional_module("rosbags.highlevel.AnyReader", what, "rosbags", "ros")
    typesys = optional_module("rosbags.typesys", what, "rosbags", "ros")
    return any_reader, typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)


def _check_bag_path(path: Path) -> None:
    """Raise :class:`LogFormatError` for a missing path, a plain directory or an empty file."""
    name = str(path)
    if not path.exists():
        raise log_error(name, "input file does not exist", "check the path and the current directory")
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise log_error(name, "is a directory without metadata.yaml, so not a ROS 2 bag",
                            "give a ROS 2 bag directory, a .db3/.mcap file or a ROS 1 .bag file")
        return
    if path.stat().st_size == 0:
        raise log_error(name, "file is empty", "give a ROS 1 .bag or a ROS 2 .db3/.mcap bag")


def _unreadable(path: Path, exc: BaseException) -> LogFormatError:
    """The error for a bag the rosbags library cannot read."""
    detail = one_line(str(exc)) or type(exc).__name__
    kinds = {p.suffix.lower() for p in ([path] if path.is_file() else path.iterdir())}
    repair = ""
    if ".bag" in kinds:
        repair = ", or repair an unclosed/truncated bag with 'rosbag reindex'"
    elif ".mcap" in kinds:
        repair = ", or repair a truncated file with 'mcap recover'"
    return log_error(str(path), f"is not a readable ROS bag ({detail})",
                     f"check that the bag is complete and was closed properly (copy it again){repair}")


# ---------------------------------------------------------------------------
# topics
# ---------------------------------------------------------------------------


def _show_topics(topics: dict[str, str]) -> str:
    """List topics with their types for a message."""
    items = [f"{t!r} ({typ})" for t, typ in sorted(topics.items())]
    if not items:
        return "(none)"
    if len(items) > _MAX_TOPICS_SHOWN:
        items = items[:_MAX_TOPICS_SHOWN] + [f"... ({len(items) - _MAX_TOPICS_SHOWN} more)"]
    return ", ".join(items)


def _choose_topic(topics: dict[str, str], role: _Role, given: str | None, name: str) -> str | None:
    """The topic for ``role``: named by its option, else the only one of its type (None: none, not required)."""
    of_type = {t: typ for t, typ in topics.items() if typ == role.msgtype}
    if given is not None:
        if given not in topics:
            raise option_error(name,
                               f"there is no topic {given!r} in the bag; {role.msgtype} topics: {_show_topics(of_type)}",
                               f"fix {role.option}")
        if topics[given] != role.msgtype:
            raise option_error(name, f"topic {given!r} has type {topics[given]}, not {role.msgtype};"
                               f" {role.msgtype} topics: {_show_topics(of_type)}", f"fix {role.option}")
        return given
    if len(of_type) == 1:
        return next(iter(of_type))
    if not of_type and not role.required:
        return None
    if not of_type:
        raise log_error(name, f"no {role.msgtype} topic in the bag (needed for {role.purpose});"
                        f" topics found: {_show_topics(topics)}", role.advice)
    raise option_error(name, f"{len(of_type)} {role.msgtype} topics: {_show_topics(of_type)}",
                       f"choose one with {role.option}")


# ---------------------------------------------------------------------------
# messages
# ---------------------------------------------------------------------------


class _Raw(NamedTuple):
    """Values collected from the messages of one topic (lists, one entry per message)."""

    stamp: list  #: header stamp (s); 0.0 if the stamp is zero
    received: list  #: bag record time (s)
    values: list  #: per message: a tuple of numbers


def _stamp_s(msg) -> float:
    """``header.stamp`` in seconds (0.0 for a zero stamp)."""
    stamp = msg.header.stamp
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


def _imu_values(msg) -> tuple:
    """Rate (3), acceleration (3), quaternion w, x, y, z (4) and orientation_covariance[0]."""
    w, a, q = msg.angular_velocity, msg.linear_acceleration, msg.orientation
    return (w.x, w.y, w.z, a.x, a.y, a.z, q.w, q.x, q.y, q.z, float(msg.orientation_covariance[0]))


def _temperature_values(msg) -> tuple:
    """The temperature (degC)."""
    return (msg.temperature,)


def _mag_values(msg) -> tuple:
    """The magnetic field (tesla)."""
    f = msg.magnetic_field
    return (f.x, f.y, f.z)


_EXTRACT = {_IMU: _imu_values, _TEMPERATURE: _temperature_values, _MAGNETIC_FIELD: _mag_values}


def _collect(reader, chosen: dict[str, str]) -> dict[str, _Raw]:
    """Deserialize the messages of the chosen topics (topic -> msgtype)."""
    raw = {topic: _Raw([], [], []) for topic in chosen}
    connections = [c for c in reader.connections if c.topic in chosen]
    for conn, received_ns, data in reader.messages(connections=connections):
        msg = reader.deserialize(data, conn.msgtype)
        out = raw[conn.topic]
        out.stamp.append(_stamp_s(msg))
        out.received.append(received_ns * 1e-9)
        out.values.append(_EXTRACT[chosen[conn.topic]](msg))
    return raw


def _to_stream(topic: str, raw: _Raw, width: int) -> tuple[Stream, int]:
    """Stream with header-stamp times (bag time where the stamp is zero); and that count."""
    stamp = np.asarray(raw.stamp, dtype=np.float64)
    received = np.asarray(raw.received, dtype=np.float64)
    zero = stamp == 0.0
    t = np.where(zero, received, stamp)
    values = np.asarray(raw.values, dtype=np.float64).reshape(len(raw.values), width)
    return Stream(f"topic {topic!r}", t, values), int(zero.sum())


def _read_bag(rosbags_api, path: Path, imu_topic, temp_topic, mag_topic) -> tuple[dict[str, str], dict[str, _Raw]]:
    """Open the bag, choose the topics (topic -> msgtype) and collect their messages; any error of
    rosbags is one :class:`LogFormatError`."""
    any_reader, default_types = rosbags_api
    name = str(path)
    given = (imu_topic, temp_topic, mag_topic)
    try:
        with any_reader([path], default_typestore=default_types) as reader:
            topics = {t: (info.msgtype or "(mixed types)") for t, info in reader.topics.items()}
            chosen = {_choose_topic(topics, role, g, name): role.msgtype for role, g in zip(_ROLES, given)}
            chosen.pop(None, None)  # a type the bag has no topic of
            return chosen, _collect(reader, chosen)
    except (ConfigError, LogFormatError):
        raise
    except Exception as exc:  # any failure of a third-party parser on an untrusted file
        raise _unreadable(path, exc) from exc


# ---------------------------------------------------------------------------
# conversion
# ---------------------------------------------------------------------------


def _temperature(name: str, stream: Stream) -> tuple[Stream | None, str]:
    """Temperature samples that hold a value, and ``""``; or None and why there is none."""
    if not stream.t.size:
        return None, f"no message on {stream.label}"
    out, why = measured_temperature(stream.label, stream.t, stream.values[:, 0], "is", "messages")
    if out is not None:
        check_temperature(name, stream.label, out.values)
    return out, why


def _reference_heading(imu: Stream) -> tuple[np.ndarray, int]:
    """``ref_heading`` (deg, NED) from the Imu orientation where it is set; NaN elsewhere."""
    q = imu.values[:, 6:10]
    cov0 = imu.values[:, 10]
    finite = np.all(np.isfinite(q), axis=1)
    valid = (cov0 != -1.0) & finite & (np.sum(np.where(finite[:, None], q, 0.0) ** 2, axis=1) > 0.0)
    with np.errstate(invalid="ignore"):
        yaw_enu = yaw_deg(q[:, 0], q[:, 1], q[:, 2], q[:, 3])
    heading = np.where(valid, wrap_360(90.0 - yaw_enu), np.nan)
    return heading, int(valid.sum())


def _check_imu_count(name: str, imu: Stream) -> None:
    """The Imu topic needs at least two messages."""
    if imu.t.size < _MIN_IMU_SAMPLES:
        raise log_error(name, f"too few messages ({imu.t.size}) on {imu.label}",
                        f"give a bag with at least {_MIN_IMU_SAMPLES} message(s) on it")


def _notes(zero_stamps: int, dropped: int, ref_count: int) -> list[str]:
    """Summary remarks: reference heading, receive-time fallbacks, dropped duplicates."""
    notes = [
        f"ref_heading from the Imu orientation on {ref_count} rows"
        if ref_count
        else "no Imu orientation, so no ref_heading"
    ]
    if zero_stamps:
        notes.append(f"{zero_stamps} messages with a zero header stamp timed by the bag receive time")
    if dropped:
        notes.append(f"{dropped} Imu messages with a repeated time dropped")
    return notes


class _Gaps(NamedTuple):
    """Why the bag has no measured temperature or no compass (``""``: it has one)."""

    temp: str
    compass: str


def _streams(
    name: str, chosen: dict[str, str], raw: dict[str, _Raw]
) -> tuple[dict[str, Stream | None], int, int, _Gaps]:
    """Time-ordered Imu, temperature and magnetometer streams (FLU), the messages timed by their receive
    time, the Imu messages dropped for a repeated time, and why temperature or magnetometer is None."""
    by_type = {msgtype: topic for topic, msgtype in chosen.items()}
    widths = {"imu": (_IMU, 11), "temp": (_TEMPERATURE, 1), "mag": (_MAGNETIC_FIELD, 3)}
    streams: dict[str, Stream | None] = {}
    zero_stamps = 0
    for role, (msgtype, width) in widths.items():
        topic = by_type.get(msgtype)
        streams[role], zero = _to_stream(topic, raw[topic], width) if topic is not None else (None, 0)
        zero_stamps += zero
    _check_imu_count(name, streams["imu"])
    streams["imu"], dropped = increasing(streams["imu"])
    if streams["imu"].t.size < _MIN_IMU_SAMPLES:
        raise log_error(name, f"too few Imu messages with distinct times ({streams['imu'].t.size}) on"
                        f" {streams['imu'].label}", "give a longer bag")
    temp_gap = f"no {_TEMPERATURE} topic in the bag"
    if streams["temp"] is not None:
        streams["temp"], temp_gap = _temperature(name, increasing(streams["temp"])[0])
    mag_gap = f"no {_MAGNETIC_FIELD} topic in the bag"
    if streams["mag"] is not None and not streams["mag"].t.size:
        mag_gap = f"no message on {streams['mag'].label}"
        streams["mag"] = None
    elif streams["mag"] is not None:
        streams["mag"], mag_gap = increasing(streams["mag"])[0], ""
    return streams, zero_stamps, dropped, _Gaps(temp_gap, mag_gap)


def read_rosbag(
    path, *, imu_topic: str | None = None, temp_topic: str | None = None, mag_topic: str | None = None,
    gyro_max_dps: float = GYRO_MAX_DPS,
) -> pd.DataFrame:
    """Read a ROS 1 or ROS 2 bag into the gyrodrift input contract.

    See docs/log-formats.md, section "ROS bags", for the messages each column comes from.

    Parameters
    ----------
    path : str or os.PathLike
        ROS 1 ``.bag`` file, ROS 2 bag directory or ROS 2 ``.db3``/``.mcap`` file.
    imu_topic, temp_topic, mag_topic : str, optional
        Topics of type ``sensor_msgs/Imu``, ``Temperature`` and ``MagneticField``; each
        may be left out when the bag has one topic of that type.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        One row per Imu message (``mag_*`` in tesla; ``ref_heading`` only when the Imu
        has an orientation); ``attrs`` as docs/log-formats.md, section "Alignment",
        with ``format`` "rosbag".

    Raises
    ------
    LogFormatError
        Missing, empty, unreadable or truncated bag; no Imu topic; fewer than two Imu
        messages with distinct times; an implausible value.
    ConfigError
        rosbags is not installed; a named topic missing or of another type; several
        topics of a type and no option naming one.
    """
    gyro_max_dps = check_gyro_max_dps(gyro_max_dps)
    rosbags_api = _import_rosbags()
    path = Path(path)
    name = str(path)
    _check_bag_path(path)
    chosen, raw = _read_bag(rosbags_api, path, imu_topic, temp_topic, mag_topic)
    streams, zero_stamps, dropped, gaps = _streams(name, chosen, raw)
    imu, temp, mag = streams["imu"], streams["temp"], streams["mag"]
    t = imu.t
    if mag is not None:
        mag = Stream(mag.label, mag.t, mag.values * _FLU_TO_FRD)
    mag_rows, mag_count, compass_gap = compass_on_rows(t, mag, imu, gaps.compass, "", sample="message",
                                                       record="Imu")
    ref_heading, ref_count = _reference_heading(imu)
    topics = {"imu": imu.label, "temp": temp.label if temp is not None else None,
              "mag": mag.label if mag_count else None}
    summary = read_summary(name, t, f"gyro {median_rate_hz(t):.3g} Hz from {imu.label} (ROS FLU converted to FRD)",
                           temp, compass_parts(mag, mag_count, imu.label), _notes(zero_stamps, dropped, ref_count))
    return binary_log_frame(
        name, "rosbag", t, np.degrees(imu.values[:, 0:3]) * _FLU_TO_FRD,
        interp_held(temp.t, temp.values, t) if temp is not None else None, mag_rows, imu.values[:, 3:6] * _FLU_TO_FRD,
        ref_heading if ref_count else None, topics=topics, summary=summary, no_compass_why=compass_gap,
        no_temp_why=gaps.temp, gyro_max_dps=gyro_max_dps, mag_unit="T")

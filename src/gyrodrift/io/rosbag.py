"""Read ROS 1 and ROS 2 bags into the gyrodrift input contract.

Needs the optional package rosbags (``pip install 'gyrodrift[ros]'``); no ROS
installation is used. Accepted: a ROS 1 ``.bag`` file, a ROS 2 bag directory (with
``metadata.yaml``) or a single ROS 2 storage file (``.db3`` or ``.mcap``).

Messages and columns
--------------------
``sensor_msgs/Imu`` (one topic)
    ``angular_velocity`` (rad/s) -> ``gyro_*`` (deg/s); ``linear_acceleration`` (m/s²,
    specific force: a level, still IMU reads z ≈ +9.81 in ROS) -> ``acc_*``;
    ``orientation`` -> ``ref_heading`` where it is set (``orientation_covariance[0]``
    is not −1 and the quaternion is not zero). One output row per Imu message.
``sensor_msgs/Temperature`` (one topic)
    ``temperature`` (degC) -> ``temp``, interpolated linearly onto the Imu times and
    held at the first/last value outside the temperature stream. A temperature that
    is exactly 0 (or NaN) in every message counts as "not measured". Without a
    measured temperature (no such topic, no message, not measured), ``temp`` is 0 in
    every row and a note says so (:mod:`gyrodrift.io.notes`: the drift model is then
    a trend in elapsed time).
``sensor_msgs/MagneticField`` (one topic; a bag has no other compass form)
    ``magnetic_field`` (tesla, kept in tesla) -> ``mag_*``, each sample on the row of
    the first Imu message at or after it, NaN on the other rows. Without one (no such
    topic, or no message within the Imu record): no ``mag_*`` columns, compass
    "none" and a note.

Time of a message: its ``header.stamp`` (``sec + nanosec * 1e-9`` s, absolute, not
shifted to 0); if that stamp is zero, the time the bag recorded the message instead
(counted in the summary). Imu messages with a repeated time are dropped (the first
is kept, counted in the summary).

Frames (REP-103): the body frame is FLU (x forward, y left, z up), the world frame ENU.
They are converted to FRD/NED here: x stays, y and z change sign for the rate, the
acceleration and the field (``gyro_z`` > 0 then means the heading increases, and
level specific force reads ``acc_z`` ≈ −9.81); the orientation's yaw (measured
counter-clockwise from east) becomes ``ref_heading = wrap_360(90 − yaw_enu)``
(clockwise from north). The yaw is ``atan2(2 (w z + x y), w² + x² − y² − z²)``, which
equals the usual ``1 − 2 (y² + z²)`` form for a unit quaternion and does not need one.
An IMU without a magnetometer reports a yaw with an arbitrary origin, so its
``ref_heading`` is only good for heading changes.

Topics: an option (``imu_topic``, ``temp_topic``, ``mag_topic``) names the topic; if
it is not given, the only topic of that type is used. Several, or a named topic the
bag lacks, raise a one-line error that lists the topics and says which option to
use; so does a bag without an Imu topic. A bag without a Temperature or a
MagneticField topic is read without it (see above).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.conventions import wrap_360
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io.align import (
    Stream,
    check_temperature,
    binary_log_frame,
    describe_rate,
    increasing,
    interp_held,
    median_rate_hz,
    on_following_rows,
    yaw_deg,
)
from gyrodrift.io.limits import GYRO_MAX_DPS, check_gyro_max_dps
from gyrodrift.io.notes import NO_TEMPERATURE_C
from gyrodrift.io.messages import message, one_line

__all__ = ["read_rosbag", "ROS2_SUFFIXES"]

_INSTALL = "pip install 'gyrodrift[ros]'"
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
    """Return rosbags' ``AnyReader`` and a default typestore, or raise :class:`ConfigError`."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:
        raise ConfigError(
            f"reading ROS bags needs the optional package rosbags; install it with {_INSTALL}"
        ) from exc
    # used only for ROS 2 bags that do not embed their message definitions
    return AnyReader, get_typestore(Stores.ROS2_HUMBLE)


def _check_bag_path(path: Path) -> None:
    """Raise :class:`LogFormatError` for a missing path, a plain directory or an empty file."""
    name = str(path)
    if not path.exists():
        raise LogFormatError(
            message(name, "input file does not exist", "check the path and the current directory")
        )
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise LogFormatError(
                message(
                    name,
                    "is a directory without metadata.yaml, so not a ROS 2 bag",
                    "give a ROS 2 bag directory, a .db3/.mcap file or a ROS 1 .bag file",
                )
            )
        return
    if path.stat().st_size == 0:
        raise LogFormatError(message(name, "file is empty", "give a ROS 1 .bag or a ROS 2 .db3/.mcap bag"))


def _unreadable(path: Path, exc: BaseException) -> LogFormatError:
    """The error for a bag the rosbags library cannot read."""
    detail = one_line(str(exc)) or type(exc).__name__
    kinds = {p.suffix.lower() for p in ([path] if path.is_file() else path.iterdir())}
    repair = ""
    if ".bag" in kinds:
        repair = ", or repair an unclosed/truncated bag with 'rosbag reindex'"
    elif ".mcap" in kinds:
        repair = ", or repair a truncated file with 'mcap recover'"
    return LogFormatError(
        message(
            str(path),
            f"is not a readable ROS bag ({detail})",
            f"check that the bag is complete and was closed properly (copy it again){repair}",
        )
    )


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
    """The topic for ``role``: the one named by its option, else the only one of its type;
    None when the bag has none and the role is not required."""
    of_type = {t: typ for t, typ in topics.items() if typ == role.msgtype}
    if given is not None:
        if given not in topics:
            raise ConfigError(
                message(
                    name,
                    f"there is no topic {given!r} in the bag; {role.msgtype} topics: {_show_topics(of_type)}",
                    f"fix {role.option}",
                )
            )
        if topics[given] != role.msgtype:
            raise ConfigError(
                message(
                    name,
                    f"topic {given!r} has type {topics[given]}, not {role.msgtype};"
                    f" {role.msgtype} topics: {_show_topics(of_type)}",
                    f"fix {role.option}",
                )
            )
        return given
    if len(of_type) == 1:
        return next(iter(of_type))
    if not of_type and not role.required:
        return None
    if not of_type:
        raise LogFormatError(
            message(
                name,
                f"no {role.msgtype} topic in the bag (needed for {role.purpose});"
                f" topics found: {_show_topics(topics)}",
                role.advice,
            )
        )
    raise ConfigError(
        message(
            name,
            f"{len(of_type)} {role.msgtype} topics: {_show_topics(of_type)}",
            f"choose one with {role.option}",
        )
    )


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
    """Open the bag, choose the topics (topic -> msgtype; a type without a topic is left
    out) and collect their messages.

    Any error raised by rosbags or its storage back ends (sqlite3, MCAP, compression)
    while reading means the file is not a readable bag: it becomes one
    :class:`LogFormatError` (the original exception is chained for debugging).
    """
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
    """Temperature samples that hold a value, and ``""``; or None and why there is no
    measured temperature (for the note): no message, or exactly 0 or NaN in all."""
    temp = stream.values[:, 0]
    ok = np.isfinite(temp)
    if not temp.size:
        return None, f"no message on {stream.label}"
    if not ok.any() or not np.any(temp[ok] != 0.0):
        what = f"{NO_TEMPERATURE_C:g} degC" if ok.any() else "NaN"
        return None, f"{stream.label} is {what} in all {temp.size} messages"
    out = Stream(stream.label, stream.t[ok], temp[ok])
    check_temperature(name, stream.label, out.values)
    return out, ""


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
        raise LogFormatError(
            message(
                name,
                f"too few messages ({imu.t.size}) on {imu.label}",
                f"give a bag with at least {_MIN_IMU_SAMPLES} message(s) on it",
            )
        )


def _summary(path: Path, t: np.ndarray, streams: dict[str, Stream | None], mag_count: int, notes: list[str]) -> str:
    """One human line describing what was read (``mag_count`` 0: no compass)."""
    imu, temp, mag = streams["imu"], streams["temp"], streams["mag"]
    parts = [
        f"{path.name}: {t[-1] - t[0]:.1f} s of data from t={t[0]:.3f} s, {t.size} rows",
        f"gyro {median_rate_hz(t):.3g} Hz from {imu.label} (ROS FLU converted to FRD)",
        f"temperature {np.min(temp.values):.1f}..{np.max(temp.values):.1f} degC from {temp.label}"
        f" ({describe_rate(temp.t)}, interpolated)"
        if temp is not None
        else f"no gyro temperature (temp set to {NO_TEMPERATURE_C:g} degC)",
        f"compass: mag from {mag.label} ({describe_rate(mag.t)}, on {mag_count} rows) + acc from {imu.label}"
        if mag_count
        else f"no compass; acc from {imu.label}",
    ]
    return "; ".join(parts + notes)


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
    """Time-ordered Imu, temperature and magnetometer streams (FLU values as recorded).

    Returns the streams (``"temp"``, ``"mag"``: None without a topic, without a
    message, or for a temperature not measured), the number of messages timed by their
    receive time, the number of Imu messages dropped for a repeated time, and why the
    temperature or the magnetometer is None.
    """
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
        raise LogFormatError(
            message(
                name,
                f"too few Imu messages with distinct times ({streams['imu'].t.size}) on {streams['imu'].label}",
                "give a longer bag",
            )
        )
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

    Parameters
    ----------
    path : str or os.PathLike
        ROS 1 ``.bag`` file, ROS 2 bag directory (with ``metadata.yaml``) or ROS 2
        ``.db3``/``.mcap`` file.
    imu_topic, temp_topic, mag_topic : str, optional
        Topics of type ``sensor_msgs/Imu``, ``sensor_msgs/Temperature`` and
        ``sensor_msgs/MagneticField``. Each may be left out if the bag has exactly one
        topic of that type.
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s; a larger rate (a corrupt record)
        is refused, as are the other implausible values of :mod:`gyrodrift.io.limits`.

    Returns
    -------
    pandas.DataFrame
        One row per Imu message: ``t`` (s, absolute, strictly increasing), ``gyro_z``,
        ``gyro_x``, ``gyro_y`` (deg/s, body FRD), ``temp`` (degC; 0 in every row
        without a measured temperature), ``mag_x``, ``mag_y``, ``mag_z`` (tesla, body
        FRD, NaN on rows without a new sample; no columns without a compass),
        ``acc_x``, ``acc_y``, ``acc_z`` (m/s², specific force, body FRD) and
        ``ref_heading`` (deg, [0, 360), NaN where the Imu has no orientation; no column
        if it never has one). ``df.attrs``: ``source``, ``format`` ("rosbag"),
        ``gyro_unit`` ("deg/s"), ``frame`` ("ned"), ``compass`` ("mag", or "none"),
        ``mag_unit`` ("T", with the mag columns), ``acc_unit`` ("m/s^2"), ``topics``
        (column group -> topic; None for a group without data), ``summary`` (one
        line) and, when the bag has no compass or no measured temperature, ``notes``
        (one line each, :mod:`gyrodrift.io.notes`).

    Raises
    ------
    LogFormatError
        Missing, empty, unreadable or truncated bag; no Imu topic; fewer than two Imu
        messages (with distinct times); an implausible temperature, gyro rate or
        magnetometer or accelerometer value (:mod:`gyrodrift.io.limits`).
    ConfigError
        rosbags is not installed; a named topic is missing or has another type; several
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
    mag_rows, mag_count, compass_gap = None, 0, gaps.compass
    if mag is not None:
        mag_rows, mag_count = on_following_rows(t, mag.t, mag.values * _FLU_TO_FRD)
        if mag_count == 0:
            mag_rows = None
            compass_gap = f"no message of {mag.label} falls within the Imu record, t = {t[0]:.3f}..{t[-1]:.3f} s"
    ref_heading, ref_count = _reference_heading(imu)
    topics = {"imu": imu.label, "temp": temp.label if temp is not None else None,
              "mag": mag.label if mag_count else None}
    return binary_log_frame(
        name, "rosbag", t, np.degrees(imu.values[:, 0:3]) * _FLU_TO_FRD,
        interp_held(temp.t, temp.values, t) if temp is not None else None, mag_rows, imu.values[:, 3:6] * _FLU_TO_FRD,
        ref_heading if ref_count else None, topics=topics,
        summary=_summary(path, t, streams, mag_count, _notes(zero_stamps, dropped, ref_count)),
        no_compass_why=compass_gap, no_temp_why=gaps.temp, gyro_max_dps=gyro_max_dps, mag_unit="T")

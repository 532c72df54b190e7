"""A small ArduPilot DataFlash (``.bin``) writer for the tests, and simulated logs in it.

Written for gyrodrift from the format description (no code taken from elsewhere): a
DataFlash log is a sequence of messages, each ``0xA3 0x95 <type id>`` followed by the
packed little-endian fields of that type. Type 128 is ``FMT``, which defines every
type (its own included): ``Type`` (uint8), ``Length`` (uint8, whole message with the
3 header bytes), ``Name`` (char[4]), ``Format`` (char[16]) and ``Columns``
(char[64], comma separated). Format characters used here, as pymavlink's DFReader
reads them: ``Q`` uint64, ``B`` uint8, ``h``/``H`` int16/uint16, ``I`` uint32, ``f``
float32, ``n``/``N``/``Z`` char[4]/[16]/[64], ``c``/``C`` int16/uint16 holding
value × 100.

:func:`write_simulated` turns a log of :func:`gyrodrift.simulate.simulate` (made
with ``raw_mag=True`` and a ``triad``) into what an ArduPilot vehicle logs: ``IMU``
(rad/s and m/s², body FRD, temperature degC), ``MAG`` (milligauss, int16, body FRD)
and ``ATT`` (yaw in centidegrees, uint16), either in the current form (one ``IMU``
and one ``MAG`` type with an instance field ``I``) or the older one (``IMU``,
``IMU2``, ``MAG``, ``MAG2`` without ``I``). :func:`logged_values` gives the values as
stored, in the reader's units, for exact comparisons.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pandas as pd

HEAD = b"\xa3\x95"
FMT_ID = 128
_FMT_BODY = "<BB4s16s64s"
_STRUCT = {"Q": "Q", "q": "q", "B": "B", "b": "b", "h": "h", "H": "H", "i": "i", "I": "I", "f": "f", "d": "d",
           "n": "4s", "N": "16s", "Z": "64s", "c": "h", "C": "H"}
_HUNDREDTHS = frozenset("cC")

#: Standard gravity, m/s² per g (the simulator's accelerometer is in g).
G_MPS2 = 9.80665
#: Milligauss per microtesla (the simulator's magnetometer is in µT).
MGAUSS_PER_UT = 10.0

IMU_COLUMNS = "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"
IMU_FORMAT = "QBffffffIIfBBHH"
MAG_COLUMNS = "TimeUS,I,MagX,MagY,MagZ,OfsX,OfsY,OfsZ,MOX,MOY,MOZ,Health,S"
MAG_FORMAT = "QBhhhhhhhhhBI"
ATT_COLUMNS = "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF"
ATT_FORMAT = "QccccCCCCB"
PARM_COLUMNS = "TimeUS,Name,Value"
PARM_FORMAT = "QNf"


class DataFlashWriter:
    """Write DataFlash messages to a binary file object.

    Parameters
    ----------
    fh : binary file object
        Where the bytes go.
    """

    def __init__(self, fh):
        self._fh = fh
        self._types: dict[str, tuple[int, str, list[str]]] = {}
        self._next_id = 129
        self._emit(FMT_ID, _FMT_BODY, FMT_ID, 3 + struct.calcsize(_FMT_BODY), b"FMT", b"BBnNZ",
                   b"Type,Length,Name,Format,Columns")

    def _emit(self, type_id: int, layout: str, *values) -> None:
        self._fh.write(HEAD + bytes([type_id]) + struct.pack(layout, *values))

    def define(self, name: str, fmt: str, columns: str) -> int:
        """Write the ``FMT`` message of a new type; return its type id."""
        layout = "<" + "".join(_STRUCT[c] for c in fmt)
        type_id = self._next_id
        self._next_id += 1
        self._types[name] = (type_id, layout, list(fmt))
        self._emit(FMT_ID, _FMT_BODY, type_id, 3 + struct.calcsize(layout), name.encode(), fmt.encode(),
                   columns.encode())
        return type_id

    def write(self, name: str, *values) -> None:
        """Write one message of type ``name``; ``c``/``C`` fields take the value itself (× 100 here)."""
        type_id, layout, chars = self._types[name]
        packed = []
        for char, value in zip(chars, values):
            if char in _HUNDREDTHS:
                value = int(round(value * 100.0))
            elif isinstance(value, str):
                value = value.encode()
            packed.append(value)
        self._emit(type_id, layout, *packed)


def _frames(log: pd.DataFrame, instances: int):
    """Per instance: gyro (rad/s), acc (m/s²), temperature (degC) as stored (float32).

    Instance k > 0 reads the same motion with 0.5·k deg/s more on every gyro axis and
    a temperature 5·k degC warmer, so a test can tell the instances apart.
    """
    gyro = np.radians(log[["gyro_x", "gyro_y", "gyro_z"]].to_numpy(np.float64))
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy(np.float64) * G_MPS2
    temp = log["temp"].to_numpy(np.float64)
    out = []
    for k in range(instances):
        out.append((
            (gyro + np.radians(0.5 * k)).astype(np.float32),
            acc.astype(np.float32),
            (temp + 5.0 * k).astype(np.float32),
        ))
    return out


def time_us(log: pd.DataFrame, t0_us: int) -> np.ndarray:
    """``TimeUS`` of every row: ``t0_us`` + the row time in whole microseconds."""
    return t0_us + np.round(log["t"].to_numpy(np.float64) * 1e6).astype(np.int64)


def mag_mgauss(log: pd.DataFrame) -> np.ndarray:
    """The magnetometer as stored: milligauss rounded to int16, NaN rows kept NaN."""
    mag = log[["mag_x", "mag_y", "mag_z"]].to_numpy(np.float64) * MGAUSS_PER_UT
    return np.where(np.isfinite(mag), np.round(mag), np.nan)


def write_simulated(
    path: Path,
    log: pd.DataFrame,
    *,
    legacy: bool = False,
    instances: int = 2,
    t0_us: int = 5_000_000,
    mag: bool = True,
    att_every: int = 5,
    temp_fill: float | None = None,
    params: dict[str, float] | None = None,
) -> Path:
    """Write ``log`` (simulated, ``raw_mag=True`` and a triad) as an ArduPilot ``.bin``.

    Parameters
    ----------
    path : pathlib.Path
        Output file.
    log : pandas.DataFrame
        ``t`` (s), ``gyro_x..z`` (deg/s, FRD), ``acc_x..z`` (g), ``temp`` (degC),
        ``mag_x..z`` (µT, NaN off compass rows), ``ref_heading`` (deg).
    legacy : bool
        Older form: ``IMU``/``IMU2``, ``MAG``/``MAG2`` types without the ``I`` field, and
        the temperature named ``Temp`` (ArduPilot before about 2016).
    instances : int
        IMUs (and magnetometers) written, 1 or 2.
    t0_us : int
        ``TimeUS`` of the first row.
    mag : bool
        Write the ``MAG`` messages (False: a vehicle without compass).
    att_every : int
        One ``ATT`` message every this many rows (0: none).
    temp_fill : float, optional
        Log this value as every ``IMU.T`` instead of the temperature (0.0: as SITL).
    params : dict, optional
        ``PARM`` messages written first.
    """
    frames = _frames(log, instances)
    stamps = time_us(log, t0_us)
    field = mag_mgauss(log)
    heading = log["ref_heading"].to_numpy(np.float64)
    imu_fmt, imu_cols = (IMU_FORMAT.replace("QB", "Q", 1),
                         IMU_COLUMNS.replace(",I,", ",", 1).replace(",T,", ",Temp,")) if legacy \
        else (IMU_FORMAT, IMU_COLUMNS)
    mag_fmt, mag_cols = (MAG_FORMAT.replace("QB", "Q", 1), MAG_COLUMNS.replace(",I,", ",", 1)) if legacy \
        else (MAG_FORMAT, MAG_COLUMNS)
    imu_names = ["IMU", "IMU2", "IMU3"][:instances] if legacy else ["IMU"]
    mag_names = ["MAG", "MAG2", "MAG3"][:instances] if legacy else ["MAG"]
    with open(path, "wb") as fh:
        w = DataFlashWriter(fh)
        w.define("PARM", PARM_FORMAT, PARM_COLUMNS)
        for name in imu_names:
            w.define(name, imu_fmt, imu_cols)
        if mag:
            for name in mag_names:
                w.define(name, mag_fmt, mag_cols)
        if att_every:
            w.define("ATT", ATT_FORMAT, ATT_COLUMNS)
        for key, value in (params or {}).items():
            w.write("PARM", int(stamps[0]) - 1000, key, float(value))
        for row in range(stamps.size):
            us = int(stamps[row])
            for k, (gyro, acc, temp) in enumerate(frames):
                t_c = temp[row] if temp_fill is None else temp_fill
                head = (us,) if legacy else (us, k)
                name = imu_names[k] if legacy else "IMU"
                w.write(name, *head, *gyro[row], *acc[row], 0, 0, float(t_c), 1, 1, 50, 50)
            if mag and np.isfinite(field[row, 0]):
                for k in range(instances):
                    head = (us,) if legacy else (us, k)
                    name = mag_names[k] if legacy else "MAG"
                    values = [int(v) + 7 * k for v in field[row]]  # instance 1 reads 7 mG more
                    w.write(name, *head, *values, 0, 0, 0, 0, 0, 0, 1, us)
            if att_every and row % att_every == 0:
                w.write("ATT", us, 0.0, 0.0, 0.0, 0.0, 0.0, heading[row] % 360.0, 0.0, 0.0, 0)
    return path


def logged_values(log: pd.DataFrame, *, instance: int = 0, t0_us: int = 5_000_000) -> dict[str, np.ndarray]:
    """What :func:`write_simulated` stored for IMU ``instance``, in the reader's units.

    Returns ``t`` (s), ``gyro`` (deg/s, n × 3), ``acc`` (m/s², n × 3), ``temp``
    (degC), ``mag`` (gauss, n × 3, NaN off compass rows) and ``att_yaw`` (deg, every
    row, as the ``C`` field holds it).
    """
    gyro, acc, temp = _frames(log, instance + 1)[instance]
    heading = np.round(log["ref_heading"].to_numpy(np.float64) % 360.0 * 100.0) / 100.0
    return {
        "t": time_us(log, t0_us) * 1e-6,
        "gyro": np.degrees(gyro.astype(np.float64)),
        "acc": acc.astype(np.float64),
        "temp": temp.astype(np.float64),
        "mag": (mag_mgauss(log) + 7 * instance) / 1000.0,
        "att_yaw": heading,
    }


def write_fixture(path: Path) -> Path:
    """Write ``tests/data/ardupilot_sim.bin``: 20 s of the simulated ``vehicle-rawmag``
    run (seed 7) at 25 Hz, one IMU and one compass, ``ATT`` at 5 Hz."""
    from gyrodrift.simulate import TriadModel, simulate

    log = simulate("vehicle-rawmag", seed=7, duration_s=20.0, fs_hz=25.0, raw_mag=True, triad=TriadModel())
    return write_simulated(Path(path), log, instances=1)


if __name__ == "__main__":  # python tests/dataflash_writer.py tests/data/ardupilot_sim.bin
    import sys

    print(write_fixture(Path(sys.argv[1])))

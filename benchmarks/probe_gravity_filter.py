"""The gyro-aided gravity's tilt against the generator's truth (docs/results.md, "The gravity
filter a Kalman filter"), before any estimator runs.

For the generated classes with x/y gyros (their true roll and pitch rebuilt from the recipe:
``imu-drive`` a constant mount, ``handheld-imu`` the hand's wobbling roll, ``banked-flight`` the
coordinated turn's bank, ``quadplane``, ``vessel-imu`` and ``multicopter-imu`` their whole attitude), the RMS angle between :class:`gyrodrift.attitude.GravityFilter`'s down
vector and the true one over each log, and the median, mean and worst over the seeds::

    python benchmarks/probe_gravity_filter.py                   # tuning seeds 0-11
    python benchmarks/probe_gravity_filter.py held-out 20
    python benchmarks/probe_gravity_filter.py tuning 6 coverage # the filter's own sd against its error
    python benchmarks/probe_gravity_filter.py flight            # the real telemetry flight (needs pymavlink)
    python benchmarks/probe_gravity_filter.py speed             # rows per second, one core

``flight``: roll and pitch of ``tests/data/ardupilot_vtol.tlog`` against its autopilot's
ATTITUDE messages (interpolated to the log's rows, both clocks from their first message), RMS,
by the filter and by the accelerometer alone. ``speed``: :meth:`GravityFilter.feed` on 1 M rows
of a synthetic 100-Hz IMU in one call, with the accelerometer on every row and on its first only.

``coverage``: the tilt error over the filter's sd (:attr:`GravityFilter.tilt_sd_deg`) at the end
of every second after the first 30 s; two axes across gravity, so an honest sd puts the ratio
below 1, 2 and 3 on 39 %, 86 % and 99 % of the seconds (a Rayleigh distribution), its median 1.18.
"""

from __future__ import annotations

import math
import sys
import warnings
import zlib

import numpy as np

CLASSES = ("handheld-imu", "imu-drive", "banked-flight", "quadplane", "vessel-imu", "multicopter-imu")


def true_down(cls: str, seed: int) -> np.ndarray:
    """The true down unit vectors (n, 3), body FRD, of the logged rows of a generated case."""
    import gyrodrift.simulate.generator as G

    rng = G.seeded_streams([zlib.crc32(cls.encode()), int(seed)], G._STREAMS)
    rec = G._BUILDERS[cls](rng["recipe"], 1.0)
    fs = rec.fs_sim_hz
    t = np.arange(int(math.floor(rec.duration_s * fs)) + 1) / fs
    rows = G._logged_rows(rec, t, rng["log"])
    pitch = np.full(rows.size, math.radians(rec.pitch_deg))
    if rec.attitude is not None:
        att = rec.attitude(t, rec.rate(t))
        roll, pitch = np.radians(att.roll_deg[rows]), np.radians(att.pitch_deg[rows])
    elif rec.airspeed is not None:
        roll = np.arctan2(rec.airspeed(t) * np.radians(rec.rate(t)), G.GRAVITY_MPS2)[rows]
    elif rec.wobble is not None:
        roll = np.radians(rec.wobble(t)[rows])
    else:
        roll = np.full(rows.size, math.radians(rec.roll_deg))
    return np.column_stack([-np.sin(pitch), np.sin(roll) * np.cos(pitch), np.cos(roll) * np.cos(pitch)])


def _case(cls: str, seed: int):
    """A generated case's times, x/y/z gyro columns, accelerometer and true down vectors."""
    from gyrodrift.simulate.generator import generate

    log = generate(cls, seed).log
    gyro = [log[c].to_numpy(float) for c in ("gyro_x", "gyro_y", "gyro_z")]
    return log["t"].to_numpy(float), gyro, log[["acc_x", "acc_y", "acc_z"]].to_numpy(float), true_down(cls, seed)


def tilt_rms_deg(cls: str, seed: int) -> float:
    """RMS tilt error of the gravity filter on one generated case, deg."""
    from gyrodrift.attitude import GravityFilter

    t, gyro, acc, truth = _case(cls, seed)
    down = GravityFilter().feed(t, *gyro, acc)
    cos = np.clip(np.sum(down * truth, axis=1), -1.0, 1.0)
    return float(np.sqrt(np.mean(np.degrees(np.arccos(cos)) ** 2)))


def coverage(cls: str, seed: int) -> np.ndarray:
    """The tilt error over the filter's sd at the end of each second after the first 30 s."""
    from gyrodrift.attitude import GravityFilter

    t, gyro, acc, truth = _case(cls, seed)
    filt, ratios = GravityFilter(), []
    edges = np.searchsorted(t, np.arange(t[0], t[-1], 1.0))
    for a, b in zip(edges[:-1], edges[1:]):
        if b <= a:
            continue
        down = filt.feed(t[a:b], *(g[a:b] for g in gyro), acc[a:b])
        if t[a] - t[0] > 30.0:
            err = math.degrees(math.acos(min(1.0, float(down[-1] @ truth[b - 1]))))
            ratios.append(err / filt.tilt_sd_deg)
    return np.asarray(ratios)


def flight() -> str:
    """Roll and pitch RMS (deg) of the real telemetry flight, by the filter and the accelerometer."""
    from pathlib import Path

    from pymavlink import mavutil

    from gyrodrift.attitude import GravityFilter, accel_down
    from gyrodrift.compass import roll_pitch_deg
    from gyrodrift.io import read_log

    path = Path(__file__).resolve().parents[1] / "tests" / "data" / "ardupilot_vtol.tlog"
    link = mavutil.mavlink_connection(str(path))
    stamps, attitude = [], []
    while (msg := link.recv_match(type="ATTITUDE")) is not None:
        stamps.append(msg._timestamp)
        attitude.append((math.degrees(msg.roll), math.degrees(msg.pitch)))
    stamps, attitude = np.asarray(stamps) - stamps[0], np.asarray(attitude)
    log = read_log(path)
    t = log["t"].to_numpy(float)
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy(float)
    down = GravityFilter().feed(t, *(log[c].to_numpy(float) for c in ("gyro_x", "gyro_y", "gyro_z")), acc)
    truth = [np.interp(t - t[0], stamps, attitude[:, k]) for k in range(2)]
    cells = []
    for d in (down, accel_down(acc)):
        est = roll_pitch_deg(*(-d).T)
        cells += [f"{np.sqrt(np.nanmean((est[k] - truth[k]) ** 2)):.1f}" for k in range(2)]
    return ("| tilt | roll | pitch (deg RMS against ATTITUDE) |\n| :--- | ---: | ---: |\n"
            f"| gyro-aided gravity | {cells[0]} | {cells[1]} |\n| accelerometer alone | {cells[2]} | {cells[3]} |")


def speed() -> str:
    """Rows per second of the filter on 1 M rows, the accelerometer on every row and on the first only."""
    import time

    from gyrodrift.attitude import GravityFilter

    n = 1_000_000
    rng = np.random.default_rng(0)
    t = np.arange(n) / 100.0
    gyro = rng.normal(0.0, 5.0, (3, n))
    acc = np.column_stack([rng.normal(0.0, 0.02, n), rng.normal(0.0, 0.02, n), rng.normal(-1.0, 0.02, n)])
    GravityFilter().feed(t[:10], *gyro[:, :10], acc[:10])  # compiled
    lines = []
    first_only = np.full_like(acc, np.nan)
    first_only[0] = acc[0]
    for name, a in (("every row", acc), ("its first row only", first_only)):
        start = time.perf_counter()
        GravityFilter().feed(t, *gyro, a)
        lines.append(f"accelerometer on {name}: {n / (time.perf_counter() - start) / 1e6:.2f} M rows/s")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    from gyrodrift.simulate.generator import seeds

    if argv and argv[0] in ("flight", "speed"):
        print(flight() if argv[0] == "flight" else speed())
        return 0
    split = argv[0] if argv else "tuning"
    n = int(argv[1]) if len(argv) > 1 else 12
    if len(argv) > 2 and argv[2] == "coverage":
        print("| class | error within 1 / 2 / 3 sd | median error / sd |")
        print("| :--- | ---: | ---: |")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for cls in CLASSES:
                z = np.concatenate([coverage(cls, s) for s in seeds(split, n)])
                print(f"| {cls} | {np.mean(z <= 1):.2f} / {np.mean(z <= 2):.2f} / {np.mean(z <= 3):.2f} | "
                      f"{np.median(z):.2f} |")
        return 0
    print("| class | median | mean | worst (deg RMS) |")
    print("| :--- | ---: | ---: | ---: |")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for cls in CLASSES:
            rms = [tilt_rms_deg(cls, s) for s in seeds(split, n)]
            print(f"| {cls} | {np.median(rms):.3f} | {np.mean(rms):.3f} | {np.max(rms):.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

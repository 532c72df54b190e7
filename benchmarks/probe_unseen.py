"""Every method on scenario classes the generator does not have: a check of how the default
generalises (docs/results.md, "The gyro's scale factor").

    PYTHONPATH=src python benchmarks/probe_unseen.py CLASSES N OUT.csv [METHODS]
    # e.g. loiter,mower,cooling-still,turntable-sf,handheld-sf,drive-sf,loiter-sf 10 probe.csv
    #      pedestrian,garage,cycling,spin 10 probe2.csv

The classes are composed from the generator's own pieces (its private helpers, registered for
this run only): ``loiter``, a fixed-wing circling 2–8 deg/s for 1–10 min between legs after a
cold start, a steady 1–6-deg compass offset in flight; ``mower``, 180-deg turns at 20–40 deg/s
every 20–60 s with a 3–15-deg motor-correlated compass offset while moving; ``cooling-still``,
a still unit cooling from 35–45 degC for 4–8 h, logged at 1 Hz with a 1-Hz compass;
``pedestrian``, a unit carried indoors: turns of 30–180 deg every 5–30 s, a 1.6–2.2-Hz yaw
swing of 3–12 deg/s from the steps, a noisy compass (1–3 deg) disturbed 4–10 times for 10–120 s;
``garage``, a vehicle parked for 2–4 h whose compass is offset by 5–30 deg for 40–65 % of it
(steel nearby), logged at 1–5 Hz; ``cycling``, a still unit through a 5–15-degC temperature
cycle of 10–40 min, half of them with thermal lag and backlash; ``spin``, a platform turning
one way at 5–60 deg/s, its speed changing between random knots, for 20–60 min. A class
ending in ``-sf`` is an existing one whose gyro reads a further 0.3–2 % scale-factor error (a
seeded sign and size); ``vessel-rawmag`` is ``vessel-imu`` without its x/y gyros (a boat's
tilt-compensated compass from the magnetometer and accelerometer, and a yaw-rate gyro). N held-out seeds each, every method by default (``heldout.METHODS``);
prints the acceptance table of ``gyrodrift.evaluate.heldout``. About a minute for 7 classes ×
10 seeds on the 2-core machine.
"""

from __future__ import annotations

import multiprocessing as mp
import sys
import warnings
from dataclasses import replace

import numpy as np
import pandas as pd

from gyrodrift.evaluate import heldout as H
from gyrodrift.simulate import generator as G


def _loiter(rng, scale):
    ground = G._u(rng, 60, 240) * scale
    duration = G._u(rng, 1800, 3600) * scale
    way = G._sign(rng)
    circles = []
    t = ground + 30
    while t < duration - 60:
        t += G._u(rng, 30, 300)  # a leg
        length = G._u(rng, 60, 600)
        circles.append((t, length, (way if rng.random() < 0.8 else -way) * G._u(rng, 2.0, 8.0)))
        t += length
    k = G._sign(rng) * G._u(rng, 1.0, 6.0)

    def rate(t):
        r = np.zeros(t.size)
        for start, length, w in circles:
            r += w * G._pulse(t, start, start + length, 5.0)
        return r

    return G._Recipe(duration, 100.0, G._device(rng), G._compass(rng, noise=(0.5, 2.0)),
                     G._warmup(rng, start=(-5.0, 15.0), rise=(10.0, 30.0), tau=(300.0, 1200.0)), rate=rate,
                     offset=lambda t: k * G._pulse(t, ground, duration - 30, 5.0), heading0_deg=G._u(rng, 0, 360),
                     log_fs_hz=50.0)


def _mower(rng, scale):
    duration = G._u(rng, 1200, 3600) * scale
    turns, stops = [], []
    t = start = G._u(rng, 30, 120)
    sign = G._sign(rng)
    while t < duration - 60:
        t += G._u(rng, 20, 60)
        peak = G._u(rng, 20, 40)
        turns.append((t, sign * 180.0, peak))
        sign = -sign
        t += 180.0 / peak + 1.0
        if rng.random() < 0.1:
            stops.append((t, G._u(rng, 10, 60)))
            t += stops[-1][1]
    turning = G._turns_rate(turns, ramp=1.0)
    wobble = G._child(rng)
    k = G._sign(rng) * G._u(rng, 3.0, 15.0)

    def moving(t):
        m = G._pulse(t, start, duration - 30, 2.0)
        for s, length in stops:
            m = m * (1 - G._pulse(t, s, s + length, 2.0))
        return m

    return G._Recipe(duration, 100.0, G._device(rng), G._compass(rng),
                     G._warmup(rng, rise=(5.0, 20.0), tau=(300.0, 1200.0)),
                     rate=lambda t: turning(t) + G._sway(wobble(), t, (0.1, 0.5), (3.0, 20.0), 2) * moving(t),
                     offset=lambda t: k * moving(t), heading0_deg=G._u(rng, 0, 360), log_fs_hz=50.0)


def _cooling(rng, scale):
    duration = G._u(rng, 14400, 28800) * scale
    hot, ambient, tau = G._u(rng, 35, 45), G._u(rng, 5, 20), G._u(rng, 1000, 4000)
    return G._Recipe(duration, 10.0, G._device(rng), G._compass(rng, noise=(1.0, 3.0), rate_hz=1.0),
                     lambda t: ambient + (hot - ambient) * np.exp(-t / tau), heading0_deg=G._u(rng, 0, 360),
                     log_fs_hz=1.0)


def _pedestrian(rng, scale):
    duration = G._u(rng, 600, 1800) * scale
    rate_turns = G._turns_rate(G._turn_plan(rng, G._u(rng, 10, 60), duration - 10, (30.0, 180.0), (30.0, 90.0),
                                            (5.0, 30.0), after=lambda a, p: abs(a) / p + 1.0))
    step_hz, step_amp = G._u(rng, 1.6, 2.2), G._u(rng, 3.0, 12.0)
    walking = G._u(rng, 5, 30)
    episodes = G._disturbances(rng, duration, (4, 10), (5.0, 40.0), (10.0, 120.0), ("wander", "step", "ramp"))
    return G._Recipe(duration, 100.0, G._device(rng), G._compass(rng, noise=(1.0, 3.0), rate_hz=float(rng.choice([10.0, 50.0]))),
                     G._warmup(rng, start=(15.0, 25.0), rise=(3.0, 10.0), tau=(300.0, 900.0)),
                     rate=lambda t: rate_turns(t) + step_amp * np.sin(2 * np.pi * step_hz * t) * (t > walking),
                     offset=G._offset_fn(episodes), heading0_deg=G._u(rng, 0, 360))


def _garage(rng, scale):
    duration = G._u(rng, 7200, 14400) * scale
    t_in = G._u(rng, 0.05, 0.3) * duration
    t_out = t_in + G._u(rng, 0.4, 0.65) * duration
    k = G._sign(rng) * G._u(rng, 5.0, 30.0)
    return G._Recipe(duration, 10.0, G._device(rng), G._compass(rng, rate_hz=2.0), G._day_cycle(rng, duration),
                     offset=lambda t: k * G._pulse(t, t_in, t_out, 5.0), heading0_deg=G._u(rng, 0, 360),
                     log_fs_hz=float(rng.choice([1.0, 5.0])))


def _cycling(rng, scale):
    duration = G._u(rng, 3600, 10800) * scale
    mean, amp, period = G._u(rng, 15, 35), G._u(rng, 5, 15), G._u(rng, 600, 2400)
    return G._Recipe(duration, 20.0, G._device(rng, memory=rng.random() < 0.5), G._compass(rng),
                     lambda t: mean + amp * np.sin(2 * np.pi * t / period), heading0_deg=G._u(rng, 0, 360),
                     log_fs_hz=float(rng.choice([10.0, 20.0])))


def _spin(rng, scale):
    duration = G._u(rng, 1200, 3600) * scale
    knots_t = np.sort(np.concatenate([[0.0, duration], rng.uniform(0, duration, int(rng.integers(2, 6)))]))
    way = G._sign(rng)
    speeds = way * rng.uniform(5.0, 60.0, knots_t.size) * (rng.random(knots_t.size) < 0.8)
    start = G._u(rng, 30, 120)

    def rate(t):
        return np.interp(t, knots_t, speeds) * G._pulse(t, start, duration - 30, 5.0)

    return G._Recipe(duration, 100.0, G._device(rng), G._compass(rng, rate_hz=20.0),
                     G._warmup(rng, rise=(5.0, 20.0), tau=(300.0, 1200.0)), rate=rate,
                     heading0_deg=G._u(rng, 0, 360), log_fs_hz=50.0)


NEW = {"loiter": _loiter, "mower": _mower, "cooling-still": _cooling, "pedestrian": _pedestrian,
       "garage": _garage, "cycling": _cycling, "spin": _spin}
WITH_SF = {"turntable-sf": "turntable", "handheld-sf": "handheld-stalls", "drive-sf": "drive", "loiter-sf": "loiter"}
WITHOUT_XY = {"vessel-rawmag": "vessel-imu"}
_generate = G.generate


def generate(cls, seed, duration_scale=1.0):
    """A probe class's case (the generator's own for its classes)."""
    if cls in WITH_SF:
        case = generate(WITH_SF[cls], seed, duration_scale)
        rng = np.random.default_rng(seed + 77)
        sf = rng.choice([-1, 1]) * rng.uniform(0.003, 0.02)
        log = case.log.copy()
        log.attrs = dict(case.log.attrs)
        log["gyro_z"] = log["gyro_z"] + sf * log[G.TRUE_RATE_Z]
        return replace(case, log=log)
    if cls in WITHOUT_XY:
        case = generate(WITHOUT_XY[cls], seed, duration_scale)
        log = case.log.drop(columns=["gyro_x", "gyro_y"])
        log.attrs = dict(case.log.attrs)
        return replace(case, log=log)
    return _generate(cls, seed, duration_scale=duration_scale)


G._BUILDERS.update(NEW)  # this process (and its forked workers) only
H.generate = generate


def _task(args):
    warnings.simplefilter("ignore")
    cls, seed, methods = args
    return H.run_case(cls, seed, methods)


def main(argv) -> int:
    classes, n, out = argv[0].split(","), int(argv[1]), argv[2]
    methods = tuple(argv[3].split(",")) if len(argv) > 3 else H.METHODS
    tasks = [(c, s, methods) for c in classes for s in G.seeds("held-out", n)]
    with mp.get_context("fork").Pool(2) as pool:
        rows = [r for rs in pool.map(_task, tasks, chunksize=1) for r in rs]
    df = pd.DataFrame(rows)
    df.to_csv(out, index=False)
    acc = H.acceptance(H.summarise(df))
    pd.set_option("display.width", 250)
    print(acc.drop(columns=["split"]).to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    for _, r in df[df.status != "ok"].head(5).iterrows():
        print("failed", r["class"], r["seed"], r["method"], r["error"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))

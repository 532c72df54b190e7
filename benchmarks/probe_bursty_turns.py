"""Hand-held turns logged by a logger that stalls, or that stamps its samples as they arrive in
clusters: the default against the paper's STKF and the gyro alone, on random draws
(docs/results.md, "A compass sample after a time gap in a turn", "Samples that arrive in clusters").

The generator's classes have no time gaps inside a motion, nor clustered timestamps. ``stalls``
draws ``N`` logs from one seed (numpy): a board turned by hand through 90–720° at 20–90 deg/s
between pauses of 1–10 s, with a wobble of 2–10 deg/s, for 60–180 s at 400 Hz; the logger stalls
for 50–250 ms after every 0.2–1.5 s of rows (the rows in a stall are lost, every stall a time gap);
a calibrated compass heading at 10 Hz with 1–4° of noise; a drift of ±2 deg/s plus 0.02
deg/s/degC over a warm-up of 2–8 degC. ``clusters`` draws the same turns at 100 Hz with no row
lost, stamped as the real ``mpu6050_rotate_z`` (an Arduino-style serial log) is: its samples
arrive 4–10 at a time, 1–2.5 ms apart, each cluster stamped from its last sample's true time on
(the real log: clusters of 1–10 rows, about 9.8 ms of log per row, 2.2 ms its median step);
``even`` the same draws stamped at their true times. It
prints the median and worst heading RMS (deg, against the truth, every row) and bias RMS (deg/s)
of the default's gyro heading and fused heading and of the STKF's:

    PYTHONPATH=src python benchmarks/probe_bursty_turns.py [N] [SEED] [stalls|clusters|even]   # 40, 3, stalls

About a minute for 40 draws on the 2-core machine.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pandas as pd

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.conventions import wrap_180

#: Sampling rate of each arrival, Hz.
FS_HZ = {"stalls": 400.0, "clusters": 100.0, "even": 100.0}


def _rate(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """Turns by hand (a raised-cosine rate profile each) between pauses, plus a wobble."""
    rate = np.zeros(t.size)
    start = rng.uniform(1.0, 5.0)
    while start < t[-1] - 5.0:
        angle = rng.uniform(90.0, 720.0) * rng.choice([-1.0, 1.0])
        peak = rng.uniform(20.0, 90.0)
        dur = 2.0 * abs(angle) / peak  # the raised cosine's mean is half its peak
        inside = (t >= start) & (t < start + dur)
        rate[inside] += np.sign(angle) * peak * 0.5 * (1.0 - np.cos(2.0 * np.pi * (t[inside] - start) / dur))
        start += dur + rng.uniform(1.0, 10.0)
    wobble = rng.uniform(2.0, 10.0)
    for period in rng.uniform(0.3, 3.0, 3):
        rate += wobble / 3.0 * np.sin(2.0 * np.pi * t / period + rng.uniform(0.0, 2.0 * np.pi))
    return rate


def _kept(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """The rows a logger that stalls keeps."""
    keep = np.ones(t.size, dtype=bool)
    at = rng.uniform(0.2, 1.5)
    while at < t[-1]:
        stall = rng.uniform(0.05, 0.25)
        keep[(t >= at) & (t < at + stall)] = False
        at += stall + rng.uniform(0.2, 1.5)
    return keep


def _clustered(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """The times a logger stamps ``t`` with as its samples arrive in clusters."""
    stamped = np.empty_like(t)
    i = 0
    while i < t.size:
        n = int(rng.integers(4, 11))
        n = t.size - i if t.size - i - n < 4 else n  # the last rows join the last cluster
        stamped[i:i + n] = t[i + n - 1] + np.arange(n) * rng.uniform(0.001, 0.0025)
        i += n
    return stamped


def draw(rng: np.random.Generator, arrival: str = "stalls") -> pd.DataFrame:
    """One log in the input contract with ``ref_heading`` and ``true_bias_z``."""
    fs_hz = FS_HZ[arrival]
    t = np.arange(0.0, rng.uniform(60.0, 180.0), 1.0 / fs_hz)
    rate = _rate(rng, t)
    heading = rng.uniform(0.0, 360.0) + np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) / fs_hz)])
    temp = 25.0 + rng.uniform(2.0, 8.0) * (1.0 - np.exp(-t / rng.uniform(30.0, 120.0)))
    drift = rng.uniform(-2.0, 2.0) + 0.02 * (temp - 25.0)
    gyro = rate + drift + rng.normal(0.0, 0.05, t.size)
    compass = np.where(np.arange(t.size) % int(fs_hz / 10.0) == 0,
                       np.mod(heading + rng.normal(0.0, rng.uniform(1.0, 4.0), t.size), 360.0), np.nan)
    log = pd.DataFrame({"t": t, "gyro_z": gyro, "temp": temp, "heading": compass,
                        "ref_heading": np.mod(heading, 360.0), "true_bias_z": drift})
    if arrival != "stalls":  # the same draws, clustered or not (the stalls' draws as they always were)
        stamps = np.random.default_rng(int(rng.integers(2**32)))
        if arrival == "clusters":
            log["t"] = _clustered(stamps, t)
        return log
    return log[_kept(rng, t)].reset_index(drop=True)


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2)))


def main(n: int = 40, seed: int = 3, arrival: str = "stalls") -> None:
    if arrival not in FS_HZ:
        raise SystemExit(f"arrival must be one of {', '.join(FS_HZ)}, not {arrival!r}")
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(n):
        log = draw(rng, arrival)
        truth = log["ref_heading"]
        own = compensate(log)
        paper = compensate(log, CompensatorConfig(estimator="stkf"))
        rows.append({
            "heading": _rms(wrap_180(own["heading"] - truth)), "fused": _rms(wrap_180(own["heading_fused"] - truth)),
            "bias": _rms(own["bias_z"] - log["true_bias_z"]), "stkf_heading": _rms(wrap_180(paper["heading"] - truth)),
            "stkf_bias": _rms(paper["bias_z"] - log["true_bias_z"]),
            "compass": _rms(wrap_180(log["heading"] - truth)),
        })
    table = pd.DataFrame(rows)
    print(f"{n} draws (seed {seed}, {arrival}): median (worst)")
    for name, unit in (("heading", "deg"), ("fused", "deg"), ("bias", "deg/s"), ("stkf_heading", "deg"),
                       ("stkf_bias", "deg/s"), ("compass", "deg")):
        print(f"  {name:13s} {table[name].median():8.3f} ({table[name].max():8.3f}) {unit}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]), *sys.argv[3:4])

"""How well the difference of a raw compass's two tilts tells its tilt error (docs/model.md,
"The compass's tilt"), before any estimator runs.

For generated cases of a class with x/y gyros and a raw compass, and the repository's real
telemetry flight (against its ATTITUDE yaw, with the declination its autopilot used): each
sample levelled by the accelerometer and by the gyro-aided gravity
(:class:`gyrodrift.attitude.GravityFilter`), the RMS error of each against the truth (its median
taken off), the RMS of their difference, the correlation of |difference| with the
accelerometer-levelled error, and ρ, the correlation of successive 1-s means of the difference
(the persistence the model measures)::

    python benchmarks/probe_tilt_difference.py                      # banked-flight tuning seeds 0-5
    python benchmarks/probe_tilt_difference.py imu-drive 3
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def probe(name: str, log, truth_deg, declination_deg: float = 0.0) -> str:
    """One line for one log (its raw compass, x/y gyros and accelerometer; truth in deg)."""
    from gyrodrift.attitude import GravityFilter
    from gyrodrift.compass import compass_columns
    from gyrodrift.compensator.intake import tilt_difference
    from gyrodrift.conventions import wrap_180

    t = log["t"].to_numpy(float)
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy(float)
    mag = log[["mag_x", "mag_y", "mag_z"]].to_numpy(float)
    down, _ = GravityFilter().run(t, log["gyro_x"].to_numpy(float), log["gyro_y"].to_numpy(float),
                                  log["gyro_z"].to_numpy(float), acc)
    by_acc = compass_columns(t.size, mag=mag, acc=acc)[0] + declination_deg
    by_gravity = compass_columns(t.size, mag=mag, acc=acc, down=down)[0] + declination_deg
    diff = tilt_difference(by_acc, by_gravity)
    e_acc, e_grav = wrap_180(by_acc - truth_deg), wrap_180(by_gravity - truth_deg)
    ok = np.isfinite(e_acc) & np.isfinite(e_grav) & np.isfinite(diff)
    e_acc, e_grav, d = e_acc[ok] - np.median(e_acc[ok]), e_grav[ok] - np.median(e_grav[ok]), diff[ok]
    second = np.floor(t[ok] - t[0]).astype(int)
    means = np.bincount(second, d) / np.maximum(np.bincount(second), 1)
    rho = np.sum(means[1:] * means[:-1]) / np.sum(0.5 * (means[1:] ** 2 + means[:-1] ** 2))
    return (f"| {name} | {np.sqrt(np.mean(e_acc ** 2)):.1f} | {np.sqrt(np.mean(e_grav ** 2)):.1f} | "
            f"{np.sqrt(np.mean(d ** 2)):.1f} | {np.corrcoef(np.abs(e_acc), np.abs(d))[0, 1]:.2f} | {rho:.2f} |")


def main(argv: list[str]) -> int:
    from gyrodrift.io import read_log
    from gyrodrift.simulate.generator import generate, seeds

    cls = argv[0] if argv else "banked-flight"
    n = int(argv[1]) if len(argv) > 1 else 6
    print("| log | by accelerometer (deg RMS) | by gyro-aided gravity | difference RMS | corr(abs) | ρ |")
    print("| :--- | ---: | ---: | ---: | ---: | ---: |")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed in seeds("tuning", n):
            log = generate(cls, seed).log
            print(probe(f"{cls} {seed}", log, log["ref_heading"].to_numpy(float)))
        flight = read_log(ROOT / "tests" / "data" / "ardupilot_vtol.tlog")
        declination = flight.attrs["onboard"].declination
        print(probe("ardupilot_vtol.tlog", flight, flight["ref_heading"].to_numpy(float),
                    0.0 if declination is None else float(declination[0])))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

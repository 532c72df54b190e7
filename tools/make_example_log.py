"""Regenerate the built-in example log used by ``gyrodrift demo``.

    python tools/make_example_log.py

A simulated motionless gyro (``static-outages`` scenario of :mod:`gyrodrift.simulate`,
seed 1, 1 h, 10 Hz): heated 23 -> 58 degC and cooled, with a 10 Hz compass and three
magnetic-interference windows. Written as gzip CSV, rounded to what a logger would store.
"""

from pathlib import Path

from gyrodrift.simulate import simulate

OUT = Path(__file__).resolve().parents[1] / "src" / "gyrodrift" / "data" / "example_static.csv.gz"


def main() -> None:
    log = simulate("static-outages", seed=1, duration_s=3600.0, fs_hz=10.0)
    log = log.round({"t": 3, "gyro_z": 5, "temp": 4, "heading": 3, "ref_heading": 4, "true_bias_z": 6})
    log.to_csv(OUT, index=False, compression={"method": "gzip", "mtime": 0})
    print(f"wrote {OUT} ({OUT.stat().st_size / 1e3:.0f} kB, {len(log)} rows)")


if __name__ == "__main__":
    main()

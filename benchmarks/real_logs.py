"""The default estimator on the real logs at hand: each log's heading against its autopilot's own
(where it has one), and the heading turned over the whole log.

Reads the repository's ``tests/data`` logs and, where present, the shared data beside the
checkout (``../shared/data``, its README). For each log: the rows, whether it has the x/y
gyros and a raw magnetometer, the heading turned by ``heading`` over the log (deg; the
``mpu6050_rotate_z`` contract turns -720), the mean drift, and, with a ``ref_heading``
column (the autopilot's ATTITUDE yaw or attitude estimate), the RMS against it of the
compass alone, the gyro heading and the fused heading (deg). The numbers docs/results.md
quotes for the real logs come from here::

    python benchmarks/real_logs.py
    python benchmarks/real_logs.py heading_rate=gyro_z tilt=gyro   # CompensatorConfig settings
    python benchmarks/real_logs.py path/to/sample.ulg              # and more logs (any readable path)

An argument that names an existing file is a further log; any other is a ``name=value`` setting.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"
LOGS = [
    ROOT / "tests" / "data" / "ardupilot_vtol.tlog",
    ROOT / "tests" / "data" / "mpu6050_still_120s.csv.gz",
    SHARED / "px4" / "sample_log_small.ulg",
    SHARED / "px4" / "sample_px4_events.ulg",
    SHARED / "ardupilot" / "pymavlink_test.BIN",
    SHARED / "mpu6050_rotate_z" / "contract.csv",
    SHARED / "mpu6050_rotate_z" / "contract_heading.csv",
    SHARED / "actigraph_gt9x_cooling" / "contract.csv",
    SHARED / "pan_lsm6dsm_tvac" / "contract.csv",
]


def _setting(text: str):
    """``name=value`` as a CompensatorConfig keyword (numbers as floats, true/false as bools)."""
    name, _, value = text.partition("=")
    if value.lower() in ("true", "false"):
        return name, value.lower() == "true"
    try:
        return name, float(value)
    except ValueError:
        return name, value


def _rms(err) -> str:
    """The RMS (deg) of the finite errors, or "–" without any."""
    err = np.asarray(err, dtype=float)
    err = err[np.isfinite(err)]
    return f"{np.sqrt(np.mean(err ** 2)):.2f}" if err.size else "–"


def main(argv: list[str], logs=LOGS) -> int:
    from gyrodrift.compensator import CompensatorConfig, compensate
    from gyrodrift.conventions import wrap_180
    from gyrodrift.io import read_log

    extra = [Path(a) for a in argv if Path(a).is_file()]
    config = CompensatorConfig(**dict(_setting(a) for a in argv if not Path(a).is_file()))
    logs = list(logs) + extra
    print("| log | rows | x/y gyros, raw mag | turned (deg) | mean drift (deg/s) | compass | heading | fused |")
    print("| :--- | ---: | :---: | ---: | ---: | ---: | ---: | ---: |")
    for path in logs:
        if not path.exists():
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            log = read_log(path)
            out = compensate(log, config)
        heading = out["heading"].to_numpy(float)
        turned = float(np.nansum(wrap_180(np.diff(heading))))
        kind = f"{'gyro_x' in log and 'gyro_y' in log}, {'mag_x' in log}"
        cells = ["–", "–", "–"]
        if "ref_heading" in log:
            ref = log["ref_heading"].to_numpy(float)
            cells = [_rms(wrap_180(out[c].to_numpy(float) - ref)) for c in ("compass_heading", "heading", "heading_fused")]
        name = f"{path.parent.name}/{path.name}"
        print(f"| {name} | {len(log)} | {kind} | {turned:.2f} | {out['bias_z'].mean():.4f} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

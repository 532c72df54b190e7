"""Fused heading of gyrodrift against x-io Fusion's AHRS (imufusion), over the Monte Carlo families.

Run from the repository root (needs ``pip install imufusion``, a benchmark-only dependency)::

    python benchmarks/bench_fused_heading.py                      # 20 seeds per family, full length
    python benchmarks/bench_fused_heading.py --seeds 3 --duration-scale 0.2

For every family of :data:`gyrodrift.evaluate.montecarlo.FAMILIES` and every seed, the same
simulated log (randomised device and compass, :func:`gyrodrift.evaluate.montecarlo.draw_case`)
goes to:

* gyrodrift: :func:`gyrodrift.compensate` with its defaults; ``heading_fused``
  (compensated gyro + compass under the compensator's gates, :mod:`gyrodrift.fusion`),
  and for context ``heading`` (the gyro alone, as the paper) and the compass;
* imufusion 1.3 (x-io Fusion): per sample, ``Bias.update`` (its gyroscope offset
  correction) then ``Ahrs.update_external_heading`` on rows with a compass heading and
  ``update_no_magnetometer`` on the others, with magnetic rejection on (10 deg, Fusion's
  recommended setting, recovery after 5 s), acceleration rejection 10 deg, gain 0.5;
  the heading is the yaw of its quaternion (NED).

Both see the same gyro (z axis; x, y zero), a level accelerometer and the same compass
headings: the ``heading`` column, or for a log with the raw magnetometer and
accelerometer instead (``vehicle-rawmag``) the compensator's tilt-compensated
``compass_heading``. Errors are against ``ref_heading``, wrapped to ±180 deg, RMS over
the rows where the method has a heading. A log that gyrodrift refuses (too short, no
compass) gets NaN for gyrodrift and the reason in ``error``; imufusion still runs when
the log has a heading column. Prints one Markdown table: per family the mean and
median RMS of each (over the seeds that ran), on how many seeds ``heading_fused`` is
lower, and how many seeds gyrodrift refused.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
import pandas as pd


def imufusion_filters(fs_hz: float, magnetic_rejection_deg: float):
    """x-io Fusion's gyroscope offset correction (``Bias``) and ``Ahrs`` (NED, gain 0.5,
    acceleration rejection 10 deg, recovery after 5 s) at ``fs_hz``; also used by
    ``bench_throughput.py``."""
    import imufusion

    bias = imufusion.Bias()
    bias.set_settings(imufusion.BiasSettings(sample_rate=fs_hz, stationary_threshold=3.0, stationary_period=5.0))
    ahrs = imufusion.Ahrs()
    ahrs.set_settings(
        imufusion.AhrsSettings(
            sample_rate=fs_hz, convention=imufusion.CONVENTION_NED, gain=0.5, gyroscope_range=2000.0,
            acceleration_rejection=10.0, magnetic_rejection=magnetic_rejection_deg, rejection_timeout=int(5 * fs_hz),
        )
    )
    return bias, ahrs


def imufusion_heading(log: pd.DataFrame, fs_hz: float, heading=None) -> np.ndarray:
    """Heading (deg, [0, 360)) of x-io Fusion's AHRS with gyroscope offset correction, per row.

    ``heading``: the compass heading per row, deg, NaN without a sample (default the
    log's ``heading`` column)."""
    bias, ahrs = imufusion_filters(fs_hz, magnetic_rejection_deg=10.0)
    acc = np.array([0.0, 0.0, -1.0])  # level (NED body, g), as the compensator's heading assumes
    gyro_z = log["gyro_z"].to_numpy(float)
    heading = np.asarray(log["heading"] if heading is None else heading, dtype=float)
    out = np.empty(len(log))
    for i in range(len(log)):
        gyro = bias.update(np.array((0.0, 0.0, gyro_z[i])))
        if heading[i] == heading[i]:
            ahrs.update_external_heading(gyro, acc, heading[i])
        else:
            ahrs.update_no_magnetometer(gyro, acc)
        q = ahrs.get_quaternion()
        w, x, y, z = (q.w, q.x, q.y, q.z) if hasattr(q, "w") else tuple(np.asarray(q, dtype=float).ravel()[:4])
        out[i] = math.degrees(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
    return np.mod(out, 360.0)


def rms_deg(heading, ref) -> float:
    e = (np.asarray(heading, dtype=float) - np.asarray(ref, dtype=float) + 180.0) % 360.0 - 180.0
    e = e[np.isfinite(e)]
    return float(np.sqrt(np.mean(e**2))) if e.size else math.nan


def run(families, seeds, duration_scale: float, fs_hz: float, estimator: str | None = None) -> pd.DataFrame:
    from gyrodrift import CompensatorConfig, compensate
    from gyrodrift.evaluate.montecarlo import draw_case, simulate_case

    rows = []
    for family in families:
        for seed in seeds:
            case = draw_case(family, seed, duration_scale=duration_scale)
            log, _ = simulate_case(case, fs_hz=fs_hz, calibration=False)
            ref = log["ref_heading"].to_numpy(float)
            try:
                out, error = compensate(log, CompensatorConfig(estimator=estimator) if estimator else None), ""
            except Exception as err:  # a log gyrodrift refuses: reported in the row, the others go on
                out, error = None, " ".join(f"{type(err).__name__}: {err}".split())
            if "heading" in log.columns:
                compass = log["heading"].to_numpy(float)
            else:
                compass = None if out is None else out["compass_heading"].to_numpy(float)
            rows.append({
                "family": family, "seed": seed,
                "heading_fused": math.nan if out is None else rms_deg(out["heading_fused"], ref),
                "imufusion": math.nan if compass is None else rms_deg(imufusion_heading(log, fs_hz, compass), ref),
                "heading (gyro alone)": math.nan if out is None else rms_deg(out["heading"], ref),
                "compass": math.nan if compass is None else rms_deg(compass, ref),
                "error": error,
            })
            print(f"{family} seed {seed}: " + ", ".join(f"{k} {v:.2f}" for k, v in rows[-1].items()
                                                         if k not in ("family", "seed", "error"))
                  + (f" ({error})" if error else ""), flush=True)
    return pd.DataFrame(rows)


def summary(df: pd.DataFrame) -> pd.DataFrame:
    cols = ["heading_fused", "imufusion", "heading (gyro alone)", "compass"]
    groups = list(df.groupby("family", sort=False)) + [("all", df)]
    out = []
    for family, g in groups:
        row = {"family": family, "seeds": len(g)}
        for c in cols:
            row[f"{c} mean"] = g[c].mean()
            row[f"{c} median"] = g[c].median()
        both = g["heading_fused"].notna() & g["imufusion"].notna()
        row["fused < imufusion"] = f"{int((g['heading_fused'] < g['imufusion']).sum())}/{int(both.sum())}"
        row["gyrodrift refused"] = int((g["error"] != "").sum())
        out.append(row)
    return pd.DataFrame(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--families", nargs="+", help="families (default: all)")
    p.add_argument("--seeds", type=int, default=20, help="seeds per family (default 20)")
    p.add_argument("--duration-scale", type=float, default=1.0, help="log lengths x this (default 1)")
    p.add_argument("--fs-hz", type=float, default=10.0, help="sample rate, Hz (default 10)")
    p.add_argument("--estimator", help="drift estimator of gyrodrift (default: CompensatorConfig's)")
    p.add_argument("-o", "--output", help="write every run as CSV")
    args = p.parse_args(argv)
    try:
        import imufusion  # noqa: F401
    except ImportError:
        print("imufusion is not installed: pip install imufusion", file=sys.stderr)
        return 2
    from gyrodrift.evaluate.montecarlo import FAMILIES

    families = args.families or list(FAMILIES)
    start = time.perf_counter()
    df = run(families, range(args.seeds), args.duration_scale, args.fs_hz, args.estimator)
    if args.output:
        df.to_csv(args.output, index=False)
    table = summary(df)
    print()
    from gyrodrift.evaluate.metrics import markdown_table

    print(markdown_table(table.set_index("family"), floatfmt=".3g"))
    print(f"\nestimator {args.estimator or 'default'}; heading RMS error, deg, against ref_heading; {args.seeds} seeds per family, duration x "
          f"{args.duration_scale:g}, {args.fs_hz:g} Hz; {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

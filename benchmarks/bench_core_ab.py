"""The default engine's core on the throughput benchmark's log, best of a few runs, for A/B.

A busy shared machine moves a single run of ``bench_throughput.py`` by tens of percent, so two
trees are compared by alternating this script between them, each under its own ``PYTHONPATH``::

    for i in 1 2 3; do
        PYTHONPATH=../before/src python benchmarks/bench_core_ab.py
        PYTHONPATH=src python benchmarks/bench_core_ab.py
    done

It prints the best time of ``--repeat`` calls of ``compensate_arrays`` on the first ``--rows``
rows of :func:`bench_throughput.make_log` (100 Hz, compass every 10th row) written into kept
buffers, as samples/s, and the same rows re-timed at ``--slow-hz`` (an epoch every few rows:
the model's per-epoch cost).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_throughput import FS_HZ, make_log  # noqa: E402


def best_time(t, cols, buffers, repeat: int) -> float:
    from gyrodrift.compensator import compensate_arrays

    compensate_arrays(t[:5000], cols["gyro_z"][:5000], cols["temp"][:5000], cols["heading"][:5000])
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        compensate_arrays(t, cols["gyro_z"], cols["temp"], cols["heading"], buffers=buffers)
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--slow-hz", type=float, default=10.0)
    args = parser.parse_args()
    from gyrodrift import OutputBuffers, __file__ as where

    cols = make_log(args.rows)
    buffers = OutputBuffers(args.rows)
    fast = best_time(cols["t"], cols, buffers, args.repeat)
    slow = best_time(cols["t"] * (FS_HZ / args.slow_hz), cols, buffers, args.repeat)
    epochs = args.rows / args.slow_hz
    print(f"{Path(where).parent}: {FS_HZ:.0f} Hz {args.rows / fast / 1e6:.2f} M samples/s; "
          f"{args.slow_hz:.0f} Hz {slow / epochs * 1e6:.1f} us per epoch with its rows")


if __name__ == "__main__":
    main()

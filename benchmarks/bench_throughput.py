"""Throughput of gyrodrift against the memory, I/O and per-sample limits (see README.md here).

Run from the repository root::

    python benchmarks/bench_throughput.py                 # 10 million rows
    python benchmarks/bench_throughput.py --rows 1000000  # quicker

All measurements use one generated log (static device, 100 Hz, compass on every 10th
row) written once as CSV and as Parquet in a temporary folder, and print one table with
PASS/FAIL against the targets. filterpy and imufusion rows are skipped when the package
is missing.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pa_pq

FS_HZ = 100.0
COMPASS_EVERY = 10
#: Targets: core >= 20 % of the copy rate; end-to-end <= 1.5 x the I/O limit; streaming <= 20 µs/sample
#: inside the init window and <= 10 µs/sample after it.
CORE_VS_COPY_MIN = 0.20
E2E_VS_IO_MAX = 1.5
STREAM_US_MAX = 20.0
STREAM_AFTER_INIT_US_MAX = 10.0


# --------------------------------------------------------------------------- data


def true_drift(temp_c):
    """Drift of the generated gyro, deg/s (linear in temperature)."""
    return 0.2 + 0.01 * (temp_c - 25.0)


def make_log(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Static device at 100 Hz: drift linear in a slow temperature cycle, compass every 10th row.

    Columns t (s), gyro_z (deg/s), temp (degC, 0.0625 steps), heading (deg, NaN off compass rows).
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float) / FS_HZ
    temp = np.round((25.0 + 10.0 * np.sin(2 * np.pi * t / 7200.0)) / 0.0625) * 0.0625
    gyro = true_drift(temp) + 0.4 * rng.standard_normal(n)
    heading = np.full(n, np.nan)
    heading[::COMPASS_EVERY] = np.mod(123.0 + 0.5 * rng.standard_normal(heading[::COMPASS_EVERY].size), 360.0)
    return {"t": t, "gyro_z": gyro, "temp": temp, "heading": heading}


def arrow_table(cols: dict[str, np.ndarray]) -> pa.Table:
    """Arrow table with NaN as null (empty CSV cells), as a logger would write."""
    return pa.table({k: pa.array(v, from_pandas=True) for k, v in cols.items()})


def write_inputs(cols, folder: Path) -> dict[str, Path]:
    table = arrow_table(cols)
    paths = {"csv": folder / "in.csv", "parquet": folder / "in.parquet"}
    pa_csv.write_csv(table, paths["csv"])
    pa_pq.write_table(table, paths["parquet"])
    return paths


# --------------------------------------------------------------------------- measurements


def timed(fn, repeat: int = 1):
    """Best wall time (s) of ``repeat`` calls, and the last result."""
    best, result = math.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def warm_up() -> float:
    """Run the compiled engine once on a small log (loads or, the first time, compiles its
    numba kernels into the on-disk cache); returns the seconds it took."""
    from gyrodrift.compensator import compensate_arrays

    small = make_log(20_000)
    return timed(lambda: compensate_arrays(small["t"], small["gyro_z"], small["temp"], small["heading"]))[0]


def bench_core(cols, repeat: int, buffers=None):
    """``compensate_arrays`` on the log: best time (s) and the output table. ``buffers``: an
    :class:`gyrodrift.OutputBuffers` the calls write into (None: new output memory each call)."""
    from gyrodrift.compensator import compensate_arrays

    return timed(lambda: compensate_arrays(cols["t"], cols["gyro_z"], cols["temp"], cols["heading"], buffers=buffers),
                 repeat)


def copy_sources(cols, out) -> list[np.ndarray]:
    """The input columns and the output columns as arrays (text columns as their 1-byte codes)."""
    arrays = [np.ascontiguousarray(v) for v in cols.values()]
    for name in out.columns:
        if hasattr(out[name], "cat"):
            arrays.append(np.ascontiguousarray(out[name].cat.codes.to_numpy()))
        elif out[name].dtype == object:
            arrays.append(np.unique(out[name].to_numpy(dtype=object).astype(str), return_inverse=True)[1].astype(np.int8))
        else:
            arrays.append(np.ascontiguousarray(out[name].to_numpy()))
    return arrays


def bench_copy(sources: list[np.ndarray], repeat: int) -> float:
    targets = [np.empty_like(a) for a in sources]
    for dst in targets:  # touch the pages once, so the copy measures bandwidth, not page faults
        dst.fill(0)

    def copy_all():
        for dst, src in zip(targets, sources):
            np.copyto(dst, src)

    return timed(copy_all, repeat)[0]


def bench_copy_fresh(sources: list[np.ndarray], repeat: int) -> float:
    """As :func:`bench_copy`, into new arrays each time (their page faults counted), the last
    call's copies still held, as :func:`bench_core`'s calls hold the last result: the memory
    cost that the core pays for its output columns, for comparison only."""

    def copy_new():
        targets = [np.empty_like(a) for a in sources]
        for dst, src in zip(targets, sources):
            np.copyto(dst, src)
        return targets

    return timed(copy_new, repeat)[0]


def bench_io(path: Path, fmt: str, out_table: pa.Table, folder: Path, repeat: int) -> tuple[float, float]:
    """pyarrow alone: read the input file; write a table with the output columns in the same format.

    Best of ``repeat`` for each; every write goes to a new file (the one before is deleted,
    untimed), as the end-to-end run writes a new file.
    """
    out_path = folder / f"io_out.{fmt}"
    if fmt == "csv":
        read = lambda: pa_csv.read_csv(path)  # noqa: E731
        write = lambda: pa_csv.write_csv(out_table, out_path)  # noqa: E731
    else:
        read = lambda: pa_pq.read_table(path)  # noqa: E731
        write = lambda: pa_pq.write_table(out_table, out_path)  # noqa: E731
    t_write = math.inf
    for _ in range(repeat):
        out_path.unlink(missing_ok=True)
        t_write = min(t_write, timed(write)[0])
    out_path.unlink(missing_ok=True)
    return timed(read, repeat)[0], t_write


def _child_env() -> dict[str, str]:
    """Environment in which ``python -m gyrodrift`` imports the gyrodrift this script imported."""
    import gyrodrift

    src = str(Path(gyrodrift.__file__).resolve().parents[1])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([src, env["PYTHONPATH"]]) if env.get("PYTHONPATH") else src
    return env


#: Runs ``gyrodrift`` like ``python -m gyrodrift`` and reports the peak RSS of its own memory
#: (``VmHWM`` of /proc/self/status). The rusage of a child is no good here: Linux starts a
#: child's ``ru_maxrss`` from the parent's, as ``subprocess`` forks (vfork) this big process.
_RSS_WRAPPER = (
    "import sys\n"
    "from gyrodrift.cli import main\n"
    "rc = main(sys.argv[1:])\n"
    "try:\n"
    "    hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')][0]\n"
    "except OSError:\n"
    "    import resource; hwm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
    "sys.stderr.write(f'VMHWM_KIB {hwm}\\n')\n"
    "sys.exit(rc)\n"
)


def bench_cli_rss(in_path: Path, out_path: Path, repeat: int = 1) -> tuple[float, float]:
    """``gyrodrift compensate IN -o OUT -q`` in a fresh process: best wall time (s) of
    ``repeat`` runs, each writing a new file, and the largest peak RSS (MiB)."""
    cmd = [sys.executable, "-c", _RSS_WRAPPER, "compensate", str(in_path), "-o", str(out_path), "-q"]
    best, peak = math.inf, 0.0
    for _ in range(repeat):
        out_path.unlink(missing_ok=True)
        start = time.perf_counter()
        proc = subprocess.run(cmd, env=_child_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        best = min(best, time.perf_counter() - start)
        if proc.returncode != 0:
            raise RuntimeError(f"gyrodrift compensate failed ({proc.returncode}): {proc.stderr[-500:]}")
        kib = [float(line.split()[1]) for line in proc.stderr.splitlines() if line.startswith("VMHWM_KIB")][-1]
        peak = max(peak, kib / 1024.0)
    return best, peak


def write_long_log(path: Path, hours: float, fs_hz: float, chunk_rows: int = 2_000_000) -> int:
    """A long static log as Parquet, written chunk by chunk (constant memory); returns its rows.

    Same device as :func:`make_log` but sampled at ``fs_hz``, compass at 10 Hz.
    """
    n = int(round(hours * 3600.0 * fs_hz))
    every = max(int(round(fs_hz / 10.0)), 1)
    rng = np.random.default_rng(1)
    writer = None
    for start in range(0, n, chunk_rows):
        idx = np.arange(start, min(start + chunk_rows, n))
        t = idx / fs_hz
        temp = np.round((25.0 + 10.0 * np.sin(2 * np.pi * t / 7200.0)) / 0.0625) * 0.0625
        gyro = true_drift(temp) + 0.4 * rng.standard_normal(idx.size)
        heading = np.where(idx % every == 0, np.mod(123.0 + 0.5 * rng.standard_normal(idx.size), 360.0), np.nan)
        table = arrow_table({"t": t, "gyro_z": gyro, "temp": temp, "heading": heading})
        if writer is None:
            writer = pa_pq.ParquetWriter(path, table.schema)
        writer.write_table(table)
    writer.close()
    return n


def bench_startup() -> float:
    """Wall time (s) of ``python -m gyrodrift --version``: process start and imports, the fixed cost of (d)."""
    cmd = [sys.executable, "-m", "gyrodrift", "--version"]
    return timed(lambda: subprocess.run(cmd, env=_child_env(), check=True, capture_output=True), 3)[0]


def bench_inprocess(in_path: Path, out_path: Path) -> dict[str, float]:
    """Breakdown of the end-to-end run in this process: read_log, compensate, write_table (s)."""
    from gyrodrift.compensator import compensate
    from gyrodrift.io import read_log, write_table

    t_read, log = timed(lambda: read_log(in_path))
    t_comp, out = timed(lambda: compensate(log))
    t_write, _ = timed(lambda: write_table(out, out_path))
    return {"read_log": t_read, "compensate": t_comp, "write_table": t_write}


def bench_stream(cols, m: int) -> tuple[float, float, float]:
    """µs per sample of ``Compensator.push`` over the first ``m`` rows, over the rows of its
    init window (``config.init_s``; the push that completes it, which compensates the
    window's rows, included) and over the rows after it; after an untimed stream of the
    window and 100 rows more, as the other rows are timed after the warm-up."""
    from gyrodrift.compensator import Compensator

    t, g, T, h = (cols[k][:m].tolist() for k in ("t", "gyro_z", "temp", "heading"))
    comp = Compensator()
    end = min(m, int(np.searchsorted(cols["t"][:m], cols["t"][0] + comp.config.init_s, "left")) + 1)
    for i in range(min(m, end + 100)):  # untimed: the streaming kernels loaded from numba's cache
        comp.push(t[i], g[i], T[i], heading_deg=h[i])
    comp = Compensator()
    push = comp.push
    start = time.perf_counter()
    for i in range(end):
        push(t[i], g[i], T[i], heading_deg=h[i])
    inside = time.perf_counter() - start
    start = time.perf_counter()
    for i in range(end, m):
        push(t[i], g[i], T[i], heading_deg=h[i])
    after = time.perf_counter() - start
    return (inside + after) / m * 1e6, inside / end * 1e6, after / max(m - end, 1) * 1e6


def raw_compass(cols, m: int) -> tuple[list, list]:
    """A level magnetometer (µT, FRD) on the log's compass rows (None on the others) that reads
    its heading, and an accelerometer (m/s², FRD) on every row, for the first ``m`` rows."""
    rng = np.random.default_rng(1)
    h = np.radians(cols["heading"][:m])
    mag = np.column_stack([20.0 * np.cos(h), -20.0 * np.sin(h), np.full(m, 45.0)])
    acc = np.column_stack([np.zeros(m), np.zeros(m), np.full(m, -9.80665)]) + 0.02 * rng.standard_normal((m, 3))
    return [None if math.isnan(v[0]) else tuple(v) for v in mag.tolist()], [tuple(v) for v in acc.tolist()]


def bench_stream_raw(cols, m: int) -> float:
    """µs per sample of ``Compensator.push`` with a raw magnetometer and accelerometer
    (:func:`raw_compass`) over the rows after the init window, after an untimed stream of it."""
    from gyrodrift.compensator import Compensator

    t, g, T = (cols[k][:m].tolist() for k in ("t", "gyro_z", "temp"))
    mag, acc = raw_compass(cols, m)
    comp = Compensator()
    end = min(m, int(np.searchsorted(cols["t"][:m], cols["t"][0] + comp.config.init_s, "left")) + 1)
    push = comp.push
    for i in range(end):
        push(t[i], g[i], T[i], mag=mag[i], acc=acc[i])
    start = time.perf_counter()
    for i in range(end, m):
        push(t[i], g[i], T[i], mag=mag[i], acc=acc[i])
    return (time.perf_counter() - start) / max(m - end, 1) * 1e6


def bench_filterpy(cols, m: int, interval_s: float = 10.0) -> tuple[float, str]:
    """µs per sample, and what it learned, of a per-sample Python loop with filterpy's KalmanFilter for [a, b, c].

    Same structure as gyrodrift: per-sample compensation ``rate = gyro - (a T + b T' + c)``
    and trapezoid heading; every 10 s one drift measurement
    ``m = (∫gyro dt - Δcompass)/Δt`` with ``H = [mean T, T', 1]`` (T' a plain 10-s
    difference, as in the paper), fading memory ``alpha = sqrt(1.2)``.
    """
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=3, dim_z=1)
    kf.x = np.zeros((3, 1))
    kf.P = np.diag([0.05**2, 5.0**2, 5.0**2])
    kf.Q = np.diag([1e-4**2, 0.05**2, 1e-3**2])
    kf.R = np.array([[2 * 0.5**2 / interval_s**2 + 0.04**2 / interval_s]])
    kf.alpha = math.sqrt(1.2)
    t, g, T, h = (cols[k][:m].tolist() for k in ("t", "gyro_z", "temp", "heading"))
    a = b = c = 0.0
    temp_rate = 0.0
    heading = 0.0
    i_gyro = i_temp = 0.0
    start_t, start_gyro, start_temp, start_compass = t[0], 0.0, 0.0, None
    last_compass = None
    interval_temp = T[0]
    updates = 0
    started = time.perf_counter()
    for i in range(1, m):
        dt = t[i] - t[i - 1]
        bias = a * T[i] + b * temp_rate + c
        rate = g[i] - bias
        heading += 0.5 * (rate + g[i - 1] - bias) * dt
        i_gyro += 0.5 * (g[i] + g[i - 1]) * dt
        i_temp += 0.5 * (T[i] + T[i - 1]) * dt
        if h[i] == h[i]:  # not NaN: a compass sample
            last_compass = h[i]
            if start_compass is None:
                start_compass, start_t, start_gyro, start_temp = h[i], t[i], i_gyro, i_temp
        if t[i] - start_t >= interval_s and start_compass is not None and last_compass is not None:
            span = t[i] - start_t
            d = ((i_gyro - start_gyro) - (last_compass - start_compass) + 180.0) % 360.0 - 180.0
            temp_rate = (T[i] - interval_temp) / span
            interval_temp = T[i]
            kf.predict()
            kf.update(np.array([[d / span]]), H=np.array([[(i_temp - start_temp) / span, temp_rate, 1.0]]))
            a, b, c = (float(v) for v in kf.x[:, 0])
            updates += 1
            start_compass, start_t, start_gyro, start_temp = last_compass, t[i], i_gyro, i_temp
    us = (time.perf_counter() - started) / (m - 1) * 1e6
    est = a * T[-1] + b * temp_rate + c
    return us, f"{updates} updates; drift at the end {est:.3f} deg/s, true {true_drift(T[-1]):.3f}"


def bench_imufusion(cols, m: int) -> tuple[float, str]:
    """µs per sample, and its final gyro offset, of x-io Fusion (imufusion >= 1.3): ``Bias`` (gyro offset) + ``Ahrs`` with external heading."""
    from bench_fused_heading import imufusion_filters

    bias, ahrs = imufusion_filters(FS_HZ, magnetic_rejection_deg=0.0)
    acc = np.array([0.0, 0.0, -1.0])  # level and still (NED, g)
    g, h = (cols[k][:m].tolist() for k in ("gyro_z", "heading"))
    start = time.perf_counter()
    for i in range(m):
        gyro = bias.update(np.array((0.0, 0.0, g[i])))
        if h[i] == h[i]:
            ahrs.update_external_heading(gyro, acc, h[i])
        else:
            ahrs.update_no_magnetometer(gyro, acc)
        ahrs.get_quaternion()
    us = (time.perf_counter() - start) / m * 1e6
    truth = true_drift(cols["temp"][m - 1])
    return us, f"offset z at the end {float(bias.get_offset()[2]):.3f} deg/s, true {truth:.3f}"


# --------------------------------------------------------------------------- report


@dataclass
class Row:
    name: str
    value: float
    unit: str
    target: str = ""
    ratio: float = math.nan
    verdict: str = ""


def _fmt(v: float) -> str:
    if isinstance(v, float) and math.isnan(v):
        return ""
    if abs(v) >= 1e5:
        return f"{v:,.0f}"
    return f"{v:.3g}" if abs(v) < 100 else f"{v:.0f}"


def table(rows: list[Row]) -> str:
    lines = ["| measurement | value | unit | target | ratio | result |", "| :--- | ---: | :--- | :--- | ---: | :--- |"]
    for r in rows:
        lines.append(f"| {r.name} | {_fmt(r.value)} | {r.unit} | {r.target} | {_fmt(r.ratio)} | {r.verdict} |")
    return "\n".join(lines)


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rows", type=int, default=10_000_000, help="rows of the generated log (default 10 million)")
    p.add_argument("--stream-rows", type=int, default=200_000, help="rows for the per-sample loops (default 200k)")
    p.add_argument("--repeat", type=int, default=1,
                   help="best of N for the timings, the end-to-end runs included (default 1)")
    p.add_argument("--formats", default="csv,parquet",
                   help="file formats of the I/O-limit and end-to-end rows, comma-separated (default csv,parquet)")
    p.add_argument("--tmp", type=Path, help="folder for the generated files (default: a temporary folder)")
    p.add_argument("--no-breakdown", action="store_true", help="skip the in-process read/compensate/write breakdown")
    p.add_argument("--long-hours", type=float, default=0.0,
                   help="also compensate a log this many hours long at --long-hz, as Parquet, and report the peak RSS "
                        "(24 at 1000 Hz: 86.4 million rows, about 4 GB of files; default 0 = skip)")
    p.add_argument("--long-hz", type=float, default=1000.0, help="sample rate of the long log, Hz (default 1000)")
    args = p.parse_args(argv)
    formats = [f.strip() for f in args.formats.split(",") if f.strip()]
    if not formats or any(f not in ("csv", "parquet") for f in formats):
        p.error(f"--formats: csv and/or parquet, got {args.formats!r}")

    import gyrodrift

    n, m = args.rows, min(args.stream_rows, args.rows)
    print(f"gyrodrift {gyrodrift.__version__}, Python {platform.python_version()}, numpy {np.__version__}, "
          f"pyarrow {pa.__version__}, {os.cpu_count()} CPUs, {platform.machine()}", flush=True)
    print(f"log: {n:,} rows at {FS_HZ:g} Hz ({n / FS_HZ / 3600:.1f} h), compass every {COMPASS_EVERY}th row; "
          f"per-sample loops on the first {m:,} rows", flush=True)
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(dir=args.tmp) as tmp:
        folder = Path(tmp)
        cols = make_log(n)
        paths = write_inputs(cols, folder)
        sizes = {fmt: path.stat().st_size / 2**20 for fmt, path in paths.items()}
        print(f"input files: CSV {sizes['csv']:.0f} MiB, Parquet {sizes['parquet']:.0f} MiB", flush=True)

        t_warm = warm_up()
        print(f"warm-up (numba kernels from the cache, or compiled the first time): {t_warm:.2f} s", flush=True)
        # (a) and (b) write into memory touched before; their second rows, into new memory
        t_new, out = bench_core(cols, args.repeat)
        sources = copy_sources(cols, out)
        out_frame = out.copy()
        del out
        buffers = gyrodrift.OutputBuffers(n)
        t_core, _ = bench_core(cols, max(args.repeat, 3), buffers)
        del buffers, _
        core_rate = n / t_core
        t_copy = bench_copy(sources, max(args.repeat, 3))
        copy_rate = n / t_copy
        copied_mib = sum(a.nbytes for a in sources) / 2**20
        rows.append(Row("(a) core compensate_arrays, output into kept memory (buffers=OutputBuffers(n))", core_rate,
                        "samples/s", f">= {CORE_VS_COPY_MIN:.0%} of copy",
                        core_rate / copy_rate, verdict(core_rate / copy_rate >= CORE_VS_COPY_MIN)))
        rows.append(Row(f"(b) numpy.copyto of inputs + outputs ({copied_mib:.0f} MiB) into arrays touched before",
                        copy_rate, "samples/s"))
        t_fresh = bench_copy_fresh(sources, max(args.repeat, 3))
        rows.append(Row("    (a) with new output memory each call (its page faults included)", n / t_new, "samples/s",
                        "", n / t_new / copy_rate))
        rows.append(Row("    (b) into new arrays (page faults included); ratio: the row above over this", n / t_fresh,
                        "samples/s", "", t_fresh / t_new))
        print(f"core {t_core:.2f} s into kept memory, {t_new:.2f} s into new memory; copy {t_copy:.3f} s, "
              f"into new arrays {t_fresh:.3f} s", flush=True)

        out_frame["gyro_z"], out_frame["temp"] = cols["gyro_z"], cols["temp"]  # the CLI passes these through
        out_frame.attrs = {}
        out_table = pa.Table.from_pandas(out_frame, preserve_index=False)
        del out_frame, sources

        rows.append(Row("    fixed cost in (d): python -m gyrodrift --version", bench_startup(), "s"))
        for fmt in formats:
            t_read, t_write = bench_io(paths[fmt], fmt, out_table, folder, args.repeat)
            io_limit = t_read + t_write
            t_e2e, rss = bench_cli_rss(paths[fmt], folder / f"cli_out.{fmt}", args.repeat)
            rows.append(Row(f"(c) I/O limit {fmt}: pyarrow read {t_read:.2f} s + write {t_write:.2f} s", io_limit, "s"))
            rows.append(Row(f"(d) end-to-end gyrodrift compensate, {fmt}", t_e2e, "s", f"<= {E2E_VS_IO_MAX:g} x I/O limit",
                            t_e2e / io_limit, verdict(t_e2e / io_limit <= E2E_VS_IO_MAX)))
            rows.append(Row(f"    peak RSS of that run ({fmt})", rss, "MiB"))
            rows.append(Row(f"    end-to-end rate ({fmt})", n / t_e2e, "samples/s"))
            print(f"{fmt}: read {t_read:.2f} s, write {t_write:.2f} s, end-to-end {t_e2e:.2f} s, peak RSS {rss:.0f} MiB",
                  flush=True)
            if not args.no_breakdown:
                parts = bench_inprocess(paths[fmt], folder / f"inproc_out.{fmt}")
                detail = ", ".join(f"{k} {v:.2f} s" for k, v in parts.items())
                rows.append(Row(f"    in-process breakdown ({fmt}): {detail}", sum(parts.values()), "s"))
                print(f"{fmt} breakdown: {detail}", flush=True)
        del out_table

        if args.long_hours > 0:
            long_in, long_out = folder / "long.parquet", folder / "long_out.parquet"
            n_long = write_long_log(long_in, args.long_hours, args.long_hz)
            t_long, rss_long = bench_cli_rss(long_in, long_out)
            label = f"{args.long_hours:g} h at {args.long_hz:g} Hz, {n_long:,} rows"
            rows.append(Row(f"(g) peak RSS of gyrodrift compensate, Parquet, {label}", rss_long, "MiB", "< 1024 MiB",
                            rss_long / 1024.0, verdict(rss_long < 1024.0)))
            rows.append(Row(f"    wall time of that run ({n_long / t_long:,.0f} samples/s)", t_long, "s"))
            print(f"long log: {label}: {t_long:.1f} s, peak RSS {rss_long:.0f} MiB", flush=True)
            long_in.unlink()
            long_out.unlink()

        us_stream, us_init, us_after = bench_stream(cols, m)
        rows.append(Row("(e) streaming Compensator.push, init window", us_init, "µs/sample",
                        f"<= {STREAM_US_MAX:g} µs/sample", us_init / STREAM_US_MAX, verdict(us_init <= STREAM_US_MAX)))
        rows.append(Row("(e) streaming Compensator.push, after the init window", us_after, "µs/sample",
                        f"<= {STREAM_AFTER_INIT_US_MAX:g} µs/sample", us_after / STREAM_AFTER_INIT_US_MAX,
                        verdict(us_after <= STREAM_AFTER_INIT_US_MAX)))
        rows.append(Row("    streaming, all the rows (the (f) ratios are to this)", us_stream, "µs/sample"))
        print(f"streaming {us_init:.1f} µs/sample in the init window, {us_after:.1f} after it", flush=True)
        us_raw = bench_stream_raw(cols, m)
        rows.append(Row(f"(e) streaming, raw magnetometer (every {COMPASS_EVERY}th row) and accelerometer, after the "
                        "init window", us_raw, "µs/sample", f"<= {STREAM_US_MAX:g} µs/sample", us_raw / STREAM_US_MAX,
                        verdict(us_raw <= STREAM_US_MAX)))
        print(f"streaming with a raw magnetometer {us_raw:.1f} µs/sample after the init window", flush=True)
        for name, fn, package in (
            ("(f) filterpy KalmanFilter per-sample loop", bench_filterpy, "filterpy"),
            ("(f) imufusion Bias + Ahrs per sample", bench_imufusion, "imufusion"),
        ):
            try:
                us, note = fn(cols, m)
            except ImportError:
                rows.append(Row(f"{name} (skipped: {package} not installed)", math.nan, ""))
                continue
            rows.append(Row(f"{name} ({note})", us, "µs/sample", "reference", us / us_stream))
            print(f"{name}: {us:.2f} µs/sample", flush=True)

    print()
    print(table(rows))
    print("ratio: core/copy rate (their second rows: core in new memory/copy, then core/copy both in new memory); "
          "end-to-end/I/O-limit time; streaming/target; (f) rows: reference/streaming time.")
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / (1.0 if sys.platform == "darwin" else 1024.0)
    print(f"peak RSS of this benchmark process (data, core run, I/O tables): {own:.0f} MiB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

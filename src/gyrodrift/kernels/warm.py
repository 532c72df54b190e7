"""Compile every kernel, for every argument type a command passes, into numba's cache.

``pip install .`` runs it while it builds the wheel (``setup.py``); by hand, for an install
without the compiled copies: ``python -m gyrodrift.kernels.warm [--jobs 1]``. When and why,
and how it runs without the package's ``__init__``: ``docs/engine.md`` ("Compiled copies").
Only the standard library is imported at the top.
"""

from __future__ import annotations

import argparse
import importlib
import os
import subprocess
import sys
import time
import types

__all__ = ["SIGNATURES", "GROUPS", "command", "compile_group", "main"]

#: function (module path under ``gyrodrift``) -> its argument types, one string per signature:
#: ``f`` float64, ``i`` int64, ``b`` bool; arrays ``F`` float64, ``I`` int64, ``B`` bool, ``C`` int8,
#: then the number of dimensions (C order), and ``r`` when read-only.
SIGNATURES: dict[str, list[str]] = {
    # the default estimator's model (gyrodrift.kernels.evloop and .evidence)
    "kernels.evloop.run": ["F1r F1r F1r F1r F1r B1r F1r F1r F1r i F1 F1 F1 F1 F1 C1 i F2",
                           "F1 F1 F1 F1 F1 B1 F1 F1 F1 i F1 F1 F1 F1 F1 C1 i F2"],  # a streamed row
    "kernels.evloop.settle": ["F1r F1r F1r F1r F1r i i f F1 F1 C1 i"],
    "kernels.evloop.unobservable": ["F1 F1"],
    "kernels.evloop._close": ["F1 F1 F1 F1 f f f f F2"],
    "kernels.evidence.init_state": ["F1 F1 F1 F2 f"],
    "kernels.evidence.epoch": ["F1 F1 f f"],
    "kernels.evidence.combine": ["F1"],
    "kernels.evidence.seed_heading": ["F1 f"],
    "kernels.evidence.seed_noise": ["F1 F1 f"],
    "kernels.evidence._measure": ["F1 F2 i F1 F1 b f f f F1 f f f f f f F1 F1 f F1 F1 F1 F1"],
    "kernels.evidence._branches": ["F1 F2 f F2 F3 F1 F1 F1"],
    "kernels.evidence._update": ["F1 F2 F1 f f b i i F1"],
    # the front of every engine: input checks, held cells, T'
    "kernels.loop.prepare": ["F1r F1r F1r F1r F1 I1 F1 I1 F2 F1 F1 F1 F1 B1",
                             "F1 F1 F1 F1 F1 I1 F1 I1 F2 F1 F1 F1 F1 B1"],  # a streamed row
    "kernels.loop._hold": ["F1r f B1 F1"],
    "kernels.drift.temp_rate_chunk": ["F1 F1 i i f F1 I1 F2 F1", "F1r F1r i i f F1 I1 F2 F1"],
    "kernels.drift._ring_slope": ["F2 i i"],
    "kernels.drift._short_slope": ["F2 i i i f f"],
    "kernels.drift._end_slope": ["F2 i i i f f"],
    "kernels.drift.bias": ["f f f f f"],
    "kernels.drift.bias_sd": ["f f f f f f f f f f f"],
    "kernels.numeric.wrap360": ["f"],
    "kernels.numeric.wrap180": ["f"],
    "kernels.numeric.wrap360_all": ["F1 F1", "F1r F1"],
    "kernels.numeric.near_boundary": ["f f f"],
    "kernels.fusion.fuse_rows": ["F1 F1 F1 F1 B1 F1 F1 f F1 F1 F1", "F1 F1r F1 F1r B1 F1 F1 f F1 F1 F1"],
    "kernels.fusion.step": ["f f f f f f f f f f f f f f b f f f f f f f b"],
    # the paper's interval filters (gyrodrift.kernels.loop.run_chunk, aiding, kalman)
    "kernels.loop.run_chunk": ["F1r F1r F1r F1r F1r B1r F1r F1r i F1 I1 F1 I1 F2 F2 F1 F2 F1 I1 F1 C1 i"],
    "kernels.loop._anchor": ["F1r F1 i i i"],
    "kernels.loop._fill_params": ["F1 C1 i i i f f f i"],
    "kernels.aiding.begin": ["f F1 I1 F1"],
    "kernels.aiding.close": ["f F1 I1 F1 I1 F2 F1 F2 F1 I1 f"],
    "kernels.aiding.compass_measurement": ["F1 F1 f f"],
    "kernels.aiding.field_reference": ["F1r F1r i"],
    "kernels.aiding.in_force": ["F1 I1 F1 F1 I1"],
    "kernels.aiding.init_measurements": ["F1r F1r F1r F1 F1r i i f F1 I1 F2 F2 i"],
    "kernels.aiding.push_measurement": ["f f f f f I1 F2 F2 i"],
    "kernels.aiding.stacked": ["F2 i"],
    "kernels.aiding.steady_disagreement": ["f F1 i i"],
    "kernels.aiding.unobservable_code": ["F2 f f"],
    "kernels.kalman.update": ["F1 I1 F1 F2 F2"],
    "kernels.kalman.hold": ["F1 I1 f"],
    "kernels.kalman.params": ["F1 I1"],
    "kernels.kalman.cov": ["F1 I1"],
    "kernels.kalman._sub": ["F2 I1"],
    "kernels.kalman._put": ["F2 I1 F2"],
    "kernels.numeric.correct": ["F1 F2 F1 F2 F2"],
    "kernels.numeric.cap_covariance": ["F2 F1"],
    "kernels.numeric.solve": ["F2 F2"],
    # the x and y axes (gyrodrift.kernels.tilt) and the gyro-aided gravity (gyrodrift.attitude)
    "kernels.tilt.run": ["F1r F1r F1r F1r F1r F2r F1r i F1 I1 F1 I1 F2 F1 I1 F1 I1 F2 C1"],
    "kernels.tilt._check": ["F1r F1r F1 I1"],
    "kernels.tilt.edge_window": ["F2 i i f F1"],
    "kernels.tilt.measurement": ["F1 F1 f f"],
    "kernels.tilt.residual_ok": ["f F1 f f F1 F2 F1 i i f f"],
    "kernels.tilt.window_step": ["F2 F1 I1 f f f"],
    "kernels.compass.row": ["f f f f f f"],  # a raw compass (gyrodrift.compass and a stream's rows)
    "kernels.compass.rows": ["F1 F1 F1 F1 F1 F1 F1 F1 F1"],
    "attitude.propagate": ["F1r F1r F1r F1r F2r F1 F2 F1", "F1 F1 F1 F1 F2 F1 F2 F1"],  # chunks; a stream's rows
    "attitude._heading_rate": ["i f F1 F2 F1"],
    "attitude._about_the_vertical": ["f f f f f f"],
    "attitude._start": ["F1 f f f b"],
    "attitude._inverse3": ["F2 f F2"],
    "attitude._rotation": ["F2 f f f"],
    "attitude._predict": ["F1 F2 F2 F2 f f f f"],
    "attitude._project": ["F2 F1 F2 F2"],
    "attitude._update": ["F1 F2 F1 F2 F2 F2 F2 f"],
    "attitude._renormalise": ["F1 F2"],
    # the gyro-unit check (gyrodrift.gyro_units)
    "gyro_units._turns": ["F1r F1r F1r F1"],
}

#: The functions split in two groups of about the same compile time (one process each);
#: a group's functions share the callees they have in common.
GROUPS: tuple[tuple[str, ...], ...] = (
    tuple(k for k in SIGNATURES if k.split(".")[-2] in ("evloop", "evidence", "drift", "fusion")
          or k in ("kernels.loop.prepare", "kernels.loop._hold", "kernels.numeric.wrap360",
                   "kernels.numeric.wrap180", "kernels.numeric.wrap360_all", "kernels.numeric.near_boundary")),
)
GROUPS += (tuple(k for k in SIGNATURES if k not in GROUPS[0]),)

_SCALARS = {"f": "float64", "i": "int64", "b": "boolean"}
_DTYPES = {"F": "float64", "I": "int64", "B": "boolean", "C": "int8"}


def signature(codes: str):
    """The numba argument types of a :data:`SIGNATURES` string."""
    from numba.core import types as nt

    args = []
    for code in codes.split():
        if code in _SCALARS:
            args.append(getattr(nt, _SCALARS[code]))
        else:
            args.append(nt.Array(getattr(nt, _DTYPES[code[0]]), int(code[1]), "C", readonly=code.endswith("r")))
    return tuple(args)


def dispatcher(name: str):
    """The compiled function :data:`SIGNATURES` names (``module.function`` under gyrodrift)."""
    module, _, fn = name.rpartition(".")
    return getattr(importlib.import_module(f"gyrodrift.{module}"), fn)


def compile_group(names, out=sys.stderr) -> None:
    """Compile (or load from the cache) every signature of ``names``; one line per function."""
    for name in names:
        start = time.perf_counter()
        disp = dispatcher(name)
        for codes in SIGNATURES[name]:
            disp.compile(signature(codes))
        print(f"  {name}: {time.perf_counter() - start:.1f} s", file=out, flush=True)


def _load_without_init(root: str) -> None:
    """Make ``gyrodrift`` importable from ``root`` without running its ``__init__``."""
    if "gyrodrift" not in sys.modules:
        pkg = types.ModuleType("gyrodrift")
        pkg.__path__ = [os.path.join(root, "gyrodrift")]
        sys.modules["gyrodrift"] = pkg


def command(root: str, *args: str) -> list[str]:
    """The command line that runs :func:`main` with ``args`` on the package under ``root`` in
    a new interpreter (without the package's ``__init__``)."""
    code = ("import os, sys, types; root = sys.argv[1]; pkg = types.ModuleType('gyrodrift'); "
            "pkg.__path__ = [os.path.join(root, 'gyrodrift')]; sys.modules['gyrodrift'] = pkg; "
            "from gyrodrift.kernels.warm import main; sys.exit(main(sys.argv[2:]))")
    return [sys.executable, "-c", code, root, "--root", root, *args]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m gyrodrift.kernels.warm", description=__doc__.split("\n\n")[0])
    p.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    p.add_argument("--root", help="the folder holding the gyrodrift package (loaded without its __init__)")
    p.add_argument("--group", type=int, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.root:
        _load_without_init(args.root)
    root = args.root or os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    if args.group is not None:
        compile_group(GROUPS[args.group])
        return 0
    start = time.perf_counter()
    jobs = max(1, min(args.jobs, len(GROUPS)))
    children = [subprocess.Popen(command(root, "--group", str(g))) for g in range(1, jobs)]
    for g in range(len(GROUPS)):
        if g == 0 or g >= jobs:
            compile_group(GROUPS[g])
    failed = sum(child.wait() != 0 for child in children)
    print(f"gyrodrift: kernels compiled in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

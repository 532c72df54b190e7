"""The compiled kernels an install ships (:mod:`gyrodrift.kernels.warm`): every argument type
a command passes is in the list the build compiles, so no command compiles after ``pip install .``."""

import json
import subprocess
import sys
import textwrap
from pathlib import Path

from gyrodrift.kernels import warm

#: The commands run in a fresh process; it prints the signatures every compiled function got.
_COMMANDS = textwrap.dedent("""
    import gc, io, json, contextlib, sys
    from pathlib import Path
    from gyrodrift.cli import main
    from gyrodrift.compensator import Compensator
    import pandas as pd

    d = Path(sys.argv[1])
    def run(*args):
        with contextlib.redirect_stdout(io.StringIO()):
            main([str(a) for a in args])
    run("demo", "-o", d / "demo.csv")
    run("simulate", "vehicle", "-o", d / "v.csv", "--triad", "--raw-mag", "--duration-s", "300", "-q")
    run("simulate", "calibration", "-o", d / "cal.csv", "--duration-s", "1200", "-q")
    for extra in ([], ["--estimator", "stkf"], ["--estimator", "kf"], ["--smooth"], ["--scale-factor"]):
        run("compensate", d / "v.csv", "-o", d / "o.parquet", "-q", *extra)
    run("compare", d / "v.csv")
    run("calibrate", d / "cal.csv", "-o", d / "cal.json", "--format", "json", "-q")
    log = pd.read_csv(d / "v.csv").head(3000)
    for kw in ({}, {"mag": True}, {"gyro": True}):
        c = Compensator()
        for r in log.itertuples():
            c.push(r.t, r.gyro_z, r.temp,
                   mag=(r.mag_x, r.mag_y, r.mag_z) if kw else None, acc=(r.acc_x, r.acc_y, r.acc_z) if kw else None,
                   gyro_x_dps=r.gyro_x if "gyro" in kw else None, gyro_y_dps=r.gyro_y if "gyro" in kw else None)
        c.flush()
    from numba.core.registry import CPUDispatcher
    found = {}
    for o in gc.get_objects():
        if isinstance(o, CPUDispatcher) and o.py_func.__module__.startswith("gyrodrift."):
            found.setdefault(o.py_func.__module__[len("gyrodrift."):] + "." + o.py_func.__name__, []).extend(
                str(s) for s in o.signatures)
    print(json.dumps(found))
""")


def test_every_listed_signature_names_a_compiled_function():
    for name, sigs in warm.SIGNATURES.items():
        disp = warm.dispatcher(name)
        assert hasattr(disp, "compile"), name
        assert len(set(sigs)) == len(sigs) and all(warm.signature(s) for s in sigs), name
    assert sorted(k for g in warm.GROUPS for k in g) == sorted(warm.SIGNATURES)


def test_the_commands_compile_nothing_outside_the_list(tmp_path):
    """Every command on every kind of input (heading and raw magnetometer, x/y axes, each
    filter, smoother, scale factor, streaming with and without raw sensors) calls the compiled
    functions only with argument types the build compiled."""
    out = subprocess.run([sys.executable, "-c", _COMMANDS, str(tmp_path)], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    found = json.loads(out.stdout.strip().splitlines()[-1])
    listed = {name: {str(warm.signature(s)) for s in sigs} for name, sigs in warm.SIGNATURES.items()}
    missing = {name: sorted(set(sigs) - listed.get(name, set())) for name, sigs in found.items()}
    # a function inlined everywhere (inline="always") has no signature of its own; numba's
    # literal and omitted-argument types are its callers' (compiled within them)
    missing = {k: [s for s in v if "Literal" not in s and "omitted" not in s] for k, v in missing.items()}
    assert not {k: v for k, v in missing.items() if v}, missing


_IMPORTS_WITHOUT_PANDAS = textwrap.dedent("""
    import importlib.abc, sys

    class NoPandas(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name == "pandas" or name.startswith("pandas."):
                raise ImportError("pandas is not installed where the wheel is built")

    sys.meta_path.insert(0, NoPandas())
    from gyrodrift.kernels import warm  # loaded as the build loads it, without the package's __init__
    for name in warm.SIGNATURES:
        warm.dispatcher(name)
    print("ok", len(warm.SIGNATURES))
""")


def test_every_listed_function_imports_where_the_wheel_is_built():
    """``pip install .`` compiles the list in an environment with numba, numpy and scipy only
    (setup.py): every module it names must import without pandas, or the build compiles nothing
    after it and the first command compiles instead."""
    src = str(Path(warm.__file__).resolve().parents[2])
    code = ("import os, sys, types; pkg = types.ModuleType('gyrodrift'); "
            f"pkg.__path__ = [os.path.join({src!r}, 'gyrodrift')]; sys.modules['gyrodrift'] = pkg; "
            f"exec({_IMPORTS_WITHOUT_PANDAS!r})")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.startswith("ok"), out.stderr[-2000:]

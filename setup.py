"""The build step that compiles the numba kernels into the wheel (metadata: pyproject.toml).

After the sources are copied to the build folder, ``gyrodrift.kernels.warm`` compiles every
kernel there (two processes; only numba, numpy and scipy are needed), so numba's cache is installed
with the package and the first command after ``pip install .`` does not compile. Skipped for
editable installs and when ``GYRODRIFT_NO_PRECOMPILE`` is set; if compiling fails, the
package is built without the cache and compiles on first use, as before.
"""

import importlib.util
import os
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py

WARM = ("gyrodrift", "kernels", "warm.py")


class BuildPyCompiled(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False) or os.environ.get("GYRODRIFT_NO_PRECOMPILE"):
            return
        root = os.path.abspath(self.build_lib)
        # the module alone, by its path: the package's __init__ needs pandas, not installed here
        spec = importlib.util.spec_from_file_location("_gyrodrift_warm", os.path.join(root, *WARM))
        warm = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(warm)  # imports the standard library only
        # numba's cache goes next to the sources in the build folder, nowhere else
        env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
        print("gyrodrift: compiling the numba kernels into the package (about a minute) ...", file=sys.stderr)
        done = subprocess.run(warm.command(root), env=env)
        if done.returncode:
            print("gyrodrift: warning: compiling the kernels failed; they compile on first use", file=sys.stderr)


setup(cmdclass={"build_py": BuildPyCompiled})

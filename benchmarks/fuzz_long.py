"""The long fuzz run of issues 16 and 24: the fuzz tests with 2000 examples per entry point.

    PYTHONPATH=src python benchmarks/fuzz_long.py [EXAMPLES]

Runs pytest on ``tests/test_fuzz.py`` (readers, streaming, loaders; issue 16) and
``tests/test_fuzz_edges.py`` (file system, injection, streaming against files; issue 24)
with ``GYRODRIFT_FUZZ_EXAMPLES`` set (default 2000), hypothesis statistics on, and prints
the examples run and the failures found per test.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The test files run.
FUZZ_FILES = ("tests/test_fuzz.py", "tests/test_fuzz_edges.py")


def main(argv: list[str]) -> int:
    examples = int(argv[0]) if argv else 2000
    env = {**os.environ, "GYRODRIFT_FUZZ_EXAMPLES": str(examples)}
    start = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--hypothesis-show-statistics",
         *(str(ROOT / f) for f in FUZZ_FILES)],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )
    seconds = time.monotonic() - start
    for line in proc.stdout.splitlines():
        failure = line.startswith(("FAILED", "E       Failing test case", "E           data=", "E           samples="))
        statistics = ("::test_" in line and line.endswith(":")) or "passing," in line  # per test: examples run
        if failure or statistics:
            print(line)
    print(proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else proc.stderr)
    print(f"examples per test: {examples}; wall time {seconds:.0f} s; exit {proc.returncode}")
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

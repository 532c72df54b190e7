"""The long fuzz run of issue 16: tests/test_fuzz.py with 2000 examples per entry point.

    PYTHONPATH=src python benchmarks/fuzz_long.py [EXAMPLES]

Runs pytest on ``tests/test_fuzz.py`` with ``GYRODRIFT_FUZZ_EXAMPLES`` set (default 2000),
hypothesis statistics on, and prints the examples run and the failures found per test.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str]) -> int:
    examples = int(argv[0]) if argv else 2000
    env = {**os.environ, "GYRODRIFT_FUZZ_EXAMPLES": str(examples)}
    start = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--hypothesis-show-statistics",
         str(ROOT / "tests" / "test_fuzz.py")],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )
    seconds = time.monotonic() - start
    for line in proc.stdout.splitlines():
        if line.startswith(("FAILED", "E       Failing test case", "E           data=", "E           samples=")):
            print(line)
    print(proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else proc.stderr)
    print(f"examples per test: {examples}; wall time {seconds:.0f} s; exit {proc.returncode}")
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Benchmark of `linsense reproduce` (make bench): the full run (target under 5 minutes on 2 cores)
and `--quick` (under 1 minute), each as its own process (imports included), with its peak RSS.
A report: the exit status is 0 whatever the result."""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(*args: str) -> tuple[float, float, str]:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        cmd = [sys.executable, "-m", "linsense", "reproduce", *args, "--out", str(Path(tmp) / "o")]
        p = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0  # (the largest child so far)
    first = next((ln for ln in p.stdout.splitlines() if "claims" in ln), p.stderr.strip()[-200:])
    return wall, rss, first


def main() -> None:
    wall, rss, line = run()
    print(f"reproduce (full): {wall:.1f} s, peak RSS {rss:.0f} MB {'PASS' if wall < 300 else 'FAIL'} "
          f"(target < 5 min); {line}")
    wall, _, line = run("--quick")
    print(f"reproduce --quick: {wall:.1f} s {'PASS' if wall < 60 else 'FAIL'} (target < 1 min)")


if __name__ == "__main__":
    main()

"""Closed-loop processor in the loop: a scenario's plant on the host, its drive on the Cortex-M4F under
QEMU (docs/firmware.md, "Processor in the loop"); the loop is :func:`linsense.firmware.pil.run_pil`.

Usage: ``python tools/pil_closed.py SCENARIO [--duration S] [--out DIR]``; exit 1 on any difference.
``DIR/pil.json`` holds both runs' metrics and their differences (what ``linsense simulate SCENARIO
--pil`` reports).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from linsense.firmware.pil import metric_differences, run_pil

ROOT = Path(__file__).resolve().parents[1]

__all__ = ["main", "metric_differences"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--duration", type=float, default=None, help="s (default: the scenario's)")
    ap.add_argument("--out", type=Path, default=ROOT / "build" / "pil-closed")
    a = ap.parse_args(argv)
    return 0 if run_pil(a.scenario, a.out, duration=a.duration, say=print)["pass"] else 1


if __name__ == "__main__":
    sys.exit(main())

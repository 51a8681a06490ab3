"""Processor in the loop, closed: a scenario's plant on the host, its drive on a Cortex-M4F under
QEMU (docs/firmware.md, "Processor in the loop"); what ``linsense simulate SCENARIO --pil`` runs.

The loop itself is the source tree's ``tools/pil_closed.py`` (``make pil`` runs it on the Fig. 13
trajectory): it cross-compiles the firmware's replay in its closed-loop build (csrc/pil/), builds the
host side around the simulator's own time loop (csrc/sim/), exchanges one PWM period at a time
through named pipes with the firmware under ``qemu-system-arm``, and runs the same loop on the host
build of the drive for the reference, each side with its own C library (newlib on the target,
glibc on the host): the two must agree bit for bit on every output of every step. It needs what a
wheel does not ship (the simulator's and the harness's C sources, the ARM cross compiler, QEMU, a C
compiler): a source tree of linsense, with ``make tools`` run once.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

from linsense.errors import InputError

#: the programs the closed loop needs, and the Debian packages that bring them (``make tools``)
TOOLS = {"arm-none-eabi-gcc": "gcc-arm-none-eabi libnewlib-arm-none-eabi",
         "qemu-system-arm": "qemu-system-arm", "cc": "gcc"}


def source_tree() -> Path | None:
    """The source tree linsense runs from (an editable install), if it holds the PIL harness.

    Returns
    -------
    Path or None
        The repository's root, or None for an installed wheel.
    """
    root = Path(__file__).resolve().parents[3]
    needed = (root / "tools" / "pil_closed.py", root / "csrc" / "pil", root / "csrc" / "sim")
    return root if all(p.exists() for p in needed) else None


def closed_loop(scenario: str | Path, out: str | Path, *, duration: float | None = None) -> dict:
    """Run a scenario with its drive on the Cortex-M4F under QEMU and on the host; both runs' metrics.

    Parameters
    ----------
    scenario : str or Path
        The scenario file.
    out : str or Path
        Folder for the builds, the pipes and ``pil.json``.
    duration : float or None, optional
        Simulated time in s (default: the scenario's).

    Returns
    -------
    dict
        ``pil.json``: ``metrics_pil`` (the firmware's run), ``metrics_host``, ``metric_differences``
        (absolute, of the numeric metrics that differ), ``metric_mismatches`` (the other metrics that
        differ: [pil, host]), ``identical_steps`` (every output of every step), ``pass`` (identical
        steps and metrics), ``steps``, ``simulated_s``, ``wall_s``, ``qemu_cpu_s``, ``libm`` (each
        side's C library).

    Raises
    ------
    linsense.errors.InputError
        Not a source tree, a program missing, or the closed loop failing to run.
    """
    root = source_tree()
    if root is None:
        raise InputError("--pil", "", "needs a source tree of linsense (csrc/pil, csrc/sim, "
                         "tools/pil_closed.py; an installed wheel has none): clone it, then make pil")
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if missing:
        pkgs = " ".join(TOOLS[t] for t in missing)
        raise InputError("--pil", "", f"needs {', '.join(missing)} (Debian: apt-get install {pkgs}; "
                         "make tools installs them as root)")
    out = Path(out)
    record = out / "pil.json"
    record.unlink(missing_ok=True)  # (a folder used before: never an earlier run's record)
    cmd = [sys.executable, str(root / "tools" / "pil_closed.py"), str(scenario), "--out", str(out)]
    if duration is not None:
        cmd += ["--duration", repr(float(duration))]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if not record.is_file():
        last = (r.stderr or r.stdout).strip().splitlines()[-1:] or ["no output"]
        raise InputError(str(scenario), "", f"the closed loop with the firmware under QEMU did not run "
                         f"(exit {r.returncode}): {last[0]}")
    return json.loads(record.read_text(encoding="utf-8"))


__all__ = ["TOOLS", "closed_loop", "source_tree"]

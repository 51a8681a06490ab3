"""Closed-loop processor in the loop: a scenario's plant on the host, its drive on the Cortex-M4F under
QEMU (docs/firmware.md, "Processor in the loop").

The simulator's time loop (the host recorder, csrc/pil/pil_record.c, ``pil_remote``) sends each
step's measurements (and the commands between them) through a named pipe to the firmware's replay in
its closed-loop build (``-DPIL_REMOTE``: one event at a time) and applies the duties the firmware
returns through another, one exchange per PWM period. The same loop is run on the host with the
host build of the drive (``pil_record``) for the reference. Each side links its own C library
(newlib-nano on the target, glibc on the host); the two runs must agree bit for bit on every output
of every step, hence on every metric (docs/firmware.md, "Processor in the loop": why no bound is
needed).

Usage: ``python tools/pil_closed.py SCENARIO [--duration S] [--out DIR]``; exit 1 on any difference.
``DIR/pil.json`` holds both runs' metrics and their differences (what ``linsense simulate SCENARIO
--pil`` reports).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import pil  # noqa: E402

#: the C library of each side (pil.json's ``libm``: what ``linsense simulate --pil`` prints)
LIBM = "newlib on the target, glibc on the host"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--duration", type=float, default=None, help="s (default: the scenario's)")
    ap.add_argument("--out", type=Path, default=ROOT / "build" / "pil-closed")
    a = ap.parse_args(argv)

    import cffi
    from linsense._ctrl import ffi
    from pil_cgen import DriveWriter

    from linsense.sim.build import build
    from linsense.sim.core import BLOCKS, run_closed_loop
    from linsense.sim.simulation import finish_metrics, run_metrics

    out = a.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    spec = {"file": a.scenario} if a.duration is None else {"file": a.scenario,
                                                            "scenario": {"duration": a.duration}}
    sc = pil._scenario(spec)
    w = DriveWriter(ffi, "pil_closed")
    b = build(sc)
    cases = '\nstatic const pil_case pil_cases[] = {{"closed", &pil_closed_drive}};\n'
    (out / "pil_cases.h").write_text('#include <math.h>\n#include <stddef.h>\n#include "pil.h"\n'
                                     + w.drive(b.drive.state) + cases)
    elf = pil.build_replay(out, "m4f", "m4f", "-O2", ("-DPIL_REMOTE",))
    rffi = cffi.FFI()
    args = ("void *cfg, void *drive, void *cmds, int32_t n_cmds, int64_t n_steps, void *out, void *res, "
            "const char *in_path, const char *out_path")
    rffi.cdef(f"int pil_record({args}); int pil_remote({args}, const char *to_path, const char *from_path);")
    rlib = rffi.dlopen(str(pil.build_recorder(out)))

    def addr(p):
        return rffi.cast("void *", int(ffi.cast("uintptr_t", p)))

    def run(remote: bool):
        """One closed loop (the scenario's drive copied) through the package's loop, its time loop
        the host recorder's or the firmware's under QEMU: its RawRun and metrics."""
        drive = ffi.new("ls_drive *")
        ffi.memmove(drive, b.drive.state, ffi.sizeof("ls_drive"))
        tag = "pil" if remote else "host"
        paths = [str(out / f"closed.{tag}.in").encode(), str(out / f"closed.{tag}.steps").encode()]

        def runner(cfg, drv, cmds, n_cmds, n_steps, o, res):
            ptrs = [addr(p) for p in (cfg, drv, cmds)]
            if not remote:
                return rlib.pil_record(*ptrs, n_cmds, n_steps, addr(o), addr(res), *paths)
            q = subprocess.Popen(pil.qemu_cmd(elf), cwd=out, stdout=subprocess.DEVNULL)
            st = rlib.pil_remote(*ptrs, n_cmds, n_steps, addr(o), addr(res), *paths,
                                 str(out / "closed.in").encode(), str(out / "closed.m4f.out").encode())
            q.wait(timeout=60)
            return st

        runner.__name__ = f"the {tag} run"
        if remote:
            for f in ("closed.in", "closed.m4f.out"):
                (out / f).unlink(missing_ok=True)
                os.mkfifo(out / f)
        t0 = time.perf_counter()
        raw = run_closed_loop(b.cfg, drive, b.n_steps, b.commands, blocks=tuple(BLOCKS) if b.cfg.decimate > 1
                              else (), runner=runner)
        wall = time.perf_counter() - t0
        m = run_metrics(b, raw)
        finish_metrics(b, raw, m, b.cfg.decimate)
        return raw, m, wall

    host, m_host, _ = run(False)
    c0 = os.times()
    fw, m_fw, wall = run(True)
    c1 = os.times()
    cpu = c1.children_user - c0.children_user + c1.children_system - c0.children_system
    steps = fw.steps_done
    print(f"pil_closed: {sc.name}: {steps} steps ({steps / b.setup.f_pwm:.3g} s simulated) with the drive on "
          f"the Cortex-M4F under QEMU: {wall:.1f} s wall, QEMU {cpu:.1f} s CPU; libm: {LIBM}")
    same_steps = np.array_equal(pil.read_out(out / "closed.host.steps"),
                                pil.read_out(out / "closed.pil.steps"))
    diffs, mismatches = metric_differences(m_fw, m_host)
    print(f"pil_closed: every output of every step {'identical' if same_steps else 'NOT identical'} to the "
          f"host run's; metrics {'identical' if not (diffs or mismatches) else 'differing: ' + str(diffs)}"
          f"{' ' + str(mismatches) if mismatches else ''}; stable {m_fw.get('stable')} / "
          f"{m_host.get('stable')}, fault {m_fw.get('fault')!r} / {m_host.get('fault')!r}")
    ok = same_steps and not diffs and not mismatches
    # what `linsense simulate --pil` reads: the firmware's run, the host's, and how they differ
    record = {"scenario": sc.name, "steps": int(steps), "simulated_s": steps / b.setup.f_pwm,
              "wall_s": wall, "qemu_cpu_s": cpu, "libm": LIBM, "identical_steps": bool(same_steps),
              "metric_differences": diffs, "metric_mismatches": mismatches, "pass": ok,
              "metrics_pil": m_fw, "metrics_host": m_host}
    (out / "pil.json").write_text(json.dumps(record, indent=1, sort_keys=True, default=_plain) + "\n")
    if not ok:
        print("pil_closed: FAIL (the firmware must reproduce the host bit for bit)")
        return 1
    print("pil_closed: PASS")
    return 0


#: metrics of the run's timing, not of its outcome (not compared)
TIMING = ("wall_s", "realtime_factor")


def _same(a, b) -> bool:
    """Equal bit for bit: floats by their bits (NaN equals NaN), anything else by ``==``."""
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or np.float64(a).tobytes() == np.float64(b).tobytes()
    return type(a) is type(b) and a == b


def metric_differences(m_pil: dict, m_host: dict) -> tuple[dict, dict]:
    """How two runs' metrics differ, every key but :data:`TIMING`.

    Parameters
    ----------
    m_pil, m_host : dict
        The metrics of the firmware's run and of the host's.

    Returns
    -------
    diffs : dict
        Key -> |pil - host| of the numeric metrics (not bool) that differ (inf where one is NaN).
    mismatches : dict
        Key -> [pil, host] of every other metric that differs, or is present in one run only.
    """
    diffs, mismatches = {}, {}
    for k in sorted(set(m_pil) | set(m_host)):
        if k in TIMING:
            continue
        a, b = m_pil.get(k), m_host.get(k)
        if k in m_pil and k in m_host and _same(a, b):
            continue
        num = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (a, b))
        if num:
            d = abs(float(a) - float(b))
            diffs[k] = math.inf if math.isnan(d) else d
        else:
            mismatches[k] = [a, b]
    return diffs, mismatches


def _plain(v):
    """numpy scalars and arrays as JSON values."""
    return v.tolist() if hasattr(v, "tolist") else str(v)


if __name__ == "__main__":
    sys.exit(main())

"""Processor in the loop, closed: a scenario's plant on the host, its drive on a Cortex-M4F under
QEMU (docs/firmware.md, "Processor in the loop"); what ``linsense simulate SCENARIO --pil`` and
``make pil`` (through ``tools/pil_closed.py``) run.

:func:`closed_loop` cross-compiles the firmware's replay in its closed-loop build (csrc/pil/,
``-DPIL_REMOTE``: one event at a time) and the host recorder around the simulator's own time loop
(csrc/sim/), then runs :func:`~linsense.sim.core.run_closed_loop` twice with its ``runner`` given:
once exchanging one PWM period at a time through named pipes with the firmware under
``qemu-system-arm``, once on the host build of the drive for the reference. Each side links its own
C library (newlib on the target, glibc on the host): the two must agree bit for bit on every
output of every step, hence on every metric. :func:`closed_loop_to` writes its output set. It needs
what a wheel does not ship (the simulator's and the harness's C sources and build tools, the ARM
cross compiler, QEMU, a C compiler): a source tree of linsense, with ``make tools`` run once.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from linsense.errors import InputError
from linsense.io import quiet

#: the programs the closed loop needs, and the Debian packages that bring them (``make tools``)
TOOLS = {"arm-none-eabi-gcc": "gcc-arm-none-eabi libnewlib-arm-none-eabi",
         "qemu-system-arm": "qemu-system-arm", "cc": "gcc"}
#: the C library of each side (pil.json's ``libm``: what ``linsense simulate --pil`` prints)
LIBM = "newlib on the target, glibc on the host"
#: metrics of the run's timing, not of its outcome (not compared)
TIMING = ("wall_s", "realtime_factor")
#: the source tree's harness the loop builds with: the cross builds and the drive's C initializer
_HARNESS = ("tools/pil.py", "tools/pil_cgen.py", "csrc/pil", "csrc/sim")


def source_tree() -> Path | None:
    """The source tree linsense runs from (an editable install), if it holds the PIL harness.

    Returns
    -------
    Path or None
        The repository's root, or None for an installed wheel.
    """
    root = Path(__file__).resolve().parents[3]
    return root if all((root / p).exists() for p in _HARNESS) else None


def _ready() -> Path:
    """The source tree, once the programs the loop needs are found."""
    root = source_tree()
    if root is None:
        raise InputError("--pil", "", "needs a source tree of linsense (csrc/pil, csrc/sim, tools/pil.py; "
                         "an installed wheel has none): clone it, then make pil")
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if missing:
        pkgs = " ".join(TOOLS[t] for t in missing)
        raise InputError("--pil", "", f"needs {', '.join(missing)} (Debian: apt-get install {pkgs}; "
                         "make tools installs them as root)")
    return root


@contextmanager
def _harness(root: Path) -> Iterator[tuple]:
    """The source tree's ``tools/pil.py`` and ``pil_cgen.DriveWriter``, with tools/ importable while
    the loop runs (the harness imports its neighbours as it builds)."""
    import importlib.util

    tools, saved = str(root / "tools"), list(sys.path)
    sys.path.insert(0, tools)
    try:
        spec = importlib.util.spec_from_file_location("linsense_pil_harness", root / "tools" / "pil.py")
        pil = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(pil)
        from pil_cgen import DriveWriter

        yield pil, DriveWriter
    finally:
        sys.path[:] = saved


@dataclass
class _Loop:
    """The builds of one closed loop: the scenario built, the harness, the firmware's ELF and the
    host recorder."""

    b: object
    out: Path
    pil: object
    elf: Path
    rlib: object
    rffi: object = field(repr=False, default=None)


def _build(b, out: Path, pil, drive_writer) -> _Loop:
    """Write the drive's C initializer, cross-compile the firmware's closed-loop replay and build the
    host recorder."""
    import cffi

    from linsense.ctrl import ffi

    w = drive_writer(ffi, "pil_closed")
    cases = '\nstatic const pil_case pil_cases[] = {{"closed", &pil_closed_drive}};\n'
    (out / "pil_cases.h").write_text('#include <math.h>\n#include <stddef.h>\n#include "pil.h"\n'
                                     + w.drive(b.drive.state) + cases)
    elf = pil.build_replay(out, "m4f", "m4f", "-O2", ("-DPIL_REMOTE",))
    rffi = cffi.FFI()
    args = ("void *cfg, void *drive, void *cmds, int32_t n_cmds, int64_t n_steps, void *out, void *res, "
            "const char *in_path, const char *out_path")
    rffi.cdef(f"int pil_record({args}); int pil_remote({args}, const char *to_path, const char *from_path);")
    return _Loop(b, out, pil, elf, rffi.dlopen(str(pil.build_recorder(out))), rffi)


def _runner(lp: _Loop, remote: bool) -> Callable:
    """``run_closed_loop``'s time loop: the host recorder's, or the firmware's under QEMU."""
    from linsense.ctrl import ffi

    out, rffi, rlib = lp.out, lp.rffi, lp.rlib
    tag = "pil" if remote else "host"
    paths = [str(out / f"closed.{tag}.in").encode(), str(out / f"closed.{tag}.steps").encode()]

    def addr(p):
        return rffi.cast("void *", int(ffi.cast("uintptr_t", p)))

    def runner(cfg, drv, cmds, n_cmds, n_steps, o, res):
        ptrs = [addr(p) for p in (cfg, drv, cmds)]
        if not remote:
            return rlib.pil_record(*ptrs, n_cmds, n_steps, addr(o), addr(res), *paths)
        with open(out / "closed.qemu.err", "wb") as err:  # (its words said after the run)
            q = subprocess.Popen(lp.pil.qemu_cmd(lp.elf), cwd=out, stdout=subprocess.DEVNULL, stderr=err)
            st = rlib.pil_remote(*ptrs, n_cmds, n_steps, addr(o), addr(res), *paths,
                                 str(out / "closed.in").encode(), str(out / "closed.m4f.out").encode())
            q.wait(timeout=60)
        return st

    runner.__name__ = f"the {tag} run"
    if remote:
        for f in ("closed.in", "closed.m4f.out"):
            (out / f).unlink(missing_ok=True)
            os.mkfifo(out / f)
    return runner


def _run(lp: _Loop, remote: bool) -> tuple:
    """One closed loop (the scenario's drive copied) through the package's loop, its time loop the
    host recorder's or the firmware's under QEMU: its RawRun, metrics and wall time."""
    from linsense.ctrl import ffi
    from linsense.sim.core import BLOCKS, run_closed_loop
    from linsense.sim.simulation import finish_metrics, run_metrics

    b = lp.b
    drive = ffi.new("ls_drive *")
    ffi.memmove(drive, b.drive.state, ffi.sizeof("ls_drive"))
    runner = _runner(lp, remote)
    t0 = time.perf_counter()
    raw = run_closed_loop(b.cfg, drive, b.n_steps, b.commands, blocks=tuple(BLOCKS) if b.cfg.decimate > 1
                          else (), runner=runner)
    wall = time.perf_counter() - t0
    m = run_metrics(b, raw)
    finish_metrics(b, raw, m, b.cfg.decimate)
    return raw, m, wall


def run_pil(scenario: str | Path, out: str | Path, *, duration: float | None = None,
            say: Callable[[str], object] = quiet) -> dict:
    """The closed loop with the drive on the Cortex-M4F under QEMU and on the host; ``out/pil.json``.

    Parameters
    ----------
    scenario : str or Path
        The scenario file.
    out : str or Path
        Folder for the builds, the pipes and ``pil.json``.
    duration : float or None, optional
        Simulated time in s (default: the scenario's).
    say : callable, optional
        Called with each line of the report (the runs and the verdict, ``PASS`` or ``FAIL``).

    Returns
    -------
    dict
        ``pil.json`` (:func:`closed_loop`).
    """
    from linsense.sim.build import build

    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    with _harness(_ready()) as (pil, drive_writer):
        spec = {"file": scenario}
        if duration is not None:
            spec["scenario"] = {"duration": duration}
        sc = pil._scenario(spec)
        b = build(sc)
        lp = _build(b, out, pil, drive_writer)
        _, m_host, _ = _run(lp, False)
        c0 = os.times()
        fw, m_fw, wall = _run(lp, True)
        c1 = os.times()
        same_steps = np.array_equal(pil.read_out(out / "closed.host.steps"),
                                    pil.read_out(out / "closed.pil.steps"))
    cpu = c1.children_user - c0.children_user + c1.children_system - c0.children_system
    for line in (out / "closed.qemu.err").read_text(encoding="utf-8", errors="replace").splitlines():
        say(line)  # (the firmware's semihosted words)
    steps = fw.steps_done
    say(f"pil_closed: {sc.name}: {steps} steps ({steps / b.setup.f_pwm:.3g} s simulated) with the drive on "
        f"the Cortex-M4F under QEMU: {wall:.1f} s wall, QEMU {cpu:.1f} s CPU; libm: {LIBM}")
    diffs, mismatches = metric_differences(m_fw, m_host)
    say(f"pil_closed: every output of every step {'identical' if same_steps else 'NOT identical'} to the "
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
    say("pil_closed: PASS" if ok else "pil_closed: FAIL (the firmware must reproduce the host bit for bit)")
    return json.loads((out / "pil.json").read_text(encoding="utf-8"))


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
    _ready()
    (Path(out) / "pil.json").unlink(missing_ok=True)  # (a folder used before: never an earlier run's record)
    try:
        return run_pil(scenario, out, duration=duration)
    except (OSError, subprocess.SubprocessError) as exc:  # (a build or QEMU failing)
        raise InputError(str(scenario), "", f"the closed loop with the firmware under QEMU did not run: "
                         f"{exc}") from None


@dataclass
class PilOutput:
    """What :func:`closed_loop_to` ran and wrote.

    Parameters
    ----------
    metrics : dict
        ``metrics.json``: the firmware's run (without the timing).
    timing : dict
        ``timing.json``: its timing and QEMU's CPU time (``qemu_cpu_s``).
    record : dict
        ``pil.json``: :func:`closed_loop`'s record without the timing, the host run's metrics
        without theirs.
    files : list of Path
        The files written.
    """

    metrics: dict
    timing: dict
    record: dict
    files: list[Path] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """The firmware's run stable and identical to the host build's."""
        return bool(self.metrics["stable"]) and bool(self.record["pass"])


def closed_loop_to(out: str | Path, scenario: str | Path, *, duration: float | None = None) -> PilOutput:
    """Run :func:`closed_loop` in a temporary folder and write its output set (what ``linsense
    simulate SCENARIO --pil`` writes).

    Parameters
    ----------
    out : str or Path
        The folder: missing, empty or an earlier output of linsense; ``metrics.json`` (the
        firmware's run), ``timing.json`` and ``pil.json`` (both runs and how they differ).
    scenario : str or Path
        The scenario file.
    duration : float or None, optional
        Simulated time in s (default: the scenario's).

    Returns
    -------
    PilOutput
        The metrics, timing, record and files written.

    Raises
    ------
    linsense.errors.InputError
        As :func:`closed_loop`.
    """
    import tempfile

    from linsense.io import output_set, split_timing
    from linsense.sim.to_folder import write_metrics

    with tempfile.TemporaryDirectory(prefix="linsense-pil-") as tmp:
        rec = closed_loop(scenario, tmp, duration=duration)
    metrics, timing = split_timing(rec.pop("metrics_pil"))
    host, _ = split_timing(rec.pop("metrics_host"))
    rec.pop("wall_s")  # (the run's wall time is timing.json's wall_s)
    timing["qemu_cpu_s"] = rec.pop("qemu_cpu_s")
    rec["metrics_host"] = host
    with output_set(out, "simulate") as s:
        write_metrics(s, metrics, timing)
        s.write("pil.json", json.dumps(rec, indent=1, sort_keys=True) + "\n")
    return PilOutput(metrics, timing, rec, list(s.files))


__all__ = ["LIBM", "TIMING", "TOOLS", "PilOutput", "closed_loop", "closed_loop_to", "metric_differences",
           "run_pil", "source_tree"]

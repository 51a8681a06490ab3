"""Benchmark of the C simulator (``csrc/sim/``): realtime factor of a closed-loop run.

Run by ``make bench`` (never by the tests). One core, the ecce2010 preset, the firmware drive in
sensorless mode with the resistance-aware LUT, a 2 s trajectory scenario (minimum-time moves
0 -> 20 mm -> 0 at v_max 0.2 m/s, a_max 1 m/s^2), every period recorded, built with
``linsense.sim.core`` directly (independent of the scenario layer). Each fidelity is repeated
and the best and median realtime factor (simulated seconds / wall seconds of the C call alone)
are reported with the time per PWM period. Each target line says PASS or FAIL; the exit status is
1 when any says FAIL, so that ``make bench`` names this benchmark among its misses.

Then the memory of a long run: a 600 s hold (ecce2010, sensorless with the LUT, average
inverter) in metrics-only mode (``simulate(..., record="metrics")``) in a subprocess, its peak RSS
against 150 MB, and ``linsense simulate`` of the same scenario with the default outputs
(metrics.json, timing.json, trace.parquet written chunk by chunk, no plot) against 400 MB
(``--rss-seconds 0`` skips both; the CLI run gets ``--cli-timeout`` s).

And the cost of a short single run: ``linsense simulate`` of a 2 s scenario
(the example step3_lut.toml) with its default outputs, the whole process's CPU time (user +
sys of the child, imports included) against 0.6 s: the best and the median of ``--cli-repeat``
runs after one warm-up run (which lets Python cache the bytecode, as an installed package has it:
the child runs without PYTHONDONTWRITEBYTECODE).

Usage: ``python tools/bench_sim.py [--repeat N] [--seconds S] [--rss-seconds S] [--cli-timeout S]
[--cli-repeat N]``
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from linsense import ctrl
from linsense.compensation.lut import build_lut
from linsense.model.motor import load_motor
from linsense.sim import core

TARGETS = {"average": 500.0, "switching": 100.0}  # realtime factor, the targets
RSS_TARGETS = {"metrics": 150.0, "cli": 400.0}  # MB, peak RSS of a 600 s run
CPU_TARGET = 0.6  # s, CPU (user + sys) of linsense simulate of a 2 s scenario, default outputs
CPU_SCENARIO = Path(__file__).resolve().parent.parent / "src/linsense/examples/scenarios/step3_lut.toml"

#: runs argv[1:] and prints the peak RSS (kB on Linux) of that child alone, then its exit code
_RSS_WRAPPER = ("import resource, subprocess, sys\n"
                "rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode\n"
                "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, rc)\n")

#: runs argv[1:] and prints the CPU time (user + sys, s) of that child alone, then its exit code
_CPU_WRAPPER = ("import resource, subprocess, sys\n"
                "rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode\n"
                "r = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
                "print(r.ru_utime + r.ru_stime, rc)\n")

#: the long run: a hold, so that the run is stable whatever its duration
LONG_SCENARIO = """motor = "ecce2010"
[scenario]
name = "hold_long"
duration = {seconds}
seed = 1
[control]
mode = "sensorless_lut"
[reference]
type = "hold"
"""



def _default_quad() -> float:
    """The firmware's default elliptical share (the configuration kept alive while its nested
    struct is read: a field of ``cfg.inject`` does not own ``cfg``)."""
    cfg = ctrl.drive_default_cfg()
    return float(cfg.inject.quad)

def peak_rss(argv: list[str], timeout: float) -> tuple[float | None, float, str]:
    """Peak RSS (MB) of the process ``argv`` (measured by a wrapper process of its own, so that no
    earlier child counts), its wall time (s) and a note (exit status, timeout)."""
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, "-c", _RSS_WRAPPER, *argv], capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, time.perf_counter() - t0, f"did not finish within {timeout:g} s"
    wall = time.perf_counter() - t0
    try:
        kb, rc = p.stdout.split()
    except ValueError:
        return None, wall, f"wrapper failed: {p.stderr.strip()[-200:]}"
    return int(kb) / 1024.0, wall, "" if rc == "0" else f"exit status {rc}"


def child_cpu(argv: list[str], env: dict) -> tuple[float | None, str]:
    """CPU time (user + sys, s) of the process ``argv`` (measured by a wrapper of its own) and a note."""
    p = subprocess.run([sys.executable, "-c", _CPU_WRAPPER, *argv], capture_output=True, text=True, env=env,
                       timeout=300)
    try:
        cpu, rc = p.stdout.split()
    except ValueError:
        return None, f"wrapper failed: {p.stderr.strip()[-200:]}"
    return float(cpu), "" if rc == "0" else f"exit status {rc}"


def cpu_bench(repeat: int) -> None:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    exe = Path(sys.executable).with_name("linsense")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "linsense"]
    with tempfile.TemporaryDirectory() as tmp:
        argv = [*cmd, "simulate", str(CPU_SCENARIO), "--out", str(Path(tmp) / "out")]
        child_cpu(argv, env)  # warm-up: bytecode caches
        runs, notes = [], set()
        for _ in range(repeat):
            cpu, note = child_cpu(argv, env)
            if note:
                notes.add(note)
            if cpu is not None:
                runs.append(cpu)
        files = sorted(p.name for p in (Path(tmp) / "out").iterdir() if not p.name.startswith("."))
    if not runs:
        print(f"CPU of linsense simulate, 2 s scenario: n/a (target <= {CPU_TARGET:g} s) FAIL "
              f"({'; '.join(sorted(notes))})")
        return
    med = statistics.median(runs)
    verdict = "PASS" if med <= CPU_TARGET and not notes else "FAIL"
    print(f"CPU of linsense simulate {CPU_SCENARIO.name} (2 s, default outputs: {', '.join(files)}): "
          f"{min(runs):.2f} s best, {med:.2f} s median of {len(runs)} (user + sys, whole process; target <= "
          f"{CPU_TARGET:g} s) {verdict} (median)" + (f" ({'; '.join(sorted(notes))})" if notes else ""))


def memory_bench(seconds: float, cli_timeout: float) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hold_long.toml"
        path.write_text(LONG_SCENARIO.format(seconds=seconds), encoding="utf-8")
        code = ("import sys; from linsense.sim.simulation import simulate; "
                "r = simulate(sys.argv[1], record='metrics'); "
                "assert r.metrics['stable'], r.metrics['unstable_reason']")
        runs = {
            "metrics": (f"{seconds:g} s run, metrics-only (simulate(record='metrics'))",
                        [sys.executable, "-c", code, str(path)], 3600.0),
            "cli": (f"{seconds:g} s run, linsense simulate with the default outputs (trace.parquet)",
                    [sys.executable, "-m", "linsense", "simulate", str(path), "--out",
                     str(Path(tmp) / "out")], cli_timeout),
        }
        for key, (label, argv, timeout) in runs.items():
            mb, wall, note = peak_rss(argv, timeout)
            target = RSS_TARGETS[key]
            verdict = "FAIL" if mb is None or mb > target else "PASS"
            shown = "n/a" if mb is None else f"{mb:.0f} MB"
            print(f"peak RSS, {label}: {shown} (target <= {target:.0f} MB) {verdict}; {wall:.1f} s wall"
                  + (f" ({note})" if note else ""))


def one_run(motor, lut, fidelity: str, seconds: float) -> tuple[float, int, int, dict]:
    """Wall time (s) of the C call, steps done, fault bits, recorded arrays."""
    drive = ctrl.Drive(comp=lut.values)
    drive.set_position(0.0)
    drive.set_mode("sensorless_lut")
    cfg = core.sim_cfg(motor, core.PlantSetup(fidelity=fidelity, x0=0.0))
    n_steps = int(round(seconds * cfg.f_pwm))
    cmds = [(0.1, 0.020, True), (1.0, 0.0, True)]
    c_cmds = ctrl.ffi.new("ls_sim_cmd[]", len(cmds))
    for j, (t, x, move) in enumerate(cmds):
        c_cmds[j].t, c_cmds[j].x, c_cmds[j].move = t, x, int(move)
    arrays, out = core._outputs(n_steps + 2)
    res = ctrl.ffi.new("ls_sim_result *")
    t0 = time.perf_counter()
    st = ctrl.lib.ls_sim_run(cfg, drive.state, c_cmds, len(cmds), n_steps, out, res)
    wall = time.perf_counter() - t0
    if st != ctrl.lib.LS_OK:
        raise SystemExit(f"ls_sim_run refused its inputs (status {st})")
    n = int(res.n_rec)
    return wall, int(res.steps_done), int(res.fault), {k: a[:n] for k, a in arrays.items()}


class _Verdicts:
    """Standard output that remembers whether a line said FAIL."""

    def __init__(self, out):
        self.out, self.failed = out, False

    def write(self, text: str) -> int:
        self.failed = self.failed or " FAIL" in text
        return self.out.write(text)

    def flush(self) -> None:
        self.out.flush()


def main() -> int:
    verdicts = _Verdicts(sys.stdout)
    sys.stdout = verdicts
    try:
        _main()
    finally:
        sys.stdout = verdicts.out
    return 1 if verdicts.failed else 0


def _main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--rss-seconds", type=float, default=600.0,
                    help="simulated duration of the memory benchmark (0: skip it)")
    ap.add_argument("--cli-timeout", type=float, default=900.0,
                    help="wall-time limit (s) of the CLI run of the memory benchmark")
    ap.add_argument("--cli-repeat", type=int, default=5,
                    help="runs of the CPU benchmark of a 2 s linsense simulate (0: skip it)")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        try:
            os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        except OSError:
            pass
    motor = load_motor("ecce2010")
    # the table of the firmware's default injection (kappa from ls_drive_default_cfg)
    lut = build_lut(motor, 360, f_inj=1000.0, quad=_default_quad())
    print(f"simulator benchmark: ecce2010, sensorless with LUT, {args.seconds:g} s moves 0 -> 20 mm -> 0 "
          f"(0.2 m/s, 1 m/s^2), 16 kHz, every period recorded, best/median of {args.repeat}, one core")
    for fidelity in ("average", "switching"):
        one_run(motor, lut, fidelity, 0.05)  # warm-up
        walls, steps, fault = [], 0, 0
        for _ in range(args.repeat):
            w, steps, fault, rec = one_run(motor, lut, fidelity, args.seconds)
            walls.append(w)
        sim_s = steps / 16000.0
        best, med = sim_s / min(walls), sim_s / statistics.median(walls)
        ns = min(walls) / max(steps, 1) * 1e9
        target = TARGETS[fidelity]
        note = "" if fault == 0 and steps == int(round(args.seconds * 16000)) else \
            f" (run stopped early: {steps} steps, fault 0x{fault:x})"
        print(f"realtime factor {fidelity}: {best:.0f}x best, {med:.0f}x median (target >= {target:.0f}x) "
              f"{'PASS' if med >= target else 'FAIL'} (median); {ns:.0f} ns per step{note}")
        e_max = math.degrees(abs(rec["theta_err"]).max())
        print(f"  scenario check: peak |x| {1e3 * abs(rec['x']).max():.2f} mm, "
              f"final x {1e3 * rec['x'][-1]:+.3f} mm, max |theta_err| {e_max:.2f} deg")
    if args.cli_repeat > 0:
        cpu_bench(args.cli_repeat)
    if args.rss_seconds > 0:
        memory_bench(args.rss_seconds, args.cli_timeout)


if __name__ == "__main__":
    raise SystemExit(main())

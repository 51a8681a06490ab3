"""Benchmark of the C simulator (``csrc/sim/ls_sim.c``): realtime factor of a closed-loop run.

Run by ``make bench`` (never by the tests). One core, the ecce2010 preset, the firmware drive in
sensorless mode with the resistance-aware LUT, a 2 s trajectory scenario (minimum-time moves
0 -> 20 mm -> 0 at v_max 0.2 m/s, a_max 1 m/s^2), every period recorded, built with
``linsense.sim.core`` directly (independent of the scenario layer). Each fidelity is repeated
and the best and median realtime factor (simulated seconds / wall seconds of the C call alone)
are reported with the time per PWM period. It is a report: the exit status is 0 whatever the
result, and each target line says PASS or FAIL.

Usage: ``python tools/bench_sim.py [--repeat N] [--seconds S]``
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

from linsense import ctrl
from linsense.compensation.lut import build_lut
from linsense.model.motor import load_motor
from linsense.sim import core

TARGETS = {"average": 500.0, "switching": 100.0}  # realtime factor, the targets


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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=2.0)
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        try:
            os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        except OSError:
            pass
    motor = load_motor("ecce2010")
    # the table of the firmware's default injection (kappa from ls_drive_default_cfg)
    lut = build_lut(motor, 360, f_inj=1000.0, quad=float(ctrl.drive_default_cfg().inject.quad))
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

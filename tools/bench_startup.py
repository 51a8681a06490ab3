#!/usr/bin/env python3
"""Start-up from an unknown position with the magnet polarity (make bench).

200 random start positions over two electrical periods, the drive's estimate at 0, ecce2010 with
the saturated plant (polarity 1.31 %/A, the FEA's thin-back-iron figure), the switching inverter
with 0.8 us dead time, 10 mA rms current noise and a 12-bit ADC; without load (free, frictionless
mover) and with a 20 N load held by 30 N of Coulomb friction (a guide or brake: no drive can hold
a load before it knows the sign of its force). Prints per load: right / total, the worst motion
while detecting (bar: 0.1 mm), the detection time and the smallest pulse-current difference.

  PYTHONPATH=src python tools/bench_startup.py [N] [--fidelity average|switching]
"""

from __future__ import annotations

import argparse
import time

from linsense.studies.startup_runs import base_scenario, startup_runs, summary


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("n", nargs="?", type=int, default=200)
    ap.add_argument("--fidelity", default="switching", choices=["average", "switching"])
    ap.add_argument("--polarity", type=float, default=0.0131, help="1/A, (L_d(-I) - L_d(+I)) / L_d per A")
    a = ap.parse_args()
    t0 = time.perf_counter()
    runs = startup_runs(base_scenario(fidelity=a.fidelity, polarity=a.polarity), n=a.n)
    wall = time.perf_counter() - t0
    for load, s in summary(runs).items():
        print(f"start-up, {a.fidelity}, load {load:g} N: polarity right {s['right']}/{s['n']}, worst motion "
              f"while detecting {s['motion_mm']:.4f} mm (at {s['worst_x0_mm']:.2f} mm), detection "
              f"{s['detect_s'] * 1e3:.1f} ms, smallest |i_diff| {s['i_diff_min_a'] * 1e3:.1f} mA, "
              f"worst motion in the first 100 ms of position control {s['motion_after_mm']:.3f} mm")
    wrong = [r for r in runs if not r.right]
    for r in wrong:
        print(f"  wrong: x0 {r.x0_mm:.2f} mm, load {r.load_n:g} N, fault {r.fault:#x}, "
              f"i_diff {r.i_diff_a * 1e3:.1f} mA")
    print(f"start-up benchmark: {len(runs)} runs in {wall:.1f} s")


if __name__ == "__main__":
    main()

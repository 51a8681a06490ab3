"""Benchmark of the saturated plant: the calibrated LUT against load versus the FEA, and
the cost of the saturated plant.

Run by ``make bench`` (never by the tests). The motor is src/linsense/examples/motors/tubular56_thin_sat (the
tubular motor with a 1 mm back iron; FEA tables at i_q = 0, 0.5, 1, 1.5, 2 A and its polarity
signal). The firmware's calibration mode runs on its saturated plant at 0, 20 and 40 N (i_q = F /
27.3 N/A = 0, 0.73, 1.47 A, inside the FEA's 0..2 A) on the switching inverter with 0.8 us dead
time, at ``--positions`` (56) points; for each load the change of the calibrated table from 0 N is
printed next to the FEA's LUT change at the same q current (lut_<I>A.csv, interpolated in the
current), with their difference (target: within 0.3 electrical deg). Then the realtime factor of a
closed-loop hold on the saturated plant against the linear one. A report: exit status 0 whatever
the result; the target line says PASS or FAIL.

Usage: ``python tools/bench_saturation.py [--positions N]``
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from linsense.scenario.load import scenario_from_dict
from linsense.sim.simulation import simulate
from linsense.studies.lut_load import lut_vs_load

MOTOR = (Path(__file__).resolve().parent.parent / "src/linsense/examples" / "motors" / "tubular56_thin_sat"
         / "motor.toml")
TARGET_DEG = 0.3


def lut_bench(positions: int) -> None:
    t0 = time.perf_counter()
    r = lut_vs_load(MOTOR, loads=(0.0, 20.0, 40.0), positions=positions, fidelity="switching")
    wall = time.perf_counter() - t0
    print(f"calibrated LUT against load on the saturated plant ({MOTOR.parent.name}, {positions} "
          f"positions, switching inverter, 0.8 us dead time; {wall:.1f} s):")
    print("  load    i_q     cal. change (deg)       FEA change (deg)        |cal - FEA| (deg)")
    for f, iq, c, e in zip(r.loads, r.i_q, r.cal_change, r.fea_change, strict=True):
        cd, ed = np.degrees(c), np.degrees(e)
        print(f"  {f:4.0f} N {iq:5.2f} A  mean {cd.mean():+.3f} max {np.abs(cd).max():.3f}   "
              f"mean {ed.mean():+.3f} max {np.abs(ed).max():.3f}   max {np.abs(cd - ed).max():.3f} "
              f"mean {np.abs(cd - ed).mean():.3f}")
    for run in r.metrics["runs"]:
        print(f"  {run['load_n']:4.0f} N: table vs the model LUT (0 A, with R_s) max "
              f"{run['max_diff_deg']:.3f} deg, {run['sim_s']:.1f} s simulated in {run['wall_s']:.2f} s")
    verdict = "PASS" if r.max_diff_deg <= TARGET_DEG else "FAIL"
    print(f"LUT change with load, calibrated vs FEA: max {r.max_diff_deg:.3f} deg "
          f"(target <= {TARGET_DEG:g} deg) {verdict}")


def cost_bench() -> None:
    base = {"motor": str(MOTOR), "scenario": {"name": "hold", "duration": 2.0},
            "control": {"mode": "sensorless_lut"}, "reference": {"type": "hold"},
            "inverter": {"fidelity": "switching"}, "load": {"force": 20.0},
            "initial": {"load_balanced": True}}
    for sat in (False, True):
        data = dict(base, saturation={"enabled": sat})
        sc = scenario_from_dict(data, "<bench>")
        simulate(sc, record="metrics")  # warm-up (caches)
        walls = []
        for _ in range(3):
            t0 = time.perf_counter()
            res = simulate(sc, record="metrics")
            walls.append(time.perf_counter() - t0)
        w = min(walls)
        m = res.metrics
        print(f"  {'saturated' if sat else 'linear   '} plant, 2 s sensorless hold at 20 N, switching: "
              f"{2.0 / w:.0f}x realtime (best of 3, build included); stable {m['stable']}, "
              f"bias {m.get('bias_deg')} deg")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--positions", type=int, default=56)
    args = ap.parse_args()
    lut_bench(args.positions)
    print("cost of the saturated plant:")
    cost_bench()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

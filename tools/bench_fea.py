"""Benchmark of the axisymmetric FEA (make bench): 56 positions x 3 excitations (+ the magnets' solve)
with linear iron at the default mesh of the tubular56 preset, target <= 30 s on 2 cores; then the
same with the default B-H curve and 1 A of q-current (src/linsense/examples/fea/tubular56_bh.toml), target
3 min;
then the load sweep 0, 1, 2 A of q-current in one run (one linear pass for theta's origin, each load
started from the previous one's states) and the largest difference of the LUT against 0 A.
A report: the exit status is 0 whatever the result."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from linsense.fea.geometry import load_geometry
from linsense.fea.solver import run, run_loads


def main() -> None:
    g = load_geometry("tubular56")
    t0 = time.perf_counter()
    res = run(g, 56, "default")
    wall = time.perf_counter() - t0
    m = res.mesh
    s = res.keep["solver"]
    print(f"bench_fea: tubular56, default mesh {m.mesh.t.shape[1]:,} P2 triangles, {s.ndofs:,} dofs "
          f"(z step {m.size * 1e3:.2f} mm); 56 positions x 3 excitations + magnets, linear iron: "
          f"{wall:.1f} s ({res.times['per_position_s'] * 1e3:.0f} ms per position) "
          f"{'PASS' if wall <= 30 else 'FAIL'} (target <= 30 s)", flush=True)
    g = load_geometry(str(Path(__file__).resolve().parents[1] / "src/linsense/examples/fea"
                          / "tubular56_bh.toml"))
    t0 = time.perf_counter()
    res = run(g, 56, "default", load_current=1.0, workers=2)
    wall = time.perf_counter() - t0
    print(f"bench_fea: tubular56_bh (default B-H curve), default mesh {res.keep['solver'].ndofs:,} dofs; "
          f"56 positions, Newton at 1 A of i_q (iterations max {res.newton['max']}, mean "
          f"{res.newton['mean']:.1f}) + incremental inductances, 2 worker processes: {wall:.1f} s "
          f"{'PASS' if wall <= 180 else 'FAIL'} (target <= 180 s)", flush=True)
    t0 = time.perf_counter()
    loads = run_loads(g, [0.0, 1.0, 2.0], 56, "default", workers=2)
    wall = time.perf_counter() - t0
    diffs = [_lut_diff_deg(loads[0], r) for r in loads]
    print(f"bench_fea: tubular56_bh load sweep 0, 1, 2 A of i_q (Newton iterations mean "
          f"{', '.join(format(r.newton['mean'], '.1f') for r in loads)}), 2 worker processes: {wall:.1f} s; "
          f"LUT against 0 A: max difference {', '.join(f'{d:.2g}' for d in diffs)} deg", flush=True)


def _lut_diff_deg(a, b, points: int = 360) -> float:
    """Largest |Psi_LUT_b - Psi_LUT_a| (electrical deg) of the tables' motor models."""
    from linsense.fea.per_load import lut_of

    return float(np.degrees(np.abs(lut_of(b, points) - lut_of(a, points)).max()))


if __name__ == "__main__":
    main()

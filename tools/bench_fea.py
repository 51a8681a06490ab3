"""Benchmark of the axisymmetric FEA (make bench): 56 positions x 3 excitations (+ the magnets' solve)
with linear iron at the default mesh of the tubular56 preset; target <= 30 s on 2 cores.
A report: the exit status is 0 whatever the result."""

from __future__ import annotations

import time

from linsense.fea.geometry import load_geometry
from linsense.fea.solver import run


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
          f"{'PASS' if wall <= 30 else 'FAIL'} (target <= 30 s)")


if __name__ == "__main__":
    main()

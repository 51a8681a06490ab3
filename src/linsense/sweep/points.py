"""The points of a sweep: grid, random or Latin-hypercube samples of its axes (docs/sweeps.md).

Every sampling is deterministic for a given file and seed, so a resumed sweep asks for the same
runs in the same order.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.stats import qmc

from linsense.errors import InputError
from linsense.sweep.spec import MAX_RUNS, Axis, SweepSpec


def grid_values(axis: Axis) -> list:
    """The values of one grid axis: its ``values``, or ``n`` points from ``min`` to ``max``."""
    if axis.values is not None:
        return list(axis.values)
    if axis.log:
        return [float(v) for v in np.geomspace(axis.min, axis.max, axis.n)]
    return [float(v) for v in np.linspace(axis.min, axis.max, axis.n)]


def _from_unit(axis: Axis, u: np.ndarray) -> list:
    """Map samples ``u`` in [0, 1) to the axis: an index into ``values`` or a point in [min, max]."""
    if axis.values is not None:
        idx = np.minimum((u * len(axis.values)).astype(int), len(axis.values) - 1)
        return [axis.values[i] for i in idx]
    if axis.log:
        lo, hi = np.log(axis.min), np.log(axis.max)
        return [float(v) for v in np.exp(lo + u * (hi - lo))]
    return [float(v) for v in axis.min + u * (axis.max - axis.min)]


def points(sweep: SweepSpec) -> list[dict]:
    """The runs of ``sweep`` in order, each ``{axis key: value}`` (a factor for relative axes)."""
    s = sweep.spec.sweep
    axes = sweep.spec.axis
    if s.sampling == "grid":
        n = int(np.prod([len(grid_values(a)) for a in axes], dtype=float))
        if n > MAX_RUNS:
            raise InputError(sweep.source, "axis", f"the grid has {n:,} runs, beyond the limit of "
                             f"{MAX_RUNS:,} (docs/limits.md)")
        combos = itertools.product(*(grid_values(a) for a in axes))
        return [dict(zip([a.key for a in axes], c, strict=True)) for c in combos]
    n = s.samples
    if s.sampling == "random":
        u = np.random.default_rng(s.seed).random((n, len(axes)))
    else:
        u = qmc.LatinHypercube(d=len(axes), seed=np.random.default_rng(s.seed)).random(n)
    cols = [_from_unit(a, u[:, j]) for j, a in enumerate(axes)]
    return [{a.key: cols[j][i] for j, a in enumerate(axes)} for i in range(n)]

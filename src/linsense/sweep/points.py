"""The points of a sweep: grid, random or Latin-hypercube samples of its axes (docs/sweeps.md).

Every sampling is deterministic for a given file and seed, so a resumed sweep asks for the same
runs in the same order.
"""

from __future__ import annotations

import itertools

import numpy as np

from linsense.errors import InputError
from linsense.sweep.spec import MAX_RUNS, Axis, SweepSpec


def _checked(axis: Axis, v: np.ndarray, source: str) -> list[float]:
    """The points ``v`` of an axis from ``min`` to ``max``, each kept within ``[min, max]`` (against
    rounding) and finite.

    Raises
    ------
    InputError
        Naming the axis and its ends, if a point is not a finite number (never passed on as a run).
    """
    lo, hi = float(axis.min), float(axis.max)
    v = np.clip(np.asarray(v, dtype=float), lo, hi)
    if not np.all(np.isfinite(v)):
        raise InputError(source, f"axis {axis.key}",
                         f"min = {lo!r}, max = {hi!r} give points that are not finite numbers")
    return [float(x) for x in v]


def _convex(lo: float, hi: float, t: np.ndarray) -> np.ndarray:
    """``lo (1 - t) + hi t``: the points ``t`` in [0, 1] of the way from ``lo`` to ``hi`` for any
    finite ends. ``lo + (hi - lo) t`` overflows when ``hi - lo`` does (``min = -1.7e308, max =
    1.7e308``: the grid and the samples held inf and nan); it is kept where it does not,
    so that the points of every sweep that ran before stay the same to the last bit (a resumed
    sweep asks for the same runs)."""
    return lo * (1.0 - t) + hi * t


def grid_values(axis: Axis, source: str = "sweep") -> list:
    """The values of one grid axis.

    Its ``values``, or ``n`` points from ``min`` to ``max`` (both included; equally spaced, or in
    log with ``log``), each finite and within ``[min, max]``.

    Parameters
    ----------
    axis : Axis
        The axis.
    source : str, optional
        Named in messages.

    Returns
    -------
    list
        The values.

    Raises
    ------
    linsense.errors.InputError
        A value that is not finite or out of ``[min, max]``.
    """
    if axis.values is not None:
        return list(axis.values)
    lo, hi = float(axis.min), float(axis.max)
    if axis.log:
        with np.errstate(over="ignore"):  # (max near 1.8e308: an end rounds to inf before it is set)
            v = np.geomspace(lo, hi, axis.n)
    elif np.isfinite(hi - lo):
        v = np.linspace(lo, hi, axis.n)
    else:
        v = _convex(lo, hi, np.linspace(0.0, 1.0, axis.n))
    return _checked(axis, v, source)


def _from_unit(axis: Axis, u: np.ndarray, source: str) -> list:
    """Map samples ``u`` in [0, 1) to the axis: an index into ``values`` or a point in [min, max]."""
    if axis.values is not None:
        idx = np.minimum((u * len(axis.values)).astype(int), len(axis.values) - 1)
        return [axis.values[i] for i in idx]
    lo, hi = float(axis.min), float(axis.max)
    if axis.log:
        llo, lhi = np.log(lo), np.log(hi)
        with np.errstate(over="ignore"):  # (rounding near 1.8e308: clipped to max in _checked)
            v = np.exp(llo + u * (lhi - llo))
    elif np.isfinite(hi - lo):
        v = lo + u * (hi - lo)
    else:
        v = _convex(lo, hi, u)
    return _checked(axis, v, source)


def points(sweep: SweepSpec) -> list[dict]:
    """The runs of a sweep in order.

    Parameters
    ----------
    sweep : SweepSpec
        The sweep.

    Returns
    -------
    list of dict
        ``{axis key: value}`` per run (a factor for relative axes).

    Raises
    ------
    linsense.errors.InputError
        A grid beyond :data:`~linsense.limits.MAX_RUNS` runs, or an axis value out of range.
    """
    s = sweep.spec.sweep
    axes = sweep.spec.axis
    if s.sampling == "grid":
        grids = [grid_values(a, sweep.source) for a in axes]
        n = int(np.prod([len(g) for g in grids], dtype=float))
        if n > MAX_RUNS:
            raise InputError(sweep.source, "axis", f"the grid has {n:,} runs, beyond the limit of "
                             f"{MAX_RUNS:,} (docs/limits.md)")
        combos = itertools.product(*grids)
        return [dict(zip([a.key for a in axes], c, strict=True)) for c in combos]
    n = s.samples
    if s.sampling == "random":
        u = np.random.default_rng(s.seed).random((n, len(axes)))
    else:
        from scipy.stats import qmc  # (1 s of imports: only for a Latin hypercube)

        u = qmc.LatinHypercube(d=len(axes), seed=np.random.default_rng(s.seed)).random(n)
    cols = [_from_unit(a, u[:, j], sweep.source) for j, a in enumerate(axes)]
    return [{a.key: cols[j][i] for j, a in enumerate(axes)} for i in range(n)]

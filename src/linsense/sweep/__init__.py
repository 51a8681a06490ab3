"""Sweeps: thousands of runs of a base scenario with some keys varied, on worker threads or dask.

``sweep(spec, out)`` returns one pandas row per run (the swept values and every scalar metric);
``load_sweep(path)`` reads a sweep file. docs/sweeps.md.
"""

from linsense.sweep.engine import sweep
from linsense.sweep.spec import SweepSpec, load_sweep, sweep_from_dict

__all__ = ["SweepSpec", "load_sweep", "sweep", "sweep_from_dict"]

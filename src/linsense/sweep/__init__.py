"""Sweeps: thousands of runs of a base scenario with some keys varied, on worker threads or dask.

``sweep(spec, out)`` returns one pandas row per run (the swept values and every scalar metric);
``load_sweep(path)`` reads a sweep file; ``sweep_to(out, spec)`` (what ``linsense sweep`` runs) writes
the results, the summary and the study's figure beside the runs. docs/sweeps.md.
"""

from linsense._extras import require_extras

# (dask.distributed, pandas, pyarrow: the sweep extra; without it one line naming the extra)
require_extras("sweep", feature="the sweep engine (linsense sweep)")

from linsense.sweep.engine import sweep  # noqa: E402
from linsense.sweep.spec import SweepSpec, load_sweep, sweep_from_dict  # noqa: E402
from linsense.sweep.sweep_folder import SweepOutput, sweep_to  # noqa: E402

__all__ = ["SweepOutput", "SweepSpec", "load_sweep", "sweep", "sweep_from_dict", "sweep_to"]

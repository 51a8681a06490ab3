"""A sweep's fixed cost: local runs on a pool of worker threads (no dask, no
cluster to start), nothing heavy imported that the sweep does not use, a batch that stops when the
engine lets go of it, and rows identical to those of a dask cluster."""

from __future__ import annotations

import json
import subprocess
import sys
import threading

import pandas as pd
import pytest

from linsense.sweep import sweep
from linsense.sweep.runner import context, run_batch
from test_sweep import AXES, spec


def test_a_local_sweep_imports_neither_dask_nor_qmc_nor_matplotlib(tmp_path):
    """`linsense sweep` of a grid without a study, in a fresh process: the rows are written, and dask,
    scipy.stats (Latin hypercubes only) and matplotlib (a study's figure only) were never imported."""
    f = spec(tmp_path, AXES)
    out = tmp_path / "out"
    code = ("import json, sys\nfrom linsense.cli import main\ntry:\n"
            f"    main(['sweep', {str(f)!r}, '--out', {str(out)!r}, '--workers', '2', '--no-progress'])\n"
            "except SystemExit as e:\n    assert not e.code, e.code\n"
            "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed', "
            "'matplotlib') or m.startswith('scipy.stats'))))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.splitlines()[-1]) == []
    assert list(pd.read_parquet(tmp_path / "out" / "results.parquet")["run"]) == list(range(6))


def test_a_batch_stops_before_its_next_run_once_told(tmp_path):
    f = spec(tmp_path, AXES)
    from linsense.sweep import load_sweep
    from linsense.sweep.points import points

    sw = load_sweep(f)
    ctx = context(sw, tmp_path / "motors")
    batch = list(enumerate(points(sw)))
    stop = threading.Event()
    assert [r["run"] for r in run_batch(ctx, batch[:2], {}, stop)] == [0, 1]
    stop.set()
    assert run_batch(ctx, batch, {}, stop) == []


@pytest.mark.slow
def test_worker_threads_give_the_rows_of_a_dask_cluster(tmp_path):
    """The same rows, bit for bit, on the pool of threads (1 and 2) and on dask's worker processes."""
    f = spec(tmp_path, AXES)
    one, two = sweep(f, workers=1), sweep(f, workers=2)
    procs = sweep(f, workers=2, processes=True)
    pd.testing.assert_frame_equal(one, two)
    pd.testing.assert_frame_equal(one, procs)

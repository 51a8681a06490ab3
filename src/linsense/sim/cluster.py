"""Where scenarios run in parallel.

A dask client for a dask cluster (the ``sweep`` extra): the sweep engine
(:mod:`linsense.sweep.engine`) with ``--scheduler`` or ``--processes``, and
:func:`linsense.sim.simulation.simulate_many` with a scheduler's address. Local runs otherwise go on a
pool of worker threads of the standard library (:func:`thread_map`; the sweep engine keeps its own,
which yields batches as they finish and stops them when told).
"""

from __future__ import annotations

import logging
import os
import warnings
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

from linsense._extras import require


def thread_map(fn, items, workers: int | None, name: str) -> list:
    """``[fn(x) for x in items]``, on a pool of worker threads; results in input order.

    The C loop releases the GIL, so the threads run in parallel; the pool is the standard
    library's, so the core install (without dask) runs in parallel too.

    Parameters
    ----------
    fn : callable
        One item's work.
    items : iterable
        The items.
    workers : int or None
        Worker threads (None: one per core); one worker, or fewer than two items, run in this thread.
    name : str
        The threads' name prefix.

    Returns
    -------
    list
        ``fn`` of each item, in order.
    """
    items = list(items)
    n = min(workers or os.cpu_count() or 1, len(items))
    if n <= 1:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(n, thread_name_prefix=name) as pool:
        return list(pool.map(fn, items))


@contextmanager
def cluster_client(workers: int | None, scheduler: str | None, processes: bool):
    """A dask client, closed at the end (a context manager).

    Of the cluster at ``scheduler``, or of a local cluster of ``workers`` worker threads or
    processes.

    Parameters
    ----------
    workers : int or None
        Local workers (None: one per core).
    scheduler : str or None
        Address of a running scheduler (then ``workers`` and ``processes`` are not used).
    processes : bool
        Local workers as processes rather than threads.

    Yields
    ------
    dask.distributed.Client
        The client.
    """
    distributed = require("dask.distributed", extra="sweep", feature="running scenarios on a dask cluster")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    if scheduler:
        with Client(scheduler) as c:
            yield c
        return
    n = workers or os.cpu_count() or 1
    with quiet("distributed"):
        with warnings.catch_warnings():
            # the scheduler's HTTP server (health, metrics) takes port 8787 even with the dashboard
            # off, and warns when another cluster has it: it then takes a free port, all we need
            warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes,
                                   dashboard_address=None, silence_logs=40)
        with cluster, Client(cluster) as c:
            yield c


@contextmanager
def quiet(name: str):
    """Errors only from the logger ``name`` meanwhile (a context manager).

    A local cluster that shuts down while a message is in flight logs a harmless "Batched Comm
    Closed" with its traceback at INFO.

    Parameters
    ----------
    name : str
        The logger's name.

    Yields
    ------
    None
        While the logger is quiet.
    """
    log = logging.getLogger(name)
    old = log.level
    log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        log.setLevel(old)

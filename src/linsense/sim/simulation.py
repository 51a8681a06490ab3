"""``simulate`` and ``simulate_many``: scenarios in, :class:`Result` out.

The whole time loop runs in C (``linsense.sim.core.run_closed_loop_chunks``), recording every PWM
period; Python builds the configuration before, and computes the metrics from those samples and
keeps the record asked for (:mod:`linsense.sim.stream`): the metrics are the same whatever is kept
(``record.decimate``, ``record="metrics"``). ``wall_s`` is measured around the C run only.
"""

from __future__ import annotations

import numbers
from pathlib import Path

import numpy as np

from linsense.errors import InputError
from linsense.limits import MAX_STEPS
from linsense.scenario.load import Scenario, as_scenario
from linsense.sim.build import build
from linsense.sim.core import BLOCKS, SIGNALS
from linsense.sim.result import Result
from linsense.sim.stream import (
    AVERAGE_NOTE,
    METRICS_BLOCKS,
    METRICS_SIGNALS,
    finish_metrics,
    run_metrics,
    simulate_streamed,
)

__all__ = ["AVERAGE_NOTE", "METRICS_BLOCKS", "METRICS_SAMPLES", "METRICS_SIGNALS", "RECORD_MODES",
           "finish_metrics", "metrics_decimate", "metrics_only", "run_metrics", "simulate", "simulate_many"]

#: samples a metrics-only run keeps at most, whatever its duration (2 s at 16 kHz: blocks of 16
#: periods, 1 ms; few enough that a sweep's run costs little beyond its C loop)
METRICS_SAMPLES = 2_000
RECORD_MODES = ("trace", "metrics")


def metrics_decimate(n_steps: int, decimate: int = 1) -> int:
    """Block length of the record a metrics-only run keeps.

    The scenario's ``decimate`` or more, so that at most :data:`METRICS_SAMPLES` samples are kept.

    Parameters
    ----------
    n_steps : int
        PWM periods of the run.
    decimate : int, optional
        The scenario's ``record.decimate``.

    Returns
    -------
    int
        PWM periods per block.
    """
    return max(int(decimate), -(-int(n_steps) // METRICS_SAMPLES))


def simulate(scenario: Scenario | str | Path | dict, record: str = "trace") -> Result:
    """Run one scenario (a :class:`Scenario`, a TOML path or a dict of sections).

    The metrics are computed from every PWM period whatever is kept (:mod:`linsense.sim.stream`).
    ``record="trace"`` keeps one sample every ``record.decimate`` periods (with the block
    statistics when ``decimate > 1``). ``record="metrics"`` keeps at most :data:`METRICS_SAMPLES`
    samples whatever the duration, with their block statistics (the block length raised to
    :func:`metrics_decimate`, the scenario of the Result saying it in ``record.decimate``): the
    point arrays are then one value per block (aliased: plot the envelopes ``x_min``/``x_max``...).

    A run that diverges or trips a protection ends early and cleanly: ``metrics["stable"]`` is
    False and ``metrics["fault"]`` names the reason; no exception, no NaN in the metrics.

    Parameters
    ----------
    scenario : Scenario or str or Path or dict
        The scenario, a TOML path or a dict of sections.
    record : {"trace", "metrics"}, optional
        What to keep (above).

    Returns
    -------
    Result
        The arrays, metrics and scenario of the run.

    Raises
    ------
    InputError
        The scenario (or its motor) is invalid, or the drive trips at its very first step (a
        configuration that cannot run); the message names the file, key and value. ``scenario``
        that is none of the above, or a ``record`` that is not a mode, is named as the argument.
    """
    _check_record("simulate", record)
    sc = as_scenario(scenario)
    if record == "metrics":
        sc = _metrics_blocks(sc)
    b = build(sc, trace_in_memory=record == "trace")
    dec = int(b.setup.decimate)
    blocks = record == "metrics" or dec > 1
    names = list(SIGNALS) + ["fault"] + (list(BLOCKS) if blocks else [])
    kept = _Collector(-(-int(b.n_steps) // dec) + 1, names)
    sr = simulate_streamed(b, on_chunk=kept.add, blocks=blocks)
    return Result(**kept.arrays(), metrics=sr.metrics, scenario=sc, fault_bits=sr.fault_bits)


class _Collector:
    """The stored record of a run, chunk by chunk into arrays of ``n`` samples (cut at the end):
    memory allocated once, as the C loop's own outputs were."""

    def __init__(self, n: int, names) -> None:
        width = {**SIGNALS, **BLOCKS, "fault": 1}
        # (every row up to n is written before the arrays are cut there: no fill)
        self.a = {k: np.empty((n, width[k]) if width[k] > 1 else n) for k in names if k != "fault"}
        self.a["fault"] = np.empty(n, dtype=np.uint32)
        self.n = 0

    def add(self, chunk: dict) -> None:
        m = len(chunk["t"])
        for k, v in self.a.items():
            v[self.n:self.n + m] = chunk[k]
        self.n += m

    def arrays(self) -> dict:
        return {k: v[:self.n] for k, v in self.a.items()}


def _check_record(caller: str, record) -> None:
    """:class:`InputError` naming the argument ``record`` unless it is one of :data:`RECORD_MODES`."""
    if not (isinstance(record, str) and record in RECORD_MODES):
        raise InputError(caller, "record", f"must be one of {', '.join(map(repr, RECORD_MODES))}, "
                         f"got {' '.join(repr(record).split())}")


def metrics_only(scenario: Scenario | str | Path | dict) -> dict:
    """The metrics of ``simulate(scenario)``, whatever its record.

    Records only what they are computed from, in chunks (no Result: a sweep's run; memory does
    not grow with the duration).

    Parameters
    ----------
    scenario : Scenario or str or Path or dict
        The scenario.

    Returns
    -------
    dict
        The metrics.

    Raises
    ------
    linsense.errors.InputError
        As :func:`simulate`.
    """
    return simulate_streamed(build(as_scenario(scenario, "metrics_only"), trace_in_memory=False)).metrics


def _metrics_blocks(sc: Scenario) -> Scenario:
    """``sc`` with the block length of a metrics-only run's record (:func:`metrics_decimate`)."""
    sp = sc.spec
    periods = sp.scenario.duration * sp.inverter.f_pwm
    if not periods <= MAX_STEPS:  # (range-checked before the integer count: refused by the build)
        return sc
    dec = metrics_decimate(int(round(periods)), sp.record.decimate)
    if dec == sp.record.decimate:
        return sc
    if dec <= 1_000_000:  # (a valid value: set without validating the whole scenario again)
        record = sp.record.model_copy(update={"decimate": dec})
        return Scenario(sp.model_copy(update={"record": record}), sc.source, sc.base_dir)
    return sc.replace(record={"decimate": dec})  # (refused there, with the limit in the message)


def simulate_many(scenarios, workers: int = 1, *, scheduler: str | None = None,
                  record: str = "trace") -> list[Result]:
    """Run several scenarios on worker threads or a dask cluster; results in input order.

    Scenarios may be :class:`Scenario` objects, paths or dicts. Every scenario is validated here
    first, so a bad one raises before any run starts. ``workers=1`` runs them one after the other
    in this process; more run on a pool of worker threads (the C loop releases the GIL; no dask
    needed, and a script needs no ``if __name__ == "__main__"`` guard); ``scheduler`` sends them to
    a running dask cluster by address (the ``sweep`` extra). For thousands of runs, or runs that
    must survive a kill, use :func:`linsense.sweep.sweep`, which keeps only the metrics.

    Parameters
    ----------
    scenarios : iterable of Scenario or str or Path or dict
        The scenarios.
    workers : int, optional
        Worker threads, at least 1.
    scheduler : str or None, optional
        Address of a running dask cluster.
    record : {"trace", "metrics"}, optional
        As :func:`simulate`.

    Returns
    -------
    list of Result
        In input order.

    Raises
    ------
    linsense.errors.InputError
        Bad ``workers``, ``scenarios`` not a list, or an invalid scenario (before any run).
    """
    _check_record("simulate_many", record)
    integral = isinstance(workers, numbers.Integral) and not isinstance(workers, bool | np.bool_)
    if not (integral and workers >= 1):
        raise InputError("simulate_many", "workers", f"must be an integer of at least 1, got "
                         f"{' '.join(repr(workers).split())}")
    if isinstance(scenarios, Scenario | str | Path | dict):
        raise InputError("simulate_many", "scenarios", f"expected a list of scenarios, got one "
                         f"{type(scenarios).__name__} (use simulate)")
    try:
        items = [as_scenario(s, "simulate_many") for s in scenarios]
    except TypeError:  # (not iterable)
        raise InputError("simulate_many", "scenarios", f"expected a list of scenarios, got "
                         f"{type(scenarios).__name__}") from None
    if scheduler is None:
        from linsense.sim.cluster import thread_map

        return thread_map(lambda s: simulate(s, record=record), items, workers, "linsense-sim")
    from linsense.sim.cluster import cluster_client

    with cluster_client(min(workers, len(items)), scheduler, processes=False) as client:
        return client.gather(client.map(simulate, items, record=record, pure=False))

"""``simulate_to``: one scenario run into an output folder, what ``linsense simulate`` writes.

The trace is written chunk by chunk while the C loop runs (never whole in memory), with
``metrics.json`` and ``timing.json``, and on request ``trace.mat`` and the run's figure; the set
replaces the folder atomically (:func:`linsense.io.output_set`).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from linsense.errors import InputError
from linsense.io import output_set, split_timing
from linsense.scenario.load import Scenario
from linsense.sim import stream
from linsense.sim.build import Built, build, check_trace_file
from linsense.sim.stream import PlotData, StreamedRun
from linsense.sim.trace import MAT_MAX_SAMPLES, TraceWriter, have_parquet, trace_columns, write_mat
from linsense.version import docs

__all__ = ["TRACE_FORMATS", "SimulateOutput", "default_trace_format", "simulate_to", "write_metrics"]

#: the trace files ``simulate_to`` writes (``none``: no trace)
TRACE_FORMATS = ("parquet", "csv", "none")


@dataclass
class SimulateOutput:
    """What :func:`simulate_to` wrote and measured.

    Attributes
    ----------
    files : list of pathlib.Path
        The files of the output set, as shown to the user.
    metrics : dict
        The run's metrics (``metrics.json``), without the timing.
    timing : dict
        The run's timing (``timing.json``).
    run : StreamedRun
        The end of the run (its whole metrics, fault bits, samples written).
    warnings : list of str
        The scenario's warnings.
    """

    files: list[Path]
    metrics: dict
    timing: dict
    run: StreamedRun
    warnings: list[str] = field(default_factory=list)

    @property
    def stable(self) -> bool:
        """Whether the run was stable (``metrics["stable"]``)."""
        return bool(self.run.metrics["stable"])


def default_trace_format() -> str:
    """``parquet``, or ``csv`` on the core install (no pyarrow).

    Returns
    -------
    str
        The trace format.
    """
    return "parquet" if have_parquet() else "csv"


def write_metrics(s, metrics: dict, timing: dict) -> None:
    """A run's ``metrics.json`` and ``timing.json`` into an output set.

    Parameters
    ----------
    s : linsense.io.OutputSet
        The output set.
    metrics : dict
        The metrics (without the timing).
    timing : dict
        The timing.
    """
    s.write("metrics.json", json.dumps(metrics, indent=1) + "\n")
    s.write("timing.json", json.dumps(timing, indent=1) + "\n")


def _built(scenario: Scenario, trace: str, decimate: int | None, fidelity: str | None, mat: bool,
           warn: Callable[[str], object] | None) -> Built:
    """The scenario built for a streamed run (the options over it), its warnings said; refused
    before anything runs: a trace format unknown, a trace file beyond its limits, ``mat`` beyond
    the samples it holds."""
    if trace not in TRACE_FORMATS:
        raise InputError("trace", "", f"{trace!r}: one of {', '.join(TRACE_FORMATS)}")
    if fidelity is not None:
        scenario = scenario.replace(inverter={"fidelity": fidelity})
    if decimate is not None:
        scenario = scenario.replace(record={"decimate": decimate})
    b = build(scenario, trace_in_memory=False)  # streamed: the trace is never whole in memory
    for w in b.warnings if warn is not None else ():
        warn(w)
    if trace != "none":
        check_trace_file(b)
    n_rec = -(-b.n_steps // int(b.cfg.decimate))
    if mat and n_rec > MAT_MAX_SAMPLES:
        need = -(-b.n_steps // MAT_MAX_SAMPLES)
        raise InputError("--mat", "", f"trace.mat is written from the whole trace held in memory: {n_rec:,} "
                         f"samples is beyond the limit of {MAT_MAX_SAMPLES:,} ({docs('limits')}); "
                         f"record fewer (--decimate {need}) or use the Parquet trace")
    return b


def simulate_to(out: str | Path, scenario: Scenario, *, trace: str | None = None, decimate: int | None = None,
                fidelity: str | None = None, mat: bool = False,
                plot: Callable[[PlotData, Path], object] | None = None,
                command: str = "simulate", warn: Callable[[str], object] | None = None) -> SimulateOutput:
    """Run a scenario and write its output set into folder ``out``.

    Parameters
    ----------
    out : str or pathlib.Path
        The output folder (missing, empty or an earlier output set).
    scenario : Scenario
        The scenario (:func:`linsense.sim.load_scenario`).
    trace : str or None, optional
        ``parquet``, ``csv`` or ``none`` (default: :func:`default_trace_format`).
    decimate : int or None, optional
        One recorded sample every N PWM periods (over ``record.decimate``).
    fidelity : str or None, optional
        ``average`` or ``switching`` (over ``inverter.fidelity``).
    mat : bool, optional
        Also ``trace.mat`` (the whole trace held in memory: at most ``MAT_MAX_SAMPLES`` samples).
    plot : callable or None, optional
        ``plot(data, path)`` draws ``sim.png`` from the run's figure data, e.g.
        :func:`linsense.report.sim_figures.write_sim_figure` (the simulator is below the figures).
    command : str, optional
        The command recorded in the output set's manifest.
    warn : callable or None, optional
        Called with each of the scenario's warnings once it is built, before the run (they are
        also in the result).

    Returns
    -------
    SimulateOutput
        The files written, the metrics and the timing.

    Raises
    ------
    InputError
        A scenario the simulator refuses, or ``mat`` beyond its sample limit (nothing written).
    """
    trace = default_trace_format() if trace is None else trace
    b = _built(scenario, trace, decimate, fidelity, mat, warn)
    mat_parts: list[dict] = []

    def run(f=None) -> StreamedRun:
        writer = TraceWriter(f, trace) if f is not None else None

        def on_chunk(arrays) -> None:
            if writer is not None:
                writer.write(arrays)
            if mat:
                mat_parts.append({k: np.array(v, dtype=float) for k, v in trace_columns(arrays).items()})

        try:
            sr = stream.simulate_streamed(b, on_chunk=on_chunk if writer is not None or mat else None,
                                          plot=plot is not None)
        except BaseException:
            if writer is not None:
                writer.abort()
            raise
        if writer is not None:
            writer.close()
        return sr

    with output_set(out, command) as s:
        if trace == "none":
            sr = run()
        else:
            done = []
            s.write_with(f"trace.{trace}", lambda f: done.append(run(f)))
            sr = done[0]
        metrics, timing = split_timing(sr.metrics)
        write_metrics(s, metrics, timing)
        if mat:
            cols = {k: np.concatenate([p[k] for p in mat_parts]) for k in mat_parts[0]}
            mat_parts.clear()
            write_mat(cols, s.path("trace.mat"), metrics=sr.metrics)
        if plot is not None:
            plot(sr.plot, s.path("sim.png"))
    return SimulateOutput(list(s.files), metrics, timing, sr, list(b.warnings))

"""``simulate`` and ``simulate_many``: scenarios in, :class:`Result` out.

The whole time loop runs in C (``linsense.sim.core.run_closed_loop``); Python builds the
configuration before and computes the metrics after. ``wall_s`` is measured around the C run only.
"""

from __future__ import annotations

import numbers
from pathlib import Path

import numpy as np

from linsense.errors import InputError
from linsense.limits import MAX_STEPS
from linsense.sim.build import build
from linsense.sim.checks import sensor_triples
from linsense.sim.core import BLOCKS, run_closed_loop
from linsense.sim.metrics import compute_metrics
from linsense.sim.result import Result
from linsense.sim.scenario import Scenario, as_scenario

#: what the average inverter model cannot be trusted for (docs/simulator.md, "Fidelity")
AVERAGE_NOTE = ("average inverter: the dead time's effect on the HF estimate is approximated (edge "
                "currents predicted linearly, with the PWM ripple's dead zone); its steady bias can "
                "differ from the switching model's by up to about 1 deg and it can show or miss limit "
                "cycles below about 0.2 mm: check bias and limit-cycle claims with fidelity = switching")

#: fault at t = 0 -> the scenario key most likely responsible
_FAULT_KEYS = {"undervoltage": "inverter.v_dc", "overvoltage": "inverter.v_dc",
               "overcurrent": "protection.i_max", "encoder": "sensors.encoder_counts_per_period",
               "config": "control"}


#: samples a metrics-only run keeps at most, whatever its duration (2 s at 16 kHz: blocks of 16
#: periods, 1 ms; few enough that a sweep's run costs little beyond its C loop)
METRICS_SAMPLES = 2_000
RECORD_MODES = ("trace", "metrics")


def metrics_decimate(n_steps: int, decimate: int = 1) -> int:
    """Block length of a metrics-only run.

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

    ``record="trace"`` keeps one sample every ``record.decimate`` periods (with the block
    statistics when ``decimate > 1``). ``record="metrics"`` keeps at most :data:`METRICS_SAMPLES`
    samples whatever the duration (memory does not grow with it): the block length is raised to
    :func:`metrics_decimate`, and the metrics come from the block statistics (the min, max and
    mean of every period), so peaks, bias and limit cycle miss nothing between samples; times
    (settling, the windows) have the resolution of one block (``metrics["block_s"]``). The point
    arrays are then one value per block (aliased: plot the envelopes ``x_min``/``x_max``...).

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
    blocks = tuple(BLOCKS) if record == "metrics" or sc.spec.record.decimate > 1 else ()
    raw, m = _run(sc, None, blocks)
    return Result(**raw.arrays, metrics=m, scenario=sc, fault_bits=raw.fault)


def _check_record(caller: str, record) -> None:
    """:class:`InputError` naming the argument ``record`` unless it is one of :data:`RECORD_MODES`."""
    if not (isinstance(record, str) and record in RECORD_MODES):
        raise InputError(caller, "record", f"must be one of {', '.join(map(repr, RECORD_MODES))}, "
                         f"got {' '.join(repr(record).split())}")


def _run(sc: Scenario, signals, blocks) -> tuple:
    """Build ``sc``, run it recording ``signals`` (None: all) and ``blocks``; its run and metrics."""
    b = build(sc)
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, signals=signals, blocks=blocks)
    m = run_metrics(b, raw)
    finish_metrics(b, raw, m, b.cfg.decimate)
    return raw, m


#: what the metrics read: the point signals beside the block statistics (linsense.sim.metrics)
METRICS_SIGNALS = ("t", "x", "theta_err")
METRICS_BLOCKS = ("x_min", "x_max", "x_mean", "err_min", "err_max", "err_mean")


def metrics_only(scenario: Scenario | str | Path | dict) -> dict:
    """The metrics of ``simulate(scenario, record="metrics")``.

    Records only what they are computed from (no Result: a sweep's run; its cost beyond the C loop
    is about 1 ms).

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
    return _run(_metrics_blocks(as_scenario(scenario, "metrics_only")), METRICS_SIGNALS, METRICS_BLOCKS)[1]


def _metrics_blocks(sc: Scenario) -> Scenario:
    """``sc`` with the block length of a metrics-only run (:func:`metrics_decimate`)."""
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


def finish_metrics(b, raw, m: dict, block: int) -> None:
    """Complete the metrics of a run in place.

    Refuses a drive that trips at t = 0, adds the fidelity note, names and ``block_s``.

    Parameters
    ----------
    b : Built
        The built scenario.
    raw : RawRun
        Its run.
    m : dict
        The metrics, completed in place.
    block : int
        PWM periods per block, the resolution of the metrics' times.

    Raises
    ------
    linsense.errors.InputError
        The drive trips at its very first step (naming the key at fault).
    """
    sc = b.scenario
    s = sc.spec
    if raw.fault and raw.steps_done <= 1:
        # a trip at the very first step is the configuration's doing, not the closed loop's
        first = m["fault"].split("+")[0]  # the first fault named (several can trip together)
        sens = s.sensors
        offset = max(abs(o) for o in sensor_triples(sens)[1])
        on_sensor = first == "overcurrent" and (sens.current_noise or offset)
        if on_sensor and "protection.i_max" not in b.user_keys:
            # (the file gives the sensor, not the trip: name what it gives, issue 23)
            key = "sensors.current_noise" if sens.current_noise else "sensors.current_offset"
            raise InputError(sc.source, key, f"the drive trips at t = 0 (overcurrent) on the current "
                             f"sensor: {sens.current_noise:g} A rms of noise and {offset:g} A of offset "
                             f"against the over-current trip protection.i_max = {s.protection.i_max:.3g} A "
                             "(designed)")
        raise InputError(sc.source, _FAULT_KEYS.get(first, ""),
                         f"the drive trips at t = 0 ({m['fault']}): the configuration cannot run")
    if s.inverter.fidelity == "average" and s.inverter.dead_time > 0:
        m["fidelity_note"] = AVERAGE_NOTE
    m["scenario"] = sc.name
    m["mode"] = s.control.mode
    m["fidelity"] = s.inverter.fidelity
    m["motor"] = b.motor.name
    m["block_s"] = _round_s(block / s.inverter.f_pwm)


def run_metrics(b, raw, arrays: dict | None = None) -> dict:
    """The metrics of a run of a built scenario.

    The bounds are in electrical degrees of the plant motor's pole pitch.

    Parameters
    ----------
    b : Built
        The built scenario.
    raw : RawRun
        Its run.
    arrays : dict or None, optional
        The samples (default the run's own; with block statistics among them, from those).

    Returns
    -------
    dict
        The metrics (:func:`linsense.sim.metrics.compute_metrics`).
    """
    s = b.scenario.spec
    x_target = b.commands[-1][1] if b.commands else b.setup.x0
    observer_active = s.control.mode != "sensored" or s.control.inject_sensored
    pitch = b.motor.pole_pitch  # (the plant's: the controller's model has the same)
    return compute_metrics(
        raw.arrays if arrays is None else arrays, fault=raw.fault, steps_done=raw.steps_done,
        f_pwm=s.inverter.f_pwm, moves=b.moves, wall_s=raw.wall_s,  # the C run alone
        observer_active=observer_active, convergence_s=s.metrics.convergence_s,
        settle_s=s.metrics.settle_s, pole_pitch=pitch, **s.metrics.bounds_deg(pitch),
        final_window_s=s.metrics.final_window_s, x_target=x_target, x_start=b.setup.x0,
    )


def _round_s(v: float) -> float:
    return round(float(v), 9)


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

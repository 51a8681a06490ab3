"""One run of a sweep: the base scenario with the point's values set, simulated, as one table row.

A point that the scenario or motor checks refuse (a bus too low for the injection, a motor whose
saliency vanishes) is not an error of the sweep: its row has ``error`` set and ``stable = False``.
"""

from __future__ import annotations

import copy
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import tomli_w

from linsense.errors import InputError, LinsenseError
from linsense.io import folder_of, parse_toml, read_toml, write_atomic
from linsense.model.motor import motor_path, names_a_path, preset_names, preset_text, table_files
from linsense.sweep.spec import SweepSpec

#: scalar metrics copied into a sweep's rows (lists and the long texts stay out; no wall-clock time:
#: a sweep's tables are byte-reproducible, docs/cli.md)
ROW_METRICS = ("stable", "accurate", "reached", "max_abs_err_deg", "transient_max_err_deg",
               "steady_max_err_deg", "bias_deg", "limit_cycle_mm", "limit_cycle_deg", "settling_time_s",
               "final_position_mm", "final_error_mm", "final_error_deg", "final_offset_mm",
               "final_offset_deg", "overshoot_mm", "overshoot_deg", "fault", "unstable_reason",
               "hf_current_a", "sim_s")


@dataclass
class SweepContext:
    """What every run of one sweep shares (pickled once per task).

    Attributes
    ----------
    source : str
        The sweep file, for messages.
    scenario_data : dict
        The base scenario's data.
    scenario_dir : str
        Its folder.
    motor_data : dict
        The base motor's data.
    motor_dir : str
        Its folder.
    motors_out : str
        Where edited motor files go.
    trace : bool
        Keep each run's trace.
    fixed : dict
        The keys the sweep sets in every run (``sweep.set``).
    defaults : dict
        Base values of relative scenario keys, found once.
    """

    source: str
    scenario_data: dict
    scenario_dir: str
    motor_data: dict
    motor_dir: str
    motors_out: str
    trace: bool
    fixed: dict
    defaults: dict = field(default_factory=dict)  # base values of relative scenario keys, found once


def _motor_data(spec: str, scenario_dir: Path, source: str) -> tuple[dict, Path]:
    """The base motor's TOML data (a preset's or a file's, table paths made absolute)."""
    spec = motor_path(spec)  # (a packaged example motor's name: its file)
    if not names_a_path(spec) and spec in preset_names():
        return parse_toml(preset_text(spec), f"preset {spec}"), scenario_dir
    p = Path(spec) if Path(spec).is_absolute() else scenario_dir / spec
    data = read_toml(p, "motor file (the base scenario's motor)")
    folder = folder_of(p)  # (its tables beside the file it is, through a link)
    # the tables' paths made absolute: an edited copy is written under DIR/motors/ (a saturated
    # motor's tables were relative to it there: every run of a motor.* axis was refused)
    def absolute(t):
        return str((folder / t).resolve()) if isinstance(t, str) and t and not Path(t).is_absolute() else t

    kinds = {kind for kind, _ in table_files(data)}
    if "inductance table" in kinds:
        data["inductance"]["table"] = absolute(data["inductance"]["table"])
    if "saturation table" in kinds:
        data["saturation"]["tables"] = [absolute(t) for t in data["saturation"]["tables"]]
    return data, folder


def context(sweep: SweepSpec, motors_out: Path) -> SweepContext:
    """The shared context of a sweep.

    Parameters
    ----------
    sweep : SweepSpec
        The sweep.
    motors_out : Path
        Where edited motor files will be written.

    Returns
    -------
    SweepContext
        The context.

    Raises
    ------
    linsense.errors.InputError
        No base scenario file, or one without a motor.
    """
    p = sweep.scenario_path
    if not p.is_file():
        raise InputError(sweep.source, "sweep.scenario", f"no such scenario file {str(p)!r}")
    data = read_toml(p, "scenario file")
    motor_spec = data.get("motor")
    if not isinstance(motor_spec, str):
        raise InputError(str(p), "motor", "missing (a preset name or a motor file)")
    motor_data, motor_dir = _motor_data(motor_spec, folder_of(p), str(p))
    return SweepContext(sweep.source, data, str(folder_of(p)), motor_data, str(motor_dir), str(motors_out),
                        sweep.spec.sweep.trace, dict(sweep.spec.sweep.set))


def _get(data: dict, keys: list[str]):
    for k in keys:
        if not isinstance(data, dict) or k not in data:
            return None
        data = data[k]
    return data


def _set(data: dict, keys: list[str], value) -> None:
    """Set ``data[k0][k1]... = value``, copying each table on the way (the base is shared by every
    run and never changed; only the tables on the key's path are new)."""
    for k in keys[:-1]:
        child = data.get(k, {})
        if not isinstance(child, dict):
            raise InputError("sweep", ".".join(keys), "is not inside a table of the file")
        data[k] = child = dict(child)
        data = child
    data[keys[-1]] = value


def _relative(base, factor: float, key: str, source: str) -> float:
    if isinstance(base, bool) or not isinstance(base, int | float):
        raise InputError(source, key, f"relative = true needs a number in the base file, got {base!r}")
    return float(base) * float(factor)


def _scenario_default(data: dict, keys: list[str], source: str):
    """The value of a scenario key as the validated base scenario has it (defaults included)."""
    from linsense.scenario.load import scenario_from_dict

    sc = scenario_from_dict(copy.deepcopy(data), source)
    node = sc.spec
    for k in keys:
        node = getattr(node, k, None)
    return node


def _motor_file(ctx: SweepContext, motor: dict) -> str:
    """Write an edited motor (content-addressed, so every worker writes the same bytes) and give
    its path."""
    text = tomli_w.dumps(motor)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = Path(ctx.motors_out) / f"motor-{digest}.toml"
    if not path.exists():
        write_atomic(path, text)
    # (absolute: the scenario reads a relative motor path from its own folder, and a relative --out
    # made every run of a motor axis "no such motor file")
    return str(path.absolute())


def scenario_for(ctx: SweepContext, point: dict, relative: dict) -> dict:
    """The base scenario's data with the sweep's fixed keys and the point's values set.

    Motor keys are set through edited motor files.

    Parameters
    ----------
    ctx : SweepContext
        The sweep's context.
    point : dict
        ``{axis key: value}``.
    relative : dict
        Axis key to whether its values are factors of the base value.

    Returns
    -------
    dict
        The run's scenario data.
    """
    data = dict(ctx.scenario_data)
    motors = {"motor": None, "lut_motor": None}
    for key, value in [*ctx.fixed.items(), *point.items()]:
        head, *rest = key.split(".")
        if head in motors:
            if motors[head] is None:
                motors[head] = dict(ctx.motor_data)
            if relative.get(key):
                value = _relative(_get(ctx.motor_data, rest), value, key, ctx.source)
            _set(motors[head], rest, value)
        else:
            keys = key.split(".")
            if relative.get(key):
                if key not in ctx.defaults:
                    ctx.defaults[key] = _scenario_default(ctx.scenario_data, keys, ctx.source)
                base = ctx.defaults[key]
                value = _relative(base, value, key, ctx.source)
            _set(data, keys, value)
    if motors["motor"] is not None:
        data["motor"] = _motor_file(ctx, motors["motor"])
    if motors["lut_motor"] is not None:
        _set(data, ["controller", "model", "motor"], _motor_file(ctx, motors["lut_motor"]))
    return data


def hf_current(result) -> float | None:
    """The HF current's amplitude: mean half peak-to-peak of phase a's current.

    Over injection periods of the end window, from every PWM period whatever the record keeps: a
    decimated record's block envelopes (``i_abc_min``, ``i_abc_max``), enough blocks together to
    cover an injection period (``record.decimate = 16`` sampled the 1 kHz injection once
    per period at 16 kHz and gave 0).

    Parameters
    ----------
    result : Result
        A run with its trace.

    Returns
    -------
    float or None
        A; None without a trace of the currents.
    """
    import numpy as np

    i = getattr(result, "i_abc", None)
    t = getattr(result, "t", None)
    s = result.scenario.spec
    if i is None or t is None or len(t) < 4 or s.injection.amplitude == 0:
        return None
    dec = max(1, s.record.decimate)
    lo, hi = getattr(result, "i_abc_min", None), getattr(result, "i_abc_max", None)
    per_inj = s.inverter.f_pwm / s.injection.frequency / dec  # (samples per injection period)
    if lo is None or hi is None:  # (every period: one injection period of samples)
        lo = hi = np.asarray(i)
        n = max(1, round(per_inj))
    else:  # (blocks: as many as cover an injection period)
        n = max(1, math.ceil(per_inj - 1e-9))
    lo, hi = np.asarray(lo)[:, 0], np.asarray(hi)[:, 0]
    ok = np.isfinite(lo) & np.isfinite(hi)
    lo, hi = lo[ok], hi[ok]
    if lo.size < n:
        return None
    keep = (lo.size // n) * n
    lo, hi = lo[lo.size - keep:], hi[hi.size - keep:]
    win = max(1, int(round(s.metrics.final_window_s * s.inverter.f_pwm / dec)) // n)
    amp = 0.5 * (hi.reshape(-1, n).max(axis=1) - lo.reshape(-1, n).min(axis=1))[-win:]
    return float(np.mean(amp))


def run_point(ctx: SweepContext, index: int, point: dict, relative: dict) -> dict:
    """Simulate one point.

    Parameters
    ----------
    ctx : SweepContext
        The sweep's context.
    index : int
        The run's index.
    point : dict
        ``{axis key: value}``.
    relative : dict
        Axis key to whether its values are factors.

    Returns
    -------
    dict
        The row: ``run``, the swept values, the metrics of :data:`ROW_METRICS` and ``error`` (the
        message when the run was refused, its metrics None).
    """
    from linsense.scenario.load import scenario_from_dict
    from linsense.sim.simulation import metrics_only, simulate

    row: dict = {"run": index, **point}
    try:
        sc = scenario_from_dict(scenario_for(ctx, point, relative), f"{ctx.source} (run {index})",
                                ctx.scenario_dir)
        # metrics only (block statistics in C, memory independent of the duration) unless the
        # sweep keeps the traces (the HF current is measured on a trace)
        if ctx.trace:
            res = simulate(sc)
            m = dict(res.metrics)
            m["hf_current_a"] = hf_current(res)
        else:
            m = metrics_only(sc)
        for k in ROW_METRICS:
            v = m.get(k)
            row[k] = None if isinstance(v, float) and not math.isfinite(v) else v
        row["error"] = None
    except LinsenseError as exc:
        row.update({k: None for k in ROW_METRICS})
        row["stable"] = False
        row["error"] = str(exc)
    return row


def run_batch(ctx: SweepContext, batch: list[tuple[int, dict]], relative: dict, stop=None) -> list[dict]:
    """The rows of one batch of runs (one task of the engine, one Parquet partition).

    Parameters
    ----------
    ctx : SweepContext
        The sweep's context.
    batch : list of (int, dict)
        ``(index, point)`` of each run.
    relative : dict
        Axis key to whether its values are factors.
    stop : threading.Event or None, optional
        Once set, ends the batch before its next run (the engine then discards its rows).

    Returns
    -------
    list of dict
        The rows (:func:`run_point`), fewer when stopped.
    """
    rows = []
    for i, p in batch:
        if stop is not None and stop.is_set():
            break
        rows.append(run_point(ctx, i, p, relative))
    return rows

"""``linsense fea``: geometry file -> FEA -> one output set (see docs/fea.md)."""

from __future__ import annotations

import contextlib
import json
import math
import tempfile
from pathlib import Path

import numpy as np

from linsense.fea import outputs
from linsense.fea.geometry import load_geometry
from linsense.fea.solver import run_loads

_OPTION = "--load-current"


def parse_currents(value, option: str = _OPTION, what: str = "q-axis currents in A",
                   positive: bool = False) -> list[float]:
    """The q-axis load currents (A) of ``--load-current``: a number or a comma list ("0,1,2");
    ``option``, ``what`` and ``positive`` (all > 0) for another list of currents (``--polarity``)."""
    from linsense.errors import InputError

    if isinstance(value, (int, float)):
        items = [value]
    elif isinstance(value, str):
        items = [v.strip() for v in value.split(",")]
    else:
        items = list(value)
    example = "0.5,1,2" if positive else "0,1,2"
    if not items or items == [""]:
        raise InputError(option, "", f"no current given ({what}, e.g. 2 or {example})")
    currents: list[float] = []
    for v in items:
        try:
            c = float(v)
        except (TypeError, ValueError):
            raise InputError(option, "", f"{v!r} is not a number ({what}, comma-separated, "
                             f"e.g. {example})") from None
        if not math.isfinite(c) or abs(c) > 1e6:
            raise InputError(option, "", f"must be finite currents in A (|I| <= 1e6), got {v!r}")
        if positive and c <= 0:
            raise InputError(option, "", f"must be positive amplitudes in A, got {v!r}")
        if c in currents:
            raise InputError(option, "", f"{c:g} A is given twice")
        currents.append(c + 0.0)  # -0.0 -> 0.0
    return currents


def _tag(current: float) -> str:
    return f"{current:g}A"


class _Bar:
    """A rich progress bar on stderr (positions done / total, rate, time left), one task per stage."""

    def __init__(self, currents: list[float], name: str, what: str = "load") -> None:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        class Rate(TextColumn):
            def render(self, task):  # seconds per position (a Newton solve takes seconds)
                return f"{1 / task.speed:.2f} s/position" if task.speed else "- s/position"

        self.p = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), Rate(""),
                          TimeRemainingColumn(), console=Console(stderr=True), transient=False)
        self.currents, self.name, self.what, self.tasks = currents, name, what, {}

    def __enter__(self):
        self.p.start()
        return self

    def __exit__(self, *exc):
        self.p.stop()

    def __call__(self, stage, k: int, n: int) -> None:
        if stage not in self.tasks:
            what = ("theta origin (linear)" if stage == "origin" else
                    f"{self.what} {self.currents[stage]:g} A" if len(self.currents) > 1 else "positions")
            self.tasks[stage] = self.p.add_task(f"fea {self.name}: {what}", total=n)
        self.p.update(self.tasks[stage], completed=k)


def _motor_of(res, folder: Path, tag: str = ""):
    """(motor or None, ModelError message or None) of a Result's table written into ``folder``."""
    from linsense.errors import ModelError
    from linsense.model.motor import load_motor

    table = f"inductances{tag}.csv"
    (folder / table).write_text(outputs.inductances_csv(res))
    (folder / f"motor{tag}.toml").write_text(outputs.motor_toml(res, table))
    try:
        return load_motor(folder / f"motor{tag}.toml"), None
    except ModelError as exc:
        return None, str(exc)


def lut_of(res, points: int = 360) -> np.ndarray:
    """Psi_LUT (rad, eq. 12) at ``points`` positions of the motor model of a Result's table."""
    from linsense.compensation.lut import build_lut

    with tempfile.TemporaryDirectory(prefix="linsense-fea-") as d:
        motor, problem = _motor_of(res, Path(d))
        if motor is None:
            raise ValueError(problem)
        return build_lut(motor, points).values


def run_fea(spec: str, out: str, positions: int = 56, level: str = "default", lut_points: int = 360,
            progress: bool = False, load_current=0.0, workers: int = 1, polarity=None,
            polarity_positions: int = 4):
    """Solve and write the output set; return (written files, summary lines, warnings).

    ``load_current``: a q-axis current in A, or several (a list or "0,1,2"): the main outputs are
    those of the first; each load adds ``inductances_<I>A.csv``, ``motor_<I>A.toml``, ``lut_<I>A.csv``,
    and the set gets ``lut_vs_load.png`` and fea.json's ``lut_vs_load``. ``polarity``: d-axis pulse
    amplitudes in A (a list or "0.5,1,2"): ``polarity.csv`` and fea.json's ``polarity``, the saturation
    signal ``L_d(-I) - L_d(+I)`` at ``polarity_positions`` positions (:mod:`linsense.fea.polarity`).
    """
    from linsense.analysis.summary import summarize
    from linsense.compensation.lut import build_lut, to_csv
    from linsense.errors import InputError
    from linsense.io import output_set
    from linsense.report.figures import fig_inductances, fig_lut, png_bytes

    g = load_geometry(spec)
    currents = parse_currents(load_current)
    pulses = (None if polarity is None else
              parse_currents(polarity, "--polarity", "d-axis pulse amplitudes in A", positive=True))
    if any(currents) and g.bh_rod is None and g.bh_arm is None:
        raise InputError(_OPTION, "", f"{g.source} has linear iron: the incremental inductances do "
                         "not depend on the load (give rod.bh or armature.bh, a B-H curve)")
    sweep = len(currents) > 1
    warnings: list[str] = []
    bar = _Bar(currents, g.name) if progress else contextlib.nullcontext(None)
    with output_set(out, "fea") as s:
        with bar as cb:
            results = run_loads(g, currents, positions, level, progress=cb, workers=workers)
        res = results[0]
        s.write("inductances.csv", outputs.inductances_csv(res))
        s.write("motor.toml", outputs.motor_toml(res))
        fit = outputs.eq3_fit(res)
        motor, problem = _load(s.path("motor.toml"), Path(out) / "motor.toml")
        if motor is None:  # a valid table, but no HF sensorless control with it
            warnings.append(f"{problem}; motor.toml is written but does not pass load_motor's checks, "
                            "no lut.csv")
        summ = summarize(motor) if motor is not None else None
        hf = {"ok": motor is not None, "problem": None if motor is not None else warnings[0]}
        extra = {"eq3_fit": fit, "hf_sensorless": hf, "summary": summ}
        lut = build_lut(motor, lut_points) if motor is not None else None
        vs_load = None
        if sweep:
            luts = []
            for r in results:
                tag = "_" + _tag(r.load_current)
                s.write(f"inductances{tag}.csv", outputs.inductances_csv(r))
                s.write(f"motor{tag}.toml", outputs.motor_toml(r, f"inductances{tag}.csv"))
                m, _ = _load(s.path(f"motor{tag}.toml"), Path(out) / f"motor{tag}.toml")
                luts.append(build_lut(m, lut_points) if m is not None else None)
                if luts[-1] is not None:
                    s.write(f"lut{tag}.csv", to_csv(luts[-1]))
            vs_load = _vs_load(results, luts)
            extra["lut_vs_load"] = vs_load
        sig = None
        if pulses is not None:
            from linsense.fea.polarity import polarity_csv, polarity_signal

            points = [-p for p in sorted(pulses, reverse=True)] + sorted(pulses)
            pbar = _Bar(points, g.name, "polarity i_d") if progress else contextlib.nullcontext(None)
            with pbar as cb:
                sig = polarity_signal(g, pulses, polarity_positions, level, workers=workers,
                                      progress=cb)
            s.write("polarity.csv", polarity_csv(sig))
            extra["polarity"] = sig
        s.write("geometry.json", json.dumps(g.regions(), indent=2) + "\n")
        s.write("fea.json", outputs.fea_json(res, extra))
        s.write("field_lines.png", png_bytes(outputs.fig_field(res)))
        s.write("inductances_fea.png", png_bytes(outputs.fig_table(res)))
        if motor is not None:
            s.write("lut.csv", to_csv(lut))
            fig = fig_inductances(motor, f"{g.name}: table model (ABC, dq)")
            s.write("inductances_model.png", png_bytes(fig))
            s.write("lut.png", png_bytes(fig_lut(motor, lut)))
        if sweep and any(v is not None for v in luts):
            s.write("lut_vs_load.png", png_bytes(outputs.fig_lut_vs_load(g.name, vs_load, luts,
                                                                          g.pole_pitch)))
    v = fit["values_H"]
    names = ("L0", "L2", "M0", "M2", "dM0")
    lines = [
        f"{g.name}: {res.mesh.mesh.t.shape[1]} triangles, {res.keep['solver'].ndofs} dofs, "
        f"{positions} positions in {res.times['solve_s']:.1f} s"
        + (f", Newton iterations max {res.newton['max']}, mean {res.newton['mean']:.1f}, load "
           f"{res.load_current:g} A" if res.newton else ""),
        "eq. 3 fit: " + ", ".join(f"{k} {v[k] * 1e3:.3f} mH" for k in names if k in v),
        f"psi_pm {res.psi_pm_amplitude:.4f} Wb, force constant {outputs.force_constant(res) or 0:.2f} N/A",
    ]
    if summ is not None:
        sal = summ["saliency_range_H"]
        lines[-1] += (f", saliency {sal[0] * 1e3:.3f} .. {sal[1] * 1e3:.3f} mH, "
                      f"Psi_LUT peak {summ['psi_lut_peak_deg']:.2f} deg")
    if vs_load is not None:
        lines.append(_vs_load_line(vs_load))
    if sig is not None:
        from linsense.fea.polarity import polarity_line

        lines.append(polarity_line(sig))
    return s.files, lines, warnings


def _load(path: Path, shown: Path):
    """(motor, None) or (None, the ModelError's message naming the final path ``shown``)."""
    from linsense.errors import ModelError
    from linsense.model.motor import load_motor

    try:
        return load_motor(path), None
    except ModelError as exc:
        return None, str(exc).replace(str(path), str(shown))


def _vs_load(results, luts) -> dict:
    """fea.json's ``lut_vs_load``: the loads, their force, each LUT's largest difference from the first's."""
    kf = outputs.force_constant(results[0])
    ref = luts[0]
    diffs = [None if ref is None or lu is None else float(np.degrees(np.abs(lu.values - ref.values).max()))
             for lu in luts]
    e0 = outputs.table(results[0])[1]
    table_diff = [float(np.abs(outputs.table(r)[1] - e0).max() / np.abs(e0).max()) for r in results]
    return {
        "currents_A": [r.load_current for r in results],
        "force_N": [None if kf is None else kf * r.load_current for r in results],
        "max_diff_deg": diffs,
        "psi_lut_peak_deg": [None if lu is None else float(np.degrees(np.abs(lu.values).max()))
                             for lu in luts],
        "table_max_rel_diff": table_diff,
        "newton_iterations": [r.newton for r in results],
        "solve_s": [r.times["solve_s"] for r in results],
        "rule": "max_diff_deg: max over theta of |Psi_LUT(load) - Psi_LUT(first load)|, electrical deg; "
                "table_max_rel_diff: max |entry - first load's| / max |entry|",
    }


def _vs_load_line(v: dict) -> str:
    parts = []
    for i, f, d in zip(v["currents_A"], v["force_N"], v["max_diff_deg"], strict=True):
        force = "" if f is None else f" ({f:.0f} N)"
        parts.append(f"{i:g} A{force} {'n/a' if d is None else f'{d:.2g} deg'}")
    valid = [d for d in v["max_diff_deg"] if d is not None]
    tail = f": max difference {max(valid):.2g} deg" if valid else ": no LUT (no usable saliency)"
    return f"LUT against load (vs {v['currents_A'][0]:g} A): " + ", ".join(parts) + tail

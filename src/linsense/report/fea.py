"""``linsense fea``: geometry file -> FEA (:mod:`linsense.fea`) -> one output set with its figures
(see docs/fea.md). The figures are built as :class:`matplotlib.figure.Figure` objects (no pyplot
state) and rendered in memory before they are written."""

from __future__ import annotations

import contextlib
import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from matplotlib.tri import Triangulation

from linsense._extras import require
from linsense.analysis.summary import summarize
from linsense.compensation.lut import build_lut, to_csv
from linsense.errors import InputError
from linsense.fea import outputs
from linsense.fea.geometry import load_geometry
from linsense.fea.per_load import (
    LOAD_OPTION,
    load_sweep,
    load_sweep_line,
    load_tag,
    load_written,
    parse_currents,
)
from linsense.fea.polarity import polarity_csv, polarity_line, polarity_signal
from linsense.fea.solver import run_loads
from linsense.io import output_set
from linsense.report.figures import _position_axis, fig_inductances, fig_lut, png_bytes


class _Bar:
    """A rich progress bar on stderr (positions done / total, rate, time left), one task per stage."""

    def __init__(self, currents: list[float], name: str, what: str = "load") -> None:
        require("rich", extra="fea", feature="the FEA's progress display")
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


def run_fea(spec: str, out: str, positions: int = 56, level: str = "default", lut_points: int = 360,
            progress: bool = False, load_current=0.0, workers: int = 1, polarity=None,
            polarity_positions: int = 4):
    """Solve a geometry and write the FEA's output set (``linsense fea``, docs/fea.md).

    ``load_current``: a q-axis current, or several: the main outputs are those of the first; each
    load adds ``inductances_<I>A.csv``, ``motor_<I>A.toml``, ``lut_<I>A.csv``, and the set gets
    ``lut_vs_load.png`` and fea.json's ``lut_vs_load``. ``polarity``: ``polarity.csv`` and
    fea.json's ``polarity``, the saturation signal ``L_d(-I) - L_d(+I)``
    (:mod:`linsense.fea.polarity`).

    Parameters
    ----------
    spec : str
        Geometry file or preset.
    out : str
        Output folder.
    positions : int, optional
        Rod positions over one period.
    level : {"coarse", "default", "fine"}, optional
        Mesh level.
    lut_points : int, optional
        Points of the LUTs written.
    progress : bool, optional
        Show a progress bar.
    load_current : float or str or list, optional
        q-axis current(s), A (a number, a list or ``"0,1,2"``).
    workers : int, optional
        Processes.
    polarity : str or list or None, optional
        d-axis pulse amplitudes, A (a list or ``"0.5,1,2"``).
    polarity_positions : int, optional
        Rod positions of the polarity signal.

    Returns
    -------
    files : list
        The files written.
    lines : list of str
        The summary.
    warnings : list of str
        What the outputs could not give (e.g. a table without usable saliency).

    Raises
    ------
    linsense.errors.InputError
        A bad geometry or current list, or a load current with linear iron.
    """
    g = load_geometry(spec)
    currents = parse_currents(load_current)
    pulses = (None if polarity is None else
              parse_currents(polarity, "--polarity", "d-axis pulse amplitudes in A", positive=True))
    _check_loads(g, currents)
    sweep = len(currents) > 1
    bar = _Bar(currents, g.name) if progress else contextlib.nullcontext(None)
    with output_set(out, "fea") as s:
        with bar as cb:
            results = run_loads(g, currents, positions, level, progress=cb, workers=workers)
        res = results[0]
        fit, motor, summ, problem = _first_load_outputs(s, res, out)
        warnings = [problem] if problem else []
        hf = {"ok": motor is not None, "problem": None if motor is not None else warnings[0]}
        extra = {"eq3_fit": fit, "hf_sensorless": hf, "summary": summ}
        lut = build_lut(motor, lut_points) if motor is not None else None
        luts, vs_load = [], None
        if sweep:
            luts, vs_load = _load_sweep_outputs(s, results, out, lut_points)
            extra["lut_vs_load"] = vs_load
        sig = None
        if pulses is not None:
            sig = _polarity_outputs(s, g, pulses, polarity_positions, level, workers, progress)
            extra["polarity"] = sig
        s.write("geometry.json", json.dumps(g.regions(), indent=2) + "\n")
        fea_doc, timing = outputs.fea_json(res, extra)
        s.write("fea.json", fea_doc)
        s.write("timing.json", timing)
        _figures(s, g, res, motor, lut, vs_load, luts)
    return s.files, _summary_lines(g, res, fit, summ, positions, vs_load, sig), warnings


def _check_loads(g, currents: list) -> None:
    """Refuse a load current on linear iron (its incremental inductances do not depend on it)."""
    if any(currents) and g.bh_rod is None and g.bh_arm is None:
        raise InputError(LOAD_OPTION, "", f"{g.source} has linear iron: the incremental inductances do "
                         "not depend on the load (give rod.bh or armature.bh, a B-H curve)")


def _first_load_outputs(s, res, out: str) -> tuple:
    """The first load's table and motor file into the output set ``s``; ``(the eq. 3 fit, the
    motor as loaded back or None, its summary or None, why it is None or "")``."""
    s.write("inductances.csv", outputs.inductances_csv(res))
    s.write("motor.toml", outputs.motor_toml(res))
    fit = outputs.eq3_fit(res)
    motor, problem = load_written(s.path("motor.toml"), Path(out) / "motor.toml")
    if motor is None:  # a valid table, but no HF sensorless control with it
        return fit, None, None, (f"{problem}; motor.toml is written but does not pass load_motor's "
                                 "checks, no lut.csv")
    return fit, motor, summarize(motor), ""


def _figures(s, g, res, motor, lut, vs_load: dict | None, luts: list) -> None:
    """The FEA's figures into the output set ``s`` (and the LUT of a usable motor file)."""
    s.write("field_lines.png", png_bytes(fig_field(res)))
    s.write("inductances_fea.png", png_bytes(fig_table(res)))
    if motor is not None:
        s.write("lut.csv", to_csv(lut))
        fig = fig_inductances(motor, f"{g.name}: table model (ABC, dq)")
        s.write("inductances_model.png", png_bytes(fig))
        s.write("lut.png", png_bytes(fig_lut(motor, lut)))
    if vs_load is not None and any(v is not None for v in luts):
        s.write("lut_vs_load.png", png_bytes(fig_lut_vs_load(g.name, vs_load, luts, g.pole_pitch)))


def _load_sweep_outputs(s, results: list, out: str, lut_points: int) -> tuple[list, dict]:
    """Per load: its table, motor file and LUT into the output set ``s`` (a LUT where the motor
    file passes); ``(the LUTs, or None, by load; fea.json's lut_vs_load)``."""
    luts = []
    for r in results:
        tag = "_" + load_tag(r.load_current)
        s.write(f"inductances{tag}.csv", outputs.inductances_csv(r))
        s.write(f"motor{tag}.toml", outputs.motor_toml(r, f"inductances{tag}.csv"))
        m, _ = load_written(s.path(f"motor{tag}.toml"), Path(out) / f"motor{tag}.toml")
        luts.append(build_lut(m, lut_points) if m is not None else None)
        if luts[-1] is not None:
            s.write(f"lut{tag}.csv", to_csv(luts[-1]))
    return luts, load_sweep(results, luts)


def _polarity_outputs(s, g, pulses: list, polarity_positions: int, level: str, workers: int,
                      progress: bool):
    """The saturation signal for polarity detection at ``pulses`` (A), into polarity.csv of the
    output set ``s``; the signal."""
    points = [-p for p in sorted(pulses, reverse=True)] + sorted(pulses)
    pbar = _Bar(points, g.name, "polarity i_d") if progress else contextlib.nullcontext(None)
    with pbar as cb:
        sig = polarity_signal(g, pulses, polarity_positions, level, workers=workers, progress=cb)
    s.write("polarity.csv", polarity_csv(sig))
    return sig


def _summary_lines(g, res, fit: dict, summ: dict | None, positions: int, vs_load: dict | None,
                   sig) -> list[str]:
    """The FEA's summary: mesh and solve, the eq. 3 fit, the PM flux and force constant (and the
    saliency and LUT peak of a usable table), the load sweep, the polarity signal."""
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
        lines.append(load_sweep_line(vs_load))
    if sig is not None:
        lines.append(polarity_line(sig))
    return lines


def fig_field(res, excitation: int = 0) -> Figure:
    """Flux lines (contours of r A_phi) of the first position, one phase at 1 A, magnets off (Fig. 4).

    Parameters
    ----------
    res : Result
        The FEA result, its first position's fields kept.
    excitation : int, optional
        The phase, 0, 1, 2 for A, B, C.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    s = res.keep["solver"]
    first = res.keep["first"]
    g = res.geometry
    mesh = s.m.mesh
    nv = mesh.p.shape[1]
    psi = first.fields["psi"][:nv, excitation]
    fig = Figure(figsize=(9, 4))
    ax = fig.subplots()
    tri = Triangulation(mesh.p[1] * 1e3, mesh.p[0] * 1e3, mesh.t.T)
    ax.tricontour(tri, psi, levels=30, colors="k", linewidths=0.6)
    z0, z1 = (g.z_arm0 - 0.5 * g.pole_pitch) * 1e3, (g.z_arm1 + 0.5 * g.pole_pitch) * 1e3
    ax.add_patch(Rectangle((g.z_arm0 * 1e3, g.r_coil * 1e3), (g.z_arm1 - g.z_arm0) * 1e3,
                           (g.r_out - g.r_coil) * 1e3, color="0.7", alpha=0.5))
    colors = {"A": "tab:red", "B": "tab:green", "C": "tab:blue"}
    for c in g.coils:
        ax.add_patch(Rectangle((c.z0 * 1e3, c.r0 * 1e3), (c.z1 - c.z0) * 1e3, (c.r1 - c.r0) * 1e3,
                               color=colors[c.phase], alpha=0.35))
        ax.text((c.z0 + c.z1) / 2 * 1e3, (c.r0 + c.r1) / 2 * 1e3, f"{c.phase}{'+' if c.sign > 0 else '-'}",
                ha="center", va="center", fontsize=7)
    x = res.positions[0]
    k = math.floor((z0 / 1e3 - x) / g.pole_pitch) - 1
    while True:
        for off, col in ((0.0, "tab:orange"), (g.pole_pitch / 2, "tab:purple")):
            zc = x + (k * g.pole_pitch + off)
            a, b = max(zc - g.magnet_length / 2, z0 / 1e3), min(zc + g.magnet_length / 2, z1 / 1e3)
            if b > a:
                ax.add_patch(Rectangle((a * 1e3, 0), (b - a) * 1e3, g.r_rod * 1e3, color=col, alpha=0.25))
        k += 1
        if x + k * g.pole_pitch > z1 / 1e3 + g.pole_pitch:
            break
    ax.set_xlim(z0, z1)
    ax.set_ylim(0, g.r_out * 1.3e3)
    ax.set_xlabel("z (mm)")
    ax.set_ylabel("r (mm)")
    what = "incremental field" if res.newton is not None else "magnets off"
    ax.set_title(f"{g.name}: flux lines, phase {'ABC'[excitation]} at 1 A ({what}), x = {x * 1e3:.1f} mm")
    ax.set_aspect("equal")
    fig.tight_layout()
    return fig


def fig_table(res) -> Figure:
    """The FEA inductances against position as computed (markers): ABC, and dq (the paper's Fig. 3).

    Parameters
    ----------
    res : Result
        The FEA result.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    theta, e, _ = outputs.table(res)
    _, dq = outputs.dq_table(res)
    deg = np.degrees(theta)
    fig = Figure(figsize=(7.5, 7.5), layout="constrained")
    axes = fig.subplots(2, 1)
    for k, name in enumerate(outputs.COLUMNS):
        axes[0].plot(deg, e[:, k] * 1e3, ".-" if k < 3 else "x--", label=name.replace("_", "$_{") + "}$")
    axes[0].set_title("(a) ABC frame: self (solid) and mutual (dashed) inductances")
    for (i, j), name in (((0, 0), "$L_d$"), ((1, 1), "$L_q$"), ((0, 1), "$L_{dq}$")):
        axes[1].plot(deg, dq[:, i, j] * 1e3, ".-", label=name)
    axes[1].set_title("(b) dq frame (Clarke, then Park at theta)")
    motor = SimpleNamespace(pole_pitch=res.geometry.pole_pitch)
    for ax in axes:
        _position_axis(ax, motor)
        ax.set_ylabel("inductance (mH)")
        ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8)
    load = f", load {res.load_current:g} A" if res.newton is not None else ""
    fig.suptitle(f"{res.geometry.name}: FEA inductances ({len(theta)} positions{load})")
    return fig


def fig_lut_vs_load(name: str, vs_load: dict, luts: list, pole_pitch: float) -> Figure:
    """Psi_LUT against position, one curve per load current (the paper's Fig. 9).

    And each load's difference from the first load's.

    Parameters
    ----------
    name : str
        Motor name, in the title.
    vs_load : dict
        :func:`linsense.fea.per_load.load_sweep`'s result.
    luts : list of Lut or None
        Each load's LUT.
    pole_pitch : float
        m.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig = Figure(figsize=(7.5, 7.0), layout="constrained")
    axes = fig.subplots(2, 1)
    ref = luts[0]
    styles = ["-", "--", ":", "-."]
    for k, (lu, i, f) in enumerate(zip(luts, vs_load["currents_A"], vs_load["force_N"], strict=True)):
        if lu is None:
            continue
        label = f"{i:g} A" + ("" if f is None else f" ({f:.0f} N)")
        th = np.degrees(np.append(lu.theta, 2 * np.pi))
        axes[0].plot(th, np.degrees(np.append(lu.values, lu.values[0])), styles[k % 4], color=f"C{k}",
                     label=label)
        if ref is not None and k > 0:
            d = np.degrees(lu.values - ref.values)
            axes[1].plot(th, np.append(d, d[0]), styles[k % 4], color=f"C{k}",
                         label=f"{label}: max {np.abs(d).max():.2g} deg")
    axes[0].set_ylabel("Ψ_LUT (electrical deg)")
    axes[0].set_title("(a) compensation LUT against load (q-axis current)")
    i0 = vs_load["currents_A"][0]
    axes[1].axhline(0.0, color="k", lw=0.8)
    axes[1].ticklabel_format(axis="y", style="plain", useOffset=False)  # no "1e-5" under the top axis
    axes[1].set_ylabel(f"Ψ_LUT − Ψ_LUT({i0:g} A) (deg)")
    axes[1].set_title(f"(b) difference from {i0:g} A")
    motor = SimpleNamespace(pole_pitch=pole_pitch)
    for ax in axes:
        _position_axis(ax, motor)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8)
    fig.suptitle(f"{name}: Psi_LUT against load (FEA, saturating iron)")
    return fig

"""The files of ``linsense fea``: inductance table, motor file, LUT, geometry, run record, figures."""

from __future__ import annotations

import json
import math

import numpy as np
import tomli_w
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from matplotlib.tri import Triangulation

from linsense.fea.solver import Result

COLUMNS = ("L_A", "L_B", "L_C", "M_AB", "M_BC", "M_CA")


def table(res: Result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta rad sorted, entries (N, 6) H, PM flux linkages (N, 3) Wb) in the order of theta."""
    order = np.argsort(res.theta)
    L = res.L[order]
    e = np.column_stack([L[:, 0, 0], L[:, 1, 1], L[:, 2, 2], L[:, 0, 1], L[:, 1, 2], L[:, 2, 0]])
    return res.theta[order], e, res.psi_pm[order]


def inductances_csv(res: Result) -> str:
    theta, e, pm = table(res)
    lines = ["theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA,psi_pm_A,psi_pm_B,psi_pm_C,x_m"]
    x = res.positions[np.argsort(res.theta)]
    for t, row, p, xx in zip(np.degrees(theta), e, pm, x, strict=True):
        lines.append(",".join(f"{v:.12g}" for v in (t, *row, *p, xx)))
    return "\n".join(lines) + "\n"


def force_constant(res: Result) -> float | None:
    """N/A per peak phase current from the PM flux linkage: ``3 pi psi_pm / pole_pitch``."""
    g = res.geometry
    if g.force_constant is not None:
        return g.force_constant
    if res.psi_pm_amplitude > 0:
        return 3 * math.pi * res.psi_pm_amplitude / g.pole_pitch
    return None


def motor_toml(res: Result, table_file: str = "inductances.csv") -> str:
    g = res.geometry
    kf = force_constant(res)
    if kf is None:
        from linsense.errors import InputError

        raise InputError(g.source, "rod.remanence", "0: no PM flux linkage to give the force constant; "
                         "set motor.force_constant in the geometry file")
    doc = {
        "motor": {"name": g.name, "R_s": g.R_s, "pole_pitch": g.pole_pitch, "force_constant": float(kf),
                  "mass": g.mass},
        "inductance": {"table": table_file},
    }
    how = "from the geometry file" if g.force_constant else "= 3 pi psi_pm / pole_pitch"
    iron = f"B-H curve, load {res.load_current:g} A q-axis" if res.newton is not None else "linear iron"
    head = (f"# written by linsense fea from {g.source} (axisymmetric FEA, {iron})\n"
            f"# force_constant {how}\n")
    return head + tomli_w.dumps(doc)


def eq3_fit(res: Result) -> dict:
    """The eq. 3 parameters fitted to the table (least squares), with standard errors."""
    from linsense.identify.fit import fit_inductances

    theta, e, _ = table(res)
    f = fit_inductances(theta, e, 1, source="fea")
    return {"values_H": f.values, "stderr_H": f.stderr, "residual_rms_H": f.residual_rms}


def fea_json(res: Result, extra: dict) -> str:
    m = res.mesh
    s = res.keep["solver"]
    doc = {
        "geometry": res.geometry.source,
        "mesh": {"level": m.level, "element_size_m": m.size, "triangles": int(m.mesh.t.shape[1]),
                 "vertices": int(m.mesh.p.shape[1]), "element": "P2 triangles", "dofs": int(s.ndofs),
                 "r_nodes": len(m.r_nodes), "z_nodes": len(m.z_nodes), "rod_aligned": m.rod_aligned},
        "positions": len(res.positions),
        "excitations_per_position": 3 + (1 if res.geometry.remanence > 0 else 0),
        "times_s": res.times,
        "energy_balance_max_rel_error": res.energy_error,  # None with a B-H curve (not checked)
        "newton_iterations": res.newton,
        "load_current_q_A": res.load_current,
        "psi_pm_amplitude_Wb": res.psi_pm_amplitude,
        "theta": {"direction": res.direction, "offset_deg": math.degrees(res.theta_offset),
                  "rule": "theta = direction * 2 pi x / pole_pitch - offset: 0 where phase A's PM flux "
                          "linkage peaks (raw position when there are no magnets)"},
        "materials": ("B-H curve (Newton; incremental inductances at the magnets' and load current's state)"
                      if res.newton is not None else "linear (no saturation)"),
        **extra,
    }
    return json.dumps(doc, indent=2) + "\n"


def fig_field(res: Result, excitation: int = 0) -> Figure:
    """Flux lines (contours of r A_phi) of the first position, one phase at 1 A, magnets off (Fig. 4)."""
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


def dq_table(res: Result) -> tuple[np.ndarray, np.ndarray]:
    """(theta rad sorted, L_dq (N, 2, 2) H) of the FEA table by the model's frame transforms
    (amplitude-invariant Clarke with a floating star point, then the rotation by theta)."""
    from linsense.model.frames import ab_to_dq_matrix, abc_to_ab_matrix

    order = np.argsort(res.theta)
    theta = res.theta[order]
    return theta, ab_to_dq_matrix(abc_to_ab_matrix(res.L[order]), theta)


def fig_table(res: Result) -> Figure:
    """The FEA inductances against position as computed (markers): ABC, and dq (the paper's Fig. 3)."""
    from types import SimpleNamespace

    from linsense.report.figures import _position_axis

    theta, e, _ = table(res)
    _, dq = dq_table(res)
    deg = np.degrees(theta)
    fig = Figure(figsize=(7.5, 7.5), layout="constrained")
    axes = fig.subplots(2, 1)
    for k, name in enumerate(COLUMNS):
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
    """Psi_LUT against position, one curve per load current (the paper's Fig. 9), and each load's
    difference from the first load's."""
    from types import SimpleNamespace

    from linsense.report.figures import _position_axis

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

"""The files of ``linsense fea``: inductance table, motor file, LUT, geometry, run record (its figures:
:mod:`linsense.report.fea`)."""

from __future__ import annotations

import json
import math

import numpy as np
import tomli_w

from linsense.fea.solver import Result
from linsense.model.frames import phase_fundamentals

COLUMNS = ("L_A", "L_B", "L_C", "M_AB", "M_BC", "M_CA")


def table(res: Result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The FEA table in the order of theta.

    Parameters
    ----------
    res : Result
        The FEA result.

    Returns
    -------
    theta : ndarray, shape (N,)
        Electrical positions, sorted, rad.
    entries : ndarray, shape (N, 6)
        ``L_A, L_B, L_C, M_AB, M_BC, M_CA``, H.
    psi_pm : ndarray, shape (N, 3)
        PM flux linkages, Wb.
    """
    order = np.argsort(res.theta)
    L = res.L[order]
    e = np.column_stack([L[:, 0, 0], L[:, 1, 1], L[:, 2, 2], L[:, 0, 1], L[:, 1, 2], L[:, 2, 0]])
    return res.theta[order], e, res.psi_pm[order]


def inductances_csv(res: Result) -> str:
    """The table as ``inductances.csv``: theta, the six entries, the PM flux linkages and the rod position.

    Parameters
    ----------
    res : Result
        The FEA result.

    Returns
    -------
    str
        The CSV text (deg, H, Wb, m; 12 significant digits).
    """
    theta, e, pm = table(res)
    lines = ["theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA,psi_pm_A,psi_pm_B,psi_pm_C,x_m"]
    x = res.positions[np.argsort(res.theta)]
    for t, row, p, xx in zip(np.degrees(theta), e, pm, x, strict=True):
        lines.append(",".join(f"{v:.12g}" for v in (t, *row, *p, xx)))
    return "\n".join(lines) + "\n"


def force_constant(res: Result) -> float | None:
    """Force constant per peak phase current from the PM flux linkage: ``3 pi psi_pm / pole_pitch``.

    The geometry file's ``motor.force_constant`` when it gives one.

    Parameters
    ----------
    res : Result
        The FEA result.

    Returns
    -------
    float or None
        N/A; None without PM flux linkage.
    """
    g = res.geometry
    if g.force_constant is not None:
        return g.force_constant
    if res.psi_pm_amplitude > 0:
        return 3 * math.pi * res.psi_pm_amplitude / g.pole_pitch
    return None


#: digits the per-phase magnet flux is written with: 1e-6 of the amplitude, 1e-4 electrical degrees
#: (the FEA's own error is far larger: a coarse and a default mesh differ by about 1e-3)
_SCALE_DIGITS, _SHIFT_DIGITS = 6, 4


def pm_phases(res: Result) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """The end effect on the magnets' flux from the FEA: each phase's PM flux fundamental.

    Least squares of ``psi_pm_k(theta) = A_k cos(theta - 2 pi k/3 + delta_k)`` over the positions
    (an exact DFT on the FEA's even grid), relative to phase A's amplitude (the FEA's
    ``psi_pm_amplitude``, whose peak fixes theta = 0): the motor file's ``[pm_flux] scale_abc`` and
    ``shift_deg_abc`` (docs/motor-files.md, docs/theory.md section 10). Phase A is ``(1, 0)`` by
    construction; the others carry the end effect.

    Parameters
    ----------
    res : Result
        The FEA result.

    Returns
    -------
    tuple or None
        ``(scale_abc, shift_deg_abc)`` (dimensionless; electrical degrees), rounded to
        :data:`_SCALE_DIGITS` and :data:`_SHIFT_DIGITS` decimals; None without magnets or with fewer
        than 3 positions.
    """
    theta, _, pm = table(res)
    if not res.psi_pm_amplitude > 0 or theta.size < 3:
        return None
    amplitude, delta = phase_fundamentals(theta, pm)
    scale = tuple(round(a / res.psi_pm_amplitude, _SCALE_DIGITS) for a in amplitude)
    shift = tuple(round(math.degrees(d), _SHIFT_DIGITS) + 0.0 for d in delta)  # (+ 0.0: no -0.0)
    return scale, shift


def motor_toml(res: Result, table_file: str = "inductances.csv") -> str:
    """The motor file of the FEA's table.

    Parameters
    ----------
    res : Result
        The FEA result.
    table_file : str, optional
        The inductance table's file name, relative to the motor file.

    Returns
    -------
    str
        The TOML text with a comment on its provenance.

    Raises
    ------
    linsense.errors.InputError
        No PM flux linkage and no ``motor.force_constant`` to give the force constant.
    """
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
    phases = pm_phases(res)
    if phases is not None:
        doc["pm_flux"] = {"scale_abc": list(phases[0]), "shift_deg_abc": list(phases[1])}
    how = "from the geometry file" if g.force_constant else "= 3 pi psi_pm / pole_pitch (phase A's)"
    iron = f"B-H curve, load {res.load_current:g} A q-axis" if res.newton is not None else "linear iron"
    head = (f"# written by linsense fea from {g.source} (axisymmetric FEA, {iron})\n"
            f"# force_constant {how}\n"
            + ("# pm_flux: each phase's PM flux fundamental relative to phase A's (the end effect on "
               "the magnets' flux)\n" if phases is not None else ""))
    return head + tomli_w.dumps(doc)


def eq3_fit(res: Result) -> dict:
    """The eq. 3 parameters fitted to the table (least squares), with standard errors.

    Parameters
    ----------
    res : Result
        The FEA result.

    Returns
    -------
    dict
        ``values_H``, ``stderr_H``, ``residual_rms_H``.
    """
    from linsense.identify.fit import fit_inductances

    theta, e, _ = table(res)
    f = fit_inductances(theta, e, 1, source="fea")
    return {"values_H": f.values, "stderr_H": f.stderr, "residual_rms_H": f.residual_rms}


def fea_json(res: Result, extra: dict) -> tuple[str, str]:
    """The texts of ``fea.json`` (mesh, energy check, Newton iterations, theta's origin) and of
    ``timing.json`` (the solve times: wall-clock, the one file of the set that is not
    byte-reproducible, :func:`linsense.io.strip_timing`).

    Parameters
    ----------
    res : Result
        The FEA result.
    extra : dict
        Further keys written as they are.

    Returns
    -------
    fea : str
        The JSON text of fea.json.
    timing : str
        The JSON text of timing.json.
    """
    from linsense.io import strip_timing

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
        "pm_phases": (None if (ph := pm_phases(res)) is None
                      else {"scale_abc": list(ph[0]), "shift_deg_abc": list(ph[1])}),
        "theta": {"direction": res.direction, "offset_deg": math.degrees(res.theta_offset),
                  "rule": "theta = direction * 2 pi x / pole_pitch - offset: 0 where phase A's PM flux "
                          "linkage peaks (raw position when there are no magnets)"},
        "materials": ("B-H curve (Newton; incremental inductances at the magnets' and load current's state)"
                      if res.newton is not None else "linear (no saturation)"),
        **extra,
    }
    kept, timing = strip_timing(doc)
    return json.dumps(kept, indent=2) + "\n", json.dumps(timing or {}, indent=2) + "\n"


def dq_table(res: Result) -> tuple[np.ndarray, np.ndarray]:
    """The FEA table's dq inductances by the model's frame transforms.

    Amplitude-invariant Clarke with a floating star point, then the rotation by theta.

    Parameters
    ----------
    res : Result
        The FEA result.

    Returns
    -------
    theta : ndarray, shape (N,)
        Sorted, rad.
    L_dq : ndarray, shape (N, 2, 2)
        H.
    """
    from linsense.model.frames import ab_to_dq_matrix, abc_to_ab_matrix

    order = np.argsort(res.theta)
    theta = res.theta[order]
    return theta, ab_to_dq_matrix(abc_to_ab_matrix(res.L[order]), theta)

"""Saturation data for magnet polarity detection at start-up.

HF injection finds the d-axis but not its direction. A d-axis current pulse along the magnets'
flux (+d) saturates the iron further and lowers the incremental d-axis inductance; a pulse against
it (-d) relieves the iron and raises it. For each amplitude I the FEA gives the incremental
inductances at ``i_d = +I`` and ``i_d = -I`` (``i_q = 0``) at a few rod positions, and the signal
``L_d(-I) - L_d(+I)``: positive with saturating iron, zero with linear iron.
"""

from __future__ import annotations

import numpy as np

from linsense.fea.geometry import Geometry
from linsense.fea.outputs import dq_table
from linsense.fea.solver import Result, run_loads

COLUMNS = ("I_A", "L_d_plus_H", "L_d_minus_H", "diff_mean_H", "diff_min_H", "rel", "L_q_plus_H",
           "L_q_minus_H", "newton_max")


def _dq_flux(res: Result) -> np.ndarray:
    """psi_d (Wb) per position in the order of theta: the Park transform of the phase flux linkages."""
    order = np.argsort(res.theta)
    th = res.theta[order]
    psi = res.psi_pm[order]
    phase = th[:, None] - np.array([0.0, 2 * np.pi / 3, -2 * np.pi / 3])
    return 2 / 3 * (psi * np.cos(phase)).sum(axis=1)


def polarity_signal(g: Geometry, currents_A, positions: int = 4, level: str = "default", workers: int = 1,
                    progress=None) -> dict:
    """The polarity signal of d-axis current amplitudes.

    At ``positions`` rod positions over one electrical period (the theta grid of
    :func:`linsense.fea.solver.run`). Linear iron goes through the same Newton solves (its signal is
    zero to the solver's precision).

    Parameters
    ----------
    g : Geometry
        The geometry.
    currents_A : iterable of float
        d-axis current amplitudes, A, distinct and positive.
    positions : int, optional
        Rod positions over one period, at least 3.
    level : str, optional
        Mesh level.
    workers : int, optional
        Parallel solves.
    progress : callable or None, optional
        Called as solves finish.

    Returns
    -------
    dict
        ``rows``: per amplitude (ascending), ``I_A``, the means over the positions of ``L_d`` and
        ``L_q`` at ``+I`` and ``-I`` (H), ``diff_mean_H`` / ``diff_min_H`` (mean and min over the
        positions of ``L_d(-I) - L_d(+I)``), ``rel`` (``diff_mean_H`` over the mean of
        ``(L_d(+I) + L_d(-I)) / 2``), ``psi_d_plus_Wb`` / ``psi_d_minus_Wb`` (the mean d-axis flux
        linkage) and the Newton iterations; and the grid, the mesh level and the rule.

    Raises
    ------
    ValueError
        Amplitudes not distinct and positive, or fewer than 3 positions.
    """
    amps = sorted(float(c) for c in currents_A)
    if not amps or any(not np.isfinite(a) or a <= 0 for a in amps) or len(set(amps)) < len(amps):
        raise ValueError(f"d-axis current amplitudes must be distinct positive numbers, got {currents_A!r}")
    if positions < 3:
        raise ValueError(f"theta's origin needs at least 3 positions, got {positions}")
    # one sweep from -I_max to +I_max: each solve starts from the neighbouring amplitude's state
    points = [(-a, 0.0) for a in amps[::-1]] + [(a, 0.0) for a in amps]
    results = run_loads(g, points, positions, level, progress=progress, keep_first=False, workers=workers,
                        force_newton=True)
    n = len(amps)
    rows = []
    for k, a in enumerate(amps):
        minus, plus = results[n - 1 - k], results[n + k]
        dq_p, dq_m = dq_table(plus)[1], dq_table(minus)[1]
        ld_p, ld_m = dq_p[:, 0, 0], dq_m[:, 0, 0]
        diff = ld_m - ld_p
        rows.append({
            "I_A": a,
            "L_d_plus_H": float(ld_p.mean()), "L_d_minus_H": float(ld_m.mean()),
            "diff_mean_H": float(diff.mean()), "diff_min_H": float(diff.min()),
            "rel": float(diff.mean() / (0.5 * (ld_p + ld_m).mean())),
            "L_q_plus_H": float(dq_p[:, 1, 1].mean()), "L_q_minus_H": float(dq_m[:, 1, 1].mean()),
            "newton_max": int(max(plus.newton["max"], minus.newton["max"])),
            "psi_d_plus_Wb": float(_dq_flux(plus).mean()), "psi_d_minus_Wb": float(_dq_flux(minus).mean()),
            "L_d_plus_by_position_H": ld_p.tolist(), "L_d_minus_by_position_H": ld_m.tolist(),
        })
    res = results[0]
    return {
        "currents_A": amps, "positions": positions, "theta_deg": np.degrees(np.sort(res.theta)).tolist(),
        "mesh_level": level, "saturating": bool(g.bh_rod or g.bh_arm), "rows": rows,
        "solve_s": float(sum(r.times["solve_s"] for r in results)),
        "rule": "i_d = +-I, i_q = 0 (theta = 0 where phase A's PM flux linkage peaks: +d along the magnets' "
                "flux); L_d incremental, Clarke (floating star) then Park at theta; diff = L_d(-I) - L_d(+I) "
                "per position (mean, min); rel = diff_mean / mean((L_d(+I) + L_d(-I)) / 2)",
    }


def polarity_csv(sig: dict) -> str:
    """The polarity signal's rows as CSV (:data:`COLUMNS`, 12 significant digits).

    Parameters
    ----------
    sig : dict
        :func:`polarity_signal`'s result.

    Returns
    -------
    str
        The CSV text.
    """
    lines = [",".join(COLUMNS)]
    for row in sig["rows"]:
        lines.append(",".join(f"{row[c]:.12g}" for c in COLUMNS))
    return "\n".join(lines) + "\n"


def polarity_line(sig: dict) -> str:
    """The polarity signal in one line, for the report.

    Parameters
    ----------
    sig : dict
        :func:`polarity_signal`'s result.

    Returns
    -------
    str
        Per amplitude: the relative signal, its mean and minimum.
    """
    parts = [f"{r['I_A']:g} A {r['rel'] * 100:.3g} % ({r['diff_mean_H'] * 1e6:.3g} uH, min "
             f"{r['diff_min_H'] * 1e6:.3g})" for r in sig["rows"]]
    return "polarity (L_d(-I) - L_d(+I), i_q = 0): " + ", ".join(parts)

"""Figures of a bench identification: measured versus fitted inductances in the ABC and dq frames
(the layout of the paper's Fig. 3) and the LUTs from the measured table and from the fit.

Only plotting lives here. The functions return :class:`matplotlib.figure.Figure` objects (built
directly, no pyplot state, no backend switch); the caller renders them
(:func:`linsense.report.figures.png_bytes`) before it writes anything.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from linsense.analysis.hf import psi_lut
from linsense.model.inductance import ENTRIES
from linsense.report.figures import _MH, _position_axis, png_bytes

_UH = 1e6


def _label(name: str) -> str:
    return name.replace("_", "$_{") + "}$"


def fig_identified_inductances(motor, measured: dict[str, np.ndarray], title: str) -> Figure:
    """Measured (markers) and fitted (lines) inductances in ABC and dq, and the fit residuals.

    Parameters
    ----------
    motor : Motor
        The fitted motor (its model draws the lines; its pole pitch the mm axis).
    measured : dict
        The ``linsense model`` columns at the measured positions
        (:func:`linsense.identify.measured_outputs.measured_columns`).
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = np.linspace(0.0, 2.0 * np.pi, 721)
    deg = np.degrees(th)
    ind = motor.inductance
    fit = ind.entries(th) * _MH
    fit_dq = ind.L_dq(th) * _MH
    mdeg = measured["theta_deg"]
    fig = Figure(figsize=(7.5, 10.0), layout="constrained")
    axes = fig.subplots(3, 1)
    for j, name in enumerate(ENTRIES):
        color = f"C{j}"
        marker = "o" if j < 3 else "^"
        axes[0].plot(deg, fit[:, j], "-", color=color, lw=1.2, label=f"{_label(name)} fit")
        axes[0].plot(mdeg, measured[name] * _MH, marker, color=color, ms=3.5, mfc="none",
                     label=f"{_label(name)} measured")
    axes[0].set_title("(a) ABC frame: self (o) and mutual (△) inductances, measured and fitted")
    dq = (("L_d", (0, 0), "$L_d$"), ("L_q", (1, 1), "$L_q$"), ("L_dq", (0, 1), "$L_{dq}$"))
    for j, (key, (r, c), lab) in enumerate(dq):
        axes[1].plot(deg, fit_dq[:, r, c], "-", color=f"C{j}", lw=1.2, label=f"{lab} fit")
        axes[1].plot(mdeg, measured[key] * _MH, "o", color=f"C{j}", ms=3.5, mfc="none",
                     label=f"{lab} measured")
    axes[1].set_title("(b) dq frame")
    for ax in axes[:2]:
        ax.set_ylabel("inductance (mH)")
    res = np.column_stack([measured[n] for n in ENTRIES]) - ind.entries(np.radians(mdeg))
    for j, name in enumerate(ENTRIES):
        axes[2].plot(mdeg, res[:, j] * _UH, "o^"[j >= 3], color=f"C{j}", ms=3, label=_label(name))
    axes[2].axhline(0.0, color="k", lw=0.8)
    axes[2].set_ylabel("measured − fit (µH)")
    axes[2].set_title("(c) fit residuals")
    for ax in axes:
        _position_axis(ax, motor)
        ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7)
    fig.suptitle(title)
    return fig


def fig_identified_luts(motor, theta_measured: np.ndarray, psi_measured: np.ndarray, lut_fit) -> Figure:
    """Psi_LUT from the measured table (markers) and from the fitted model (line and table).

    Parameters
    ----------
    motor : Motor
        The fitted motor.
    theta_measured, psi_measured : ndarray
        Measured positions and Psi_LUT there, rad.
    lut_fit : Lut
        The LUT built from the fit (``lut_fit.csv``).

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = np.linspace(0.0, 2.0 * np.pi, 721)
    fig = Figure(figsize=(7.5, 6.5), layout="constrained")
    axes = fig.subplots(2, 1, gridspec_kw={"height_ratios": [2, 1]})
    ax = axes[0]
    ax.plot(np.degrees(th), np.degrees(psi_lut(motor, th)), "b-", label="from the fit (lut_fit.csv)")
    ax.plot(np.degrees(theta_measured), np.degrees(psi_measured), "o", ms=4, mfc="none", color="C1",
            label=f"from the measured table (lut.csv, {theta_measured.size} points)")
    ax.set_ylabel("Ψ_LUT (electrical deg)")
    ax.set_title(f"Compensation LUT, motor {motor.name}")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + 0.3 * (hi - lo))  # room for the legend above the curves
    ax.legend(fontsize=8, loc="upper center", ncol=2)
    diff = np.degrees(np.angle(np.exp(1j * (psi_measured - lut_fit(theta_measured)))))
    axes[1].plot(np.degrees(theta_measured), diff, "o", ms=3, color="C1")
    axes[1].axhline(0.0, color="k", lw=0.8)
    axes[1].set_ylabel("measured − fit (deg)")
    axes[1].set_title(f"difference (max {np.abs(diff).max():.2f} deg)")
    for a in axes:
        _position_axis(a, motor)
    return fig


def identify_figure_files(ident) -> dict[str, bytes]:
    """The figures of ``linsense identify``, rendered in memory.

    Parameters
    ----------
    ident : Identification
        An :class:`~linsense.identify.identification.Identification`.

    Returns
    -------
    dict of str to bytes
        Relative path to PNG.
    """
    mo = ident.motor
    return {
        "figures/identify_inductances.png": png_bytes(fig_identified_inductances(
            mo, ident.measured, f"{mo.name}: measured (markers) and fitted (lines) inductances")),
        "figures/identify_lut.png": png_bytes(fig_identified_luts(mo, ident.table.theta, ident.psi_measured,
                                                                  ident.lut_fit)),
    }

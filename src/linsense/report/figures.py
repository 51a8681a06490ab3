"""Figures of the end-effect model (paper Figs. 5, 6, 8a, 8b, 9).

Only plotting lives here; the numbers come from :mod:`linsense.analysis` and
:mod:`linsense.compensation`. Inductances are drawn in mH, angles in electrical degrees, with a
secondary axis in mm of travel. Every ``fig_*`` function builds a :class:`matplotlib.figure.Figure`
directly (no pyplot state, no backend switch) and returns it; :func:`png_bytes` and
:func:`save_png` render one, :func:`write_model_figures` writes the whole set.
"""

from __future__ import annotations

import io
import math
from dataclasses import replace
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from linsense.analysis.hf import (
    equilibrium_error,
    loop_gain_factor,
    psi,
    psi_compensated,
    psi_lut,
    psi_lut_resistive,
    saliency,
)
from linsense.io import write_atomic
from linsense.model.inductance import ENTRIES

ERRORS_DEG = (-15, -10, -5, 0, 5, 10, 15)
_MH = 1e3
_DPI = 120


def _theta(n: int = 721) -> np.ndarray:
    return np.linspace(0.0, 2.0 * np.pi, n)


def _position_axis(ax, motor) -> None:
    ax.set_xlim(0, 360)
    ax.set_xticks(np.arange(0, 361, 60))
    ax.set_xlabel("position θ (electrical deg)")
    ax.grid(True, alpha=0.3)
    mm = motor.pole_pitch * 1e3 / 360.0
    sec = ax.secondary_xaxis("top", functions=(lambda d: d * mm, lambda x: x / mm))
    sec.set_xlabel("position x (mm)", fontsize=8)
    sec.tick_params(labelsize=7)


def png_bytes(fig: Figure, dpi: int = _DPI) -> bytes:
    """The PNG of ``fig`` (no software or date metadata: byte-reproducible).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    dpi : int, optional
        Resolution.

    Returns
    -------
    bytes
        The PNG.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    return buf.getvalue()


def save_png(fig: Figure, path: str | Path, dpi: int = _DPI) -> Path:
    """Write ``fig`` as PNG to ``path`` (atomically).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or Path
        The file.
    dpi : int, optional
        Resolution.

    Returns
    -------
    Path
        The file written.
    """
    return write_atomic(path, png_bytes(fig, dpi))


def fig_inductances(motor, title: str) -> Figure:
    """Inductances in the ABC, alpha-beta and dq frames (paper Fig. 5 / Fig. 6 layout).

    Parameters
    ----------
    motor : Motor
        The motor.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = _theta()
    deg = np.degrees(th)
    ind = motor.inductance
    e = ind.entries(th) * _MH
    L_ab = ind.L_ab(th) * _MH
    L_dq = ind.L_dq(th) * _MH
    fig = Figure(figsize=(7.5, 9.5), layout="constrained")
    axes = fig.subplots(3, 1)
    styles = ["-", "-", "-", "--", "--", "--"]
    for j, name in enumerate(ENTRIES):
        axes[0].plot(deg, e[:, j], styles[j], label=name.replace("_", "$_{") + "}$")
    axes[0].set_title("(a) ABC frame: self (solid) and mutual (dashed) inductances")
    axes[1].plot(deg, L_ab[:, 0, 0], label=r"$L_\alpha$")
    axes[1].plot(deg, L_ab[:, 1, 1], label=r"$L_\beta$")
    axes[1].plot(deg, L_ab[:, 0, 1], label=r"$L_{\alpha\beta}$")
    axes[1].set_title(r"(b) $\alpha\beta$ frame")
    axes[2].plot(deg, L_dq[:, 0, 0], label="$L_d$")
    axes[2].plot(deg, L_dq[:, 1, 1], label="$L_q$")
    axes[2].plot(deg, L_dq[:, 0, 1], label="$L_{dq}$")
    axes[2].set_title("(c) dq frame")
    for ax in axes:
        _position_axis(ax, motor)
        ax.set_ylabel("inductance (mH)")
        ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8)
    fig.suptitle(title)
    return fig


def fig_psi(motor, compensated: bool) -> Figure:
    """psi versus position for theta_err in -15..15 deg (paper Fig. 8a, or 8b if compensated).

    Parameters
    ----------
    motor : Motor
        The motor.
    compensated : bool
        Draw ``psi - Psi_LUT`` (Fig. 8b).

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = _theta()
    deg = np.degrees(th)
    fig = Figure(figsize=(7.5, 4.8), layout="constrained")
    ax = fig.subplots()
    cmap = matplotlib.colormaps["coolwarm"]
    for i, e_deg in enumerate(ERRORS_DEG):
        e = np.radians(e_deg)
        y = psi_compensated(motor, th, e) if compensated else psi(motor, th, e)
        if e_deg == 0:
            label = "θ_err = 0°" + ("" if compensated else " (= Ψ_LUT)")
            ax.plot(deg, np.degrees(y), "r--", lw=2, label=label)
        else:
            ax.plot(deg, np.degrees(y), color=cmap(i / (len(ERRORS_DEG) - 1)), label=f"θ_err = {e_deg:+d}°")
    ax.axhline(0.0, color="k", lw=0.8)
    _position_axis(ax, motor)
    ax.set_ylabel("ψ − Ψ_LUT(θ_est) (deg)" if compensated else "ψ (deg)")
    ax.set_title(
        "(b) HF current phase in the compensated frame" if compensated
        else "(a) HF current phase in the estimated frame"
    )
    ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8)
    return fig


def fig_lut(motor, lut) -> Figure:
    """The compensation LUT: model curve and the exported table points (paper Fig. 9).

    Parameters
    ----------
    motor : Motor
        The motor.
    lut : Lut
        The exported table.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = _theta()
    fig = Figure(figsize=(7.5, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(np.degrees(th), np.degrees(psi_lut(motor, th)), "b-", label="model, eq. (12)")
    ax.plot(np.degrees(lut.theta), np.degrees(lut.values), "o", ms=3, mfc="none", color="C1",
            label=f"exported table ({lut.points} points)")
    _position_axis(ax, motor)
    ax.set_ylabel("Ψ_LUT (electrical deg)")
    ax.set_title(f"Compensation LUT, motor {motor.name}")
    ax.legend(fontsize=8)
    return fig


def fig_uncompensated(motor) -> Figure:
    """Saliency, equilibrium error and loop-gain factor of the uncompensated observer.

    Parameters
    ----------
    motor : Motor
        The motor.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = _theta()
    deg = np.degrees(th)
    fig = Figure(figsize=(7.5, 8.0), layout="constrained")
    axes = fig.subplots(3, 1)
    axes[0].plot(deg, saliency(motor, th) * _MH)
    axes[0].set_ylabel("$L_q - L_d$ (mH)")
    axes[0].set_title("Saliency")
    axes[1].plot(deg, np.degrees(equilibrium_error(motor, th)), label="e* without LUT")
    axes[1].plot(deg, np.degrees(psi_lut(motor, th)), "--", label="Ψ_LUT")
    axes[1].set_ylabel("angle (electrical deg)")
    axes[1].set_title("Equilibrium estimation error of the uncompensated observer")
    axes[1].legend(fontsize=8)
    axes[2].plot(deg, loop_gain_factor(motor, th))
    axes[2].axhline(1.0, color="k", lw=0.8)
    axes[2].set_ylabel("1 + de*/dθ (-)")
    axes[2].set_title("Position-loop gain factor without LUT")
    for ax in axes:
        _position_axis(ax, motor)
    return fig


def write_model_figures(motor, lut, out_dir: str | Path) -> list[Path]:
    """Write every model figure of ``motor`` into ``out_dir``.

    ``fig5`` (no end-effect) needs a parametric model; it is skipped for tabulated ones.

    Parameters
    ----------
    motor : Motor
        The motor.
    lut : Lut
        Its exported table.
    out_dir : str or Path
        The folder.

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(out_dir)
    figs = {}
    if motor.inductance.params:
        ideal = replace(motor, inductance=motor.inductance.without_end_effect())
        figs["fig5_inductances_no_end_effect.png"] = fig_inductances(
            ideal, f"{motor.name}: model without end-effect (ΔM0 = 0)")
    figs["fig6_inductances_end_effect.png"] = fig_inductances(motor, f"{motor.name}: model with end-effect")
    figs["fig8a_psi_estimated.png"] = fig_psi(motor, compensated=False)
    figs["fig8b_psi_compensated.png"] = fig_psi(motor, compensated=True)
    figs["fig9_lut.png"] = fig_lut(motor, lut)
    figs["uncompensated_observer.png"] = fig_uncompensated(motor)
    return [save_png(fig, out / name) for name, fig in figs.items()]


def fig_commission(cal, motor) -> Figure:
    """The commissioning's table against the plant's own (docs/tuning.md, "Commissioning without a
    sensor"): the table the drive is given and, on the pulsating route, the table learned with the
    pulsating injection, with their differences from the plant's.

    Parameters
    ----------
    cal : linsense.studies.commission.Commissioning
        The commissioning.
    motor : Motor
        The plant's motor.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    m = cal.metrics
    fig = Figure(figsize=(7.5, 5.6), layout="constrained")
    top, bot = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    th = np.degrees(cal.theta)
    top.plot(th, np.degrees(cal.psi_model), "b-", lw=1.2,
             label=f"the plant's own (kappa {m['injection_quad']:g})")
    done = bool(m.get("completed", True))
    off = done and m["max_diff_deg"] > m.get("table_bound_deg", math.inf)  # (completed, the table off)
    what = ("the drive's, as the run left it (NOT commissioned)" if not done else
            "the drive's, learned (NOT commissioned: off the plant's)" if off else
            "the drive's, commissioned")
    top.plot(th, np.degrees(cal.psi_measured), "o", ms=4, mfc="none", color="C3", label=what)
    bot.plot(th, np.degrees(cal.psi_measured - cal.psi_model), "o-", ms=3, color="C3", lw=0.8,
             label="the drive's - the plant's")
    learned = getattr(cal, "psi_learned", None)
    if learned is not None:
        top.plot(th, np.degrees(cal.psi_learned_plant), "-", color="0.5", lw=1.0,
                 label="the plant's own, pulsating")
        top.plot(th, np.degrees(learned), "x", ms=4, color="C2", label="learned, pulsating")
        bot.plot(th, np.degrees(learned - cal.psi_learned_plant), "x-", ms=3, color="C2", lw=0.8,
                 label="learned - the plant's, pulsating")
    top.set_ylabel("Ψ_LUT (electrical deg)")
    bot.set_ylabel("difference (deg)")
    bot.set_xlabel("position θ (electrical deg)")
    top.legend(fontsize=7)
    bot.legend(fontsize=7)
    head = (f"DID NOT COMPLETE ({m['points_done']} of {m['points']} points, fault {m['fault']}): not a "
            "commissioned table\n" if not done else
            f"NOT WITHIN {m.get('table_bound_deg', 0.0):g} deg of the plant's table: not a commissioned "
            "table\n" if off else "")
    top.set_title(head +
                  f"Commissioning without a sensor, {m['motor']}: {m['fidelity']} inverter, dead time "
                  f"{m['dead_time_s'] * 1e6:g} µs, {m['speed_m_s']:.3g} m/s, {m['sim_s']:.3g} s\nroute "
                  f"{m['route']}, scale {m['end_effect_k']:.3f}; max |table - plant's| "
                  f"{m['max_diff_deg']:.2f} deg", fontsize=8)
    return fig


def fig_calibration(cal, motor) -> Figure:
    """The calibration's measured table against the model.

    Paper Fig. 9: LUT from the model and measured at 56 positions under sensored control.

    Parameters
    ----------
    cal : Calibration
        The calibration.
    motor : Motor
        The motor.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = _theta()
    m = cal.metrics
    fig = Figure(figsize=(7.5, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(np.degrees(th), np.degrees(psi_lut(motor, th)), "-", color="0.6", lw=1.0, label="model, eq. (12)")
    shape = m.get("injection_shape", "pulsating")
    if shape == "pulsating":
        model = psi_lut_resistive(motor, th, m["f_inj_hz"], quad=m["injection_quad"])
    else:  # (the shape's own table, on the same grid: 720 points and the first again at 360 deg)
        from linsense.compensation.lut import build_lut

        model = build_lut(motor, th.size - 1, f_inj=m["f_inj_hz"], injection=shape).values
        model = np.append(model, model[0])
    ax.plot(np.degrees(th), np.degrees(model), "b-", lw=1.2, label="model with R_s (the injection used)")
    ok = np.isfinite(cal.psi_measured)
    ax.plot(np.degrees(cal.theta[ok]), np.degrees(cal.psi_measured[ok]), "o", ms=4, mfc="none", color="C3",
            label=f"measured ({int(ok.sum())} of {m['points']} points)")
    _position_axis(ax, motor)
    ax.set_ylabel("Ψ_LUT (electrical deg)")
    md = m["max_diff_deg"]
    diff = "no point reached" if md is None else f"max |measured - model| {md:.2f} deg"
    ax.set_title(f"Calibration, motor {m['motor']}: {m['fidelity']} inverter, dead time "
                 f"{m['dead_time_s'] * 1e6:g} µs, load {m['load_n']:g} N; {diff}", fontsize=9)
    ax.legend(fontsize=8)
    return fig

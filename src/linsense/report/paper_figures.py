"""Figures of ``linsense reproduce`` drawn like the paper's (ECCE 2010, Figs. 9, 11, 12, 13) and the
figures beyond the paper on the same page.

Closed-loop runs are drawn as the paper does: measured (true) and estimated position in mm against
time, and the estimation error in electrical degrees with its equivalent in mm on a second axis.
The curves are the means of bins of whole injection periods and the error's band is its min-max
over every PWM period of a bin (:func:`linsense.report.sim_figures.result_plot_data`), so nothing
aliases. Every function returns a :class:`matplotlib.figure.Figure`; the caller saves it.
"""

from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.figure import Figure

from linsense.analysis.hf import loop_gain_factor, psi_lut, psi_lut_resistive
from linsense.report.figures import _position_axis, _theta
from linsense.report.sim_figures import result_plot_data

_LOAD_STYLE = {0: ("o", "C3"), 20: ("s", "C2"), 40: ("^", "C4")}


def fig9_luts(motor, cals: dict[float, object], f_inj: float, quad: float = 0.0) -> Figure:
    """Paper Fig. 9: the LUT from the model and the LUTs measured by the calibration at each load.

    The model's is drawn from eq. 12 and with R_s for the injection used.

    Parameters
    ----------
    motor : Motor
        The motor.
    cals : dict of float to Calibration
        Load in N to the calibration there.
    f_inj : float
        Injection frequency, Hz.
    quad : float, optional
        Elliptical share of the injection.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th = _theta()
    fig = Figure(figsize=(7.5, 4.4), layout="constrained")
    ax = fig.subplots()
    ax.plot(np.degrees(th), np.degrees(psi_lut(motor, th)), "-", color="0.55", lw=1.2,
            label="model, eq. (12)")
    ax.plot(np.degrees(th), np.degrees(psi_lut_resistive(motor, th, f_inj, quad=quad)), "b-", lw=1.2,
            label=f"model with R_s ({f_inj:g} Hz injection)")
    for load, cal in cals.items():
        marker, color = _LOAD_STYLE.get(int(round(load)), ("x", "k"))
        ok = np.isfinite(cal.psi_measured)
        md = cal.metrics.get("max_diff_deg")
        ax.plot(np.degrees(cal.theta[ok]), np.degrees(cal.psi_measured[ok]), marker, ms=4, mfc="none",
                color=color, label=f"measured, {load:g} N ({int(ok.sum())} points; max |diff| "
                                   f"{md if md is None else f'{md:.2f}'} deg)")
    _position_axis(ax, motor)
    ax.set_ylabel("Ψ_LUT (electrical deg)")
    m = next(iter(cals.values())).metrics if cals else {}
    ax.set_title(f"Fig. 9: compensation LUT, model and calibrated under sensored control "
                 f"({m.get('fidelity', '')} inverter, dead time {m.get('dead_time_s', 0) * 1e6:g} µs)",
                 fontsize=9)
    ax.legend(fontsize=7, loc="best")
    return fig


def _run_columns(fig: Figure, runs: dict[str, object], pole_pitch: float, ylim_err: float | None = None,
                 axes=None):
    """Columns of (position, error) panels, one per run in ``runs`` (title -> Result). ``axes``
    given (2 x n, :func:`fig_runs_beside`): the runs in pairs on shared scales, so the legends in
    the first column only, the y labels on the first column of a pair and the error's mm axis on
    the second."""
    light = axes is not None
    if axes is None:
        axes = fig.subplots(2, len(runs), sharex="col", squeeze=False)
    mm_per_deg = pole_pitch * 1e3 / 360.0
    for col, (title, res) in enumerate(runs.items()):
        b = result_plot_data(res).bins
        m = res.metrics
        t = b["t"]
        ax = axes[0, col]
        ax.plot(t, b["x_ref"] * 1e3, "k--", lw=0.9, label="reference")
        ax.plot(t, b["x_mean"] * 1e3, color="tab:blue", lw=1.3, label="measured")
        ax.plot(t, b["x_est"] * 1e3, color="tab:red", lw=1.0, alpha=0.85, label="estimated")
        if not light or col % 2 == 0:
            ax.set_ylabel("position (mm)")
        else:
            ax.tick_params(labelleft=False)
        reason = (m.get("unstable_reason") or "?").split(":")[0]
        verdict = "stable" if m.get("stable") else f"NOT stable: {reason}"
        if light:  # (narrow columns)
            verdict = "\n".join(textwrap.wrap(verdict, 56))
        ax.set_title(f"{title}\n{verdict}", fontsize=9)
        if not light or col == 0:
            ax.legend(fontsize=7, loc="best")
        ax = axes[1, col]
        ax.fill_between(t, np.degrees(b["err_lo"]), np.degrees(b["err_hi"]), color="tab:red", alpha=0.25,
                        lw=0, label="min-max")
        ax.plot(t, np.degrees(b["err_mean"]), color="tab:red", lw=1.0, label="mean")
        ax.axhline(0.0, color="k", lw=0.5)
        if not light or col % 2 == 0:
            ax.set_ylabel("estimation error (electrical deg)")
        else:
            ax.tick_params(labelleft=False)
        ax.set_xlabel("time (s)")
        if ylim_err:
            ax.set_ylim(-ylim_err, ylim_err)
        if not light or col % 2 == 1:
            sec = ax.secondary_yaxis("right", functions=(lambda d: d * mm_per_deg, lambda x: x / mm_per_deg))
            sec.set_ylabel("(mm)", fontsize=8)
        pk = m.get("max_abs_err_deg")
        st = m.get("steady_max_err_deg")
        ax.set_title(f"peak |error| {pk if pk is None else f'{pk:.2f}'} deg, steady "
                     f"{st if st is None else f'{st:.2f}'} deg", fontsize=8)
        if not light or col == 0:
            ax.legend(fontsize=7, loc="best")
        for a in axes[:, col]:
            a.grid(True, alpha=0.3)
    return axes


def fig_runs(runs: dict[str, object], pole_pitch: float, title: str) -> Figure:
    """Closed-loop runs side by side (paper Figs. 11-13).

    Parameters
    ----------
    runs : dict of str to Result
        Column title to run.
    pole_pitch : float
        m.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig = Figure(figsize=(4.6 * len(runs), 6.4), layout="constrained")
    _run_columns(fig, runs, pole_pitch)
    fig.suptitle(title, fontsize=10)
    return fig


def fig_runs_beside(runs: dict[str, object], pole_pitch: float, title: str) -> Figure:
    """Closed-loop runs side by side in pairs, each pair's error panels on one scale.

    ``runs`` in the order a1, b1, a2, b2, ...: e.g. the pulsating and the rotating injection with
    the table, then without it, so that the two injections compare at a glance.

    Parameters
    ----------
    runs : dict of str to Result
        Column title to run.
    pole_pitch : float
        m.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    n = len(runs)
    fig = Figure(figsize=(4.0 * n, 6.6))  # (fixed margins: a constrained layout of 8 panels costs 0.4 s)
    ratios = [x for k in range(0, n, 2) for x in ([0.22, 1.0, 1.0] if k else [1.0, 1.0])][: n + (n - 1) // 2]
    gs = fig.add_gridspec(2, len(ratios), width_ratios=ratios, left=0.045, right=0.955, top=0.87, bottom=0.08,
                          wspace=0.12, hspace=0.25)
    cols = [c for c in range(len(ratios)) if ratios[c] == 1.0]
    axes = np.empty((2, n), dtype=object)
    for k, c in enumerate(cols):
        axes[0, k] = fig.add_subplot(gs[0, c])
        axes[1, k] = fig.add_subplot(gs[1, c], sharex=axes[0, k])
    axes = _run_columns(fig, runs, pole_pitch, axes=axes)
    for c in range(0, axes.shape[1] - 1, 2):
        lo = min(axes[1, c].get_ylim()[0], axes[1, c + 1].get_ylim()[0])
        hi = max(axes[1, c].get_ylim()[1], axes[1, c + 1].get_ylim()[1])
        for a in (axes[1, c], axes[1, c + 1]):
            a.set_ylim(lo, hi)
        lo = min(axes[0, c].get_ylim()[0], axes[0, c + 1].get_ylim()[0])
        hi = max(axes[0, c].get_ylim()[1], axes[0, c + 1].get_ylim()[1])
        for a in (axes[0, c], axes[0, c + 1]):
            a.set_ylim(lo, hi)
    fig.suptitle(title, fontsize=10)
    return fig


def fig_startup(runs: list, pole_pitch_mm: float, i_min: float, bound_mm: float, title: str) -> Figure:
    """The magnet-polarity start-up from random positions.

    Above, the pulses' signed current difference ``i_diff`` against the start position, by decision
    (estimate kept, or turned by pi) and outcome (polarity right or wrong), with the decision
    threshold +-``i_min``; below, the mover's largest motion while the drive detects and in the
    position control that follows, with the bound ``bound_mm``.

    Parameters
    ----------
    runs : list of StartupRun
        The start-ups (:class:`~linsense.studies.startup_runs.StartupRun`).
    pole_pitch_mm : float
        mm.
    i_min : float
        Decision threshold, A.
    bound_mm : float
        Motion bound, mm.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig = Figure(figsize=(9.0, 6.0), layout="constrained")
    ax_i, ax_m = fig.subplots(2, 1, sharex=True)
    x0 = np.array([r.x0_mm for r in runs])
    idiff = np.array([r.i_diff_a for r in runs]) * 1e3
    flip = np.array([r.flip for r in runs], dtype=bool)
    right = np.array([r.right for r in runs], dtype=bool)
    for sel, color, label in ((~flip, "C0", "estimate kept"), (flip, "C1", "estimate turned by π")):
        ok, bad = sel & right, sel & ~right
        ax_i.plot(x0[ok], idiff[ok], "o", color=color, ms=5,
                  label=f"{label}: polarity right ({int(ok.sum())})")
        if bad.any():
            ax_i.plot(x0[bad], idiff[bad], "X", color="r", ms=8,
                      label=f"{label}: polarity WRONG ({int(bad.sum())})")
    for s in (1.0, -1.0):
        ax_i.axhline(s * i_min * 1e3, color="0.4", lw=0.8, ls="--",
                     label=f"decision threshold ±{i_min * 1e3:.1f} mA" if s > 0 else None)
    ax_i.axhline(0.0, color="k", lw=0.5)
    ax_i.set_ylabel("pulse-current difference i_diff (mA)")
    ax_i.set_title(f"polarity right in {int(right.sum())} of {len(runs)} starts", fontsize=9)
    ax_i.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    motion = np.array([r.motion_mm for r in runs])
    after = np.array([r.motion_after_mm for r in runs])
    ax_m.plot(x0, motion, "o", color="C2", ms=5, label="while detecting")
    ax_m.plot(x0, after, "s", color="C4", ms=4, mfc="none", label="first 100 ms of position control after it")
    ax_m.axhline(bound_mm, color="r", lw=0.8, ls=":", label=f"bound while detecting, {bound_mm:g} mm")
    ax_m.set_ylim(0.0, None)
    ax_m.set_ylabel("largest |x - x0| (mm)")
    ax_m.set_xlabel("true start position x0 (mm; the drive's estimate starts at 0)")
    ax_m.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    deg = 360.0 / pole_pitch_mm
    sec = ax_i.secondary_xaxis("top", functions=(lambda x: x * deg, lambda d: d / deg))
    sec.set_xlabel("electrical deg", fontsize=8)
    for ax in (ax_i, ax_m):
        ax.set_xlim(-pole_pitch_mm, pole_pitch_mm)
        ax.grid(True, alpha=0.3)
    fig.suptitle(title, fontsize=9)
    return fig


def fig_gain_factor(motor, runs: dict, peak_deg: float, title: str) -> Figure:
    """Where the uncompensated runs lose stability or not.

    The true position's electrical angle against time, beside the uncompensated loop-gain factor
    ``1 + de*/dtheta`` against angle, on a shared angle axis.

    Parameters
    ----------
    motor : Motor
        The motor.
    runs : dict of str to Result
        Label to run.
    peak_deg : float
        The factor's peak the runs approach (marked), electrical deg.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    th_deg = np.linspace(peak_deg - 180.0, peak_deg + 180.0, 1441)
    g = loop_gain_factor(motor, np.radians(th_deg))
    fig = Figure(figsize=(9.0, 4.2), layout="constrained")
    ax_g, ax_t = fig.subplots(1, 2, sharey=True, gridspec_kw={"width_ratios": [1, 2]})
    ax_g.plot(g, th_deg, "k-", lw=1.2)
    ax_g.axvline(1.0, color="0.6", lw=0.7)
    ax_g.set_xlabel("1 + de*/dθ (uncompensated)")
    ax_g.set_ylabel("true position θ (electrical deg)")
    g_pk = float(loop_gain_factor(motor, np.radians(peak_deg)))
    ax_g.plot(g_pk, peak_deg, "ro")
    ax_g.annotate(f"max {g_pk:.2f} at {peak_deg:.0f} deg", (g_pk, peak_deg), fontsize=8, xytext=(-60, 8),
                  textcoords="offset points")
    ax_g.grid(True, alpha=0.3)
    lo, hi = peak_deg - 70.0, peak_deg + 20.0
    for k, (label, res) in enumerate(runs.items()):
        b = result_plot_data(res).bins
        ang = 360.0 * b["x_mean"] / motor.pole_pitch
        ax_t.plot(b["t"], ang, color=f"C{k}", lw=1.2, label=label)
        lo, hi = min(lo, float(np.nanmin(ang)) - 5.0), max(hi, float(np.nanmax(ang)) + 5.0)
    ax_g.set_ylim(lo, hi)
    ax_t.axhline(peak_deg, color="r", lw=0.8, ls=":", label="largest loop-gain factor")
    ax_t.set_xlabel("time (s)")
    ax_t.legend(fontsize=8, loc="best")
    ax_t.grid(True, alpha=0.3)
    fig.suptitle(title, fontsize=10)
    return fig


def fig_bias(angles_deg: dict[str, np.ndarray], curves: dict[str, np.ndarray], title: str,
             motor=None) -> Figure:
    """Steady estimation error (bias) of holds against the true angle the mover settled at.

    One curve per variant (label "<variant>, dead time" / "<variant>, no dead time", solid / dashed
    in one colour): the compensated variants above, the uncompensated ones below beside the model's
    equilibrium error e*(theta) (``motor`` given).

    Parameters
    ----------
    angles_deg : dict of str to ndarray
        Per curve, the settled angles, electrical deg.
    curves : dict of str to ndarray
        Per curve, the bias, electrical deg.
    title : str
        The figure's title.
    motor : Motor or None, optional
        Draws e*(theta).

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    from linsense.analysis.hf import equilibrium_error

    fig = Figure(figsize=(10.5, 6.4), layout="constrained")
    ax_c, ax_n = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    variants: list[str] = []
    for label in curves:
        v = label.rsplit(", ", 1)[0]
        if v not in variants:
            variants.append(v)
    for label, y in curves.items():
        v, dt = label.rsplit(", ", 1)
        ax = ax_n if v.lower().startswith("no lut") else ax_c
        x = np.mod(angles_deg[label], 360.0)
        order = np.argsort(x)
        ax.plot(x[order], y[order], "-" if dt == "dead time" else "--", marker="o", ms=3,
                color=f"C{variants.index(v)}", lw=1.1, label=label)
    if motor is not None:
        th = np.linspace(0.0, 2.0 * np.pi, 721)
        ax_n.plot(np.degrees(th), np.degrees(equilibrium_error(motor, th)), color="0.5", lw=0.9,
                  label="model: e*(θ), the uncompensated equilibrium error")
    for ax in (ax_c, ax_n):
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlim(0, 360)
        ax.set_xticks(np.arange(0, 361, 60))
        ax.set_ylabel("steady error (electrical deg)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax_c.set_title("with compensation", fontsize=9)
    ax_n.set_title("without compensation (the paper's scheme)", fontsize=9)
    ax_n.set_xlabel("true position θ at rest (electrical deg)")
    fig.suptitle(title, fontsize=9)
    return fig


def fig_margins(nolut, lut, run, title: str) -> Figure:
    """The linearised motion loop against the true position's angle.

    Above, the uncompensated loop-gain factor g = 1 + de*/dθ and the observer's local gain k_e;
    below, the phase margin and the upward gain margin without the LUT and with it.

    Parameters
    ----------
    nolut : LoopAlong
        Without the LUT (:class:`~linsense.analysis.stability.LoopAlong`).
    lut : LoopAlong
        With it.
    run : tuple of (Result, float) or None
        An uncompensated run and its pole pitch (m), whose range of angles after its step is shaded.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    swing_deg = None
    if run is not None:
        res, tau = run
        x = res.x[res.t >= float(res.scenario.spec.reference.at)]
        x = x[np.isfinite(x)]
        if x.size:
            swing_deg = (float(x.min()) * 360.0 / tau, float(x.max()) * 360.0 / tau)
    fig = Figure(figsize=(8.0, 6.0), layout="constrained")
    ax_g, ax_m = fig.subplots(2, 1, sharex=True)
    ax_g.plot(nolut.theta_deg, nolut.g, "k-", lw=1.2, label="g = 1 + de*/dθ (no LUT)")
    ax_g.plot(nolut.theta_deg, nolut.k_e, "C1-", lw=1.0, label="observer gain k_e (no LUT)")
    ax_g.plot(lut.theta_deg, lut.k_e, "C1--", lw=1.0, label="observer gain k_e (LUT)")
    ax_g.axhline(1.0, color="0.6", lw=0.7)
    ax_g.set_ylabel("factor (-)")
    ax_m.plot(nolut.theta_deg, nolut.pm_deg, "C0-", lw=1.2, label="phase margin, no LUT (deg)")
    ax_m.plot(nolut.theta_deg, nolut.gm_up_db, "C3-", lw=1.2, label="gain margin, no LUT (dB)")
    ax_m.plot(lut.theta_deg, lut.pm_deg, "C0--", lw=1.0, label="phase margin, LUT (deg)")
    ax_m.plot(lut.theta_deg, lut.gm_up_db, "C3--", lw=1.0, label="gain margin, LUT (dB)")
    ax_m.axhline(0.0, color="k", lw=0.7)
    w = nolut.worst()
    if w is not None:
        ax_m.plot(w["theta_deg"], w["gm_up_db"], "ro")
        ax_m.annotate(f"{w['pm_deg']:.1f} deg, {w['gm_up_db']:.2f} dB at {w['theta_deg']:.0f} deg",
                      (w["theta_deg"], w["gm_up_db"]), xytext=(6, 4), textcoords="offset points", fontsize=8)
    ax_m.set_ylabel("margin")
    ax_m.set_xlabel("true position θ (electrical deg)")
    for ax in (ax_g, ax_m):
        if swing_deg is not None:  # (within one period, where the axis is)
            lo = swing_deg[0] - 360.0 * np.floor(swing_deg[0] / 360.0)
            ax.axvspan(lo, min(360.0, lo + swing_deg[1] - swing_deg[0]), color="tab:red", alpha=0.12,
                       label="range of the 6 mm run without the LUT" if ax is ax_g else None)
        ax.set_xlim(0, 360)
        ax.set_xticks(np.arange(0, 361, 60))
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    fig.suptitle(title, fontsize=9)
    return fig

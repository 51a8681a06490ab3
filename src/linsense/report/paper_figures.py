"""Figures of ``linsense reproduce`` drawn like the paper's (ECCE 2010, Figs. 9, 11, 12, 13) and the
figures beyond the paper on the same page.

Closed-loop runs are drawn as the paper does: measured (true) and estimated position in mm against
time, and the estimation error in electrical degrees with its equivalent in mm on a second axis.
The curves are the means of bins of whole injection periods and the error's band is its min-max
over every PWM period of a bin (:func:`linsense.report.sim_figures.result_plot_data`), so nothing
aliases. Every function returns a :class:`matplotlib.figure.Figure`; the caller saves it.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from linsense.analysis.hf import loop_gain_factor, psi_lut, psi_lut_resistive
from linsense.report.figures import _position_axis, _theta
from linsense.report.sim_figures import result_plot_data

_LOAD_STYLE = {0: ("o", "C3"), 20: ("s", "C2"), 40: ("^", "C4")}


def fig9_luts(motor, cals: dict[float, object], f_inj: float, quad: float = 0.0) -> Figure:
    """Paper Fig. 9: the LUT from the model (eq. 12, and with R_s for the injection used) and the
    LUTs measured by the calibration at each load (``cals``: load in N -> Calibration)."""
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


def _run_columns(fig: Figure, runs: dict[str, object], pole_pitch: float, ylim_err: float | None = None):
    """Columns of (position, error) panels, one per run in ``runs`` (title -> Result)."""
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
        ax.set_ylabel("position (mm)")
        reason = (m.get("unstable_reason") or "?").split(":")[0]
        verdict = "stable" if m.get("stable") else f"NOT stable: {reason}"
        ax.set_title(f"{title}\n{verdict}", fontsize=9)
        ax.legend(fontsize=7, loc="best")
        ax = axes[1, col]
        ax.fill_between(t, np.degrees(b["err_lo"]), np.degrees(b["err_hi"]), color="tab:red", alpha=0.25,
                        lw=0, label="min-max")
        ax.plot(t, np.degrees(b["err_mean"]), color="tab:red", lw=1.0, label="mean")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel("estimation error (electrical deg)")
        ax.set_xlabel("time (s)")
        if ylim_err:
            ax.set_ylim(-ylim_err, ylim_err)
        sec = ax.secondary_yaxis("right", functions=(lambda d: d * mm_per_deg, lambda x: x / mm_per_deg))
        sec.set_ylabel("(mm)", fontsize=8)
        pk = m.get("max_abs_err_deg")
        st = m.get("steady_max_err_deg")
        ax.set_title(f"peak |error| {pk if pk is None else f'{pk:.2f}'} deg, steady "
                     f"{st if st is None else f'{st:.2f}'} deg", fontsize=8)
        ax.legend(fontsize=7, loc="best")
        for a in axes[:, col]:
            a.grid(True, alpha=0.3)
    return axes


def fig_runs(runs: dict[str, object], pole_pitch: float, title: str) -> Figure:
    """Closed-loop runs side by side (paper Figs. 11-13): ``runs`` maps a column title to a Result."""
    fig = Figure(figsize=(4.6 * len(runs), 6.4), layout="constrained")
    _run_columns(fig, runs, pole_pitch)
    fig.suptitle(title, fontsize=10)
    return fig


def fig_gain_factor(motor, runs: dict, peak_deg: float, title: str) -> Figure:
    """Where the uncompensated runs lose stability or not: the true position's electrical angle
    against time (``runs``: label -> Result), beside the uncompensated loop-gain factor
    ``1 + de*/dtheta`` (brief section 4) against angle, on a shared angle axis; ``peak_deg``: the
    factor's peak the runs approach (marked)."""
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
    """Steady estimation error (bias, electrical deg) of holds against the true angle the mover
    settled at (``angles_deg``, per curve), one curve per variant (label "<variant>, dead time" /
    "<variant>, no dead time", solid / dashed in one colour): the compensated variants above, the
    uncompensated ones below beside the model's equilibrium error e*(theta) (``motor`` given)."""
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
    """The linearised motion loop against the true position's angle (:class:`~linsense.analysis.
    stability.LoopAlong`): above, the uncompensated loop-gain factor g = 1 + de*/dθ and the
    observer's local gain k_e; below, the phase margin and the upward gain margin without the LUT
    and with it; ``run``: ``(Result, pole pitch)`` of an uncompensated run whose range of angles
    after its step is shaded (or None)."""
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

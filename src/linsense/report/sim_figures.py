"""Figure of one simulation run: position, estimation error, fundamental currents, the HF current's
envelope, force.

Drawn from bins of whole injection periods (:func:`linsense.sim.stream.plot_bin`, at most 2,000
bins): the position and the error as their min-max envelope over every PWM period of a bin (the
block statistics) with the bin mean, the phase currents as their fundamental (the middle of each
bin's min-max envelope: the HF swing and the PWM ripple cancel) and the HF current as half the
envelope's width over each injection period, less the fundamental's change across it, averaged over
the bin (:func:`linsense.sim.stream.hf_envelope`: the bin's own width holds the fundamental's swing
at speed). Envelopes come from every PWM period, not from the recorded samples, so a
decimated trace never aliases (the 1 kHz injection sampled every 16 periods at 16 kHz would look
constant). The force has no block statistics: it is drawn as the bin mean of the samples only when
they resolve the injection (4 samples per injection period or more).

:func:`sim_figure` builds a :class:`matplotlib.figure.Figure` directly (no pyplot state, no
backend switch) and returns it; the caller saves it (:func:`linsense.report.figures.save_png`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from linsense.sim.stream import PlotData, plot_data

DPI = 110
_PHASES = (("a", "tab:blue"), ("b", "tab:orange"), ("c", "tab:green"))


def result_plot_data(result) -> PlotData:
    """The figure's bins of a :class:`~linsense.sim.result.Result`.

    With its block statistics when it has them.

    Parameters
    ----------
    result : Result
        The run.

    Returns
    -------
    PlotData
        The bins.
    """
    m = result.metrics
    spec = getattr(result.scenario, "spec", None)
    f_pwm = float(spec.inverter.f_pwm) if spec is not None else 16000.0
    # (the record's: a metrics-only run's scenario carries its longer blocks; the metrics' block_s is
    # their own resolution, every period)
    dec = int(spec.record.decimate) if spec is not None else 1
    inj = spec.injection if spec is not None else None
    f_inj = float(inj.frequency) if inj is not None and inj.frequency and inj.amplitude else None
    arrays = {**result.arrays(), **result.blocks()}
    return plot_data([arrays], n_rec=result.t.size, decimate=dec, f_pwm=f_pwm, f_inj=f_inj, metrics=m,
                     name=getattr(result.scenario, "name", ""))


def _fmt(v, unit: str) -> str:
    return "n/a" if v is None else f"{v:.2f} {unit}"


def sim_figure(data) -> Figure:
    """The five-panel run figure.

    Parameters
    ----------
    data : Result or PlotData
        A :class:`~linsense.sim.result.Result` or a streamed run's
        :class:`~linsense.sim.stream.PlotData`.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    if not isinstance(data, PlotData):
        data = result_plot_data(data)
    b = data.bins
    t = b["t"]
    fig = Figure(figsize=(8.0, 11.0), layout="constrained")
    axes = fig.subplots(5, 1, sharex=True)

    ax = axes[0]
    ax.plot(t, b["x_ref"] * 1e3, "k--", lw=1.0, label="reference")
    ax.fill_between(t, b["x_lo"] * 1e3, b["x_hi"] * 1e3, color="tab:blue", alpha=0.3, lw=0)
    ax.plot(t, b["x_mean"] * 1e3, color="tab:blue", lw=1.2, label="true (band: min-max)")
    ax.plot(t, b["x_est"] * 1e3, color="tab:red", lw=1.0, alpha=0.8, label="estimate")
    ax.set_ylabel("position (mm)")
    ax.legend(loc="best", fontsize=8)

    ax = axes[1]
    ax.fill_between(t, np.degrees(b["err_lo"]), np.degrees(b["err_hi"]), color="tab:red", alpha=0.3, lw=0,
                    label="min-max")
    ax.plot(t, np.degrees(b["err_mean"]), color="tab:red", lw=1.0, label="mean")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("estimation error\n(electrical deg)")
    ax.legend(loc="upper right", fontsize=7, ncol=2)

    i_lo, i_hi = b["i_lo"], b["i_hi"]
    ax = axes[2]
    for k, (ph, color) in enumerate(_PHASES):
        ax.plot(t, 0.5 * (i_lo[:, k] + i_hi[:, k]), color=color, lw=1.2, label=f"$i_{ph}$")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("phase currents,\nfundamental (A)")
    ax.legend(loc="upper right", fontsize=7, ncol=3)

    ax = axes[3]
    i_hf = b["i_hf"] if "i_hf" in b else 0.5 * (i_hi - i_lo)  # (per injection period: linsense.sim.stream)
    for k, (ph, color) in enumerate(_PHASES):
        ax.plot(t, i_hf[:, k], color=color, lw=1.0, label=f"$i_{ph}$")
    ax.set_ylim(bottom=0.0)
    ax.set_ylabel("HF and ripple current,\nhalf p-p per injection\nperiod (A)")
    ax.legend(loc="upper right", fontsize=7, ncol=3)

    ax = axes[4]
    _force_panel(ax, data, t, b)
    ax.set_ylabel("motor force (N)")
    ax.set_xlabel("time (s)")
    for a in axes:
        a.grid(True, alpha=0.3)

    fig.suptitle(_sim_title(data), fontsize=9)
    return fig


def _force_panel(ax, data, t: np.ndarray, b: dict) -> None:
    """The run figure's force panel: the mean force over each bin, or why it is not drawn (a trace
    too sparse to resolve the HF force)."""
    spi = data.samples_per_injection
    if spi is None or spi >= 4.0:
        ax.plot(t, b["force"], color="darkgreen", lw=1.2, label="mean over each bin")
        ax.legend(loc="upper right", fontsize=7)
    else:
        fit = max(1, int(spi * data.decimate / 4.0))  # the decimation giving 4 samples per injection period
        ax.text(0.5, 0.5, f"not drawn: the trace, one sample every {data.decimate} PWM periods\n"
                          f"({spi:.3g} per injection period), does not resolve the HF force "
                          f"(--decimate {fit} or less draws it)",
                ha="center", va="center", transform=ax.transAxes, fontsize=8)
        ax.set_yticks([])


def _sim_title(data) -> str:
    """The run figure's title: the run, its verdict and its metrics."""
    m = data.metrics
    bin_ms = data.bin_s * 1e3
    reason = (m.get("unstable_reason") or "?").split(":")[0]
    verdict = "stable" if m.get("stable") else f"not stable: {reason}"
    title = (f"{data.name} ({m.get('mode', '')}, {m.get('fidelity', '')}): {verdict}\n"
             f"max |err| {_fmt(m.get('max_abs_err_deg'), 'deg')} (transient "
             f"{_fmt(m.get('transient_max_err_deg'), 'deg')}, "
             f"steady {_fmt(m.get('steady_max_err_deg'), 'deg')}, bias {_fmt(m.get('bias_deg'), 'deg')}), "
             f"limit cycle {_fmt(m.get('limit_cycle_mm'), 'mm')}, "
             f"overshoot {_fmt(m.get('overshoot_mm'), 'mm')}\n"
             f"bins of {bin_ms:.3g} ms; bands and envelopes over every PWM period")
    return title


def sim_figure_png(result) -> bytes:
    """PNG bytes of :func:`sim_figure`.

    Parameters
    ----------
    result : Result or PlotData
        The run.

    Returns
    -------
    bytes
        The PNG.
    """
    from linsense.report.figures import png_bytes

    return png_bytes(sim_figure(result), DPI)


def write_sim_figure(result, path: str | Path) -> Path:
    """Write the run figure to ``path`` (atomically).

    Parameters
    ----------
    result : Result or PlotData
        The run.
    path : str or Path
        The file.

    Returns
    -------
    Path
        The file written.
    """
    from linsense.report.figures import save_png

    return save_png(sim_figure(result), path, DPI)

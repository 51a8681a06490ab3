"""Figure of one simulation run (PNG): position, estimation error, currents, force."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from linsense.io import write_atomic  # noqa: E402

_DPI = 110
_MAX_POINTS = 20000  # plotted samples per line (decimated for drawing only)


def _hf_period_samples(result) -> int:
    """Recorded samples per injection period (1 when unknown)."""
    spec = getattr(result.scenario, "spec", None)
    if spec is None or result.t.size < 2:
        return 1
    dt = float(result.t[1] - result.t[0])
    return max(1, int(round(1.0 / (spec.injection.frequency * dt))))


def _period_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over n samples (the HF injection's period): the fundamental."""
    if n <= 1 or x.size < n:
        return x
    ok = np.isfinite(x)
    m = np.convolve(np.where(ok, x, 0.0), np.ones(n) / n, mode="same")
    # no whole period around the first and last half period: not drawn
    m[: n // 2] = np.nan
    m[x.size - n // 2:] = np.nan
    return m


def sim_figure_png(result) -> bytes:
    """PNG bytes of the four-panel run figure."""
    t = result.t
    step = max(1, t.size // _MAX_POINTS)
    sl = slice(None, None, step)
    m = result.metrics
    fig, axes = plt.subplots(4, 1, figsize=(8.0, 9.5), sharex=True, constrained_layout=True)
    ax = axes[0]
    ax.plot(t[sl], result.x_ref[sl] * 1e3, "k--", lw=1.0, label="reference")
    ax.plot(t[sl], result.x[sl] * 1e3, lw=1.2, label="true")
    ax.plot(t[sl], result.x_est[sl] * 1e3, lw=1.0, alpha=0.8, label="estimate")
    ax.set_ylabel("position (mm)")
    ax.legend(loc="best", fontsize=8)
    ax = axes[1]
    ax.plot(t[sl], np.degrees(result.theta_err[sl]), lw=0.8, color="tab:red")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("estimation error\n(electrical deg)")
    ax = axes[2]
    for k, name in enumerate("abc"):
        ax.plot(t[sl], result.i_abc[sl, k], lw=0.5, label=f"$i_{name}$")
    ax.plot(t[sl], result.i_dq[sl, 1], "k", lw=0.5, alpha=0.35, label="$i_q$ (true frame)")
    n_hf = _hf_period_samples(result)
    ax.plot(t[sl], _period_mean(result.i_dq[:, 1], n_hf)[sl], "k", lw=1.2,
            label="$i_q$, mean over an HF period")
    ax.set_ylabel("current (A)")
    ax.legend(loc="upper right", fontsize=7, ncol=5)
    ax = axes[3]
    ax.plot(t[sl], result.force[sl], lw=0.5, alpha=0.35, color="tab:green", label="force")
    ax.plot(t[sl], _period_mean(result.force, n_hf)[sl], lw=1.2, color="darkgreen",
            label="mean over an HF period")
    ax.set_ylabel("motor force (N)")
    ax.legend(loc="upper right", fontsize=7)
    ax.set_xlabel("time (s)")
    for a in axes:
        a.grid(True, alpha=0.3)

    def fmt(v, unit):
        return "n/a" if v is None else f"{v:.2f} {unit}"

    name = getattr(result.scenario, "name", "")
    # the reason's first clause ("not settled (limit cycle)", "fault"): the numbers are on line two
    reason = (m.get("unstable_reason") or "?").split(":")[0]
    verdict = "stable" if m.get("stable") else f"not stable: {reason}"
    title = (f"{name} ({m.get('mode', '')}, {m.get('fidelity', '')}): {verdict}\n"
             f"max |err| {fmt(m.get('max_abs_err_deg'), 'deg')} (transient "
             f"{fmt(m.get('transient_max_err_deg'), 'deg')}, "
             f"steady {fmt(m.get('steady_max_err_deg'), 'deg')}, bias {fmt(m.get('bias_deg'), 'deg')}), "
             f"limit cycle {fmt(m.get('limit_cycle_mm'), 'mm')}, "
             f"overshoot {fmt(m.get('overshoot_mm'), 'mm')}")
    fig.suptitle(title, fontsize=9)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def write_sim_figure(result, path: str | Path) -> Path:
    """Write the run figure to ``path`` (atomically)."""
    return write_atomic(path, sim_figure_png(result))

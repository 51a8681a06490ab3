"""Figures of the built-in sweep studies (docs/sweeps.md). Each returns a Figure; callers save it."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from linsense._extras import require

if TYPE_CHECKING:
    import pandas as pd


def _label(key: str, relative: bool = False) -> str:
    return f"{key} (x base)" if relative else key


def _ordered(values) -> list:
    vals = list(dict.fromkeys(values))
    try:
        return sorted(vals)
    except TypeError:
        return vals


#: outcome of a run -> (code, colour, legend)
OUTCOMES = [("refused", "#bbbbbb", "refused by the checks"),
            ("fault", "#7a1c1c", "fault or never reached"),
            ("cycle", "#d9544d", "limit cycle"),
            ("offset", "#f0a742", "ends off the target (beyond the bound)"),
            ("stable", "#3f9b5a", "stable"),
            ("moving", "#8fb9d9", "still moving (an approach, a drift)")]


def outcome(row) -> int:
    """Index into :data:`OUTCOMES` of one sweep row (from ``stable``, ``error``, ``unstable_reason``).

    Parameters
    ----------
    row : pandas.Series or dict
        The row.

    Returns
    -------
    int
        The outcome's index.
    """
    if isinstance(row.get("error"), str):
        return 0
    if bool(row.get("stable")):
        return 4
    reason = str(row.get("unstable_reason") or "")
    if reason.startswith("not settled (still moving)"):  # (not a cycle)
        return 5
    if reason.startswith("not settled"):
        return 2
    if reason.startswith("|x - target|"):
        return 3
    return 1


def _tick(v) -> str:
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def stability_map(df: pd.DataFrame, axes: list[str], relative: dict | None = None) -> Figure:
    """The outcome of each run over the first two axes, one panel per value of the third.

    Each cell gives the limit cycle in mm.

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's rows.
    axes : list of str
        The axis keys.
    relative : dict or None, optional
        Axis key to whether its values are factors of the base value (labelled "x base").

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    isna = require("pandas", extra="sweep", feature="the sweep figures").isna
    relative = relative or {}
    kx, ky = axes[0], axes[1]
    kp = axes[2] if len(axes) > 2 else None
    panels = _ordered(df[kp]) if kp else [None]
    fig = Figure(figsize=(5.2 * len(panels), 4.4), layout="constrained")
    xs, ys = _ordered(df[kx]), _ordered(df[ky])
    cmap = ListedColormap([c for _, c, _ in OUTCOMES])
    for j, pv in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), j + 1)
        sub = df if kp is None else df[df[kp] == pv]
        grid = np.full((len(ys), len(xs)), np.nan)
        for _, r in sub.iterrows():
            i, k = ys.index(r[ky]), xs.index(r[kx])
            code = outcome(r)
            grid[i, k] = code
            lc = r.get("limit_cycle_mm")
            txt = "x" if code == 0 else ("" if lc is None or isna(lc) else f"{lc:.2f}")
            ax.text(k, i, txt, ha="center", va="center", fontsize=7)
        ax.imshow(grid, cmap=cmap, vmin=-0.5, vmax=len(OUTCOMES) - 0.5, origin="lower", aspect="auto")
        ax.set_xticks(range(len(xs)), [_tick(v) for v in xs], fontsize=8)
        ax.set_yticks(range(len(ys)), [_tick(v) for v in ys], fontsize=8)
        ax.set_xlabel(_label(kx, relative.get(kx)))
        ax.set_ylabel(_label(ky, relative.get(ky)))
        ax.set_title(f"{kp} = {pv}" if kp else "stability", fontsize=9)
    from matplotlib.patches import Patch

    fig.legend(handles=[Patch(color=c, label=lab) for _, c, lab in OUTCOMES], loc="outside lower center",
               ncols=len(OUTCOMES), fontsize=8, frameon=False)
    fig.suptitle("outcome of each run (numbers: limit cycle in mm, peak to peak in the end window)",
                 fontsize=9)
    return fig


def lut_robustness(df: pd.DataFrame, axes: list[str], relative: dict | None = None) -> Figure:
    """Steady bias and steady peak error against each parameter of the controller's motor.

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's rows.
    axes : list of str
        The axis keys.
    relative : dict or None, optional
        Axis key to whether its values are factors of the base value.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    relative = relative or {}
    fig = Figure(figsize=(3.4 * len(axes), 4.6), layout="constrained")
    ok = df[df["error"].isna()] if "error" in df else df
    for j, k in enumerate(axes):
        ax = fig.add_subplot(2, len(axes), j + 1)
        ax.scatter(ok[k], ok["bias_deg"], s=10, c=np.where(ok["stable"], "#3f9b5a", "#d9544d"))
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel("bias (el. deg)") if j == 0 else None
        ax.set_title(_label(k, relative.get(k)), fontsize=8)
        ax2 = fig.add_subplot(2, len(axes), len(axes) + j + 1)
        ax2.scatter(ok[k], ok["steady_max_err_deg"], s=10, color="#3b6fb6")
        ax2.set_xlabel("factor" if relative.get(k) else k, fontsize=8)
        ax2.set_ylabel("steady max |error| (el. deg)") if j == 0 else None
    fig.suptitle("LUT built from a motor with parameters off (green: stable, red: not)", fontsize=9)
    return fig


def injection(df: pd.DataFrame, axes: list[str], relative: dict | None = None) -> Figure:
    """Steady error and HF current against the first axis, one curve per value of the second.

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's rows.
    axes : list of str
        The axis keys.
    relative : dict or None, optional
        Axis key to whether its values are factors of the base value.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    relative = relative or {}
    kx = axes[0]
    kc = axes[1] if len(axes) > 1 else None
    fig = Figure(figsize=(9.0, 3.8), layout="constrained")
    a1, a2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    ok = df[df["error"].isna()] if "error" in df else df
    for cv in (_ordered(ok[kc]) if kc else [None]):
        sub = (ok if kc is None else ok[ok[kc] == cv]).sort_values(kx)
        lab = None if kc is None else f"{kc} = {cv:g}" if isinstance(cv, float) else f"{kc} = {cv}"
        a1.plot(sub[kx], sub["steady_max_err_deg"], "o-", ms=3, label=lab)
        a2.plot(sub[kx], sub["hf_current_a"], "o-", ms=3, label=lab)
    a1.set_xlabel(_label(kx, relative.get(kx)))
    a1.set_ylabel("steady max |error| (el. deg)")
    a2.set_xlabel(_label(kx, relative.get(kx)))
    a2.set_ylabel("HF current amplitude (A)")
    if kc:
        a1.legend(fontsize=7)
    fig.suptitle("injection against estimation error and HF current", fontsize=9)
    return fig


FIGURES = {"stability-map": stability_map, "lut-robustness": lut_robustness, "injection": injection}


def write_sweep_figure(study: str, df: pd.DataFrame, axes: list[str], relative: dict,
                       path: str | Path) -> Path:
    """Draw a built-in study's figure and save it (the ``figure`` of
    :func:`linsense.sweep.sweep_folder.sweep_to`).

    Parameters
    ----------
    study : str
        The study (a key of :data:`FIGURES`).
    df : pandas.DataFrame
        The sweep's rows.
    axes : list of str
        The swept keys.
    relative : dict
        Key -> whether the axis is a factor of the base value.
    path : str or Path
        The PNG.

    Returns
    -------
    Path
        The file written.
    """
    from linsense.report.figures import save_png

    return save_png(FIGURES[study](df, axes, relative), path, 110)

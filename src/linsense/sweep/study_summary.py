"""The built-in studies' one-line summaries (their figures: :mod:`linsense.report.sweep_figures`)."""

from __future__ import annotations

import pandas as pd


def _fmt(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _n_stable(df: pd.DataFrame) -> int:
    return int(df["stable"].fillna(False).astype(bool).sum())


def summary_line(study: str | None, df: pd.DataFrame, axes: list[str]) -> str:
    """What the sweep found, in one line.

    Parameters
    ----------
    study : str or None
        The sweep's study (its summary names what the study looks for).
    df : pandas.DataFrame
        The sweep's rows.
    axes : list of str
        The axis keys.

    Returns
    -------
    str
        Runs stable, not, refused, and the study's finding.
    """
    n = len(df)
    refused = int(df["error"].notna().sum()) if "error" in df else 0
    stable = _n_stable(df)
    base = f"{n} runs: {stable} stable, {n - stable - refused} not, {refused} refused"
    if study == "stability-map" and len(axes) > 2:
        k = axes[2]
        groups = df.groupby(k, sort=True)
        per = "; ".join(f"{k} = {_fmt(v)}: {_n_stable(g)}/{len(g)} stable" for v, g in groups)
        return f"{base}; {per}"
    ok = df[df["error"].isna()] if "error" in df else df
    if study == "lut-robustness" and not ok.empty:
        spans = ", ".join(f"{a} {ok[a].min():g}..{ok[a].max():g}" for a in axes)
        return (f"{base}; max |bias| {ok['bias_deg'].abs().max():.3g} deg, max steady |error| "
                f"{ok['steady_max_err_deg'].max():.3g} deg over {spans}")
    if study == "injection" and not ok.empty and ok["steady_max_err_deg"].notna().any():
        best = ok.loc[ok["steady_max_err_deg"].idxmin()]
        where = ", ".join(f"{a} = {_fmt(best[a])}" for a in axes)
        hf = best.get("hf_current_a")
        hf_txt = "" if hf is None or pd.isna(hf) else f", HF current {hf:.3g} A"
        return f"{base}; lowest steady |error| {best['steady_max_err_deg']:.3g} deg at {where}{hf_txt}"
    return base

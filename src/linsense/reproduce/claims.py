"""The paper's claims (ECCE 2010, Section V; ../shared/brief.md section 5 in the project's notes,
docs/reproduce.md here), each with the paper's number, ours, and whether it holds.

Each claim is judged by a stated rule on the reproduction's metrics (``metrics.json``); a claim
whose quantity is missing (a run that did not produce it) does not hold.
"""

from __future__ import annotations

import math


def _num(v) -> float | None:
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else float(v)


def _fmt(v, unit: str = "deg", nd: int = 2) -> str:
    return "n/a" if v is None else f"{v:.{nd}f} {unit}".strip()


def _stable(run: dict) -> bool:
    return bool(run.get("stable"))


def _verdict(run: dict) -> str:
    off = _num(run.get("final_offset_mm"))
    beside = f", {abs(off):.2f} mm beside the target" if off is not None and abs(off) >= 0.05 else ""
    if run.get("stable"):
        return "stable" + beside
    return "not stable (" + (run.get("unstable_reason") or "?").split(":")[0] + ")" + beside


def claims(m: dict) -> list[dict]:
    """The claim table from the reproduction's metrics ``m`` (the structure of metrics.json)."""
    out = []

    def add(claim: str, paper: str, ours: str, holds: bool, rule: str) -> None:
        out.append({"claim": claim, "paper": paper, "ours": ours, "holds": bool(holds), "rule": rule})

    peak = _num(m["lut"]["peak_deg"])
    add("Fig. 9: the compensation LUT peaks at about 4 electrical deg", "about 4 deg", _fmt(peak),
        peak is not None and abs(peak - 4.0) <= 1.0, "|peak - 4| <= 1 deg")
    f9 = m["fig9"]
    d0 = _num(f9["cal_0N_max_diff_deg"])
    add("Fig. 9: the LUT measured under sensored control agrees with the model (no load)", "agree",
        f"max |measured - model with R_s| {_fmt(d0)}", d0 is not None and d0 <= 0.5, "<= 0.5 deg")
    dl = _num(f9.get("load_max_diff_deg"))
    add("Fig. 9: the measured LUT does not depend on the load (0, 20, 40 N)", "independent of load",
        f"max |LUT(load) - LUT(0 N)| {_fmt(dl)}", dl is not None and dl <= 0.5, "<= 0.5 deg")
    for fig, step in (("fig11", 3), ("fig12", 6)):
        for var, name in (("lut", "with the LUT"), ("nolut", "without the LUT")):
            run = m[fig][var]
            want = not (fig == "fig12" and var == "nolut")
            paper = "stable" if want else "unstable"
            add(f"Fig. {fig[3:]}: a {step} mm step is {paper} {name}", paper, _verdict(run),
                _stable(run) == want, f"metrics 'stable' is {want}")
    nd = m["fig12"]["nolut_no_dead_time"]
    add("Fig. 12: the uncompensated instability is the end-effect's, not the inverter's (it persists "
        "with dead_time = 0)", "(implied: the end-effect destabilises)", _verdict(nd), not _stable(nd),
        "6 mm without the LUT, dead time 0: metrics 'stable' is False")
    on = m["fig12"].get("onset", {})
    g_at = _num(on.get("gain_max_at_deg"))
    run_at = _num(on.get("unstable_at_deg"))
    swing = on.get("swing_deg")
    ours = (f"the run swings through {swing[0]:.0f} to {swing[1]:.0f} deg" if swing else "no oscillation")
    add("Fig. 12: the uncompensated drive loses stability once the position passes about 60 deg",
        "about 60 deg", ours, run_at is not None and abs(run_at - 60.0) <= 10.0,
        "the swing's far turning point within 60 +- 10 deg")
    add("Fig. 12 (evidence): the oscillation sets in where the uncompensated loop-gain factor "
        "1 + de*/dθ is largest", "(brief section 4)",
        f"largest factor {_fmt(_num(on.get('gain_max')), '', 2)} at {_fmt(g_at, 'deg', 0)}; far turning "
        f"point {_fmt(run_at, 'deg', 0)}",
        g_at is not None and run_at is not None and abs(run_at - g_at) <= 10.0,
        "the swing's far turning point within 10 deg of the largest factor")
    lin = m["fig12"].get("linearised", {})
    w = lin.get("worst", {})
    unstable = bool(w) and (w["gm_up_db"] < 0.0 or w["pm_deg"] < 0.0 or w["max_pole_re"] > 0.0)
    ours = ("n/a" if not w else f"smallest margins {w['pm_deg']:.1f} deg / {w['gm_up_db']:.2f} dB at "
            f"{w['theta_deg']:.0f} deg ({'unstable' if unstable else 'stable, at the edge'}); with the "
            f"LUT {lin['lut']['pm_deg']:.1f} deg / {lin['lut']['gm_up_db']:.2f} dB")
    add("Fig. 12 (evidence): the linearised loop of the tuning command predicts the uncompensated "
        "instability", "(implied)", ours, unstable, "a negative margin (or an unstable pole) at some angle")
    f13 = m["fig13"]["lut"]
    pk = _num(f13.get("transient_max_err_deg"))
    add("Fig. 13: peak estimation error in the transients about 9 electrical deg (< 1.4 mm), with the LUT",
        "about 9 deg", _fmt(pk), pk is not None and pk <= 9.0, "<= 9 deg")
    ss = _num(f13.get("steady_max_err_deg"))
    add("Fig. 13: estimation error below 3 electrical deg (< 0.5 mm) at steady state, with the LUT",
        "< 3 deg", _fmt(ss), ss is not None and ss < 3.0, "< 3 deg")
    return out

"""The paper's claims (ECCE 2010, Section V; docs/reproduce.md), each with the paper's number, ours,
and whether it holds by a stated rule on the reproduction's metrics (``metrics.json``).

A claim whose evidence is missing or invalid does not hold: a calibration that did not complete,
a run that tripped on its configuration or went non-finite (not an instability of the loop).
"""

from __future__ import annotations

import math

#: faults that say nothing about the loop's stability (the run could not be judged)
_INVALID_FAULTS = ("config", "nonfinite")


def finite_or_none(v) -> float | None:
    """``v`` as a float, or None when it is missing or not finite (JSON has no NaN).

    Parameters
    ----------
    v : float or None
        The value.

    Returns
    -------
    float or None
        ``float(v)`` or None.
    """
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else float(v)


def _fmt(v, unit: str = "deg", nd: int = 2) -> str:
    return "n/a" if v is None else f"{v:.{nd}f} {unit}".strip()


def _valid(run: dict) -> bool:
    return not any(f in str(run.get("fault", "none")).split("+") for f in _INVALID_FAULTS)


def _unstable(run: dict) -> bool:
    """Not stable, and for a reason of the loop (not a configuration trip or a non-finite state)."""
    return not run.get("stable") and _valid(run)


def _verdict(run: dict) -> str:
    off = finite_or_none(run.get("final_offset_mm"))
    lc = finite_or_none(run.get("limit_cycle_mm"))
    beside = f", {abs(off):.2f} mm beside the target" if off is not None and abs(off) >= 0.05 else ""
    if run.get("stable"):
        return "stable" + beside
    cycle = f"limit cycle {lc:.2f} mm" if lc is not None else "no limit cycle measured"
    reason = (run.get("unstable_reason") or "?").split(":")[0]
    if reason.startswith("|x - target|"):
        reason = "beyond the bound"
    return f"not stable ({reason}; {cycle}{beside})"


def claims(m: dict) -> list[dict]:
    """The claim table from the reproduction's metrics (docs/reproduce.md).

    Parameters
    ----------
    m : dict
        The reproduction's metrics (the structure of metrics.json).

    Returns
    -------
    list of dict
        One per claim of the paper: ``claim``, ``paper``, ``ours``, ``holds``, ``rule``.
    """
    out = []

    def add(claim: str, paper: str, ours: str, holds: bool, rule: str) -> None:
        out.append({"claim": claim, "paper": paper, "ours": ours, "holds": bool(holds), "rule": rule})

    _fig9_claims(m, add)
    for fig, step in (("fig11", 3), ("fig12", 6)):
        for var, name in (("lut", "with the LUT"), ("nolut", "without the LUT")):
            run = m[fig][var]
            want = not (fig == "fig12" and var == "nolut")
            ok = bool(run.get("stable")) if want else _unstable(run)
            add(f"Fig. {fig[3:]}: a {step} mm step is {'stable' if want else 'unstable'} {name}",
                "stable" if want else "unstable", _verdict(run), ok,
                "the run's 'stable'" if want else "the run is not stable (and did not trip on its set-up)")
    n6, nd = m["fig12"]["nolut"], m["fig12"]["nolut_no_dead_time"]
    lc6, lcd = finite_or_none(n6.get("limit_cycle_mm")), finite_or_none(nd.get("limit_cycle_mm"))
    add("Fig. 12: the uncompensated instability is the end-effect's, not the inverter's (it persists "
        "with dead_time = 0)", "(implied)",
        f"limit cycle {_fmt(lc6, 'mm')} with the dead time, {_fmt(lcd, 'mm')} without",
        _unstable(n6) and _unstable(nd) and lc6 is not None and lcd is not None and lcd >= 0.5 * lc6,
        "both unstable; without dead time at least half the limit cycle")
    _fig12_evidence_claims(m, add)
    f13 = m["fig13"]["lut"]
    pk = finite_or_none(f13.get("transient_max_err_deg"))
    ok = pk is not None and pk <= 9.0 and _valid(f13)
    add("Fig. 13: peak estimation error in the transients about 9 electrical deg (< 1.4 mm), with the LUT",
        "about 9 deg", _fmt(pk) + (", below the paper's" if ok else ""), ok, "<= 9 deg")
    ss = finite_or_none(f13.get("steady_max_err_deg"))
    ok = ss is not None and ss < 3.0 and _valid(f13)
    add("Fig. 13: estimation error below 3 electrical deg (< 0.5 mm) at steady state, with the LUT",
        "< 3 deg", _fmt(ss), ok, "< 3 deg")
    return out


#: mm, the largest motion allowed while the start-up detects (a free, frictionless mover:
#: tests/test_startup.py's bound; docs/firmware.md measures up to 0.10 mm over 200 starts)
STARTUP_MOTION_MM = 0.15


def _err(run: dict) -> str:
    return (f"{_fmt(finite_or_none(run.get('steady_max_err_deg')))} at rest, "
            f"{_fmt(finite_or_none(run.get('transient_max_err_deg')))} in transients")


def _fig9_claims(m: dict, add) -> None:
    """Fig. 9's claims (the compensation table's peak and its calibrations), each given to ``add``."""
    peak = finite_or_none(m["lut"]["peak_deg"])
    add("Fig. 9: the compensation LUT peaks at about 4 electrical deg", "about 4 deg", _fmt(peak),
        peak is not None and abs(peak - 4.0) <= 1.0, "|peak - 4| <= 1 deg")
    f9 = m["fig9"]
    cals = f9.get("calibrations", {})
    done = all(c.get("completed") for c in cals.values()) and bool(cals)
    incomplete = ", ".join(f"{k}: {c.get('points_done')}/{c.get('points')} points, fault {c.get('fault')}"
                           for k, c in cals.items() if not c.get("completed"))
    d0 = finite_or_none(f9["cal_0N_max_diff_deg"])
    add("Fig. 9: the LUT measured under sensored control agrees with the model (no load)", "agree",
        f"max |measured - model with R_s| {_fmt(d0)}" if done else f"calibration incomplete ({incomplete})",
        done and d0 is not None and d0 <= 0.5, "every calibration completed; <= 0.5 deg")
    dl = finite_or_none(f9.get("load_max_diff_deg"))
    add("Fig. 9: the measured LUT does not depend on the load (0, 20, 40 N)", "independent of load",
        (f"max |LUT(load) - LUT(0 N)| {_fmt(dl)} (the simulator's plant is magnetically linear: "
         "the FEA with saturating iron tests the physics, docs/fea.md)") if done else
        f"calibration incomplete ({incomplete})",
        done and dl is not None and dl <= 0.5, "every calibration completed; <= 0.5 deg")


def _fig12_evidence_claims(m: dict, add) -> None:
    """The evidence of Fig. 12's instability (the onset angle, the loop-gain factor, the linearised
    loop), each claim given to ``add``."""
    n6 = m["fig12"]["nolut"]
    an = m.get("fig12_analysis", {})
    on = an.get("onset", {})
    a6, a3 = finite_or_none(on.get("reach6_deg")), finite_or_none(on.get("reach3_deg"))
    add("Fig. 12: the uncompensated drive loses stability once the position passes about 60 deg",
        "about 60 deg",
        f"the 6 mm run reaches {_fmt(a6, 'deg', 0)} and oscillates; the 3 mm run stays below "
        f"{_fmt(a3, 'deg', 0)} and settles",
        a6 is not None and a3 is not None and _unstable(n6) and bool(m["fig11"]["nolut"].get("stable"))
        and a6 >= 50.0 and a3 < 50.0,
        "the unstable run passes 50 deg (60 - 10), the stable one stays below")
    g_at, g_max = finite_or_none(on.get("gain_peak_deg")), finite_or_none(on.get("gain_max"))
    add("Fig. 12 (evidence): it sets in where the uncompensated loop-gain factor 1 + de*/dθ is largest",
        "(brief section 4)",
        f"largest factor {_fmt(g_max, '', 2)} at {_fmt(g_at, 'deg', 0)}; the 6 mm run reaches "
        f"{_fmt(a6, 'deg', 0)}, the 3 mm run {_fmt(a3, 'deg', 0)}",
        None not in (g_at, a6, a3) and abs(a6 - g_at) <= 10.0 and a3 < g_at - 10.0,
        "the unstable run reaches the peak within 10 deg, the stable one stays 10 deg short of it")
    lin = an.get("linearised", {})
    w, lw = lin.get("worst"), lin.get("lut_worst")
    unstable = bool(lin.get("any_unstable"))
    if w:
        verdict = "unstable" if unstable else "stable at every angle, at the edge there"
        ours = (f"smallest margins {w['pm_deg']:.1f} deg / {w['gm_up_db']:.2f} dB at "
                f"{w['theta_deg']:.0f} deg ({verdict})")
        if lw:
            ours += f"; with the LUT at worst {lw['pm_deg']:.1f} deg / {lw['gm_up_db']:.2f} dB"
    else:
        ours = "n/a"
    add("Fig. 12 (evidence): the linearised loop of the tuning command predicts the uncompensated "
        "instability", "(implied)", ours, unstable, "a negative margin or an unstable pole at some angle")


def claims_beyond(m: dict) -> list[dict]:
    """The claims beyond the paper (metrics.json ``claims_beyond``).

    The rotating-vector variant of Figs. 11-13 judged by the paper's (pulsating) outcome and rules,
    the rotating estimate without its table against its model, and the magnet-polarity start-up.

    Parameters
    ----------
    m : dict
        The reproduction's metrics.

    Returns
    -------
    list of dict
        As :func:`claims`.
    """
    out = []

    def add(claim: str, paper: str, ours: str, holds: bool, rule: str) -> None:
        out.append({"claim": claim, "paper": paper, "ours": ours, "holds": bool(holds), "rule": rule})

    rot = m.get("rotating")
    if rot:
        r11, r12, r13 = rot["fig11"], rot["fig12"], rot["fig13"]
        add("Fig. 11 with the rotating vector: a 3 mm step is stable with its table (psi_rot) and without it",
            "stable with and without (pulsating)",
            f"with the table {_verdict(r11['lut'])}; without {_verdict(r11['nolut'])}",
            bool(r11["lut"].get("stable")) and bool(r11["nolut"].get("stable")), "both runs' 'stable'")
        add("Fig. 12 with the rotating vector: a 6 mm step is stable with its table", "stable (pulsating)",
            f"{_verdict(r12['lut'])}; error {_err(r12['lut'])}", bool(r12["lut"].get("stable")),
            "the run's 'stable'")
        n6, nd = r12["nolut"], r12["nolut_no_dead_time"]
        lc6, lcd = finite_or_none(n6.get("limit_cycle_mm")), finite_or_none(nd.get("limit_cycle_mm"))
        reach = finite_or_none(rot.get("analysis", {}).get("reach6_deg"))
        pul = m.get("fig12", {}).get("nolut", {})
        add("Fig. 12 with the rotating vector: without its table the 6 mm step loses stability as the "
            "pulsating drive's does (the end-effect's instability, persisting with dead_time = 0)",
            f"unstable (pulsating: limit cycle {_fmt(finite_or_none(pul.get('limit_cycle_mm')), 'mm')})",
            f"reaches {_fmt(reach, 'deg', 0)}; {_verdict(n6)}; without dead time {_verdict(nd)}",
            _unstable(n6) and _unstable(nd) and lc6 is not None and lcd is not None and lcd >= 0.5 * lc6,
            "not stable, and without dead time still not stable with at least half the limit cycle "
            "(the rules of the pulsating claims)")
        f13 = r13["lut"]
        pk = finite_or_none(f13.get("transient_max_err_deg"))
        ss = finite_or_none(f13.get("steady_max_err_deg"))
        add("Fig. 13 with the rotating vector and its table: peak error in transients within the paper's "
            "9 deg, below 3 deg at rest", "about 9 deg, < 3 deg (pulsating)", f"{_fmt(pk)}, {_fmt(ss)}",
            pk is not None and ss is not None and pk <= 9.0 and ss < 3.0 and _valid(f13), "<= 9 and < 3 deg")
        chk = rot.get("analysis", {}).get("nolut_vs_model", {})
        diffs = [abs(v["error_deg"] - v["model_deg"]) for v in chk.values()
                 if None not in (finite_or_none(v.get("error_deg")), finite_or_none(v.get("model_deg")))]
        peak = finite_or_none(rot.get("analysis", {}).get("psi_rot_peak_deg"))
        add("Without its table the rotating estimate is off by the model's psi_rot (docs/theory.md) at the "
            "position the mover settles (Figs. 11-13)",
            f"(model: up to {_fmt(peak, 'deg', 1)})",
            "; ".join(f"{k}: {v['error_deg']:.2f} deg measured, {v['model_deg']:.2f} model at "
                      f"{v['true_deg']:.1f} deg" for k, v in chk.items()) or "n/a",
            len(diffs) == 3 and max(diffs) <= 1.0,
            "|measured - model| <= 1 deg in each run (mean over its last 0.3 s)")
    su = m.get("startup")
    if su:
        ok = su["right"] == su["n"] and su["faults"] == 0 and su["n"] > 0
        add(f"Start-up (LS_MODE_STARTUP): the magnet polarity is found from {su['n']} random start "
            "positions over two electrical periods", "(not in the paper)",
            f"right in {su['right']}/{su['n']} ({su['flips']} with the estimate turned by pi), smallest "
            f"|i_diff| {su['i_diff_min_a'] * 1e3:.1f} mA against the {su['i_min_a'] * 1e3:.1f} mA threshold, "
            f"detection {su['detect_s'] * 1e3:.0f} ms" + (f", {su['faults']} faults" if su["faults"] else ""),
            ok, "every start right, no fault")
        mo = finite_or_none(su.get("motion_max_mm"))
        add("Start-up: the mover hardly moves while the drive detects the polarity (free, frictionless "
            "mover, no load)", "(not in the paper)",
            f"at most {_fmt(mo, 'mm', 3)} (start at {su['worst_x0_mm']:.1f} mm); in the first 100 ms of "
            f"position control after it {_fmt(finite_or_none(su.get('motion_after_max_mm')), 'mm', 2)}",
            mo is not None and mo <= STARTUP_MOTION_MM, f"<= {STARTUP_MOTION_MM:g} mm while detecting")
    return out

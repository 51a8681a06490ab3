"""Metrics of one closed-loop run (definitions in docs/simulator.md, section "Metrics").

Every value is a finite number, a bool, a string or ``None`` (JSON ``null``, when a quantity is
not defined, e.g. the estimation error of an idle HF observer): never NaN.
"""

from __future__ import annotations

import math

import numpy as np

from linsense.sim.core import SIM_FAULT_DIVERGED, SIM_FAULT_TRAVEL

#: Fault bit -> reason (drive LS_FAULT_* in ls_protect.h / ls_drive.h, simulator LS_SIM_FAULT_*).
FAULT_NAMES = {
    0x01: "overcurrent",
    0x02: "undervoltage",
    0x04: "overvoltage",
    0x08: "observer",
    0x10: "overspeed",
    0x20: "nonfinite",
    0x40: "config",
    0x80: "encoder",
    SIM_FAULT_TRAVEL: "travel",
    SIM_FAULT_DIVERGED: "diverged",
}

#: Keys every metrics dict (and metrics.json) has.
REQUIRED_KEYS = ("stable", "max_abs_err_deg", "transient_max_err_deg", "steady_max_err_deg",
                 "final_position_mm", "overshoot_mm", "fault", "sim_s", "wall_s", "realtime_factor")


def fault_reason(bits: int) -> str:
    """``"none"`` or the names of the set bits joined by ``+`` (unknown bits in hex)."""
    bits = int(bits)
    if bits == 0:
        return "none"
    names = [n for b, n in FAULT_NAMES.items() if bits & b]
    rest = bits & ~sum(FAULT_NAMES)
    if rest:
        names.append(hex(rest))
    return "+".join(names)


def _fmax(a: np.ndarray) -> float | None:
    a = a[np.isfinite(a)]
    return float(np.max(a)) if a.size else None


def _round(v: float | None, nd: int = 6) -> float | None:
    return None if v is None or not math.isfinite(v) else round(float(v), nd)


def transient_mask(t: np.ndarray, moves, settle_s: float) -> np.ndarray:
    """True while the reference moves or within ``settle_s`` after a step or the end of a move."""
    m = np.zeros(t.shape, dtype=bool)
    for t0, t1, _, _ in moves:
        m |= (t >= t0) & (t < t1 + settle_s)
    return m


def compute_metrics(arrays: dict, *, fault: int, steps_done: int, f_pwm: float, moves, wall_s: float,
                    observer_active: bool, convergence_s: float, settle_s: float, tolerance_mm: float,
                    bound_mm: float,
                    settle_band_mm: float,
                    final_window_s: float, x_target: float) -> dict:
    """Metrics of a run. ``x_target`` (m) is the last commanded position; ``moves`` the planned
    moves ``(t0, t1, x_from, x_to)``."""
    t = arrays["t"]
    x = arrays["x"]
    sim_s = steps_done / f_pwm
    ok = np.isfinite(t)
    if fault:
        # the last sample is the state that tripped: keep it out of the error statistics
        ok[-1:] = False
    err = np.degrees(np.abs(arrays["theta_err"]))
    after = ok & (t >= convergence_s) & np.isfinite(err)
    tr = transient_mask(t, moves, settle_s)
    if observer_active:
        max_err = _fmax(err[after])
        tr_err = _fmax(err[after & tr])
        st_err = _fmax(err[after & ~tr])
    else:
        max_err = tr_err = st_err = None

    # overshoot beyond the final target, in the direction of the last move
    overshoot = 0.0
    if moves:
        t0, _, x_from, x_to = moves[-1]
        direction = np.sign(x_to - x_from)
        sel = ok & (t >= t0) & np.isfinite(x)
        if direction != 0 and np.any(sel):
            overshoot = max(0.0, float(np.max(direction * (x[sel] - x_to))) * 1e3)

    x_fin = np.isfinite(x)
    final_x = float(x[x_fin][-1]) if np.any(x_fin) else float("nan")
    # stability: no fault; bounded (end window within bound_mm of the target) and settled
    # (the position varies by less than settle_band_mm over the end window)
    reason = ""
    end_err_mm = None
    if fault:
        reason = f"fault: {fault_reason(fault)}"
    elif not np.all(np.isfinite(x)):
        reason = "non-finite position"
    else:
        win = t >= t[-1] - final_window_s
        end_err_mm = float(np.max(np.abs(x[win] - x_target))) * 1e3
        band = float(np.ptp(x[win])) * 1e3
        if end_err_mm > bound_mm:
            reason = (f"|x - target| reaches {end_err_mm:.3g} mm in the last {final_window_s:g} s "
                      f"(bound {bound_mm:g} mm)")
        elif band > settle_band_mm:
            reason = (f"not settled: x varies by {band:.3g} mm in the last {final_window_s:g} s "
                      f"(band {settle_band_mm:g} mm)")
    stable = reason == ""
    rt = sim_s / wall_s if wall_s > 0 else None
    return {
        "stable": bool(stable),
        "max_abs_err_deg": _round(max_err),
        "transient_max_err_deg": _round(tr_err),
        "steady_max_err_deg": _round(st_err),
        "final_position_mm": _round(final_x * 1e3),
        "overshoot_mm": _round(overshoot),
        "fault": fault_reason(fault),
        "sim_s": _round(sim_s, 9),
        "wall_s": _round(wall_s, 6),
        "realtime_factor": _round(rt, 2),
        # extras
        "fault_bits": int(fault),
        "fault_time_s": _round(float(t[-1]), 9) if fault and t.size else None,
        "unstable_reason": reason or None,
        "target_mm": _round(x_target * 1e3),
        "final_error_mm": _round(end_err_mm),
        "accurate": bool(stable and end_err_mm is not None and end_err_mm <= tolerance_mm),
        "steps": int(steps_done),
        "samples": int(t.size),
    }

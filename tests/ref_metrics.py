"""The first, mask-based implementation of ``compute_metrics`` (linsense 0.x, before the sweep made
its cost matter): kept as the reference the faster one in linsense.sim.metrics is tested against
(tests/test_sim_metrics.py, random runs with faults, non-finite samples and moves). Its bounds
became electrical degrees with the fast one's (issue 22): the pole pitch converts them, and the
position metrics are given in degrees beside mm."""

from __future__ import annotations

import math

import numpy as np

from linsense.sim.metrics import fault_reason


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


def settling_time(t: np.ndarray, x: np.ndarray, x_to: float, t0: float, band: float,
                  x_hi: np.ndarray | None = None) -> float | None:
    """Time (s) from ``t0`` after which ``|x - x_to| <= band`` holds to the end; None if it does
    not hold at the last sample. With ``x_hi``, ``x`` and ``x_hi`` are each sample's block minimum
    and maximum (the time then has the resolution of a block)."""
    sel = t >= t0
    if not np.any(sel):
        return None
    dev = np.abs(x[sel] - x_to)
    if x_hi is not None:
        dev = np.maximum(dev, np.abs(x_hi[sel] - x_to))
    out = dev > band
    if out[-1]:
        return None
    if not np.any(out):
        return 0.0
    last_out = np.flatnonzero(out)[-1]
    return float(t[sel][last_out + 1] - t0)


def compute_metrics_ref(arrays: dict, *, fault: int, steps_done: int, f_pwm: float, moves, wall_s: float,
                        observer_active: bool, convergence_s: float, settle_s: float, pole_pitch: float,
                        tolerance_deg: float, bound_deg: float, settle_band_deg: float,
                        settling_band_deg: float, final_window_s: float, x_target: float,
                        x_start: float) -> dict:
    """Metrics of a run. ``x_target`` (m) is the last commanded position, ``x_start`` (m) the initial
    one; ``moves`` the planned moves ``(t0, t1, x_from, x_to)``. Definitions: docs/simulator.md."""
    deg_per_m = 360.0 / pole_pitch
    t = arrays["t"]
    # each sample's block: lowest, highest and mean value (the point value itself without blocks)
    x = arrays.get("x_mean", arrays.get("x"))
    x_lo, x_hi = arrays.get("x_min", x), arrays.get("x_max", x)
    e_pt = arrays.get("theta_err", arrays.get("err_mean"))
    e_lo = np.degrees(arrays.get("err_min", e_pt))
    e_hi = np.degrees(arrays.get("err_max", e_pt))
    err_signed = np.degrees(arrays.get("err_mean", e_pt))
    sim_s = steps_done / f_pwm
    ok = np.isfinite(t)
    if fault:
        # the last sample is the state that tripped: keep it out of the error statistics
        ok[-1:] = False
    err = np.maximum(np.abs(e_lo), np.abs(e_hi))
    good = ok & np.isfinite(err)
    after = good & (t >= convergence_s)
    tr = transient_mask(t, moves, settle_s)
    t_end = float(t[ok][-1]) if np.any(ok) else 0.0
    win = ok & (t >= t_end - final_window_s)
    if observer_active:
        max_err = _fmax(err[good])
        tr_err = _fmax(err[after & tr])
        st_err = _fmax(err[after & ~tr])
        bias = float(np.mean(err_signed[win & good])) if np.any(win & good) else None
    else:
        max_err = tr_err = st_err = bias = None

    # the final window: limit cycle (peak to peak of the true position) and offset from the target
    x_fin = np.isfinite(x_lo) & np.isfinite(x_hi) & np.isfinite(x)
    x_last = arrays.get("x", x)  # the point value at the last sample (the block mean without it)
    final_x = float(x_last[x_fin][-1]) if np.any(x_fin) else float("nan")
    wsel = win & x_fin
    xw = x[wsel]
    limit_cycle = float(np.max(x_hi[wsel]) - np.min(x_lo[wsel])) if xw.size else None  # m
    end_err = float(max(np.max(np.abs(x_lo[wsel] - x_target)),
                        np.max(np.abs(x_hi[wsel] - x_target)))) if xw.size else None
    offset = float(np.mean(xw - x_target)) if xw.size else None

    # the last move: overshoot beyond the reference (not counting the steady offset), settling time,
    # and whether the drive reached the reference region at all
    overshoot, reached = 0.0, True
    t_last = moves[-1][0] if moves else 0.0
    if moves:
        t0, _, x_from, x_to = moves[-1]
        direction = np.sign(x_to - x_from)
        sel = ok & (t >= t0) & x_fin
        if direction != 0 and np.any(sel):
            x_far = x_hi if direction > 0 else x_lo  # the block's extreme in the move's direction
            peak = float(np.max(direction * (x_far[sel] - x_to)))
            steady = max(0.0, float(direction) * offset) if offset is not None else 0.0
            overshoot = max(0.0, peak - steady)
        dist = abs(x_to - x_from)
        if dist > 0 and np.any(sel):
            # at some time the true position came within half the move (and the bound) of the target
            # (a block whose range contains the target came within 0 of it)
            gap = np.maximum(np.maximum(x_lo[sel] - x_to, x_to - x_hi[sel]), 0.0) if x_lo is not x_hi \
                else np.abs(x[sel] - x_to)
            closest = float(np.min(gap))
            reached = closest * deg_per_m <= min(0.5 * dist * deg_per_m, bound_deg)
    x_to = moves[-1][3] if moves else x_target
    t_from = moves[-1][0] if moves else 0.0
    s_sel = ok & x_fin
    settle_t = settling_time(t[s_sel], x_lo[s_sel], x_to, t_from, settling_band_deg / deg_per_m,
                             None if x_lo is x_hi else x_hi[s_sel])

    def deg(v):
        return None if v is None else v * deg_per_m

    def mm(v):
        return None if v is None else v * 1e3

    # stability: no fault; finite; reached the reference region; bounded (end window within
    # bound_deg of the target) and settled (true position varies by at most settle_band_deg there)
    # (issue 23: the run holds its moves and an end window after them, or the verdict says why not)
    verdict, why = "", ""
    t_run = sim_s
    if fault and t.size:
        t_run = min(sim_s, float(t[-1]))
    if moves and moves[-1][0] >= t_run:
        reached, verdict = False, "not reached"
        why = (f"the run ends at {t_run:.6g} s, before the commanded move at {moves[-1][0]:.6g} s "
               f"(scenario.duration, reference.at)")
    else:
        t_move = max([m[1] for m in moves] + [0.0])
        if t_run < final_window_s or (moves and t_run - final_window_s < t_move):
            verdict = "too short"
            why = (f"the end window ({final_window_s:g} s, metrics.final_window_s) needs the run "
                   f"({t_run:.6g} s) to last at least {t_move + final_window_s:.6g} s")
            if moves:
                why += f" (the last move ends at {t_move:.6g} s)"
    reason = ""
    if fault:
        reason = f"fault: {fault_reason(fault)}"
    elif verdict:
        reason = f"{verdict}: {why}"
    elif not np.all(x_fin):
        reason = "non-finite position"
    elif not reached:
        move = abs(moves[-1][3] - moves[-1][2])
        reason = (f"never reached the target: the true position came no closer than half the move "
                  f"({deg(move):.3g} deg, {mm(move):.3g} mm)")
    elif end_err is None:
        reason = "no samples in the end window"
    elif deg(end_err) > bound_deg:
        reason = (f"|x - target| reaches {deg(end_err):.3g} deg ({mm(end_err):.3g} mm) in the last "
                  f"{final_window_s:g} s (bound {bound_deg:g} deg)")
    elif deg(limit_cycle) > settle_band_deg:
        reason = (f"not settled (limit cycle): x varies by {deg(limit_cycle):.3g} deg "
                  f"({mm(limit_cycle):.3g} mm) in the last {final_window_s:g} s "
                  f"(tolerance {settle_band_deg:g} deg)")
    stable = reason == ""
    verdict = verdict or ("stable" if stable else "unstable")
    rt = sim_s / wall_s if wall_s > 0 else None
    return {
        "stable": bool(stable),
        "verdict": verdict,
        "max_abs_err_deg": _round(max_err),
        "transient_max_err_deg": _round(tr_err),
        "steady_max_err_deg": _round(st_err),
        "bias_deg": _round(bias),
        "limit_cycle_mm": _round(mm(limit_cycle)),
        "limit_cycle_deg": _round(deg(limit_cycle)),
        "settling_time_s": _round(settle_t),
        "final_position_mm": _round(final_x * 1e3),
        "overshoot_mm": _round(mm(overshoot)),
        "overshoot_deg": _round(deg(overshoot)),
        "fault": fault_reason(fault),
        "sim_s": _round(sim_s, 9),
        "wall_s": _round(wall_s, 6),
        "realtime_factor": _round(rt, 2),
        # the windows the figures above cover (s): the whole run for max_abs_err_deg; transient and
        # steady from convergence_s on; bias and limit cycle over the end window
        "max_abs_err_window_s": [0.0, _round(t_end, 9)],
        "errors_from_s": _round(convergence_s, 9),
        "final_window_s": [_round(max(0.0, t_end - final_window_s), 9), _round(t_end, 9)],
        "settling_from_s": _round(t_last, 9),
        # extras
        "fault_bits": int(fault),
        "fault_time_s": _round(float(t[-1]), 9) if fault and t.size else None,
        "unstable_reason": reason or None,
        "target_mm": _round(x_target * 1e3),
        "start_mm": _round(x_start * 1e3),
        "final_error_mm": _round(mm(end_err)),
        "final_error_deg": _round(deg(end_err)),
        "final_offset_mm": _round(mm(offset)),
        "final_offset_deg": _round(deg(offset)),
        "reached": bool(reached),
        "accurate": bool(stable and end_err is not None and deg(end_err) <= tolerance_deg),
        "steps": int(steps_done),
        "samples": int(t.size),
        "pole_pitch_mm": _round(pole_pitch * 1e3),
    }

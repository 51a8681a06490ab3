"""A reference for ``linsense.sim.metrics.compute_metrics``, written from docs/simulator.md
("Metrics (metrics.json)" and "Block statistics"), not from the code it checks.

It shares nothing with ``linsense.sim.metrics``: no import from it, its own fault names (read from
the C headers the docs name, ls_protect.h / ls_drive.h / ls_sim.h), and a different way to the same
numbers: each window is a boolean selection by time over a list of per-sample records, each
statistic a plain reduction over the samples it selects. tests/test_sim_metrics.py compares the two
on hundreds of random runs (steps, moves, faults, NaN and inf samples, blocks, windows longer than
the run).

The documented definitions, as this module reads them (an electrical degree is
``360 / pole_pitch`` per metre; errors are ``theta_err`` in degrees; positions the true position):

* Samples: when a fault stopped the run, the last sample (the state that tripped) is left out of
  every statistic; so is every sample from the first non-finite time on. A sample's error is its
  block envelope ``max(|err_min|, |err_max|)`` (the point value without blocks), its position the
  block's ``[x_min, x_max]`` and mean ``x_mean`` (the point value ``x`` without blocks); a sample
  whose error (position) is not finite has none.
* ``t_end``: the time of the last sample kept (0 without one). Windows are half-open in time
  where they end before the run does: the transient window of a move is ``[t0, t1 + settle_s)``;
  the end window ``[t_end - final_window_s, t_end]``; the error windows start at ``convergence_s``
  and the last move's at its start ``t0`` (a sample at exactly a window's start belongs to it).
* ``max_abs_err_deg``: max error over every sample; ``transient_max_err_deg`` /
  ``steady_max_err_deg``: over the samples from ``convergence_s`` on, inside / outside every
  transient window; ``bias_deg``: mean of ``err_mean`` over the end window's samples with an
  error. ``None`` without an active observer or without a sample.
* End window: ``limit_cycle`` = max(x_max) - min(x_min); ``final_error`` = max |x_min|, |x_max| -
  target; ``final_offset`` = mean(x_mean - target) (samples with a position).
* Last move ``(t0, t1, x_from, x_to)``, samples from ``t0`` with a position: ``overshoot`` =
  ``max(0, max(s (x_far - x_to)) - max(0, s offset))`` with ``s`` the move's sign and ``x_far`` the
  block's extreme in that direction (0 for a move of no length); ``reached``: the closest approach
  to ``x_to`` (0 for a block whose range holds it) is within half the move and within
  ``bound_deg`` (not reached when no sample follows the move's start: linsense.sim.metrics says
  reached there, the one disagreement: test_sim_metrics.py::test_reached_needs_a_sample_after_the_move);
  ``settling_time_s``: from ``t0`` (0 and the target without moves), the time of
  the first sample after the last one whose block leaves ``x_to +- settling_band`` (0 if none
  does; None if the last one does).
* Verdict, in this order: a fault (``fault``, the reason naming it and the time of the last
  sample); ``not reached`` (the last move starts at or after the run's end, ``steps / f_pwm``;
  ``reached`` is false then, also with a fault, the end ``min(steps / f_pwm, t[-1])``); ``too
  short`` (the run is shorter than the end window, or the end window starts before the last move
  ends or before a step load); a non-finite position anywhere; the target never approached; the
  end window beyond ``bound_deg``; beyond ``settle_band_deg`` of peak to peak there, ``still
  moving`` (the position, ``x_mean``, never back by more than half ``settle_band`` from the
  farthest it went one way, or rings down: its peak to peak over the window's second half within
  ``settle_band`` and at most half the first half's) or else ``limit cycle``. ``accurate``: stable
  and ``final_error <= tolerance_deg``.
* ``final_position_mm``: the point ``x`` of the last recorded sample whose position is finite
  (the tripped one included: "x at the last recorded sample", and never NaN).
* Every float is rounded (6 decimals, times 9, the realtime factor 2); non-finite -> None.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

_CSRC = Path(__file__).resolve().parents[1] / "csrc"
#: the fault reasons in the order docs/simulator.md lists them, and the header macro of each
_DOC_FAULTS = ("overcurrent", "undervoltage", "overvoltage", "observer", "overspeed", "nonfinite",
               "config", "encoder", "travel", "diverged")


def _fault_bits() -> list[tuple[int, str]]:
    """(bit, reason) for each documented reason, the bits read from the C headers."""
    api = _CSRC / "include" / "linsense"
    headers = (api / "ls_protect.h", api / "ls_drive.h", _CSRC / "sim" / "ls_sim.h")
    text = "".join(p.read_text() for p in headers)
    found = re.finditer(r"#define LS_(?:SIM_)?FAULT_(\w+)\s+0x([0-9a-fA-F]+)u", text)
    bits = {m[1].lower(): int(m[2], 16) for m in found}
    return [(bits[name], name) for name in _DOC_FAULTS]


FAULTS = _fault_bits()


def fault_text(bits: int) -> str:
    """``none``, or the documented reasons of the set bits joined by ``+`` (any other bits in hex)."""
    if bits == 0:
        return "none"
    names = [name for bit, name in FAULTS if bits & bit]
    known = 0
    for bit, _ in FAULTS:
        known |= bit
    if bits & ~known:
        names.append(hex(bits & ~known))
    return "+".join(names)


def _num(v, nd: int = 6):
    if v is None:
        return None
    v = float(v)
    return round(v, nd) if math.isfinite(v) else None


def _max(values: list[float]) -> float | None:
    values = [v for v in values if math.isfinite(v)]
    return max(values) if values else None


def _mean(values: list[float]) -> float | None:
    return float(np.mean(values)) if values else None


def _motion(xs: list[float], back: float, band: float) -> tuple[str, str]:
    """The end window's motion of a run not settled there, by the docs: "still moving" when the
    position never comes back by more than ``back`` from the farthest it had gone in one direction
    (or in the other), or when its peak to peak over the window's second half is within ``band``
    and at most half the first half's; else "limit cycle"."""
    one_way = "moves one way only (an approach or a drift),"
    if len(xs) < 2:
        return "still moving", one_way
    up = down = True
    hi = lo = xs[0]
    for v in xs:
        hi, lo = max(hi, v), min(lo, v)
        up = up and hi - v <= back
        down = down and v - lo <= back
    if up or down:
        return "still moving", one_way
    h = len(xs) // 2
    first, second = xs[:h], xs[h:]
    p1, p2 = max(first) - min(first), max(second) - min(second)
    if h > 1 and p2 <= band and p2 <= 0.5 * p1:
        return "still moving", "rings down (within the tolerance over the window's second half),"
    return "limit cycle", "varies"


def compute_metrics_ref(arrays: dict, *, fault: int, steps_done: int, f_pwm: float, moves, wall_s: float,
                        observer_active: bool, convergence_s: float, settle_s: float, pole_pitch: float,
                        tolerance_deg: float, bound_deg: float, settle_band_deg: float,
                        settling_band_deg: float, final_window_s: float, x_target: float,
                        x_start: float, load_step_s: float | None = None) -> dict:
    """The metrics of a run by the definitions above (the arguments of ``compute_metrics``)."""
    deg = 360.0 / pole_pitch  # electrical degrees per metre
    to_deg = 180.0 / math.pi  # (radians -> degrees: the constant np.degrees multiplies by)
    blocks = "x_min" in arrays
    t = [float(v) for v in arrays["t"]]
    n = len(t)
    x_pt = arrays["x"]
    x_mean = arrays["x_mean"] if blocks else x_pt
    x_min = arrays["x_min"] if blocks else x_pt
    x_max = arrays["x_max"] if blocks else x_pt
    e_pt = arrays["theta_err"] if "theta_err" in arrays else arrays["err_mean"]
    e_min = arrays.get("err_min", e_pt)
    e_max = arrays.get("err_max", e_pt)
    e_mean = arrays.get("err_mean", e_pt)

    # the samples kept: not the one that tripped, none from a non-finite time on
    kept = n - 1 if (fault and n) else n
    for i in range(kept):
        if not math.isfinite(t[i]):
            kept = i
            break
    samples = []  # one record per kept sample
    for i in range(kept):
        pos = (float(x_min[i]), float(x_max[i]), float(x_mean[i]))
        lo, hi = float(e_min[i]), float(e_max[i])
        err = max(abs(lo), abs(hi)) if math.isfinite(lo) and math.isfinite(hi) else math.nan
        samples.append({
            "t": t[i],
            "pos": pos if all(math.isfinite(p) for p in pos) else None,
            "err": err * to_deg if math.isfinite(err) else None,
            "err_mean": float(e_mean[i]) * to_deg,
        })
    t_end = samples[-1]["t"] if samples else 0.0
    in_end = [s for s in samples if s["t"] >= t_end - final_window_s]

    # estimation errors
    if observer_active:
        def transient(tt: float) -> bool:
            return any(t0 <= tt < t1 + settle_s for t0, t1, _, _ in moves)

        errs = [s for s in samples if s["err"] is not None]
        later = [s for s in errs if s["t"] >= convergence_s]
        max_err = _max([s["err"] for s in errs])
        tr_err = _max([s["err"] for s in later if transient(s["t"])])
        st_err = _max([s["err"] for s in later if not transient(s["t"])])
        bias = _mean([s["err_mean"] for s in in_end if s["err"] is not None])
    else:
        max_err = tr_err = st_err = bias = None

    # the end window's positions
    target = x_target
    w = [s["pos"] for s in in_end if s["pos"] is not None]
    if w:
        limit_cycle = max(p[1] for p in w) - min(p[0] for p in w)
        final_error = max(max(abs(p[0] - target), abs(p[1] - target)) for p in w)
        offset = _mean([p[2] - target for p in w])
    else:
        limit_cycle = final_error = offset = None

    # the last move
    t_from = moves[-1][0] if moves else 0.0
    x_to = moves[-1][3] if moves else x_target
    after = [s for s in samples if s["t"] >= t_from and s["pos"] is not None]
    overshoot, reached = 0.0, True
    if moves:
        x_from = moves[-1][2]
        s_dir = 1.0 if x_to > x_from else (-1.0 if x_to < x_from else 0.0)
        if s_dir != 0.0 and after:
            far = [(p["pos"][1] if s_dir > 0 else p["pos"][0]) for p in after]
            beyond = max(s_dir * (v - x_to) for v in far)
            steady = max(0.0, s_dir * offset) if offset is not None else 0.0
            overshoot = max(0.0, beyond - steady)
        half = 0.5 * abs(x_to - x_from)
        if half > 0.0:  # (no sample from the move's start on: it never came anywhere)
            def gap(p) -> float:
                lo, hi, _ = p
                return 0.0 if lo <= x_to <= hi else min(abs(lo - x_to), abs(hi - x_to))

            reached = bool(after) and min(gap(s["pos"]) for s in after) * deg <= min(half * deg, bound_deg)
    settle_t = None
    if after:
        band = settling_band_deg / deg
        outside = [k for k, s in enumerate(after)
                   if abs(s["pos"][0] - x_to) > band or abs(s["pos"][1] - x_to) > band]
        if not outside:
            settle_t = 0.0
        elif outside[-1] < len(after) - 1:
            settle_t = after[outside[-1] + 1]["t"] - t_from

    # the verdict
    sim_s = steps_done / f_pwm
    t_run = min(sim_s, t[-1]) if (fault and n) else sim_s
    move_end = max([m[1] for m in moves], default=0.0)
    event_end = max(move_end, load_step_s if load_step_s is not None else 0.0)
    all_finite = all(math.isfinite(float(a[i])) for a in (x_min, x_max, x_mean) for i in range(n))
    verdict, reason = "", None
    if moves and t_from >= t_run:
        reached = False
    if fault:
        verdict = "fault"
    elif moves and t_from >= t_run:
        verdict = "not reached"
        judged = (f"the run ends at {t_run:.6g} s, before the commanded move at {t_from:.6g} s "
                  f"(scenario.duration, reference.at)")
    elif t_run < final_window_s or t_run - final_window_s < event_end:
        verdict = "too short"
        judged = (f"the end window ({final_window_s:g} s, metrics.final_window_s) needs the run "
                  f"({t_run:.6g} s) to last at least {event_end + final_window_s:.6g} s")
        events = [f"the last move ends at {move_end:.6g} s"] if moves else []
        if load_step_s is not None:
            events.append(f"the load steps at {load_step_s:.6g} s (load.time)")
        if events:
            judged += f" ({', '.join(events)})"
    if fault:
        reason = f"fault: {fault_text(fault)}" + (f" at {t[-1]:.6g} s" if n else "")
    elif verdict:
        reason = f"{verdict}: {judged}"
    elif not all_finite:
        reason = "non-finite position"
    elif not reached:
        move = abs(moves[-1][3] - moves[-1][2])
        reason = (f"never reached the target: the true position came no closer than half the move "
                  f"({move * deg:.3g} deg, {move * 1e3:.3g} mm)")
    elif final_error is None:
        reason = "no samples in the end window"
    elif final_error * deg > bound_deg:
        reason = (f"|x - target| reaches {final_error * deg:.3g} deg ({final_error * 1e3:.3g} mm) in the "
                  f"last {final_window_s:g} s (bound {bound_deg:g} deg)")
    elif limit_cycle * deg > settle_band_deg:
        verdict, how = _motion([p[2] for p in w], 0.5 * settle_band_deg / deg, settle_band_deg / deg)
        reason = (f"not settled ({verdict}): x {how} by {limit_cycle * deg:.3g} deg "
                  f"({limit_cycle * 1e3:.3g} mm) in the last {final_window_s:g} s "
                  f"(tolerance {settle_band_deg:g} deg)")
    stable = reason is None
    verdict = verdict or ("stable" if stable else "unstable")

    # the last recorded sample with a finite position (the point value)
    last_x = float("nan")
    for i in range(n - 1, -1, -1):
        if all(math.isfinite(float(a[i])) for a in (x_min, x_max, x_mean)):
            last_x = float(x_pt[i])
            break

    def scaled(v, k):
        return None if v is None else v * k

    return {
        "stable": stable,
        "verdict": verdict,
        "max_abs_err_deg": _num(max_err),
        "transient_max_err_deg": _num(tr_err),
        "steady_max_err_deg": _num(st_err),
        "bias_deg": _num(bias),
        "limit_cycle_mm": _num(scaled(limit_cycle, 1e3)),
        "limit_cycle_deg": _num(scaled(limit_cycle, deg)),
        "settling_time_s": _num(settle_t),
        "final_position_mm": _num(last_x * 1e3),
        "overshoot_mm": _num(overshoot * 1e3),
        "overshoot_deg": _num(overshoot * deg),
        "fault": fault_text(fault),
        "sim_s": _num(sim_s, 9),
        "wall_s": _num(wall_s, 6),
        "realtime_factor": _num(sim_s / wall_s, 2) if wall_s > 0 else None,
        "max_abs_err_window_s": [0.0, _num(t_end, 9)],
        "errors_from_s": _num(convergence_s, 9),
        "final_window_s": [_num(max(0.0, t_end - final_window_s), 9), _num(t_end, 9)],
        "settling_from_s": _num(t_from, 9),
        "fault_bits": int(fault),
        "fault_time_s": _num(t[-1], 9) if (fault and n) else None,
        "unstable_reason": reason,
        "target_mm": _num(x_target * 1e3),
        "start_mm": _num(x_start * 1e3),
        "final_error_mm": _num(scaled(final_error, 1e3)),
        "final_error_deg": _num(scaled(final_error, deg)),
        "final_offset_mm": _num(scaled(offset, 1e3)),
        "final_offset_deg": _num(scaled(offset, deg)),
        "reached": bool(reached),
        "accurate": bool(stable and final_error is not None and final_error * deg <= tolerance_deg),
        "steps": int(steps_done),
        "samples": n,
        "pole_pitch_mm": _num(pole_pitch * 1e3),
    }

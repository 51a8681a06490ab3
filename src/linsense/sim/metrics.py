"""Metrics of one closed-loop run (definitions in docs/simulator.md, section "Metrics").

Every value is a finite number, a bool, a string or ``None`` (JSON ``null``, when a quantity is
not defined, e.g. the estimation error of an idle HF observer): never NaN. Every error peak says
which window it covers (``max_abs_err_deg`` covers the whole run; ``*_window_s`` keys give the
others).

With block statistics (``x_min``, ``x_max``, ``x_mean``, ``err_min``, ``err_max``, ``err_mean`` in
the arrays, :data:`linsense.sim.core.BLOCKS`) every metric reads the envelope of each block instead
of its point value, so nothing between two samples is missed; times (settling, the windows) then
have the resolution of one block. With ``decimate = 1`` the result is exactly the point one.

The bounds that judge a run (``stable``, ``accurate``, the settling band) are electrical degrees,
fractions of the pole pitch (``theta = 360 deg * x / pole_pitch``), so that they mean the same on a
20 mm and a 100 mm motor; the positions they bound are reported in electrical degrees and in mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

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
                 "bias_deg", "limit_cycle_mm", "limit_cycle_deg", "settling_time_s", "final_position_mm",
                 "final_error_deg", "final_offset_deg", "overshoot_mm", "overshoot_deg",
                 "fault", "sim_s", "wall_s", "realtime_factor")


def fault_reason(bits: int) -> str:
    """``"none"`` or the names of the set bits joined by ``+`` (unknown bits in hex).

    Parameters
    ----------
    bits : int
        Fault bits.

    Returns
    -------
    str
        E.g. ``"observer"`` or ``"overcurrent+travel"``.
    """
    bits = int(bits)
    if bits == 0:
        return "none"
    names = [n for b, n in FAULT_NAMES.items() if bits & b]
    rest = bits & ~sum(FAULT_NAMES)
    if rest:
        names.append(hex(rest))
    return "+".join(names)


#: radians -> degrees, the constant np.degrees multiplies by (so the results are the same bit for bit)
_DEG = 180.0 / math.pi


def _fmax(a: np.ndarray) -> float | None:
    """Largest finite value of ``a`` (None if none); ``a`` holds no -inf (absolute values)."""
    if a.size == 0:
        return None
    m = float(a.max())
    if math.isfinite(m):  # (a NaN or +inf would have made the max non-finite)
        return m
    a = a[np.isfinite(a)]
    return float(a.max()) if a.size else None


def _round(v: float | None, nd: int = 6) -> float | None:
    return None if v is None or not math.isfinite(v) else round(float(v), nd)


def transient_mask(t: np.ndarray, moves, settle_s: float) -> np.ndarray:
    """True while the reference moves or within ``settle_s`` after a step or the end of a move.

    Parameters
    ----------
    t : ndarray
        Sample times, s, ascending.
    moves : iterable of (float, float, float, float)
        The planned moves ``(t0, t1, x0, x1)``.
    settle_s : float
        Settling allowance, s.

    Returns
    -------
    ndarray of bool
        Per sample.
    """
    m = np.zeros(t.shape, dtype=bool)
    for t0, t1, _, _ in moves:
        m[t.searchsorted(t0):t.searchsorted(t1 + settle_s)] = True
    return m


def block_views(arrays: dict) -> tuple:
    """Each sample's block of the position and of the estimation error: its lowest, highest and
    mean value (the point value itself where the run kept no blocks).

    Parameters
    ----------
    arrays : dict of str to ndarray
        A run's recorded signals (``x`` or ``x_mean``/``x_min``/``x_max``, ``theta_err`` or
        ``err_mean``/``err_min``/``err_max``).

    Returns
    -------
    tuple of ndarray
        ``x, x_lo, x_hi, e_pt, e_lo, e_hi``: the position (the block mean, else the point value), its
        block's lowest and highest value (``x`` itself without blocks), the error's point value
        (else the block mean) and its block's lowest and highest value.
    """
    x = arrays.get("x_mean", arrays.get("x"))
    x_lo, x_hi = arrays.get("x_min", x), arrays.get("x_max", x)
    e_pt = arrays.get("theta_err", arrays.get("err_mean"))
    e_lo, e_hi = arrays.get("err_min", e_pt), arrays.get("err_max", e_pt)
    return x, x_lo, x_hi, e_pt, e_lo, e_hi


def finite_positions(x: np.ndarray, x_lo: np.ndarray, x_hi: np.ndarray) -> np.ndarray:
    """The samples whose position (and, with blocks, its block's extremes) is finite.

    Parameters
    ----------
    x, x_lo, x_hi : ndarray
        :func:`block_views`'s position views.

    Returns
    -------
    ndarray of bool
        One flag per sample.
    """
    x_fin = np.isfinite(x)
    if x_lo is not x:
        x_fin &= np.isfinite(x_lo) & np.isfinite(x_hi)
    return x_fin


def settling_time(t: np.ndarray, x: np.ndarray, x_to: float, t0: float, band: float,
                  x_hi: np.ndarray | None = None) -> float | None:
    """Time from ``t0`` after which ``|x - x_to| <= band`` holds to the end.

    Parameters
    ----------
    t : ndarray
        Sample times, s, ascending.
    x : ndarray
        Position, m (with ``x_hi``: each sample's block minimum).
    x_to : float
        Target, m.
    t0 : float
        Start, s.
    band : float
        Band, m.
    x_hi : ndarray or None, optional
        Each sample's block maximum (the time then has the resolution of a block).

    Returns
    -------
    float or None
        s; None if the band does not hold at the last sample.
    """
    i0 = int(t.searchsorted(t0))
    if i0 >= t.size:
        return None
    dev = np.abs(x[i0:] - x_to)
    if x_hi is not None:
        dev = np.maximum(dev, np.abs(x_hi[i0:] - x_to))
    out = dev > band
    if out[-1]:
        return None
    last_out = np.flatnonzero(out)
    if last_out.size == 0:
        return 0.0
    return float(t[i0 + last_out[-1] + 1] - t0)


def end_motion(x: np.ndarray, hysteresis: float, band: float) -> tuple[str, str]:
    """How the mover moves over the end window of a run that did not settle there.

    ``"still moving"`` when it goes one way only (never back by more than ``hysteresis`` from the
    farthest it had gone: an approach or a drift), or rings down (its peak to peak over the
    window's second half within ``band`` and at most half the first half's); else ``"limit
    cycle"`` (it swings back and forth and keeps swinging).

    Parameters
    ----------
    x : ndarray
        The position over the end window, in time order (m), finite.
    hysteresis : float
        m, the backward motion still counted as one way (the HF ripple's).
    band : float
        m, the peak to peak of a settled mover (``settle_band``).

    Returns
    -------
    tuple of (str, str)
        ``("still moving" or "limit cycle", how x moves, in words)``.
    """
    one_way = "moves one way only (an approach or a drift),"
    if x.size < 2:
        return "still moving", one_way
    back_down = (np.maximum.accumulate(x) - x).max()  # (the farthest back from a maximum so far)
    back_up = (x - np.minimum.accumulate(x)).max()
    if back_down <= hysteresis or back_up <= hysteresis:
        return "still moving", one_way
    h = x.size // 2
    p1, p2 = float(np.ptp(x[:h])), float(np.ptp(x[h:]))
    if h > 1 and p2 <= band and p2 <= 0.5 * p1:
        return "still moving", "rings down (within the tolerance over the window's second half),"
    return "limit cycle", "varies"


def compute_metrics(arrays: dict, *, fault: int, steps_done: int, f_pwm: float, moves, wall_s: float,
                    observer_active: bool, convergence_s: float, settle_s: float, pole_pitch: float,
                    tolerance_deg: float, bound_deg: float, settle_band_deg: float,
                    settling_band_deg: float, final_window_s: float, x_target: float,
                    x_start: float, load_step_s: float | None = None) -> dict:
    """Metrics of one closed-loop run (definitions: docs/simulator.md, "Metrics").

    The samples' times ``t`` ascend, so every time window is a range of indices (found by
    bisection): a sweep computes these metrics thousands of times, at about 0.1 ms each.

    Parameters
    ----------
    arrays : dict
        The run's recorded signals: ``t`` (s), the true position ``x`` (m) and the estimation error
        ``theta_err`` (rad), or their block statistics (``x_min``, ``x_max``, ``x_mean``,
        ``err_min``, ``err_max``, ``err_mean``).
    fault : int
        Fault bits the run ended with (0: none).
    steps_done : int
        PWM periods run.
    f_pwm : float
        Hz, PWM frequency (= control rate).
    moves : list of tuple
        The planned moves ``(t0, t1, x_from, x_to)`` (s, s, m, m).
    wall_s : float
        s, wall-clock time of the run.
    observer_active : bool
        Whether the HF observer ran (else the estimation errors are None).
    convergence_s, settle_s : float
        s, start of the error windows; transient time after a step or the end of a move.
    pole_pitch : float
        m, one electrical period of the motor: ``theta = 360 deg * x / pole_pitch`` converts the
        bounds below, and the position metrics in degrees.
    tolerance_deg, bound_deg : float
        Electrical deg, ``|x - target|`` over the end window for ``accurate`` and for ``stable``
        (bounded).
    settle_band_deg : float
        Electrical deg, the largest peak to peak of the true position over the end window of a
        settled run (the limit-cycle threshold of ``stable``).
    settling_band_deg : float
        Electrical deg, the ``|x - target|`` band that defines ``settling_time_s``.
    final_window_s : float
        s, the end window.
    x_target, x_start : float
        m, the last commanded position and the initial one.
    load_step_s : float or None, optional
        s, the time of a step load (None: none): the end window must follow it as it follows the
        last move.

    Returns
    -------
    dict
        Finite numbers, bools, strings and None (never NaN): :data:`REQUIRED_KEYS` and the extras
        of docs/simulator.md.

    Raises
    ------
    ValueError
        ``pole_pitch`` is not a positive finite length.
    """
    if not (math.isfinite(pole_pitch) and pole_pitch > 0.0):
        raise ValueError(f"pole_pitch must be a positive length (m), got {pole_pitch!r}")
    deg_per_m = 360.0 / pole_pitch  # electrical degrees per metre of travel
    s = _samples(arrays, fault)
    sim_s = steps_done / f_pwm
    t_end = float(s.ts[-1]) if s.n_ok else 0.0
    i_win = int(s.ts.searchsorted(t_end - final_window_s))
    errors = (_error_stats(s, moves, convergence_s, settle_s, i_win) if observer_active
              else (None, None, None, None))
    end = _end_window(s, i_win, x_target)
    last = _last_move(s, moves, x_target, end[3], deg_per_m, bound_deg, settling_band_deg)
    verdict, reason, reached = _judge(s, fault, sim_s, moves, end, last, deg_per_m=deg_per_m,
                                      bound_deg=bound_deg, settle_band_deg=settle_band_deg,
                                      final_window_s=final_window_s, load_step_s=load_step_s)
    return _metrics_dict(s, verdict=verdict, reason=reason, reached=reached, errors=errors, end=end,
                         last=last, final_x=_final_position(arrays, s), fault=fault,
                         steps_done=steps_done, sim_s=sim_s, wall_s=wall_s,
                         convergence_s=convergence_s, final_window_s=final_window_s,
                         x_target=x_target, x_start=x_start, tolerance_deg=tolerance_deg,
                         pole_pitch=pole_pitch)


@dataclass(slots=True)
class _Samples:
    """A run's samples as its metrics read them: the views of :func:`block_views` and the samples
    the statistics use, ``[0, n_ok)``."""

    t: np.ndarray  # every sample's time, s
    n_ok: int  # all but the state that tripped, up to a non-finite time
    ts: np.ndarray  # the times of the samples the statistics use, s (t[:n_ok])
    x: np.ndarray
    x_lo: np.ndarray
    x_hi: np.ndarray
    e_lo: np.ndarray
    e_hi: np.ndarray
    e_mean: np.ndarray
    x_fin: np.ndarray  # the samples with a finite position
    x_all: bool  # every position finite

    def finite(self, a: np.ndarray, i0: int) -> np.ndarray:
        """``a`` over the samples [i0, n_ok) with a finite position."""
        return a[i0:self.n_ok] if self.x_all else a[i0:self.n_ok][self.x_fin[i0:self.n_ok]]


def _samples(arrays: dict, fault: int) -> _Samples:
    """The views and the usable samples of a run (the last sample of a run with a fault, the
    state that tripped, is not used; nor any from a non-finite time on, none in a run of the C
    core)."""
    t = arrays["t"]
    x, x_lo, x_hi, e_pt, e_lo, e_hi = block_views(arrays)
    n_ok = t.size - 1 if fault and t.size else t.size
    bad_t = np.flatnonzero(~np.isfinite(t[:n_ok]))
    if bad_t.size:
        n_ok = int(bad_t[0])
    x_fin = finite_positions(x, x_lo, x_hi)
    return _Samples(t, n_ok, t[:n_ok], x, x_lo, x_hi, e_lo, e_hi, arrays.get("err_mean", e_pt), x_fin,
                    bool(x_fin.all()))


def _error_stats(s: _Samples, moves, convergence_s: float, settle_s: float,
                 i_win: int) -> tuple[float | None, ...]:
    """The estimation error's peaks (whole run; transient and steady after ``convergence_s``) and
    its mean over the end window (from ``i_win``), degrees (None where no sample is finite)."""
    ts = s.ts
    i_conv = int(ts.searchsorted(convergence_s))
    err = np.maximum(np.abs(s.e_lo[:s.n_ok]), np.abs(s.e_hi[:s.n_ok]))  # rad
    tr = transient_mask(ts[i_conv:], moves, settle_s)
    after = err[i_conv:]
    peaks = (_fmax(err), _fmax(after[tr]), _fmax(after[~tr]))
    ew = s.e_mean[i_win:s.n_ok]
    good = np.isfinite(err[i_win:])
    if not good.all():
        ew = ew[good]
    bias = float((ew * _DEG).mean()) if ew.size else None  # (degrees first: as np.degrees did)
    return (*(None if v is None else v * _DEG for v in peaks), bias)


def _final_position(arrays: dict, s: _Samples) -> float:
    """The point value of the position at the last sample with a finite one (NaN if none), m."""
    x_last = arrays.get("x", s.x)  # (the block mean without point values)
    if s.x_all:
        return float(x_last[-1]) if x_last.size else float("nan")
    k = np.flatnonzero(s.x_fin)
    return float(x_last[k[-1]]) if k.size else float("nan")


def _end_window(s: _Samples, i_win: int, x_target: float) -> tuple:
    """Over the end window (from ``i_win``): its finite positions, and the limit cycle (peak to
    peak of the true position), the largest ``|x - target|`` and the mean offset from the target,
    m (None without a sample)."""
    xw, lo_w, hi_w = s.finite(s.x, i_win), s.finite(s.x_lo, i_win), s.finite(s.x_hi, i_win)
    if not xw.size:
        return xw, None, None, None
    limit_cycle = float(hi_w.max() - lo_w.min())
    end_err = float(max(np.abs(lo_w - x_target).max(), np.abs(hi_w - x_target).max()))
    return xw, limit_cycle, end_err, float((xw - x_target).mean())


class _LastMove(NamedTuple):
    """What the mover did from the last move's start."""

    t_last: float  # the last move's start (0 without a move), s
    seen: bool  # a finite position was recorded from then on
    overshoot: float  # beyond the reference, not counting the steady offset, m
    reached: bool  # came within half the move (and the bound) of the target
    settle_t: float | None  # settling time, s


def _overshoot(move, hi_f: np.ndarray, lo_f: np.ndarray, offset: float | None) -> float:
    """The last move's overshoot beyond its target, less the steady offset in its direction, m."""
    _, _, x_from, x_to = move
    direction = np.sign(x_to - x_from)
    if direction == 0 or not lo_f.size:
        return 0.0
    x_far = hi_f if direction > 0 else lo_f  # the block's extreme in the move's direction
    peak = float((direction * (x_far - x_to)).max())
    steady = max(0.0, float(direction) * offset) if offset is not None else 0.0
    return max(0.0, peak - steady)


def _reached(s: _Samples, move, i_last: int, deg_per_m: float, bound_deg: float) -> bool:
    """Whether, at some time from the last move's start, the true position came within half the
    move (and the bound) of its target (a block whose range contains the target came within 0)."""
    _, _, x_from, x_to = move
    dist = abs(x_to - x_from)
    lo_f, hi_f = s.finite(s.x_lo, i_last), s.finite(s.x_hi, i_last)
    if dist <= 0:
        return True
    if not lo_f.size:
        return False  # (nothing recorded after the move's start: never seen to reach it)
    if s.x_lo is not s.x_hi:
        closest = float(np.maximum(np.maximum(lo_f - x_to, x_to - hi_f), 0.0).min())
    else:
        closest = float(np.abs(s.finite(s.x, i_last) - x_to).min())
    return closest * deg_per_m <= min(0.5 * dist * deg_per_m, bound_deg)


def _last_move(s: _Samples, moves, x_target: float, offset: float | None, deg_per_m: float,
               bound_deg: float, settling_band_deg: float) -> _LastMove:
    """Overshoot, reach and settling time of the last move (of the start without a move)."""
    t_last = moves[-1][0] if moves else 0.0
    i_last = int(s.ts.searchsorted(t_last))
    ts_f, lo_f, hi_f = s.finite(s.t, i_last), s.finite(s.x_lo, i_last), s.finite(s.x_hi, i_last)
    overshoot, reached = 0.0, True  # (m)
    if moves:
        overshoot = _overshoot(moves[-1], hi_f, lo_f, offset)
        reached = _reached(s, moves[-1], i_last, deg_per_m, bound_deg)
    x_to = moves[-1][3] if moves else x_target
    settle_t = None
    if ts_f.size:  # (the samples from t_last on: settling_time's own search starts at 0)
        settle_t = settling_time(ts_f, lo_f, x_to, t_last, settling_band_deg / deg_per_m,
                                 None if s.x_lo is s.x_hi else hi_f)
    return _LastMove(t_last, bool(lo_f.size), overshoot, reached, settle_t)


def _coverage(t_run: float, moves, final_window_s: float, load_step_s: float | None) -> tuple[str, str]:
    """``(verdict, why)`` of a run that does not hold its commanded moves and an end window after
    them (and after a step load): a move that starts after the run ended (by its duration) was
    never reached ("not reached"); an end window longer than the run, or one that overlaps the
    last move or the load step, judges the event itself ("too short"); else ``("", "")``."""
    t_move = max(m[1] for m in moves) if moves else 0.0  # (s, the end of the last move)
    t_event = max(t_move, load_step_s or 0.0)
    if moves and moves[-1][0] >= t_run:
        return "not reached", (f"the run ends at {t_run:.6g} s, before the commanded move at "
                               f"{moves[-1][0]:.6g} s (scenario.duration, reference.at)")
    if t_run < final_window_s or t_run - final_window_s < t_event:
        last = [f"the last move ends at {t_move:.6g} s"] if moves else []
        if load_step_s is not None:
            last.append(f"the load steps at {load_step_s:.6g} s (load.time)")
        return "too short", (f"the end window ({final_window_s:g} s, metrics.final_window_s) needs "
                             f"the run ({t_run:.6g} s) to last at least {t_event + final_window_s:.6g} s"
                             + (f" ({', '.join(last)})" if last else ""))
    return "", ""


def _deg(v: float | None, deg_per_m: float) -> float | None:
    return None if v is None else v * deg_per_m


def _mm(v: float | None) -> float | None:
    return None if v is None else v * 1e3


def _instability(s: _Samples, moves, end: tuple, last: _LastMove, *, deg_per_m: float,
                 bound_deg: float, settle_band_deg: float,
                 final_window_s: float) -> tuple[str, str]:
    """``(reason, motion)`` of a run that ran to its end window without a fault: why it is not
    stable ("" if it is), and for one that did not settle, how (:func:`end_motion`, else "").

    Stable: finite; reached the reference region; bounded (end window within ``bound_deg`` of the
    target) and settled (the true position varies by at most ``settle_band_deg`` there: beyond, a
    mover still approaching or drifting, or ringing down, is still moving, one that swings back
    and forth a limit cycle).
    """
    xw, limit_cycle, end_err, _ = end

    def deg(v: float | None) -> float | None:
        return _deg(v, deg_per_m)

    if not s.x_all:
        return "non-finite position", ""
    if not last.reached and not last.seen:
        return (f"never seen to reach the target: nothing was recorded after the last move's start "
                f"({moves[-1][0]:.6g} s)"), ""
    if not last.reached:
        move = abs(moves[-1][3] - moves[-1][2])
        return (f"never reached the target: the true position came no closer than half the move "
                f"({deg(move):.3g} deg, {_mm(move):.3g} mm)"), ""
    if end_err is None:
        return "no samples in the end window", ""
    if deg(end_err) > bound_deg:
        return (f"|x - target| reaches {deg(end_err):.3g} deg ({_mm(end_err):.3g} mm) in the last "
                f"{final_window_s:g} s (bound {bound_deg:g} deg)"), ""
    if deg(limit_cycle) > settle_band_deg:
        motion, how = end_motion(xw, 0.5 * settle_band_deg / deg_per_m, settle_band_deg / deg_per_m)
        return (f"not settled ({motion}): x {how} by {deg(limit_cycle):.3g} deg "
                f"({_mm(limit_cycle):.3g} mm) in the last {final_window_s:g} s "
                f"(tolerance {settle_band_deg:g} deg)"), motion
    return "", ""


def _judge(s: _Samples, fault: int, sim_s: float, moves, end: tuple, last: _LastMove, *,
           deg_per_m: float, bound_deg: float, settle_band_deg: float, final_window_s: float,
           load_step_s: float | None) -> tuple[str, str, bool]:
    """``(verdict, unstable_reason, reached)`` of a run: a fault is the verdict of the run it
    stopped, whatever else; then a run judged on nothing (:func:`_coverage`); then stability
    (:func:`_instability`)."""
    t = s.t
    t_run = min(sim_s, float(t[-1])) if fault and t.size else sim_s
    reached = last.reached and not (moves and moves[-1][0] >= t_run)
    if fault:
        at = f" at {float(t[-1]):.6g} s" if t.size else ""
        return "fault", f"fault: {fault_reason(fault)}{at}", reached
    verdict, why = _coverage(t_run, moves, final_window_s, load_step_s)
    if verdict:
        return verdict, f"{verdict}: {why}", reached
    reason, motion = _instability(s, moves, end, last, deg_per_m=deg_per_m, bound_deg=bound_deg,
                                  settle_band_deg=settle_band_deg, final_window_s=final_window_s)
    return motion or ("unstable" if reason else "stable"), reason, reached


def _metrics_dict(s: _Samples, *, verdict: str, reason: str, reached: bool, errors: tuple,
                  end: tuple, last: _LastMove, final_x: float, fault: int, steps_done: int,
                  sim_s: float, wall_s: float, convergence_s: float, final_window_s: float,
                  x_target: float, x_start: float, tolerance_deg: float, pole_pitch: float) -> dict:
    """The metrics dict (its keys in the order of metrics.json) from the findings of
    :func:`compute_metrics`."""
    deg_per_m = 360.0 / pole_pitch
    t = s.t
    t_end = float(s.ts[-1]) if s.n_ok else 0.0
    max_err, tr_err, st_err, bias = errors
    _, limit_cycle, end_err, offset = end
    stable = reason == ""
    rt = sim_s / wall_s if wall_s > 0 else None
    return {
        "stable": bool(stable),
        # "stable"; "fault" (a fault stopped the run: unstable_reason names it and its time); "limit
        # cycle" (the mover swings back and forth in the end window); "still moving" (it approaches
        # or drifts in one direction, or rings down, in the end window); "unstable" (the bound, the
        # target never approached, a non-finite position); or, judged on nothing: "not reached"
        # (the commanded move lies after the run's end) or "too short" (no end window after the
        # last move and the load step)
        "verdict": verdict,
        "max_abs_err_deg": _round(max_err),
        "transient_max_err_deg": _round(tr_err),
        "steady_max_err_deg": _round(st_err),
        "bias_deg": _round(bias),
        "limit_cycle_mm": _round(_mm(limit_cycle)),
        "limit_cycle_deg": _round(_deg(limit_cycle, deg_per_m)),
        "settling_time_s": _round(last.settle_t),
        "final_position_mm": _round(final_x * 1e3),
        "overshoot_mm": _round(_mm(last.overshoot)),
        "overshoot_deg": _round(_deg(last.overshoot, deg_per_m)),
        "fault": fault_reason(fault),
        "sim_s": _round(sim_s, 9),
        "wall_s": _round(wall_s, 6),
        "realtime_factor": _round(rt, 2),
        # the windows the figures above cover (s): the whole run for max_abs_err_deg; transient and
        # steady from convergence_s on; bias and limit cycle over the end window
        "max_abs_err_window_s": [0.0, _round(t_end, 9)],
        "errors_from_s": _round(convergence_s, 9),
        "final_window_s": [_round(max(0.0, t_end - final_window_s), 9), _round(t_end, 9)],
        "settling_from_s": _round(last.t_last, 9),
        # extras
        "fault_bits": int(fault),
        "fault_time_s": _round(float(t[-1]), 9) if fault and t.size else None,
        "unstable_reason": reason or None,
        "target_mm": _round(x_target * 1e3),
        "start_mm": _round(x_start * 1e3),
        "final_error_mm": _round(_mm(end_err)),
        "final_error_deg": _round(_deg(end_err, deg_per_m)),
        "final_offset_mm": _round(_mm(offset)),
        "final_offset_deg": _round(_deg(offset, deg_per_m)),
        "reached": bool(reached),
        "accurate": bool(stable and end_err is not None
                         and _deg(end_err, deg_per_m) <= tolerance_deg),
        "steps": int(steps_done),
        "samples": int(t.size),
        "pole_pitch_mm": _round(pole_pitch * 1e3),
    }

"""Run the certificate's cases and judge each (docs/tuning.md, "The certificate").

Each case is the tuned scenario with its own reference, load and plant, on the switching
inverter with the drive's dead time. Off-nominal plants keep the controller's nominal model
(``controller.model.motor``): its LUT, gain table and feed-forwards are the nominal motor's.
The runs go through a pool of worker threads of the standard library (the C loop releases the
GIL; no dask, which the core install has not).
"""

from __future__ import annotations

import copy

import numpy as np

from linsense.model.motor import Motor
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.sim.core import run_closed_loop
from linsense.sim.metrics import fault_reason
from linsense.verify import criteria as C
from linsense.verify.cases import UNBOUNDED_MM, Case, off_nominal_motor

_SIGNALS = ("t", "x", "theta_err")
_BLOCKS = ("x_min", "x_max", "x_mean", "err_min", "err_max", "err_mean")


#: the kinds of case that move at the application's speed (:func:`linsense.verify.cases.moves`)
MOVES = ("trajectory", "reversal", "move_hold")

#: sections a case gives whole (the tuned scenario's own reference, load and start do not mix in)
_WHOLE = ("reference", "load", "initial", "travel")


def _merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for sec, vals in over.items():
        if sec in _WHOLE:
            out[sec] = copy.deepcopy(vals)
        elif isinstance(vals, dict):
            out.setdefault(sec, {}).update(copy.deepcopy(vals))
        else:
            out[sec] = vals
    return out


def case_scenario(case: Case, base: dict, motor_spec: str) -> dict:
    """The scenario dict of a case.

    ``base`` (the tuned scenario) with the case's sections, the switching inverter, and the
    controller's model pinned to the nominal motor.

    Parameters
    ----------
    case : Case
        The run.
    base : dict
        The tuned scenario.
    motor_spec : str
        The nominal motor (preset or absolute path).

    Returns
    -------
    dict
        The scenario's sections.
    """
    sc = _merge(base, case.sections)
    sc["motor"] = motor_spec
    sc["scenario"]["name"] = case.name
    sc.setdefault("inverter", {})["fidelity"] = "switching"
    sc.setdefault("controller", {}).setdefault("model", {})["motor"] = motor_spec
    f_pwm = float(sc["inverter"].get("f_pwm", 16000.0))
    sc.setdefault("record", {})["decimate"] = max(1, int(round(f_pwm / 2000.0)))  # 0.5 ms blocks
    if "travel" not in case.sections:  # (no stroke given: no end stops)
        sc["travel"] = {"min_mm": -UNBOUNDED_MM, "max_mm": UNBOUNDED_MM}
    return sc


def run_case(case: Case, base: dict, motor_spec: str, nominal: Motor, base_dir: str) -> dict:
    """Run a case and judge it.

    Parameters
    ----------
    case : Case
        The run.
    base : dict
        The tuned scenario.
    motor_spec : str
        The nominal motor (preset or absolute path).
    nominal : Motor
        The nominal motor.
    base_dir : str
        Folder the scenario is relative to.

    Returns
    -------
    dict
        A row of plain values (JSON-ready; :func:`judge`) with ``wall_s``.
    """
    sc = scenario_from_dict(
        case_scenario(case, base, motor_spec), source=f"<verify: {case.name}>", base_dir=base_dir
    )
    plant = off_nominal_motor(nominal, case.plant)
    b = build(sc, motor=plant)
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, signals=_SIGNALS, blocks=_BLOCKS)
    f_pwm = float(sc.spec.inverter.f_pwm)
    row = judge(
        case,
        raw.arrays,
        raw.fault,
        raw.steps_done / f_pwm,
        b.n_steps / f_pwm,  # (the duration in whole PWM periods, as run: a trajectory's is not one)
        nominal.pole_pitch,
    )
    row["wall_s"] = raw.wall_s
    return row


def judge(case: Case, a: dict, fault: int, t_done: float, duration: float, tau: float) -> dict:
    """The figures of one run and its verdict against :mod:`linsense.verify.criteria`.

    Electrical degrees, mm beside.

    Parameters
    ----------
    case : Case
        The run.
    a : dict
        Its recorded arrays (``t`` and the block statistics ``x_min``, ``x_max``, ``err_min``...).
    fault : int
        Fault bits at the end.
    t_done : float
        Time run, s.
    duration : float
        Time planned, s.
    tau : float
        Pole pitch, m.

    Returns
    -------
    dict
        ``case``, ``kind``, ``plant``, ``position_deg``, ``load_n``, ``fault``, ``passed``, ``why``
        and the kind's figures.
    """
    deg = 360.0 / tau
    t = a["t"]
    n = t.size - 1 if fault else t.size  # (the sample that tripped is not judged)
    t, lo, hi = t[:n], a["x_min"][:n], a["x_max"][:n]
    e_lo, e_hi, e_mean = a["err_min"][:n], a["err_max"][:n], a["err_mean"][:n]
    row = {
        "case": case.name,
        "kind": case.kind,
        "plant": case.plant,
        "position_deg": case.position_deg,
        "load_n": case.load,
        "table": case.table,
        "fault": fault_reason(fault),
        "passed": False,
        "why": "",
    }
    dev = np.maximum(np.abs(lo - case.target), np.abs(hi - case.target)) * deg  # |x - target|, deg
    err = np.degrees(np.maximum(np.abs(e_lo), np.abs(e_hi)))  # |estimation error|, deg
    win = t >= duration - C.END_WINDOW_S
    if case.kind != "hold":  # for the certificate's figure: one point per block (up to a fault too)
        row["trace"] = _trace(case, t, lo, hi, e_mean, deg)
    if fault or t_done < duration - 1e-9 or not win.any() or not np.all(np.isfinite(dev)):
        row["why"] = f"fault: {fault_reason(fault)} at {t_done:.3g} s" if fault else "did not finish"
        return row
    pp = float(hi[win].max() - lo[win].min()) * deg
    row.update(
        pp_deg=pp,
        pp_mm=pp / deg * 1e3,
        err_deg=float(dev[win].max()),
        est_err_deg=float(err[win].max()),
        bias_deg=float(np.degrees(e_mean[win].mean())),
    )
    why = []
    if case.kind == "hold":
        why += _judge_hold(case, row)
    elif case.kind == "step":
        why += _judge_step(case, row, t, lo, hi, dev, deg)
    elif case.kind in MOVES:
        why += _judge_move(case, row, t, lo, hi, err, tau)
    elif case.kind == "load_step":
        why += _judge_load_step(case, row, t, dev, deg)
    if pp > C.HOLD_PP_DEG:
        why += _judge_end_motion(case, row, t[win], 0.5 * (lo[win] + hi[win]), pp, deg)
    row["why"] = "; ".join(why)
    row["passed"] = not why
    return row


def _trace(case: Case, t: np.ndarray, lo: np.ndarray, hi: np.ndarray, e_mean: np.ndarray,
           deg: float) -> dict:
    """For the certificate's figure: one point per block, ``x - target`` and the estimation error,
    electrical deg."""
    x_mid = 0.5 * (lo + hi)
    ok = np.isfinite(x_mid) & np.isfinite(e_mean)
    return {"t": t[ok].tolist(), "x_deg": ((x_mid[ok] - case.target) * deg).tolist(),
            "err_deg": np.degrees(e_mean[ok]).tolist()}


def _judge_hold(case: Case, row: dict) -> list[str]:
    """A hold: the nominal plant's bound, and a plant whose table was measured on it; the others
    keep the drive's table and get the tolerance's."""
    lim = C.HOLD_ERR_DEG if case.plant == "nominal" or case.table == "measured" else C.OFF_ERR_DEG
    if row["err_deg"] > lim:
        return [f"|x - target| {row['err_deg']:.3g} deg > {lim:g}"]
    return []


def _judge_step(case: Case, row: dict, t: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                dev: np.ndarray, deg: float) -> list[str]:
    """A step: its settling time and overshoot (into ``row``)."""
    row["settle_s"] = _settle(t, dev, case.t_event)
    row["overshoot_deg"] = (
        float(
            max(
                0.0,
                np.max(
                    np.sign(case.target - lo[0]) * ((hi if case.target > lo[0] else lo) - case.target)
                ),
            )
        )
        * deg
    )
    if row["settle_s"] is None or row["settle_s"] > C.STEP_SETTLE_S:
        return [f"settles in {_s(row['settle_s'])} > {C.STEP_SETTLE_S:g} s "
                f"(within {C.SETTLE_BAND_DEG:g} deg)"]
    return []


def _judge_move(case: Case, row: dict, t: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                err: np.ndarray, tau: float) -> list[str]:
    """A move at v_max: its peak estimation error moving, its speed profile (into ``row``), and its
    errors at rest."""
    why = []
    moving = (t >= case.t_event) & (t <= case.t_end_move)
    row["peak_err_deg"] = float(err[moving].max()) if moving.any() else 0.0
    row.update(speed_profile(t, lo, hi, np.where(moving, err, 0.0), tau))  # (the crossing: while moving)
    if row["peak_err_deg"] > C.TRAJ_PEAK_ERR_DEG:
        at = row.get("err_crosses_at_speed")
        where = f" (it crosses {C.TRAJ_PEAK_ERR_DEG:g} deg at {at:.3g} m/s)" if at is not None else ""
        peak = row["peak_err_deg"]
        why.append(f"peak estimation error {peak:.3g} deg > {C.TRAJ_PEAK_ERR_DEG:g}{where}")
    if row["est_err_deg"] > C.TRAJ_REST_ERR_DEG:
        why.append(f"estimation error at rest {row['est_err_deg']:.3g} deg > {C.TRAJ_REST_ERR_DEG:g}")
    if row["err_deg"] > C.HOLD_ERR_DEG:
        why.append(f"|x - target| at rest {row['err_deg']:.3g} deg > {C.HOLD_ERR_DEG:g}")
    return why


def _judge_load_step(case: Case, row: dict, t: np.ndarray, dev: np.ndarray, deg: float) -> list[str]:
    """A load step: its peak deviation, recovery time and stiffness (into ``row``)."""
    after = t >= case.t_event
    peak = float(dev[after].max())
    rec = _settle(t, dev, case.t_event)
    row.update(
        peak_dev_deg=peak,
        peak_dev_mm=peak / deg * 1e3,
        recover_s=rec,
        stiffness_n_per_mm=abs(case.load) / max(peak / deg * 1e3, 1e-9),
    )
    if rec is None or rec > C.LOAD_RECOVER_S:
        return [f"back within {C.SETTLE_BAND_DEG:g} deg after {_s(rec)} > {C.LOAD_RECOVER_S:g} s"]
    return []


def _judge_end_motion(case: Case, row: dict, tw: np.ndarray, xm: np.ndarray, pp: float,
                      deg: float) -> list[str]:
    """A run whose peak to peak over the end window (``tw``, block middles ``xm``) exceeds the hold's:
    a limit cycle, or still moving.

    A monotonic approach in the end window is still settling, not a limit cycle; nor is an
    oscillation that decays: below the threshold over the window's second half, and at most half
    its first half's (a cycle keeps its amplitude).
    """
    resid = xm - np.polyval(np.polyfit(tw - tw[0], xm, 1), tw - tw[0]) if xm.size > 2 else xm
    h = xm.size // 2
    p1, p2 = (float(np.ptp(xm[:h])), float(np.ptp(xm[h:]))) if h > 1 else (0.0, 0.0)
    decays = h > 1 and p2 * deg <= C.HOLD_PP_DEG and p2 <= 0.5 * p1
    what = "limit cycle" if float(np.ptp(resid)) * deg > 0.5 * pp and not decays else "still moving"
    # holds, steps and the hold after a move must be still at their end; the load step and the
    # out-and-back moves are bounded by their recovery and their errors (docs/tuning.md, "The
    # certificate"): a mover still approaching within the band there passes, a limit cycle does not
    if what == "limit cycle" or case.kind in ("hold", "step", "move_hold"):
        return [f"{what} {pp:.3g} deg p-p ({pp / deg * 1e3:.3g} mm) > {C.HOLD_PP_DEG:g} deg"]
    row["note"] = (f"still settling: {pp:.3g} deg p-p ({pp / deg * 1e3:.3g} mm) at the end, "
                   f"within {C.SETTLE_BAND_DEG:g} deg, decaying")
    return []


def speed_profile(t: np.ndarray, lo: np.ndarray, hi: np.ndarray, err: np.ndarray, tau: float) -> dict:
    """A move's top speed as run and the speed at which its estimation error first exceeds the
    bound.

    From the recorded blocks: the speed is the block midpoints' difference quotient, each block's
    error its peak |estimation error|. The first block over the bound, not the slowest: an error
    that grew at speed stays over it while the mover slows to the reversal, and the slowest such
    block (0.019 m/s on a 20 mm motor whose error first crossed at 1.6 m/s) is not where the speed
    gave out.

    Parameters
    ----------
    t : ndarray
        Block times, s.
    lo, hi : ndarray
        Each block's lowest and highest position, m.
    err : ndarray
        Each block's peak |estimation error|, electrical deg.
    tau : float
        Pole pitch, m.

    Returns
    -------
    dict
        ``speed_peak_m_s`` and ``err_crosses_at_speed`` (m/s; None when the error stays within
        :data:`~linsense.verify.criteria.TRAJ_PEAK_ERR_DEG`).
    """
    if t.size < 3:
        return {"speed_peak_m_s": 0.0, "err_crosses_at_speed": None}
    x = 0.5 * (lo + hi)
    v = np.abs(np.gradient(x, t))
    ok = np.isfinite(v) & np.isfinite(err)
    over = ok & (err > C.TRAJ_PEAK_ERR_DEG)
    return {"speed_peak_m_s": float(v[ok].max()) if ok.any() else 0.0,
            "err_crosses_at_speed": float(v[np.flatnonzero(over)[0]]) if over.any() else None}


def _settle(t: np.ndarray, dev: np.ndarray, t0: float) -> float | None:
    """Time (s) from ``t0`` after which ``dev <= SETTLE_BAND_DEG`` to the end; None if never."""
    out = np.flatnonzero((dev > C.SETTLE_BAND_DEG) & (t >= t0))
    if not out.size:
        return 0.0
    if out[-1] + 1 >= t.size:
        return None
    return float(t[out[-1] + 1] - t0)


def _s(v: float | None) -> str:
    return "never" if v is None else f"{v:.3g} s"


def run_cases(
    cases: list[Case], base: dict, motor_spec: str, nominal: Motor, base_dir: str, workers: int | None = None
) -> list[dict]:
    """Every case's row, in order.

    On a pool of ``workers`` threads (default: one per core; 1 runs them in this thread).

    Parameters
    ----------
    cases : list of Case
        The runs.
    base : dict
        The tuned scenario.
    motor_spec : str
        The nominal motor (preset or absolute path).
    nominal : Motor
        The nominal motor.
    base_dir : str
        Folder the scenarios are relative to.
    workers : int or None, optional
        Worker threads.

    Returns
    -------
    list of dict
        The rows (:func:`run_case`).
    """
    from linsense.sim.cluster import thread_map

    return thread_map(lambda c: run_case(c, base, motor_spec, nominal, base_dir), cases, workers,
                      "linsense-verify")


__all__ = ["run_case", "run_cases", "judge", "case_scenario"]

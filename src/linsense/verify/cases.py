"""The runs of the certificate (docs/tuning.md, "The certificate"): holds over the period at
three loads, two steps, moves at the application's speed and acceleration over the loads (out and
back, a reversal, a hold after a move) and a load step on the nominal plant; the holds again on the
off-nominal plants, and a move on those whose table is measured. Every run is the tuned scenario on
the switching inverter with the drive's dead time; only the reference, the load, (off-nominal) the
plant and (measured) the table change.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from linsense.model.motor import Motor
from linsense.model.tolerance import perturbed
from linsense.sim.build import trapezoid_time
from linsense.tune.export import end_stops
from linsense.verify import criteria as C

#: mm, the end stops of an unbounded stroke's runs (a longer move gets its own: with_room)
UNBOUNDED_MM = 1e4


@dataclass(frozen=True)
class Case:
    """One verification run.

    Attributes
    ----------
    name : str
        The run's name in the certificate.
    kind : str
        ``hold``, ``step``, ``trajectory`` or ``load_step``.
    plant : str
        The off-nominal name (a key of :data:`~linsense.verify.criteria.OFF_NOMINAL`) or
        ``"nominal"``.
    sections : dict
        The scenario sections this run sets over the tuned scenario.
    target : float
        Where the mover must end, m.
    t_event : float
        The step, the move's start or the load step, s.
    t_end_move : float
        End of the commanded motion, s.
    load : float
        Load force, N.
    position_deg : float
        Hold position, electrical deg.
    speed : float
        A move's top speed as planned, m/s.
    table : str
        ``"design"``: the drive's own table; ``"measured"``: the table the calibration measured on
        this run's plant (:data:`~linsense.verify.criteria.CALIBRATED`).
    """

    name: str
    kind: str
    plant: str
    sections: dict = field(hash=False)
    target: float = 0.0
    t_event: float = 0.0
    t_end_move: float = 0.0
    load: float = 0.0
    position_deg: float = 0.0
    speed: float = 0.0
    table: str = "design"


#: the position grid's offset, in grid steps from 0 (so that it does not sit on the symmetric
#: positions only); the moves start at the first point of the full grid
OFFSET = 0.37


def start(tau: float) -> float:
    """Where the steps, the trajectory and the load step start.

    Parameters
    ----------
    tau : float
        Pole pitch, m.

    Returns
    -------
    float
        m.
    """
    return tau * OFFSET / C.POSITIONS


def hold_cases(
    tau: float, load_rated: float, n_pos: int, plant: str = "nominal", loads=C.HOLD_LOADS
) -> list[Case]:
    """Holds at ``n_pos`` positions over the period at ``loads``.

    Offset by half a step from 0, so the grid does not sit on the symmetric positions only.

    Parameters
    ----------
    tau : float
        Pole pitch, m.
    load_rated : float
        Rated load, N.
    n_pos : int
        Positions.
    plant : str, optional
        ``"nominal"`` or an off-nominal name.
    loads : sequence of float, optional
        Fractions of ``load_rated``.

    Returns
    -------
    list of Case
        Position by position, load by load.
    """
    out = []
    # (on the full grid's positions: --quick's 8 are every other of the full 16, so that a drive the
    # full certificate passes passes the quick one; a hold near a phase current's zero at a PWM edge
    # can cycle at one position and not a degree beside it)
    stride = C.POSITIONS // n_pos if C.POSITIONS % n_pos == 0 else 1
    grid = C.POSITIONS if stride > 1 else n_pos
    for k in range(n_pos):
        deg = 360.0 * (k * stride + OFFSET) / grid
        x0 = tau * deg / 360.0
        for lf in loads:
            f = lf * load_rated
            out.append(
                Case(
                    name=f"hold {deg:.1f} deg, {f:+.3g} N",
                    kind="hold",
                    plant=plant,
                    sections={
                        "scenario": {"duration": C.HOLD_SETTLE_S + C.END_WINDOW_S},
                        "reference": {"type": "hold"},
                        "initial": {"position_mm": x0 * 1e3, "load_balanced": True},
                        "load": {"type": "constant", "force": f},
                    },
                    target=x0,
                    position_deg=deg,
                    load=f,
                )
            )
    return out


def step_cases(tau: float) -> list[Case]:
    """Steps of :data:`~linsense.verify.criteria.STEP_FRACTIONS` of the pole pitch from rest.

    Parameters
    ----------
    tau : float
        Pole pitch, m.

    Returns
    -------
    list of Case
        One per fraction.
    """
    out = []
    t0 = 0.05
    x0 = start(tau)
    for frac in C.STEP_FRACTIONS:
        x1 = x0 + frac * tau
        out.append(
            Case(
                name=f"step {frac:g} pole pitch ({frac * tau * 1e3:.3g} mm)",
                kind="step",
                plant="nominal",
                sections={
                    "scenario": {"duration": t0 + C.STEP_SETTLE_S + C.END_WINDOW_S + 0.1},
                    "reference": {"type": "step", "position_mm": x1 * 1e3, "at": t0},
                    "initial": {"position_mm": x0 * 1e3},
                },
                target=x1,
                t_event=t0,
                t_end_move=t0,
            )
        )
    return out


def move_distance(tau: float, v_max: float, a_max: float) -> float:
    """The length of a certificate move: at least :data:`~linsense.verify.criteria.TRAJ_PITCHES`
    pole pitches, and long enough to cruise at ``v_max`` over
    :data:`~linsense.verify.criteria.CRUISE_PITCHES` of them after reaching it.

    Parameters
    ----------
    tau : float
        Pole pitch, m.
    v_max : float
        Speed, m/s.
    a_max : float
        Acceleration, m/s^2.

    Returns
    -------
    float
        m.
    """
    return max(C.TRAJ_PITCHES * tau, v_max * v_max / a_max + C.CRUISE_PITCHES * tau)


def peak_speed(distance: float, v_max: float, a_max: float) -> float:
    """The top speed of a trapezoidal move over ``distance`` (``v_max``, or less on a short move).

    Parameters
    ----------
    distance : float
        m.
    v_max : float
        m/s.
    a_max : float
        m/s^2.

    Returns
    -------
    float
        m/s.
    """
    return min(v_max, float(np.sqrt(abs(distance) * a_max)))


def trajectory_case(tau: float, v_max: float, a_max: float, load: float, distance: float | None = None,
                    kind: str = "trajectory", plant: str = "nominal") -> Case:
    """A move at the application's speed and acceleration, against a constant load.

    ``kind``: ``"trajectory"`` out and back with a pause (the load opposing one way and aiding the
    other), ``"reversal"`` out and back without one (through zero speed under load), ``"move_hold"``
    out only, then a hold judged as the holds are.

    Parameters
    ----------
    tau : float
        Pole pitch, m.
    v_max : float
        Speed, m/s.
    a_max : float
        Acceleration, m/s^2.
    load : float
        Load force opposing positive motion, N.
    distance : float or None, optional
        The move, m (default :func:`move_distance`; shorter where the stroke is).
    kind : str, optional
        ``"trajectory"``, ``"reversal"`` or ``"move_hold"``.
    plant : str, optional
        ``"nominal"`` or an off-nominal name.

    Returns
    -------
    Case
        The run.
    """
    d = move_distance(tau, v_max, a_max) if distance is None else distance
    x0 = start(tau)
    x1 = x0 + d
    t0 = 0.1
    dwell = 0.0 if kind == "reversal" else C.TRAJ_DWELL_S
    dur = trapezoid_time(d, v_max, a_max)
    v_top = peak_speed(d, v_max, a_max)
    if kind == "move_hold":
        waypoints, target, t_end = [x1 * 1e3], x1, t0 + dur + 0.01
        tail = C.HOLD_SETTLE_S + C.END_WINDOW_S
        what = f"hold after a {d * 1e3:.4g} mm move"
    else:
        waypoints, target, t_end = [x1 * 1e3, x0 * 1e3], x0, t0 + 2.0 * dur + dwell + 0.01
        tail = C.END_WINDOW_S + 0.2
        what = (f"reversal {d * 1e3:.4g} mm and back" if kind == "reversal" else
                f"trajectory {d * 1e3:.4g} mm and back")
    speed = f"{v_top:.3g} m/s" + ("" if v_top >= v_max * (1 - 1e-9) else f" (of {v_max:g}: the stroke)")
    return Case(
        name=f"{what}, {speed}, {a_max:g} m/s^2, {load:+.3g} N",
        kind=kind,
        plant=plant,
        sections={
            "scenario": {"duration": t_end + tail},
            "reference": {
                "type": "trajectory",
                "waypoints_mm": waypoints,
                "at": t0,
                "v_max": v_max,
                "a_max": a_max,
                "dwell": dwell,
            },
            "initial": {"position_mm": x0 * 1e3, "load_balanced": True},
            "load": {"type": "constant", "force": load},
        },
        target=target,
        t_event=t0,
        t_end_move=t_end,
        load=load,
        speed=v_top,
    )


def load_step_case(tau: float, load_rated: float, x0: float | None = None) -> Case:
    """A step of :data:`~linsense.verify.criteria.LOAD_STEP_FRACTION` of the rated load while holding.

    Parameters
    ----------
    tau : float
        Pole pitch, m.
    load_rated : float
        Rated load, N.
    x0 : float or None, optional
        Where it holds, m (default :func:`start`; the middle of a stroke, whose end stops the step's
        deviation must not reach).

    Returns
    -------
    Case
        The run.
    """
    x0 = start(tau) if x0 is None else x0
    t0 = 0.3
    f = C.LOAD_STEP_FRACTION * load_rated
    return Case(
        name=f"load step 0 -> {f:.3g} N while holding",
        kind="load_step",
        plant="nominal",
        sections={
            "scenario": {"duration": t0 + C.LOAD_RECOVER_S + C.END_WINDOW_S},
            "reference": {"type": "hold"},
            "initial": {"position_mm": x0 * 1e3},
            "load": {"type": "step", "force": 0.0, "force_after": f, "time": t0},
        },
        target=x0,
        t_event=t0,
        load=f,
    )


def moves(tau: float, v_max: float, a_max: float, load_rated: float, quick: bool,
          travel: float | None = None, plant: str = "nominal") -> list[Case]:
    """The certificate's moves at ``v_max`` and ``a_max``.

    Out and back over the loads of :data:`~linsense.verify.criteria.TRAJ_LOADS` (``quick``:
    :data:`~linsense.verify.criteria.TRAJ_LOADS_QUICK`), a reversal through zero speed at the rated
    load and a hold right after a move against it; an off-nominal plant gets the rated load's
    out-and-back only.

    Parameters
    ----------
    tau : float
        Pole pitch, m.
    v_max : float
        Speed, m/s.
    a_max : float
        Acceleration, m/s^2.
    load_rated : float
        Rated load, N.
    quick : bool
        The representative subset.
    travel : float or None, optional
        The stroke from 0, m: the moves are shortened to it (their names then say the speed they
        reach).
    plant : str, optional
        ``"nominal"`` or an off-nominal name.

    Returns
    -------
    list of Case
        The runs.
    """
    d = move_distance(tau, v_max, a_max)
    if travel is not None:
        d = min(d, travel - 2.0 * start(tau))
    if plant != "nominal":
        return [trajectory_case(tau, v_max, a_max, load_rated, d, plant=plant)]
    fracs = C.TRAJ_LOADS_QUICK if quick else C.TRAJ_LOADS
    out = [trajectory_case(tau, v_max, a_max, f * load_rated, d) for f in fracs]
    if not quick:
        out += [trajectory_case(tau, v_max, a_max, load_rated, d, kind="reversal"),
                trajectory_case(tau, v_max, a_max, load_rated, d, kind="move_hold")]
    return out


def all_cases(tau: float, v_max: float, a_max: float, load_rated: float, quick: bool,
              travel: float | None = None) -> list[Case]:
    """The certificate's runs.

    Parameters
    ----------
    tau : float
        Pole pitch, m.
    v_max : float
        The application's speed, m/s.
    a_max : float
        Its acceleration, m/s^2.
    load_rated : float
        Rated load, N.
    quick : bool
        Only the nominal holds at :data:`~linsense.verify.criteria.POSITIONS_QUICK` positions, the
        steps and the moves at +-rated load.
    travel : float or None, optional
        The stroke from 0, m, at least a pole pitch: the moves are shortened to it and every run
        gets its end stops (:func:`linsense.tune.export.end_stops`).

    Returns
    -------
    list of Case
        The runs; those of the plants of :data:`~linsense.verify.criteria.CALIBRATED` run with the
        table measured on them (:mod:`linsense.verify.certificate`).
    """
    if quick:
        cases = hold_cases(tau, load_rated, C.POSITIONS_QUICK) + step_cases(tau)
        cases += moves(tau, v_max, a_max, load_rated, True, travel)
    else:
        cases = hold_cases(tau, load_rated, C.POSITIONS) + step_cases(tau)
        cases += moves(tau, v_max, a_max, load_rated, False, travel)
        cases.append(load_step_case(tau, load_rated, None if travel is None else 0.5 * travel))
        for name in C.OFF_NOMINAL:
            runs = hold_cases(tau, load_rated, C.POSITIONS, plant=name)
            if name in C.CALIBRATED:
                runs += moves(tau, v_max, a_max, load_rated, False, travel, plant=name)
                runs = [dataclasses.replace(c, table="measured") for c in runs]
                # for information, not judged: the same plant at no load with the drive's own table
                runs += hold_cases(tau, load_rated, C.POSITIONS, plant=name, loads=(0.0,))
            cases += runs
    if travel is not None:
        stops = end_stops(tau, travel)
        cases = [dataclasses.replace(c, sections={**c.sections, "travel": stops}) for c in cases]
    else:  # (unbounded: a move longer than the runs' +-10 m gets end stops beyond it)
        cases = [with_room(c, tau) for c in cases]
    return cases




def with_room(case: Case, tau: float) -> Case:
    """``case`` with end stops 20 pole pitches beyond its farthest position where that passes
    :data:`UNBOUNDED_MM` (a fast move's distance grows with v_max^2 / a_max: 25 m at 5 m/s).

    Parameters
    ----------
    case : Case
        A run without end stops of its own.
    tau : float
        Pole pitch, m.

    Returns
    -------
    Case
        ``case``, or a copy with a ``[travel]`` section wide enough for it.
    """
    ref, init = case.sections.get("reference", {}), case.sections.get("initial", {})
    far = max([abs(float(w)) for w in ref.get("waypoints_mm") or []] +
              [abs(float(ref.get("position_mm") or 0.0)), abs(float(init.get("position_mm") or 0.0))])
    if far + 20.0 * tau * 1e3 <= UNBOUNDED_MM:
        return case
    span = far + 20.0 * tau * 1e3
    return dataclasses.replace(case, sections={**case.sections, "travel": {"min_mm": -span, "max_mm": span}})


def off_nominal_motor(motor: Motor, name: str) -> Motor:
    """``motor`` with a tolerance applied (:func:`linsense.model.tolerance.perturbed`).

    Parameters
    ----------
    motor : Motor
        The nominal motor.
    name : str
        A key of :data:`~linsense.verify.criteria.OFF_NOMINAL`, or ``"nominal"`` (``motor``
        unchanged).

    Returns
    -------
    Motor
        The plant.
    """
    if name == "nominal":
        return motor
    k_l, k_r, k_e = C.OFF_NOMINAL[name]
    return perturbed(motor, k_l, k_r, k_e, label=name)


def deg_of(x: np.ndarray | float, tau: float) -> np.ndarray | float:
    """Metres to electrical degrees.

    Parameters
    ----------
    x : float or ndarray
        m.
    tau : float
        Pole pitch, m.

    Returns
    -------
    float or ndarray
        Electrical deg.
    """
    return np.asarray(x) * (360.0 / tau) if not isinstance(x, float) else x * 360.0 / tau


__all__ = [
    "Case",
    "all_cases",
    "off_nominal_motor",
    "hold_cases",
    "step_cases",
    "trajectory_case",
    "moves",
    "move_distance",
    "peak_speed",
    "load_step_case",
    "deg_of",
]

"""Sensorless commissioning of the end-effect table in the simulator: ``linsense commission``.

The drive runs ``LS_MODE_COMMISSION`` (``csrc/ctrl/ls_drive_commission.c``, docs/tuning.md,
"Commissioning without a sensor"): the mover goes back and forth over the travel at a speed above
the hand-over band's top ``v_hi`` (where the EMF estimate alone drives the observer), the HF
demodulator runs beside it with the table being learned, and the drive learns the table from the
HF error against the EMF position, the forward and backward estimates apart and the table their
mean. No encoder is read. The result is a :class:`~linsense.studies.calibrate.Calibration` (the
table, the plant's own for comparison, the stamp), written in ``calibrate``'s formats by
:func:`commission_to`.

Refused before the run (:class:`~linsense.errors.InputError`), naming what is needed: a motor
without saliency (``L_q / L_d`` below :data:`SALIENCY_MIN`), a drive whose design leaves the EMF
estimate off, too little travel (the accelerations to the speed and back plus
:data:`PERIODS_AT_SPEED` electrical periods at speed), a load the drive cannot hold while it
accelerates.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from linsense.analysis.hf import demod_ratio, psi_lut, psi_lut_resistive
from linsense.compensation.lut import build_lut
from linsense.compensation.measured import FIT_RMS_WARN_DEG, end_effect_fit, interpolation_error, table_stamp
from linsense.ctrl import CAL_SLOPE_MAX, LEARN_CRUISE, ffi
from linsense.errors import InputError
from linsense.io import output_set, split_timing
from linsense.model.motor import Motor
from linsense.plausible import KINDS
from linsense.scenario.load import Scenario, scenario_from_dict
from linsense.scenario.sections import TravelSection
from linsense.sim.build import build, designed, resolve_motor
from linsense.sim.core import run_closed_loop
from linsense.sim.metrics import fault_reason
from linsense.sim.to_folder import write_metrics
from linsense.studies.calibrate import (
    Calibration,
    _drive_data,
    _drive_of_scenario,
    _set_drive,
    lut_csv,
    measured_json,
)
from linsense.tune.design import (
    RATED_LOAD_FRACTION,
    DriveData,
    drive_force_constant,
    drive_force_max,
    force_max_text,
    fundamental_speed,
    mean_dq,
    rated_load,
)

__all__ = ["SALIENCY_MIN", "SPEED_OVER_V_HI", "PERIODS_AT_SPEED", "commission", "commission_to",
           "CommissionOutput", "Commissioning", "ratio_slope"]

#: -, the least mean L_q / L_d: below it the HF error is too weak to learn a table from
SALIENCY_MIN = 1.05
#: -, the commissioning speed over the hand-over band's top (the EMF estimate alone, with margin
#: for the speed's ripple)
SPEED_OVER_V_HI = 1.3
#: -, electrical periods at speed each way, at least
PERIODS_AT_SPEED = 1.0
#: -, the force the drive may use to accelerate and hold the load, of K_f i_max
FORCE_SHARE = 0.8
#: s, simulated motion, at most
DURATION_MAX = 10.0
#: 1/s, s and s: the estimates' rate (the table's mean follows at K_INT / 2 where cal.slope is the
#: motor's), the time each point needs in each direction (5 time constants of the mean) and the wait
#: after each acceleration before learning (the speed loop and the EMF estimate settled)
K_INT = 500.0
T_HOLD = 10.0 / K_INT
T_SETTLE = 0.02
#: the share of a leg's cruise in which a point's learning counts toward T_HOLD (measured, ecce2010 at
#: 1 m/s over 345 mm: 56 points learned in 6.1 s, 64 in 7.0 s, 96 not within DURATION_MAX): sets how
#: many points a commissioning is refused beyond
LEARN_SHARE = 0.6
#: the table's points when none are given (more where the motor's table needs them: _table_points)
POINTS_DEFAULT = 56
#: -, the d-current while commissioning, of i_max: it keeps the phase currents off zero, where the
#: dead time biases the HF current in a way that follows the position (ecce2010, dM0 -25 %,
#: switching: the learned table 0.22 deg off with none, 0.16 with 0.2 i_max, 0.10 with 0.4; 0.013
#: with no dead time at all)
D_SHARE = 0.4
#: -, and at least this many times the HF current's peak, so that the d-axis current does not reach
#: zero at the carrier's troughs (small30: 0.4 i_max = 1 A against a 1.08 A peak left its table 0.67
#: deg off, the estimate's cruise error -2.2 / +2.2 deg; 1.62 A: 0.15 deg, -0.3 / +0.4; 0.5 A, under
#: the peak but crossing it cleanly: 0.03; none: 0.11)
D_OVER_HF = 1.5
#: pole pitches of room kept before the travel's end (a move's end overshoots a little: a stroke to
#: the end stop itself faulted `travel`)
END_ROOM_PITCHES = 2.0
#: electrical deg: the estimate's error beyond which the HF estimate has lost the motor (its error
#: signal, sin 2e, turns towards the wrong equilibrium): where a run that did not complete lost it
LOST_DEG = 45.0
#: electrical deg: the table's distance from the simulated plant's own a commissioning is held to
TABLE_BOUND_DEG = 0.3
#: the band's bottom over its top while commissioning (the drive's own design: 0.5). Below the band
#: the HF estimate alone carries the drive, through every reversal; the commissioning's pulsating
#: injection with its d-current holds it worse at speed than the drive's own injection, and a run
#: whose first reversal lost the motor learned nothing. Measured (switching, default drives or the
#: motors' own): at 0.5 three of ten motors (a 25 mm L_q / L_d 1.15 one at 48 V, a 55 mm one at
#: 200 V, m30_low at 72 V) lost it at the first reversal; at 0.25 they learn within 0.073, 0.025 and
#: 0.010 deg, the others within 0.25 deg as before (0.15 and 0.2 alike, m30_low 0.15 / 0.09;
#: docs/tuning.md, "Commissioning without a sensor")
V_LO_SHARE = 0.25
#: the rounds of the default speed's fixed point (:func:`_default_speed`)
DEFAULT_SPEED_ROUNDS = 4
#: m/s^2, the commissioning's acceleration without a load that limits it (and within the design's
#: force rule: the rated load and m a_max within the force at i_max)
A_DEFAULT = 10.0
#: m/s^2, the least acceleration the commissioning halves its own down to (the design's default
#: application's, 1 m/s^2, whose band the EMF check before the run is about)
A_MIN = 1.0
#: the scenario keys of a design's refusal that are about the speed asked for
SPEED_KEYS = ("reference.v_max", "controller.v_max")
#: m/s, the speed caps the band is designed for, the first the bus allows
CAPS = (2.0, 1.5, 1.0, 0.7)
#: s, the HF lock before the first move
T_START = 0.1


@dataclass
class Commissioning(Calibration):
    """A commissioning's table (a :class:`~linsense.studies.calibrate.Calibration`: the table the
    drive is given against the plant's own) with what was learned on the pulsating route.

    Attributes
    ----------
    psi_learned : ndarray or None
        The table learned with the pulsating injection, rad (None on the direct route).
    psi_learned_plant : ndarray or None
        The plant's own table for that injection, rad.
    """

    psi_learned: np.ndarray | None = None  # rad, learned with the pulsating injection (pulsating route)
    psi_learned_plant: np.ndarray | None = None  # rad, the plant's own table for it


@dataclass
class CommissionOutput:
    """What :func:`commission_to` made.

    Parameters
    ----------
    calibration : Calibration
        The commissioning (its table, stamp and metrics).
    metrics : dict
        ``metrics.json`` (without the timing).
    timing : dict
        ``timing.json``.
    files : list of Path
        The files written.
    """

    calibration: Calibration
    metrics: dict
    timing: dict
    files: list[Path] = field(default_factory=list)

    @property
    def completed(self) -> bool:
        """Whether every point was seen in both directions without a fault."""
        return bool(self.calibration.completed)


def _refuse(source: str, key: str, message: str):
    raise InputError(source, key, message)


def commission(motor: Motor | str | None = None, *, scenario: Scenario | None = None,
               plant: Motor | None = None,
               speed: float | None = None, stroke_mm: float | None = None, load: float = 0.0,
               points: int | None = None, fidelity: str = "switching", a_max: float | None = None,
               quad: float | None = None, route: str = "pulsating", drive: dict | None = None,
               d_current: float | None = None, source: str = "<commission>") -> Calibration:
    """Learn the end-effect table without a sensor (module docstring).

    Parameters
    ----------
    motor : Motor or str or None
        The motor the drive believes in (a preset name or file); None with ``scenario``.
    scenario : Scenario or None, optional
        The drive (its drive keys kept, as ``calibrate``'s); its ``[travel]`` bounds the stroke.
    plant : Motor or None, optional
        The motor the drive runs on where it differs (an off-nominal plant).
    speed : float or None, optional
        Commissioning speed, m/s; None: :data:`SPEED_OVER_V_HI` ``v_hi``.
    stroke_mm : float or None, optional
        The back-and-forth stroke, mm; None: the scenario's travel less 10 % at each end, else the
        least travel needed plus 3 pole pitches.
    load : float, optional
        Constant load opposing positive motion, N.
    points : int or None, optional
        Table points over one electrical period; None: :data:`POINTS_DEFAULT`, more where the motor's
        table needs them (:func:`_table_points`).
    fidelity : str, optional
        ``"switching"`` (default, with the drive's dead time) or ``"average"``.
    a_max : float or None, optional
        Acceleration, m/s^2; None: what :data:`FORCE_SHARE` of the force limit leaves after the load.
    quad : float or None, optional
        The drive's injection's kappa; None: the scenario's, else the design's.
    route : str, optional
        ``"pulsating"`` (default): a drive with the elliptical injection learns with the pulsating one
        and its table is the model's for the end effect that fits what was learned (:func:`_carried`);
        ``"direct"``: the drive's own injection learns its own table.
    d_current : float or None, optional
        The d-current while commissioning, A (``injection.d_current``); None: :data:`D_SHARE`
        ``i_max``, at least :data:`D_OVER_HF` times the HF current's peak.
    drive : dict or None, optional
        Drive data over the scenario's or the design's defaults, by
        :class:`~linsense.tune.design.DriveData` name (``v_dc``, ``f_pwm``, ``dead_time``, ``i_max``,
        ``v_inj``, ``f_inj``, ``quad``; SI units; ``v_max`` and ``a_max`` are the commissioning's own).
    source : str, optional
        Name for messages.

    Returns
    -------
    Calibration
        The learned table against the plant's own, ``metrics`` (``max_diff_deg``, ``end_effect_k``,
        ``sim_s``...) and the stamp.

    Raises
    ------
    InputError
        The refusals of the module docstring, one line naming what is needed.
    """
    if motor is None and scenario is None:
        motor = "ecce2010"
    if route not in ("pulsating", "direct"):
        _refuse(source, "route", f"{route!r}: \"pulsating\" or \"direct\"")
    data, source, base_dir = _base_data(motor, scenario, drive, fidelity, quad, load, source)
    obj = motor if isinstance(motor, Motor) else None
    # the design for a cap above the band: its hand-over (v_hi), with the EMF estimate on
    def probe(cap: float) -> Scenario:
        return scenario_from_dict({**data, "control": {**data.get("control", {}), "mode": "sensorless_lut"},
                                   "reference": {"type": "hold", "v_max": cap}}, source, base_dir)

    model = obj if obj is not None else resolve_motor(probe(1.0))
    l_d, l_q = mean_dq(model)
    if l_q / l_d < SALIENCY_MIN:
        _refuse(source, "motor", f"L_q / L_d = {l_q / l_d:.3f} is below {SALIENCY_MIN:g}: without saliency "
                "there is no HF error to learn a table from")
    d = _design(probe, model, source)
    drive_inj = d.injection  # (the drive's injection: its table is the one wanted)
    carried = route == "pulsating" and drive_inj.shape == "pulsating" and drive_inj.quadrature > 0.0
    if carried:  # (learned with the pulsating injection, carried to the drive's by the fitted end effect)
        data.setdefault("injection", {})["quadrature"] = 0.0
        d = _design(probe, model, source)
    _check_emf(d, data, source)
    points = _table_points(model, points, drive_inj, int(d.observer.lut_points), source)
    v = float(speed) if speed is not None else SPEED_OVER_V_HI * float(d.observer.handover_v_hi)
    i_d = _d_current(d, model) if d_current is None else float(d_current)
    data.setdefault("injection", {})["d_current"] = i_d
    dd = DriveData(i_max=float(d.controller.i_max), shape=d.injection.shape, d_current=i_d)
    data.setdefault("controller", {})["rated_load"] = _rated_load(model, dd, load)
    a = _acceleration(dd, model, load, a_max, source)
    v, a = _speed_and_acceleration(data, v, speed, a, a_max is None, model, source, base_dir)
    _check_bus(d, dd, model, load, v, source)
    by_load = a_max is None and load != 0.0 and a < A_DEFAULT  # (the load sets the acceleration)
    stroke, x0 = _stroke(scenario, stroke_mm, v, a, model, source, points, by_load)
    _set_travel(data, scenario, stroke, x0, model)
    leg = stroke / v + v / a
    legs = _legs(stroke, v, a)
    if legs < 2:  # (out and back at least: each point seen both ways)
        key = "stroke" if stroke_mm is not None else "speed"
        _refuse(source, key, f"{stroke * 1e3:.0f} mm at {v:.3g} m/s and {a:.3g} m/s^2 takes {leg:.3g} s a "
                f"way: out and back do not fit in the commissioning's {DURATION_MAX:g} s of motion (at most "
                f"{1e3 * v * ((DURATION_MAX - T_START) / 2.0 - v / a):.0f} mm of stroke at this speed)")
    _check_points(points, stroke, v, a, legs, source)
    wps = [1e3 * (x0 + (stroke if k % 2 == 0 else 0.0)) for k in range(legs)]
    data["initial"]["position_mm"] = 1e3 * x0
    data["control"] = {**data.get("control", {}), "mode": "commission"}
    data.setdefault("observer", {})["emf"] = True
    data["reference"] = {"type": "trajectory", "waypoints_mm": wps, "v_max": v, "a_max": a, "dwell": 0.0,
                         "at": T_START}
    inj = d.injection
    slope = ratio_slope(model, inj.amplitude, inj.frequency, inj.quadrature)
    data["calibration"] = {"points": int(points), "k_int": K_INT, "t_hold": T_HOLD, "t_settle": T_SETTLE,
                           "slope": slope}
    data["record"] = {"decimate": 64}
    sc = scenario_from_dict(data, source, base_dir)
    b = build(sc, obj) if plant is None else build(sc, plant, model=model)
    lut = b.extra["cal_table"]
    start = np.array(lut.table, dtype=float)
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands)
    cal = _result(b, raw, model, lut, start, points, v, a, stroke, load)
    cal.metrics["route"] = "pulsating" if carried else "direct"
    return _carried(cal, model, drive_inj) if carried else cal


def _rated_load(model: Motor, dd: DriveData, load: float) -> float:
    """The rated load the run's design holds its speed and band to, N: the commissioning's load where
    it is larger than the design's default, half the force at i_max (the band's EMF bound then covers
    the commissioning's d-current too; with the load alone the band fell to 0.72 m/s on ecce2010 and
    its table came 0.20 deg off instead of 0.023)."""
    return max(abs(float(load)), rated_load(model, dd))


def _d_current(d, model: Motor) -> float:
    """The commissioning's d-current, A: :data:`D_SHARE` ``i_max``, and at least :data:`D_OVER_HF`
    times the peak of the HF current its injection drives (:func:`~linsense.analysis.hf.
    hf_current_amplitude` over the period)."""
    from linsense.analysis.hf import hf_current_amplitude

    theta = np.linspace(0.0, 2.0 * np.pi, 90, endpoint=False)
    peak = float(np.max(hf_current_amplitude(model, theta, float(d.injection.amplitude),
                                             float(d.injection.frequency))))
    return max(D_SHARE * float(d.controller.i_max), D_OVER_HF * peak)


def _legs(stroke: float, v: float, a: float) -> int:
    """The legs (one way each) of ``stroke`` at ``v`` and ``a`` within the commissioning's motion."""
    return int((DURATION_MAX - T_START - 1e-3) / (stroke / v + v / a))


def _cruise(stroke: float, v: float, a: float) -> float:
    """A leg's cruise, m: the stroke less the acceleration, the deceleration and the settling."""
    return stroke - v * v / a - v * T_SETTLE


def _points_needed(points: int, stroke: float, v: float, a: float) -> tuple[float, float]:
    """The legs ``points`` need (:func:`_check_points`) and the time each point is seen a leg, s."""
    cruise = _cruise(stroke, v, a)
    per_leg = LEARN_SHARE * cruise / (points * v) if cruise > 0.0 else 0.0
    return (2 * math.ceil(T_HOLD / per_leg) if per_leg > 0.0 else math.inf), per_leg


def _points_stroke(points: int, v: float, a: float, base: float, top: float) -> float:
    """The default stroke without a travel: ``base`` (what the speed needs), lengthened by tenths up
    to ``top`` (m) until the motion learns ``points`` (else the longest: :func:`_check_points` says)."""
    stroke, longest = base, base
    while stroke <= top:
        if _points_needed(points, stroke, v, a)[0] <= _legs(stroke, v, a):
            return stroke
        longest = stroke
        stroke *= 1.1
    return longest  # (none fits: the longest, whose refusal names the most points any stroke learns)


def _check_bus(d, dd: DriveData, model: Motor, load: float, v: float, source: str) -> None:
    """Refuse a load the bus cannot drive at the commissioning's speed beside the injection, which
    stays on, with the commissioning's d-current (``d``: the design's scenario, ``dd``: the
    commissioning's drive data): the steady-state voltage of the cruise
    (:func:`~linsense.tune.design.fundamental_speed`)."""
    i_q = abs(load) / drive_force_constant(model, dd)
    i_d = float(dd.d_current or 0.0)
    v_hi = float(d.observer.handover_v_hi)
    l_d, l_q = mean_dq(model)
    v_avail = float(d.inverter.v_dc) / math.sqrt(3.0) - float(d.injection.amplitude)
    top = fundamental_speed(model, v_avail, i_q, l_q, i_d=i_d, L_d=l_d)
    if v > top:
        v_dc = float(d.inverter.v_dc)
        _refuse(source, "load", f"{load:g} N at {v:.3g} m/s needs more voltage than the {v_dc:g} V bus "
                f"leaves beside the injection ({v_avail:.3g} V for the back-EMF with R_s i_q, omega L_q i_q "
                f"and the commissioning's d-current of {i_d:.3g} A): at most {top:.3g} m/s with it"
                + (" (a --speed up to it whose cruise is above the hand-over band)" if top > v_hi else "")
                + ", a smaller load or a larger bus")


def _check_emf(d, data: dict, source: str) -> None:
    """Refuse a drive without the EMF estimate, saying why it is off."""
    if d.observer.emf:
        return
    shape = d.injection.shape
    if data.get("observer", {}).get("emf") is False:
        why = "the scenario turns it off (observer.emf = false)"
    elif shape != "pulsating":
        why = f"the {shape} injection has no EMF step (the pulsating or elliptical one has)"
    else:
        why = ("the design leaves it off for this motor and drive: its error bound stays above 3 deg at "
               "every speed the bus allows, or flux harmonics")
    _refuse(source, "observer.emf", f"no EMF estimate: {why}; commissioning needs it trustworthy at speed")


def _check_points(points: int, stroke: float, v: float, a: float, legs: int, source: str) -> None:
    """Refuse a table of more points than the commissioning's motion can learn: each point is seen
    for ``LEARN_SHARE cruise / (points v)`` a way per leg (the cruise: the stroke less the
    acceleration, the deceleration and the settling) and needs :data:`T_HOLD` each way."""
    cruise = _cruise(stroke, v, a)
    need, per_leg = _points_needed(points, stroke, v, a)
    if need > legs:
        most = int(legs // 2 * LEARN_SHARE * cruise / (v * T_HOLD)) if cruise > 0.0 else 0
        _refuse(source, "positions", f"{points} points need {need} legs of {stroke * 1e3:.0f} mm at "
                f"{v:.3g} m/s ({T_HOLD:g} s each way at each point, {per_leg * 1e3:.2g} ms a leg); {legs} "
                f"fit in the commissioning's {DURATION_MAX:g} s of motion: at most {most} points, or a "
                f"longer stroke (the travel allowing) or a lower speed")


def _speed_design(data: dict, v: float, a: float, model: Motor, source: str, base_dir):
    """The drive designed for the commissioning's speed and acceleration (its band and caps); a
    refusal of the speed named at ``speed``, the user's option."""
    at_speed = {**data, "control": {**data.get("control", {}), "mode": "sensorless_lut"},
                "reference": {"type": "hold", "v_max": v, "a_max": a}}
    try:
        return designed(scenario_from_dict(at_speed, source, base_dir), model).spec
    except InputError as exc:
        if exc.key.split(" ")[0] not in SPEED_KEYS:
            raise
        said = exc.message if exc.message.startswith(f"{v:g} m/s") else f"{v:g} m/s: {exc.message}"
        return _refuse(source, "speed", said)


def _table_points(model: Motor, points: int | None, inj, read_at: int, source: str) -> int:
    """The table's points: ``points``, refused where too coarse for the motor, or (None)
    :data:`POINTS_DEFAULT`, more where the motor's table needs them. Too coarse: the model's table
    at that count, read with the firmware's linear interpolation at the drive's ``read_at`` points,
    off its own by more than :data:`~linsense.compensation.measured.FIT_RMS_WARN_DEG` (``calibrate``
    warns of it; here the learning fits the interpolation over the whole period, so a coarse table's
    very points, and the end effect fitted to them, are off too: 9.3 deg and 1.68 x at 4 points on
    ecce2010, 0.14 deg and 1.01 x at 28)."""
    def err(n: int) -> float:
        return math.degrees(interpolation_error(model, n, inj.shape, inj.frequency, inj.quadrature, read_at))

    n = POINTS_DEFAULT if points is None else int(points)
    e_n = err(n) if n < read_at else 0.0
    if e_n <= FIT_RMS_WARN_DEG:
        return n
    lo, hi = n, read_at  # (the least count within the bound, by bisection: the error falls with n)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if err(mid) <= FIT_RMS_WARN_DEG else (mid, hi)
    if points is None:
        return hi
    return _refuse(source, "positions", f"{n}: the firmware's linear interpolation between {n} points is off "
                   f"this motor's table by up to {e_n:.2g} deg (bound {FIT_RMS_WARN_DEG:g} deg), and the "
                   f"learning fits that interpolation, so the table's points and the end effect it says are "
                   f"off too: at least {hi} points")


def _up(x: float) -> float:
    """``x`` rounded up to three significant digits: a least value, printed, that is not below it."""
    if not x > 0.0:
        return x
    unit = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.ceil(x / unit) * unit


def _check_speed(spec, v: float, pitch: float, source: str) -> None:
    """Refuse a commissioning speed the drive designed for it cannot cruise at: its cruise not above
    the hand-over band (``LS_DRIVE_LEARN_CRUISE v``, as ``ls_drive_set_mode`` requires), or beyond
    the speed cap, the observer's clamp or the over-speed trip a scenario gives; a scenario whose caps
    leave no such speed is named itself."""
    kx = 2.0 * np.pi / pitch
    v_min = float(spec.observer.handover_v_hi) / LEARN_CRUISE
    band = f"the hand-over band's top {v_min * LEARN_CRUISE:.3g} m/s"
    caps = (("controller.v_max", float(spec.controller.v_max)),
            ("observer.omega_max", float(spec.observer.omega_max) / kx),
            ("protection.omega_max", float(spec.protection.omega_max) / kx))
    key, top = min(caps, key=lambda c: c[1])
    if not v >= v_min:
        _refuse(source, "speed", f"{v:.3g} m/s: its cruise ({LEARN_CRUISE:g} of it) is not above {band} of "
                f"the drive designed for it, where the EMF estimate alone is trusted: at least "
                f"{_up(v_min):.3g} m/s")
    if top < v_min:  # (a scenario's own cap: the designed ones follow the speed)
        _refuse(source, key, f"{top:.3g} m/s is below {v_min:.3g} m/s, where the cruise ({LEARN_CRUISE:g} "
                f"of the speed) is above {band}: commission a scenario designed for that speed (linsense "
                f"tune --v-max {SPEED_OVER_V_HI * v_min * LEARN_CRUISE:.3g})")
    if v > top:
        _refuse(source, "speed", f"{v:.3g} m/s is beyond the drive's {key} ({top:.3g} m/s): it would never "
                f"cruise there; at most {top:.3g} m/s, or a scenario designed for it (linsense tune --v-max)")


def _base_data(motor, scenario: Scenario | None, drive: dict | None, fidelity: str, quad: float | None,
               load: float, source: str) -> tuple[dict, str, object]:
    """The scenario keys of the drive to commission (the scenario's drive keys, else the motor's;
    the drive data and kappa over them), its run and load; the source and folder for messages."""
    if scenario is not None:
        data = _drive_of_scenario(scenario)
        source, base_dir = scenario.source, scenario.base_dir
    else:
        data = {"motor": motor if isinstance(motor, str) else "ecce2010"}
        base_dir = None
    given = _drive_data(drive, None, source)  # (an unknown key refused)
    _set_drive(data, {k: v for k, v in given.items() if k not in ("v_max", "a_max")})
    data.setdefault("inverter", {})["fidelity"] = fidelity
    if quad is not None:
        data.setdefault("injection", {})["quadrature"] = float(quad)
    data["scenario"] = {"name": "commission", "duration": DURATION_MAX}
    data["load"] = {"type": "constant", "force": float(load)}
    data.setdefault("initial", {})["load_balanced"] = True
    return data, source, base_dir


def _acceleration(dd: DriveData, model: Motor, load: float, a_max: float | None, source: str) -> float:
    """The commissioning's acceleration, m/s^2, refusing a load the drive cannot hold at speed (its
    force at i_max with the commissioning's d-current, ``dd``: docs/tuning.md, "The force at i_max")."""
    f_max, kfi = drive_force_max(model, dd), force_max_text(model, dd)
    f_acc = FORCE_SHARE * f_max - abs(load)
    if f_acc <= 0.0:
        _refuse(source, "load", f"{load:g} N leaves nothing of {FORCE_SHARE:g} {kfi} = "
                f"{FORCE_SHARE * f_max:.3g} N to accelerate with: the drive cannot hold it at speed")
    # (the design's own rule: its rated load, RATED_LOAD_FRACTION of the force, and m a_max within it)
    a = float(a_max) if a_max is not None else min(A_DEFAULT, f_acc / model.mass,
                                                   0.99 * (1.0 - RATED_LOAD_FRACTION) * f_max / model.mass)
    if model.mass * a > f_acc * (1.0 + 1e-9):  # (f_acc / m times m: one rounding step over it)
        _refuse(source, "a_max", f"{a:g} m/s^2 needs {model.mass * a:.3g} N beside the load's "
                f"{abs(load):g} N: more than {FORCE_SHARE:g} {kfi} = {FORCE_SHARE * f_max:.3g} N")
    return a


def _default_speed(data: dict, v: float, a: float, model: Motor, source: str,
                   base_dir) -> tuple[float, object]:
    """The default commissioning speed, m/s: :data:`SPEED_OVER_V_HI` times the band's top of the drive
    designed for that speed and the commissioning's acceleration, and that design. ``v`` is that of
    the first cap's design at the application's acceleration; the band rises with the speed cap and
    the current of the acceleration (h20-class motors: 2.49 m/s from the first cap, whose own design's
    band tops at 2.53), so the speed follows it for a few rounds (:func:`_check_speed` then says where
    it does not settle)."""
    for _ in range(DEFAULT_SPEED_ROUNDS):
        spec = _speed_design(data, v, a, model, source, base_dir)
        top = float(spec.observer.handover_v_hi)
        if v * LEARN_CRUISE >= top or _never(spec):  # (no band to follow)
            return v, spec
        v = SPEED_OVER_V_HI * top
    return v, _speed_design(data, v, a, model, source, base_dir)


def _never(spec) -> bool:
    """Whether the design's band never starts: its EMF bound never within the band's limit (the band's
    top the design's placeholder, beyond the speeds of linear motors)."""
    return float(spec.observer.handover_v_hi) > KINDS["speed"].high


def _speed_and_acceleration(data: dict, v: float, speed: float | None, a: float, own_a: bool, model: Motor,
                            source: str, base_dir) -> tuple[float, float]:
    """The commissioning's speed (``speed``, else :func:`_default_speed` from ``v``) and acceleration,
    checked against the drive designed for them (:func:`_check_speed`), whose band the run takes
    (:func:`_widen_band`). Where that design leaves the EMF estimate off, its bound never
    within the band's limit at the current of the acceleration beside the rated load (a heavy mover:
    a 15 kg one at 8.2 m/s^2 near i_max, whose band top came back as the design's "never" and was
    offered as a speed of 1300 m/s), or where the default speed, 1.3 times that band's top, is beyond
    what the bus allows, the commissioning's own acceleration (``own_a``) is halved down to
    :data:`A_MIN`; refused if the estimate stays off."""
    while True:
        halve = own_a and a / 2.0 >= A_MIN
        try:  # (the default speed's last design is the one at it: not designed again)
            vv, spec = ((float(speed), _speed_design(data, float(speed), a, model, source, base_dir))
                        if speed is not None else _default_speed(data, v, a, model, source, base_dir))
        except InputError as exc:  # (the default speed, the band's at this current, beyond the bus)
            if speed is not None or not halve or exc.key != "speed":
                raise
            a /= 2.0
            continue
        if not _never(spec) or not halve:
            break
        a /= 2.0
    if _never(spec):
        _refuse(source, "speed" if speed is not None else "motor",
                f"the drive designed for {vv:.3g} m/s at the commissioning's {a:.3g} m/s^2 leaves the EMF "
                f"estimate off: its error bound at the current of m a = {model.mass * a:.3g} N beside the "
                f"rated load is never within the band's limit, and commissioning needs it trusted at speed")
    _check_speed(spec, vv, model.pole_pitch, source)
    _widen_band(data, spec)
    return vv, a


def _widen_band(data: dict, spec) -> None:
    """The band's bottom ``observer.handover_v_lo`` at :data:`V_LO_SHARE` of its top for the run (a
    scenario's own is the drive's, not the commissioning's; the band's other keys as the scenario
    gives them, else the design's at the speed, ``spec``'s): the EMF estimate weighs in from there, so
    that the HF estimate alone carries the reversals only at the speeds where the commissioning's
    injection holds it."""
    obs, o = data.setdefault("observer", {}), spec.observer
    for key in ("handover_v_hi", "inject_v_on", "inject_v_off"):  # (given with it: the design's at the speed)
        obs.setdefault(key, float(getattr(o, key)))
    obs["handover_v_lo"] = V_LO_SHARE * float(obs["handover_v_hi"])


def _set_travel(data: dict, scenario: Scenario | None, stroke: float, x0: float, model: Motor) -> None:
    """Without a travel the scenario bounds, the run's end stops follow the stroke where it is longer
    than the simulator's default travel allows (the machine's travel is then the user's to know: the
    message gives the stroke)."""
    if _bounded(scenario):
        return
    room = END_ROOM_PITCHES * model.pole_pitch * 1e3
    lo, hi = TravelSection().min_mm, TravelSection().max_mm
    if 1e3 * (x0 + stroke) + room > hi:
        data["travel"] = {"min_mm": lo, "max_mm": 1e3 * (x0 + stroke) + 2.0 * room}


def _bounded(scenario: Scenario | None) -> bool:
    """Whether the scenario gives a ``[travel]`` bound."""
    return scenario is not None and scenario.spec.travel is not None and scenario.spec.travel.bounded


def _stroke(scenario: Scenario | None, stroke_mm: float | None, v: float, a: float, model: Motor,
            source: str, points: int = POINTS_DEFAULT, by_load: bool = False) -> tuple[float, float]:
    """The stroke and its start, m (the scenario's travel less 10 % at each end where it gives one,
    else what the speed and the points need, any length: :func:`_set_travel`), refusing too little
    travel."""
    # m: to the speed and back, the settling at speed, and the periods learned at speed
    need = v * v / a + v * T_SETTLE + PERIODS_AT_SPEED * model.pole_pitch
    tr = scenario.spec.travel if scenario is not None else None
    bounded = _bounded(scenario)
    if stroke_mm is None:
        # (without a bounded travel: up to the longest whose out and back fit in the motion)
        longest = v * ((DURATION_MAX - T_START - 1e-3) / 2.0 - v / a)
        stroke = 0.8 * (tr.max_mm - tr.min_mm) / 1e3 if bounded else _points_stroke(
            points, v, a, need + 3.0 * model.pole_pitch, max(longest, need + 3.0 * model.pole_pitch))
    else:
        stroke = float(stroke_mm) / 1e3
    key = "stroke" if stroke_mm is not None else "travel"
    if stroke < need:
        _refuse(source, key, f"{stroke * 1e3:.4g} mm of stroke is too little: {need * 1e3:.1f} mm "
                f"needed at {v:.3g} m/s and {a:.3g} m/s^2 (v^2/a to the speed and back, {T_SETTLE:g} s "
                f"settling and {PERIODS_AT_SPEED:g} electrical period of {model.pole_pitch * 1e3:g} mm "
                f"at speed)" + (" (did you type m? the stroke is in mm)" if stroke_mm is not None and
                                stroke_mm < 10.0 else ""))
    x0 = tr.min_mm / 1e3 + 0.1 * (tr.max_mm - tr.min_mm) / 1e3 if bounded else 0.0
    lo, hi = (tr.min_mm, tr.max_mm) if tr is not None else (TravelSection().min_mm, TravelSection().max_mm)
    room = END_ROOM_PITCHES * model.pole_pitch * 1e3  # (the end of a move overshoots a little: kept)
    if bounded and (1e3 * (x0 + stroke) > hi - room or 1e3 * x0 < lo):
        # (the default stroke follows the speed, and the acceleration the load leaves)
        key = key if stroke_mm is not None or bounded else "load" if by_load else "speed"
        lead = {"speed": f"{v:g} m/s needs {stroke * 1e3:.0f} mm",
                "load": f"the acceleration the load leaves, {a:.3g} m/s^2, needs {stroke * 1e3:.0f} mm"}.get(
                    key, f"{stroke * 1e3:.0f} mm")
        _refuse(source, key, f"{lead} of stroke from {x0 * 1e3:.0f} mm, beyond the travel [{lo:g}, {hi:g}] "
                f"mm (the scenario's [travel], else the simulator's default) less {END_ROOM_PITCHES:g} pole "
                f"pitches of room at its end: at most {hi - room - 1e3 * x0:.0f} mm")
    return stroke, x0


def _lost(raw) -> dict:
    """Where the estimate was first lost (its error beyond :data:`LOST_DEG`): the time (s) and the
    mover's speed there (m/s), None where it never was."""
    err, vel, t = raw.arrays.get("theta_err"), raw.arrays.get("v"), raw.arrays.get("t")
    if err is None or vel is None or t is None:
        return {"lost_at_s": None, "lost_speed_m_s": None}
    over = np.flatnonzero(np.abs(np.degrees(np.ravel(err))) > LOST_DEG)
    if over.size == 0:
        return {"lost_at_s": None, "lost_speed_m_s": None}
    k = int(over[0])
    return {"lost_at_s": round(float(np.ravel(t)[k]), 6), "lost_speed_m_s": round(float(np.ravel(vel)[k]), 6)}


def _cruise_error(raw, v: float) -> dict:
    """The estimate's error (the EMF estimate's, the observer's error there) at the cruise, each
    direction: its mean and its largest departure, electrical deg (what the table learned against it
    carries: the means' half difference cancels, their half sum does not)."""
    err, vel = raw.arrays.get("theta_err"), raw.arrays.get("v")
    out = {}
    for name, sel in (("fwd", None if vel is None else vel > 0.97 * v),
                      ("bwd", None if vel is None else vel < -0.97 * v)):
        e = np.array([]) if err is None or sel is None else np.degrees(np.ravel(err)[np.ravel(sel)])
        out[f"cruise_err_{name}_mean_deg"] = round(float(np.mean(e)), 4) if e.size else None
        out[f"cruise_err_{name}_peak_deg"] = round(float(np.max(np.abs(e))), 4) if e.size else None
    return out


def _design(probe, model: Motor, source: str):
    """The design for the first cap of :data:`CAPS` the bus allows (its hand-over band)."""
    last = None
    for cap in CAPS:
        try:
            return designed(probe(cap), model).spec
        except InputError as exc:
            last = exc
    if last is not None and last.key.split(" ")[0] not in SPEED_KEYS:
        raise last  # (not the speed: what the slowest cap's design refused, as tune says it)
    return _refuse(source, "inverter.v_dc", f"the bus allows none of {', '.join(map(str, CAPS))} m/s: no "
                   f"speed to commission at ({last})")


def _carried(cal: Calibration, model: Motor, inj) -> Calibration:
    """A table learned with the pulsating injection carried to the drive's elliptical one: the model's
    table (:func:`linsense.compensation.lut.build_lut`) of the motor whose end effect fits the learned
    table (:func:`linsense.compensation.measured.end_effect_fit`), compared with the plant's own for
    the drive's injection; the learned table's departure from its fit kept in the metrics.

    The elliptical table follows the position error nearly one to one (about 0.8 of it on ecce2010 at
    kappa 0.9, against 0.07-0.3 for the pulsating one), so learned directly it carries the EMF
    estimate's error at speed; the pulsating table learned, the EMF's error weighs 3-10 times less."""
    m = cal.metrics
    points = m["points"]
    fit, k, rms = end_effect_fit(model, cal.psi_measured, "pulsating", inj.frequency, 0.0)
    table = build_lut(fit, points, f_inj=inj.frequency, quad=inj.quadrature, injection=inj.shape).values
    true = build_lut(cal.motor, points, f_inj=inj.frequency, quad=inj.quadrature, injection=inj.shape).values
    start = build_lut(model, points, f_inj=inj.frequency, quad=inj.quadrature, injection=inj.shape).values
    m.update({
        "learned_diff_deg": m["max_diff_deg"], "learned_start_diff_deg": m["start_diff_deg"],
        "learned_quad": 0.0,
        "max_diff_deg": round(float(np.degrees(np.max(np.abs(table - true)))), 6),
        "start_diff_deg": round(float(np.degrees(np.max(np.abs(start - true)))), 6),
        "injection_quad": float(inj.quadrature), "f_inj_hz": float(inj.frequency),
        "v_inj": float(inj.amplitude),
    })
    stamp = table_stamp(model, inj.shape, inj.frequency, inj.quadrature, points)
    return Commissioning(cal.theta, table, true, cal.psi_eq12, m, cal.motor, stamp,
                         psi_learned=cal.psi_measured, psi_learned_plant=cal.psi_model)


def ratio_slope(motor: Motor, v_inj: float, f_inj: float, quad: float, n: int = 72) -> float:
    """The demodulated ratio's mean change per rad of the table's error, ``-d ratio / d psi`` at the
    motor's table (``ls_cal_cfg.slope``): 1 for the pulsating injection, less for the elliptical one.

    :func:`linsense.analysis.hf.demod_ratio` at no estimation error, differentiated in the
    compensation angle at the resistance-aware table (docs/theory.md, the product demodulator).
    Only the learning's rate depends on it: the learned table's mean is a fixed point whatever it
    is (``csrc/ctrl/ls_drive_commission.c``).

    Parameters
    ----------
    motor : Motor
        The motor the drive believes in.
    v_inj, f_inj, quad : float
        The injection's amplitude (V), frequency (Hz) and kappa.
    n : int, optional
        Positions over the period.

    Returns
    -------
    float
        The mean slope over the period, in (0, ``CAL_SLOPE_MAX``].
    """
    theta = 2.0 * np.pi * np.arange(n) / n
    psi = psi_lut_resistive(motor, theta, f_inj, quad)
    h = 1e-3
    s = (demod_ratio(motor, theta, 0.0, v_inj, f_inj, psi - h, quad=quad)
         - demod_ratio(motor, theta, 0.0, v_inj, f_inj, psi + h, quad=quad)) / (2.0 * h)
    return float(min(max(np.mean(s), 1e-3), CAL_SLOPE_MAX))


def _result(b, raw, model: Motor, lut, start: np.ndarray, points: int, v: float, a: float, stroke: float,
            load: float) -> Calibration:
    """The commissioning's Calibration: the learned table against the plant's own."""
    s = b.scenario.spec
    inj = s.injection
    theta = 2.0 * np.pi * np.arange(points) / points
    table = np.array(lut.table, dtype=float)
    true = build_lut(b.motor, points, f_inj=inj.frequency, quad=inj.quadrature, injection=inj.shape).values
    done = int(b.drive.state.cal_index)
    learn = np.frombuffer(ffi.buffer(lut.learn), dtype=np.float32)
    fwd, bwd = learn[:points].astype(float), learn[points:2 * points].astype(float)
    _, k, rms = end_effect_fit(model, table, inj.shape, inj.frequency, inj.quadrature)
    metrics = {
        "completed": bool(done == points and raw.fault == 0),
        "table_bound_deg": TABLE_BOUND_DEG,
        "points": int(points),
        "points_done": done,
        "max_diff_deg": round(float(np.degrees(np.max(np.abs(table - true)))), 6),
        "start_diff_deg": round(float(np.degrees(np.max(np.abs(start - true)))), 6),
        "max_diff_eq12_deg": round(float(np.degrees(np.max(np.abs(table - psi_lut(b.motor, theta))))), 6),
        "direction_diff_deg": round(float(np.degrees(np.max(np.abs(fwd - bwd)))), 6),
        **_cruise_error(raw, v),
        **_lost(raw),
        "time_min_s": round(float(np.min(learn[2 * points:])), 6),
        "time_mean_s": round(float(np.mean(learn[2 * points:])), 6),
        "end_effect_k": round(float(k), 6),
        "end_effect_fit_rms_deg": round(float(np.degrees(rms)), 6),
        "speed_m_s": round(v, 6), "a_max_m_s2": round(a, 6), "stroke_mm": round(stroke * 1e3, 3),
        "v_hi_m_s": round(float(s.observer.handover_v_hi), 6),
        "load_n": float(load), "fidelity": s.inverter.fidelity, "dead_time_s": float(s.inverter.dead_time),
        "v_dc": float(s.inverter.v_dc), "injection_shape": inj.shape, "f_inj_hz": float(inj.frequency),
        "injection_quad": float(inj.quadrature), "v_inj": float(inj.amplitude),
        "fault": fault_reason(raw.fault),
        "sim_s": round(raw.steps_done / s.inverter.f_pwm, 6),
        "wall_s": round(raw.wall_s, 6),
        "motor": b.motor.name,
    }
    stamp = table_stamp(model, inj.shape, inj.frequency, inj.quadrature, points)
    return Commissioning(theta, table, true, psi_lut(b.motor, theta), metrics, b.motor, stamp)


def commission_to(out: str | Path, motor=None, figure: Callable[[Calibration, Path], object] | None = None,
                  **kwargs) -> CommissionOutput:
    """Commission (:func:`commission`) and write ``calibrate``'s output set: ``lut_measured.csv``,
    ``lut_measured.json`` (when complete and within :data:`TABLE_BOUND_DEG` of the simulated plant's
    table: ``linsense tune --table`` and ``observer.lut_model = "measured"`` read it),
    ``metrics.json``, ``timing.json``.

    Parameters
    ----------
    out : str or Path
        The folder: missing, empty or an earlier output of linsense.
    motor : Motor or str or None
        As :func:`commission`'s.
    figure : callable or None, optional
        ``figure(commissioning, path)`` draws ``commission.png`` (e.g.
        :func:`linsense.report.figures.fig_commission` saved); None: no figure.
    **kwargs : dict
        :func:`commission`'s keywords.

    Returns
    -------
    CommissionOutput
        The commissioning, its metrics and the files written.
    """
    with output_set(out, "commission") as s:  # (the folder checked before the run, not after it)
        cal = commission(motor, **kwargs)
        metrics, timing = split_timing(cal.metrics)
        s.write("lut_measured.csv", lut_csv(cal))
        if cal.completed and cal.metrics["max_diff_deg"] <= TABLE_BOUND_DEG:  # (none off the plant's)
            s.write("lut_measured.json", measured_json(cal))
        write_metrics(s, metrics, timing)
        if figure is not None:
            figure(cal, s.path("commission.png"))
    return CommissionOutput(cal, metrics, timing, list(s.files))

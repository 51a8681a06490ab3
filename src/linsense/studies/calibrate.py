"""The firmware's LUT calibration (paper Fig. 9) run in the simulator: ``linsense calibrate``.

At each of ``positions`` points over one electrical period the drive moves there under encoder
control, settles, then injects and demodulates on the encoder angle and integrates the
compensation angle until the mean demodulated error (the sensorless observer's error against the
encoder) over a window vanishes (``LS_MODE_CALIBRATION``, docs/firmware.md). A small q-current
dither sweeps the phase currents through zero meanwhile, so that the inverter's dead time averages
out instead of biasing the table at no load (docs/simulator.md).

The calibration runs the drive that will use the table: a scenario's (its bus, PWM, dead time,
injection shape, amplitude, frequency and kappa, gains), or the design for the motor
(:func:`linsense.sim.build.designed`, :class:`linsense.tune.design.DriveData`), with the drive-data
keys given over either. The measured table is compared with the model's for the injection the
drive actually runs, once the design has filled it in: the resistance-aware LUT at that frequency
and kappa (or the rotating or square wave's own table), and the paper's eq. (12).

The drive may run on another plant than the motor it believes in (``plant``: an off-nominal motor,
as a real drive runs on its real motor): the drive's gains and tables are its model motor's, the
table measured is the plant's. The table is stamped (:func:`linsense.compensation.measured.table_stamp`)
with the drive it is valid for, the model motor's data digest, the injection's shape, frequency and
kappa, and :func:`measured_json` writes it for ``observer.lut_model = "measured"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from linsense.analysis.hf import psi_lut
from linsense.compensation.lut import build_lut
from linsense.compensation.measured import TableStamp, measured_table_json, table_stamp
from linsense.errors import InputError
from linsense.model.motor import Motor
from linsense.scenario.load import Scenario, scenario_from_dict
from linsense.sim.build import build, designed, motor_key, resolve_motor
from linsense.sim.core import run_closed_loop
from linsense.sim.metrics import fault_reason
from linsense.tune.design import DriveData

#: simulated-time budget per point beyond the settling, of the time t_max after which the drive
#: trips an unconverged point (the points that converge early leave their time to the others)
_BUDGET_OF_T_MAX = 0.5

#: drive data (:class:`~linsense.tune.design.DriveData` field) -> scenario (section, key)
DRIVE_KEYS = {
    "v_dc": ("inverter", "v_dc"),
    "f_pwm": ("inverter", "f_pwm"),
    "dead_time": ("inverter", "dead_time"),
    "i_max": ("controller", "i_max"),
    "v_max": ("reference", "v_max"),
    "a_max": ("reference", "a_max"),
    "v_inj": ("injection", "amplitude"),
    "f_inj": ("injection", "frequency"),
    "quad": ("injection", "quadrature"),
}

#: scenario sections that describe the application or the run, not the drive: the calibration
#: sets its own (its reference is its sequence, its load the ``load`` argument)
_RUN_SECTIONS = ("scenario", "reference", "load", "record", "metrics", "startup")


@dataclass
class Calibration:
    """A measured compensation table and how it compares with the model (angles in rad).

    Attributes
    ----------
    theta : ndarray
        Table positions ``2 pi k / points``, rad.
    psi_measured : ndarray
        The calibration's table, rad (NaN where not reached).
    psi_model : ndarray
        The plant's model LUT with R_s for the injection the drive runs, rad (the plant's true
        table: the one the calibration should find).
    psi_eq12 : ndarray
        Paper eq. (12) of the plant, rad.
    metrics : dict
        ``completed``, ``points``, ``points_done``, ``max_diff_deg``... of the run.
    motor : Motor or None
        The plant's motor.
    stamp : TableStamp or None
        The drive the table is valid for (:func:`linsense.compensation.measured.table_stamp`): the
        motor the drive believes in, the injection's shape, the frequency it ran and kappa, the
        number of positions.
    """

    theta: np.ndarray  # rad, table positions, 2 pi k / points
    psi_measured: np.ndarray  # rad, the calibration's table (NaN where not reached)
    psi_model: np.ndarray  # rad, the plant's model LUT with R_s for the injection the drive runs
    psi_eq12: np.ndarray  # rad, paper eq. (12)
    metrics: dict = field(default_factory=dict)
    motor: Motor | None = None  # the plant's motor
    stamp: TableStamp | None = None  # the drive the table is valid for

    @property
    def completed(self) -> bool:
        """Whether every point was reached without a fault."""
        return bool(self.metrics.get("completed"))


def calibration_scenario(
    motor: Motor | str | None = None,
    positions: int = 56,
    load: float = 0.0,
    fidelity: str = "switching",
    quad: float | None = None,
    source: str = "<calibrate>",
    scenario: Scenario | None = None,
    drive: dict | None = None,
    **sections,
) -> tuple[Scenario, Motor | None]:
    """The scenario a calibration runs and the motor object to build it with.

    The scenario is the one before the design fills in its unset gains; the motor is None for the
    scenario's own motor.

    Parameters
    ----------
    motor : Motor or str or None, optional
        Motor, preset name or motor-file path, or None with ``scenario``.
    positions : int, optional
        Points over one electrical period.
    load : float, optional
        Constant load opposing positive motion, N (the drive starts balanced against it).
    fidelity : str, optional
        Inverter model, ``"switching"`` or ``"average"`` (the scenario's is not used).
    quad : float or None, optional
        Kappa, the injection's q-axis share; None: the scenario's, else the design's.
    source : str, optional
        Name for messages when there is no scenario.
    scenario : Scenario or None, optional
        The drive to calibrate: everything it says about the drive (inverter, injection, observer,
        controller, sensors, protection, calibration, saturation keys) is kept; its reference, load,
        record and start-up are the calibration's. Without it the drive is the design's:
        :class:`~linsense.tune.design.DriveData`'s defaults.
    drive : dict or None, optional
        Drive data over the scenario's or the defaults, by :class:`~linsense.tune.design.DriveData`
        name (``v_dc``, ``f_pwm``, ``dead_time``, ``i_max``, ``v_max``, ``a_max``, ``v_inj``,
        ``f_inj``, ``quad``; SI units); None values are ignored.
    **sections : dict
        Further scenario keys over all that (e.g. ``inverter={"dead_time": 0.0}``).

    Returns
    -------
    scenario : Scenario
        The calibration's scenario.
    motor : Motor or None
        The motor to build it with (None: the scenario's own).

    Raises
    ------
    InputError
        ``motor`` and the scenario's motor differ, an unknown drive key, or a scenario the
        changes make invalid (naming its file and key).
    """
    drive = _drive_data(drive, quad, source)
    explicit = set(drive)
    spec = motor if isinstance(motor, str) else None
    obj = motor if isinstance(motor, Motor) else None
    if scenario is not None:
        source, base_dir = scenario.source, scenario.base_dir
        data = _drive_of_scenario(scenario)
        if motor is not None:
            _same_motor(scenario, spec, obj)
            obj = obj if obj is not None else resolve_motor(scenario)
    else:
        base_dir = None
        data, drive = _drive_of_design(spec, drive)
    _set_drive(data, drive)
    _set_run(data, scenario, fidelity, load, positions)
    for sec, vals in sections.items():
        data.setdefault(sec, {}).update(vals)
    sc = _drive_scenario(data, source, base_dir, explicit)
    # the run's budget: per point the settling and half the time after which a point trips, with
    # the calibration's timings as the drive runs them (designed for the model the drive believes)
    cal = designed(sc, drive_motor(sc, obj)).spec.calibration
    return sc.replace(scenario={"duration": positions * (cal.t_settle + _BUDGET_OF_T_MAX * cal.t_max)}), obj


def _drive_data(drive: dict | None, quad: float | None, source: str) -> dict:
    """The drive data given (None values left out, ``quad`` over them), refusing an unknown key."""
    drive = {k: v for k, v in (drive or {}).items() if v is not None}
    unknown = sorted(set(drive) - set(DRIVE_KEYS))
    if unknown:
        raise InputError(source, unknown[0], f"not a drive-data key (known: {', '.join(DRIVE_KEYS)})")
    if quad is not None:
        drive["quad"] = float(quad)
    return drive


def _drive_of_scenario(scenario: Scenario) -> dict:
    """The keys a scenario gives about its drive: not its run sections (but the reference's speed
    and acceleration limits), nor its table (the calibration measures one)."""
    data = {k: v for k, v in scenario.given().items() if k not in _RUN_SECTIONS}
    keep_ref = {k: v for k, v in scenario.given().get("reference", {}).items() if k in ("v_max", "a_max")}
    data["reference"] = {"type": "hold", **keep_ref}
    # the scenario's table, if any, is not used: the calibration measures one
    for k in ("compensation", "lut_model", "lut_file"):
        data.get("observer", {}).pop(k, None)
    return data


def _drive_of_design(spec: str | None, drive: dict) -> tuple[dict, dict]:
    """Without a scenario: the scenario's keys naming the motor (a Motor object replaces it at the
    build: any preset names it here) and the drive data over the design's (DriveData's defaults,
    read here, never restated)."""
    dd = DriveData()
    given = {f.name: getattr(dd, f.name) for f in fields(DriveData)
             if f.name in DRIVE_KEYS and getattr(dd, f.name) is not None}
    return {"motor": spec or "ecce2010", "reference": {"type": "hold"}}, {**given, **drive}


def _set_drive(data: dict, drive: dict) -> None:
    """The drive data into the scenario's keys ``data`` (control.fs follows a PWM rate given)."""
    for key, val in drive.items():
        sec, k = DRIVE_KEYS[key]
        data.setdefault(sec, {})[k] = float(val)
    if "f_pwm" in drive:
        data.get("control", {}).pop("fs", None)


def _set_run(data: dict, scenario: Scenario | None, fidelity: str, load: float, positions: int) -> None:
    """The calibration's run into the scenario's keys ``data``: its name, seed and mode, the
    inverter model, the balanced constant load, the points and the recording."""
    data["scenario"] = {"name": "calibrate", "duration": 1.0,
                        **({"seed": scenario.spec.scenario.seed} if scenario is not None else {})}
    data.setdefault("inverter", {})["fidelity"] = fidelity
    data.setdefault("control", {})["mode"] = "calibration"
    data["load"] = {"type": "constant", "force": float(load)}
    data.setdefault("initial", {})["load_balanced"] = True
    data.setdefault("calibration", {})["points"] = int(positions)
    data["record"] = {"decimate": 16}


def _drive_scenario(data: dict, source: str, base_dir, explicit: set) -> Scenario:
    """The scenario of ``data``; a refusal of a value given as drive data says so."""
    try:
        return scenario_from_dict(data, source, base_dir)
    except InputError as exc:  # a value given as drive data: say so
        given = {".".join(DRIVE_KEYS[k]): k for k in explicit}
        if exc.key not in given:
            raise
        raise InputError(exc.source, f"{exc.key} (drive data {given[exc.key]})", exc.message) from None


def drive_motor(sc: Scenario, obj: Motor | None = None) -> Motor:
    """The motor a calibration's drive believes in, as loaded.

    ``controller.model.motor`` where the scenario names one, else ``obj``, else the scenario's motor.

    Parameters
    ----------
    sc : Scenario
        The calibration's scenario (:func:`calibration_scenario`).
    obj : Motor or None, optional
        The motor object it is built with (None: the scenario's own).

    Returns
    -------
    Motor
        The motor.
    """
    ov = sc.spec.controller.model.motor
    if ov is not None:
        return resolve_motor(sc, ov, "controller.model.motor", check=False)
    return obj if obj is not None else resolve_motor(sc)


def _same_motor(sc: Scenario, spec: str | None, obj: Motor | None) -> None:
    """Refuse a motor given beside a scenario when it is not the scenario's motor."""
    from linsense.model.motor import load_motor

    given = obj if obj is not None else load_motor(spec)
    own = resolve_motor(sc)
    if motor_key(given) != motor_key(own):
        name = spec if spec is not None else given.name
        raise InputError(sc.source, "motor",
                         f"the scenario's motor {sc.spec.motor!r} ({own.name}) is not the motor given, "
                         f"{name!r} ({given.name}): give one of them (the scenario's gains are its motor's)")


def calibrate(
    motor: Motor | str | None = None,
    positions: int = 56,
    load: float = 0.0,
    fidelity: str = "switching",
    quad: float | None = None,
    source: str = "<calibrate>",
    scenario: Scenario | None = None,
    drive: dict | None = None,
    plant: Motor | None = None,
    **sections,
) -> Calibration:
    """Run the calibration on the drive that will use the table (paper Fig. 9).

    Parameters
    ----------
    motor : Motor or str or None, optional
        A Motor, a preset name or a motor-file path; None with ``scenario`` (its motor; without
        either, ``ecce2010``). Both given: they must be the same motor.
    positions : int, optional
        Points over one electrical period (the paper: 56).
    load : float, optional
        Constant load opposing positive motion, N (the drive starts balanced against it).
    fidelity : str, optional
        Inverter model, ``"switching"`` (default) or ``"average"``.
    quad : float or None, optional
        The injection's q-axis share kappa; None (default): the scenario's, else the design's
        (:class:`~linsense.tune.design.DriveData`); 0 is the paper's pulsating injection, with
        which the table is three times stiffer (docs/theory.md).
    source : str, optional
        Name for messages when there is no scenario.
    scenario : Scenario or None, optional
        The drive; None: the design for ``motor`` on :class:`~linsense.tune.design.DriveData`'s
        drive.
    drive : dict or None, optional
        Drive data over it, by :class:`~linsense.tune.design.DriveData` name
        (:func:`calibration_scenario`).
    plant : Motor or None, optional
        The motor the drive runs on, where it differs from the one the drive believes in (an
        off-nominal plant): the drive stays the one of ``motor`` or the scenario (its design, its
        gains and tables, ``controller.model.motor`` where the scenario names one), the plant is
        this motor. None: the plant is the motor the scenario or ``motor`` names.
    **sections : dict
        Further scenario sections (e.g. ``inverter={"dead_time": 0.0}``).

    Returns
    -------
    Calibration
        The measured table and the plant's model table for the injection the drive runs (its
        frequency and kappa after the design), with ``metrics`` and the table's ``stamp`` (the motor
        the drive believes in, not the plant).

    Raises
    ------
    linsense.errors.InputError
        As :func:`calibration_scenario`, a ``plant`` that is not a Motor, or a scenario the build
        refuses.
    """
    if motor is None and scenario is None:
        motor = "ecce2010"
    _check_plant(plant, source if scenario is None else scenario.source)
    sc, obj = calibration_scenario(motor, positions, load, fidelity, quad, source, scenario, drive,
                                   **sections)
    model = drive_motor(sc, obj)
    b = build(sc, obj) if plant is None else build(sc, plant, model=model)
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands)
    return _calibration(b, raw, model, positions, load)


def _calibration(b, raw, model: Motor, positions: int, load: float) -> Calibration:
    """A calibration's result from its build ``b`` and run ``raw``: the measured table, the
    plant's model table for the injection the drive ran (its frequency and kappa after the
    design), the metrics and the table's stamp (``model``: the motor the drive believes in)."""
    table, done = _measured(b, positions)
    m = b.motor
    s = b.scenario.spec  # the scenario as it ran: the design's values filled in
    inj = s.injection
    f_inj = s.inverter.f_pwm / 2.0 if inj.shape == "square" else inj.frequency
    theta = 2.0 * np.pi * np.arange(positions) / positions
    # (the plant's own table: the one the calibration should find)
    psi_model = build_lut(m, positions, f_inj=f_inj, quad=inj.quadrature, injection=inj.shape).values
    eq12 = psi_lut(m, theta)
    ok = np.isfinite(table)
    metrics = {
        "completed": bool(done == positions and raw.fault == 0),
        "points": int(positions),
        "points_done": done,
        "max_diff_deg": _max_deg(table[ok] - psi_model[ok]),
        "max_diff_eq12_deg": _max_deg(table[ok] - eq12[ok]),
        "load_n": float(load),
        **_run_metrics(s, f_inj, raw),
        "motor": m.name,
    }
    stamp = table_stamp(model, inj.shape, f_inj, inj.quadrature, positions)
    return Calibration(theta, table, psi_model, eq12, metrics, m, stamp)


def _check_plant(plant, source: str) -> None:
    """Refuse a plant that is not a Motor."""
    if plant is not None and not isinstance(plant, Motor):
        raise InputError(source, "plant",
                         f"expected a Motor (the motor the drive runs on), got {type(plant).__name__}")


def _measured(b, positions: int) -> tuple[np.ndarray, int]:
    """The table a calibration's build ``b`` measured, rad (NaN from the first point not done),
    and the points done."""
    done = int(b.drive.state.cal_index)
    table = np.array([b.extra["cal_table"][k] for k in range(positions)], dtype=float)
    table[done:] = np.nan
    return table, done


def _run_metrics(s, f_inj: float, raw) -> dict:
    """The drive a calibration ran (the scenario's spec ``s`` as it ran, the injection frequency
    ``f_inj``, Hz) and the run ``raw``: its metrics after the points and the load."""
    inj = s.injection
    return {
        "fidelity": s.inverter.fidelity,
        "v_dc": float(s.inverter.v_dc),
        "f_pwm_hz": float(s.inverter.f_pwm),
        "dead_time_s": float(s.inverter.dead_time),
        "i_max_a": float(s.controller.i_max),
        "injection_shape": inj.shape,
        "v_inj": float(inj.amplitude),
        "f_inj_hz": float(f_inj),
        "injection_quad": float(inj.quadrature),
        "dither_a": float(s.calibration.dither_a),
        "dither_hz": float(s.calibration.dither_hz),
        "k_int": round(float(s.calibration.k_int), 6),
        "t_settle_s": round(float(s.calibration.t_settle), 6),
        "t_hold_s": round(float(s.calibration.t_hold), 6),
        "t_max_s": round(float(s.calibration.t_max), 6),
        "saturated": bool(s.saturation.enabled),
        "fault": fault_reason(raw.fault),
        "sim_s": round(raw.steps_done / s.inverter.f_pwm, 6),
        "wall_s": round(raw.wall_s, 6),
    }


def _max_deg(d: np.ndarray) -> float | None:
    return round(float(np.degrees(np.max(np.abs(d)))), 6) if d.size else None


def lut_csv(cal: Calibration) -> str:
    """``theta_deg,psi_lut_deg`` rows of the measured table (the points reached).

    Parameters
    ----------
    cal : Calibration
        The calibration.

    Returns
    -------
    str
        The CSV text.
    """
    lines = ["theta_deg,psi_lut_deg"]
    for th, p in zip(np.degrees(cal.theta), np.degrees(cal.psi_measured), strict=True):
        if math.isfinite(p):
            lines.append(f"{th:.6g},{p:.6f}")
    return "\n".join(lines) + "\n"


def measured_json(cal: Calibration) -> str:
    """The stamped JSON of a completed calibration's table (``lut_measured.json``).

    :func:`linsense.compensation.measured.measured_table_json` with the calibration's stamp and its
    reproducible metrics (``metrics``: without the wall-clock ones), for
    ``observer.lut_model = "measured"``.

    Parameters
    ----------
    cal : Calibration
        A calibration of :func:`calibrate`.

    Returns
    -------
    str
        The JSON text.

    Raises
    ------
    linsense.errors.InputError
        The calibration did not complete, has a point not reached (NaN, naming its index) or no stamp.
    """
    from linsense.io import split_timing

    src = "linsense.studies.calibrate.measured_json"
    m = cal.metrics
    if not cal.completed:
        raise InputError(src, "completed", f"the calibration did not complete ({m.get('points_done')} of "
                         f"{m.get('points')} points, fault {m.get('fault')}): no table to write")
    bad = np.nonzero(~np.isfinite(np.asarray(cal.psi_measured, dtype=float)))[0]
    if bad.size:
        raise InputError(src, f"psi_measured[{bad[0]}]", "not reached (NaN): a table needs every point")
    if cal.stamp is None:
        raise InputError(src, "stamp", "the calibration has no stamp (made by calibrate(), it has one)")
    metrics, _ = split_timing(m)
    return measured_table_json(cal.psi_measured, cal.stamp, {"metrics": metrics})

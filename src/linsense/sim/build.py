"""From a validated scenario to the C objects of one run: plant, drive, commands.

The path of a scenario (:func:`build`, read top to bottom): its motors (:func:`motors`) and the
design of every gain it leaves unset (:func:`designed`); what the controller believes about the
motor (:func:`controller_model`: mean L_d and L_q over a period for the decoupling and the
demodulator gain, psi_pm, mass, force constant, R_s, unless ``[controller.model]`` overrides
them); every check of the scenario, before any C object is made (:func:`validate`,
:mod:`linsense.sim.checks`); the plant (:func:`plant`); the drive's configuration, filled from
``ls_drive_default_cfg`` by the one scenario -> ``ls_drive_cfg`` mapping
(:mod:`linsense.tune.cfgmap`, :mod:`linsense.sim.drive_cfg`); its tables
(:mod:`linsense.sim.drive_tables`: :class:`linsense.ctrl.Lut` objects kept alive by the :class:`Built`
that owns the drive); the drive (:func:`make_drive`, :func:`start_drive`). The C library keeps its
own checks as the last line (:mod:`linsense.sim.refusal` names the key a refusal comes from).
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

from linsense import examples
from linsense.ctrl import ConfigError, Drive, LearnedLut, ffi
from linsense.errors import InputError, LinsenseError, ModelError
from linsense.model.motor import Motor, load_motor, motor_path, names_a_path, preset_names
from linsense.model.saturation import Saturation
from linsense.scenario.load import Scenario
from linsense.scenario.rules import compensation_of
from linsense.sim.cache import memo, motor_key
from linsense.sim.checks import (
    check_events,
    check_final_window,
    check_initial_load,
    check_positions,
    check_run_size,
    check_sensors,
    check_startup,
    check_trace_file,
    check_units,
    run_steps,
    sensor_triples,
    slowest_loop,
)
from linsense.sim.core import PlantSetup, SimulationError, plant_template, sim_cfg
from linsense.sim.drive_cfg import calibration_table, drive_values, fill, value_of
from linsense.sim.drive_tables import Tables, drive_tables, measured_model, measured_warnings
from linsense.sim.plant import fill_saturation, lab_fourier
from linsense.sim.refusal import explain, given_keys
from linsense.tune.cfgmap import Values
from linsense.tune.design import DriveData, drive_force_max, force_max_text, mean_dq
from linsense.tune.drive_design import design_drive
from linsense.tune.handover import HANDOVER_KEYS

#: the names other modules import from here (the checks, the cache and the tables live in their
#: own modules: linsense.sim.checks, .cache, .drive_tables, .drive_cfg)
__all__ = ["Built", "build", "designed", "drive_data", "calibration_timing", "resolve_motor", "motor_key",
           "plant_saturation", "reference_commands", "trapezoid_time", "initial_load", "compensation_of",
           "check_positions", "check_initial_load", "check_balanced_load", "check_sensors", "check_startup",
           "check_run_size", "check_trace_file", "check_events", "check_final_window", "check_units",
           "run_steps",
           "validate", "Tables"]

#: drive sub-configuration -> scenario section (for messages)
_SECTION = {"inject": "injection", "bpf": "injection", "sep": "injection", "demod": "observer",
            "obs": "observer", "enc_obs": "sensors", "current": "controller", "pos": "controller",
            "pos.speed": "controller", "traj": "reference", "mod": "inverter", "prot": "protection",
            "startup": "startup"}


@dataclass
class Built:
    """Everything one run needs; keeps the cffi objects (drive, tables) alive together.

    Attributes
    ----------
    scenario : Scenario
        The scenario, with the designed values (:func:`designed`).
    motor : Motor
        The plant's motor.
    setup : PlantSetup
        The plant's setup.
    cfg : cffi ``ls_sim_cfg *``
        The plant's C configuration.
    drive : Drive
        The initialised drive.
    commands : list of (float, float, bool)
        ``(t [s], x [m], move)`` for :func:`linsense.sim.core.run_closed_loop`.
    n_steps : int
        PWM periods of the run.
    moves : list of (float, float, float, float)
        The planned moves ``(t_start, t_end, x_from, x_to)``, s and m.
    known : dict
        Motor values the controller uses.
    extra : dict
        cffi objects kept alive with the drive (the calibration table).
    user_keys : set of str
        The dotted keys the file gives (the design sets the others).
    warnings : list of str
        Doubts about the inputs the run was built from, for the command to say (a measured table
        that does not look like the motor's, :func:`linsense.sim.drive_tables.measured_warnings`).
    """

    scenario: Scenario
    motor: Motor
    setup: PlantSetup
    cfg: object  # ls_sim_cfg *
    drive: Drive
    commands: list[tuple[float, float, bool]]
    n_steps: int
    moves: list[tuple[float, float, float, float]]  # (t_start, t_end, x_from, x_to), m and s
    known: dict = field(default_factory=dict)  # motor values the controller uses
    extra: dict = field(default_factory=dict)  # cffi objects kept alive with the drive (calibration table)
    user_keys: set = field(default_factory=set)  # the dotted keys the file gives (the design sets the others)
    warnings: list = field(default_factory=list)  # doubts about the inputs, for the command to say


# ------------------------------------------------------------------ the path of a scenario
def build(sc: Scenario, motor: Motor | None = None, trace_in_memory: bool = True, *,
          model: Motor | None = None) -> Built:
    """Configure the plant and the drive of a scenario.

    ``motor`` replaces the scenario's motor (a Motor object from Python), ``model`` the motor the
    controller believes in. Gains the scenario leaves unset are designed for the controller's motor
    (:func:`designed`).

    The path: the motors and the design, every check of the scenario (:func:`validate`, before any
    C object is made), the plant, the drive's configuration (the mapping of
    :mod:`linsense.tune.cfgmap`), its tables, the drive. The C library keeps its own checks as the
    last line: a refusal there names the scenario key it comes from (:mod:`linsense.sim.refusal`).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    motor : Motor or None, optional
        Replaces the scenario's motor.
    trace_in_memory : bool, optional
        False: the run is streamed in chunks (:mod:`linsense.sim.stream`), its trace not kept, so
        the limit on the trace kept in memory does not apply.
    model : Motor or None, optional
        Replaces the motor the controller believes in (``controller.model.motor``, else the plant's):
        e.g. the nominal motor of a drive run on an off-nominal plant (:func:`motors`).

    Returns
    -------
    Built
        Everything the run needs.

    Raises
    ------
    linsense.errors.InputError
        Bad values, naming the scenario file and the key.
    """
    motor, model_motor = motors(sc, motor, model)
    user_keys = given_keys(sc.given())  # (the keys the file gives: designed() sets the others)
    sc = designed(sc, model_motor)
    stamp_motor = model_motor  # (a measured table's stamp names the motor as loaded)
    model_motor = measured_model(sc, model_motor)  # (its end effect, with a measured table)
    known = controller_model(sc, model_motor)
    sat, n_steps = validate(sc, motor, known, user_keys, trace_in_memory)
    setup, cfg = plant(sc, motor, sat)
    v = drive_values(sc, motor, model_motor, known)
    d = fill(v)
    calibrating = sc.spec.control.mode == "calibration"
    cal_table = calibration_table(d, sc.spec.calibration.points) if calibrating else None
    learning = sc.spec.control.mode == "commission"
    drive = make_drive(sc, model_motor, known, v, d, user_keys, stamp_motor,
                       learn_points=sc.spec.calibration.points if learning else None)
    if learning:  # (the table the drive learns, read back from it: docs/tuning.md, "Commissioning")
        cal_table = drive.comp
    check_units(sc, motor.pole_pitch, user_keys, believed(model_motor))  # (after the C library's limits)
    start_drive(sc, drive, motor, setup)
    cmds, moves = reference_commands(sc)
    return Built(sc, motor, setup, cfg, drive, cmds, n_steps, moves, known,
                 extra={} if cal_table is None else {"cal_table": cal_table}, user_keys=user_keys,
                 warnings=measured_warnings(sc, stamp_motor))


def motors(sc: Scenario, motor: Motor | None = None, model: Motor | None = None) -> tuple[Motor, Motor]:
    """The plant's motor and the one the controller believes in.

    The plant's is ``motor``, else the scenario's; the controller's (its tables, gains and
    feed-forwards) is ``model``, else the plant's unless ``controller.model.motor`` names another
    (e.g. one with a parameter off, to test the LUT's robustness), with the same pole pitch.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    motor : Motor or None, optional
        Replaces the scenario's motor.
    model : Motor or None, optional
        Replaces the controller's motor.

    Returns
    -------
    plant : Motor
        The plant's motor.
    model : Motor
        The controller's.

    Raises
    ------
    linsense.errors.InputError
        A motor that cannot be loaded, or a controller's motor of another pole pitch.
    """
    motor = resolve_motor(sc) if motor is None else motor
    ov = sc.spec.controller.model
    if model is not None:
        model_motor = model
    else:
        model_motor = motor if ov.motor is None else resolve_motor(sc, ov.motor, "controller.model.motor",
                                                                   check=False)
    if not math.isclose(model_motor.pole_pitch, motor.pole_pitch, rel_tol=1e-9):
        raise InputError(sc.source, "controller.model.motor" if model is None else "motor",
                         f"pole pitch {model_motor.pole_pitch:g} m differs from the motor's "
                         f"{motor.pole_pitch:g} m: a controller cannot believe in another pole pitch")
    return motor, model_motor


def believed(model_motor: Motor) -> dict[str, float]:
    """The motor's own value of each key of ``[controller.model]`` that overrides one
    (:func:`linsense.sim.checks.check_units` holds the overrides near them).

    Parameters
    ----------
    model_motor : Motor
        The motor the controller believes in.

    Returns
    -------
    dict
        ``controller.model.L_d`` and ``L_q`` (the means over a period, H), ``R_s`` (ohm), ``psi_pm``
        (Wb), ``mass`` (kg), ``force_constant`` (N/A).
    """
    L_d, L_q = memo(("mean_dq", motor_key(model_motor)), lambda: mean_dq(model_motor))
    own = {"L_d": L_d, "L_q": L_q, "R_s": model_motor.R_s, "psi_pm": model_motor.psi_pm,
           "mass": model_motor.mass, "force_constant": model_motor.force_constant}
    return {f"controller.model.{k}": float(v) for k, v in own.items()}


def controller_model(sc: Scenario, model_motor: Motor) -> dict:
    """What the controller believes about the motor.

    ``[controller.model]``'s values, else the model's (mean L_d and L_q over a period; the
    demodulator gain ``L_q / (L_q - L_d)``, None without saliency: refused by :func:`validate`).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    model_motor : Motor
        The motor the controller believes in.

    Returns
    -------
    dict
        ``L_d``, ``L_q`` (H), ``R_s`` (ohm), ``psi_pm`` (Wb), ``mass`` (kg), ``force_constant``
        (N/A), ``demod_gain``.

    Raises
    ------
    linsense.errors.InputError
        ``controller.model.R_s`` outside the range of real motors: the tables are made for the model
        with it, a :class:`~linsense.model.motor.Motor`, held to the motor file's limits.
    """
    ov = sc.spec.controller.model
    if ov.R_s is not None:
        try:
            dataclasses.replace(model_motor, R_s=ov.R_s)
        except InputError as exc:
            raise InputError(sc.source, "controller.model.R_s", exc.message) from None
    L_d, L_q = memo(("mean_dq", motor_key(model_motor)), lambda: mean_dq(model_motor))
    known = {
        "L_d": ov.L_d if ov.L_d is not None else L_d,
        "L_q": ov.L_q if ov.L_q is not None else L_q,
        "R_s": ov.R_s if ov.R_s is not None else model_motor.R_s,
        "psi_pm": ov.psi_pm if ov.psi_pm is not None else model_motor.psi_pm,
        "mass": ov.mass if ov.mass is not None else model_motor.mass,
        "force_constant": ov.force_constant if ov.force_constant is not None else model_motor.force_constant,
    }
    if ov.demod_gain is not None:
        known["demod_gain"] = ov.demod_gain
    elif known["L_q"] != known["L_d"]:
        known["demod_gain"] = known["L_q"] / (known["L_q"] - known["L_d"])
    else:
        known["demod_gain"] = None
    return known


def validate(sc: Scenario, motor: Motor, known: dict, user_keys: set[str],
             trace_in_memory: bool = True) -> tuple[Saturation | None, int]:
    """Every check of the designed scenario the build makes, before any C object is made.

    The motor files and the design refuse while they are read.

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    motor : Motor
        The plant's motor.
    known : dict
        Motor values the controller uses.
    user_keys : set of str
        The dotted keys the file gives.
    trace_in_memory : bool, optional
        Whether the run keeps its trace in memory (its size is then limited).

    Returns
    -------
    saturation : Saturation or None
        The plant's saturation (:func:`plant_saturation`).
    n_steps : int
        The run's PWM periods.

    Raises
    ------
    InputError
        Naming the scenario key, its value and the limit.
    """
    s = sc.spec
    if known["demod_gain"] is None:
        raise InputError(sc.source, "controller.model.L_q", "equals L_d: no saliency, no demodulator gain")
    gain, offs = sensor_triples(s.sensors)
    check_sensors(sc.source, gain, offs, s.sensors.current_noise, s.protection.i_max,
                  "protection.i_max" in user_keys)
    sat = plant_saturation(sc, motor)
    if s.control.mode == "startup" and sat is not None and not sat.polarity > 0.0:
        # (a polarity of 0 given in the scenario is refused there; this is the motor file's)
        raise InputError(sc.source, "saturation.polarity", f"motor {motor.name!r} has no magnet-polarity "
                         "signal ([saturation] polarity = 0) for the pulses of control.mode = \"startup\" to "
                         "find: give saturation.polarity (1/A) here or in the motor file")
    if s.observer.load_feedforward and s.observer.type != "mech":
        raise InputError(sc.source, "observer.load_feedforward",
                         "needs observer.type = \"mech\" (the load estimate is the mechanical observer's)")
    check_positions(sc, motor.pole_pitch)
    check_initial_load(sc, initial_load(sc, motor))
    check_balanced_load(sc, motor)
    check_startup(sc)
    n_steps = run_steps(sc.source, s.scenario.duration, s.inverter.f_pwm)
    check_events(sc, n_steps, reference_commands(sc)[1], user_keys)
    check_final_window(sc, motor.mass, user_keys)
    check_run_size(sc.source, n_steps, s.record.decimate, s.inverter.f_pwm, trace_in_memory)
    return sat, n_steps


def check_balanced_load(sc: Scenario, motor: Motor) -> None:
    """Refuse a start in equilibrium with a load beyond the force the drive can make.

    ``initial.load_balanced`` with a load force at t = 0 beyond the force at ``controller.i_max``
    (:func:`~linsense.tune.design.drive_force_max`, the injection's d-current counted): the current
    reference is clamped at ``i_max`` and the drive cannot balance it (a calibration under such a
    ``--load`` ran and stopped on "fault encoder", blaming the encoder).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    motor : Motor
        The plant's motor.

    Raises
    ------
    InputError
        Naming the load key that sets the force at t = 0, its value and the largest force.
    """
    s = sc.spec
    if not s.initial.load_balanced:
        return
    f_load, dd = initial_load(sc, motor), drive_data(sc)  # (the force with the injection's d-current)
    f_max, kfi = drive_force_max(motor, dd), force_max_text(motor, dd, "controller.i_max")
    if abs(f_load) <= f_max:
        return
    ld = s.load
    key = "load.force_after" if ld.type == "step" and ld.time <= 0.0 else "load.force"
    raise InputError(sc.source, key, f"{f_load:g} N at t = 0 (initial.load_balanced = true) is beyond the "
                     f"force the drive can make to balance it, {kfi} = {f_max:.4g} N: at most "
                     f"{f_max:.4g} N in magnitude, or raise controller.i_max")


def plant(sc: Scenario, motor: Motor, sat: Saturation | None) -> tuple[PlantSetup, object]:
    """The plant's set-up and its ``ls_sim_cfg *``.

    From a cached template of the motor, saturated with ``sat``.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    motor : Motor
        The plant's motor.
    sat : Saturation or None
        The plant's saturation (None: linear).

    Returns
    -------
    setup : PlantSetup
        The set-up.
    cfg : cffi ``ls_sim_cfg *``
        The C configuration.

    Raises
    ------
    linsense.errors.InputError
        The saturated plant or the simulator's configuration refused.
    """
    s = sc.spec
    inv, sens, tr, ld = s.inverter, s.sensors, s.travel, s.load
    gain, offs = sensor_triples(sens)
    setup = PlantSetup(
        fidelity=inv.fidelity, v_dc=inv.v_dc, f_pwm=inv.f_pwm, dead_time=inv.dead_time,
        i_gain=tuple(gain), i_offset=tuple(offs), i_noise=sens.current_noise, adc_bits=sens.adc_bits,
        adc_range=sens.adc_range, enc_counts=sens.encoder_counts_per_period, seed=s.scenario.seed,
        motion="free", x0=s.initial.position_mm * 1e-3, v0=0.0,
        x_min=tr.min_mm * 1e-3, x_max=tr.max_mm * 1e-3,
        load=ld.type, load_f0=ld.force, load_f1=ld.force_after, load_t=ld.time,
        load_incline=math.radians(ld.incline_deg), decimate=s.record.decimate, i_abort=s.protection.i_abort,
    )
    try:
        template = memo(("plant", motor_key(motor)),
                        lambda: plant_template(motor, lab_fourier(motor.inductance, 1e-12)))
        if sat is not None:
            lin = template
            template = memo(("plant_sat", motor_key(motor), sat.key()),
                            lambda: _sat_template(lin, motor, sat))
        cfg = sim_cfg(motor, setup, template=template)
    except ModelError as exc:  # (the saturated plant's data: the scenario's key, or the motor file's)
        key = exc.key if exc.key == "saturation.polarity" else ""
        raise InputError(sc.source, key, f"saturated plant refused: {exc}") from None
    except (SimulationError, LinsenseError) as exc:
        raise InputError(sc.source, "", f"simulator configuration refused: {exc}") from None
    return setup, cfg


def make_drive(sc: Scenario, model_motor: Motor, known: dict, v: Values, d, user_keys: set[str],
               stamp_motor: Motor | None = None, learn_points: int | None = None) -> Drive:
    """The drive over a configuration, with its tables (:func:`linsense.sim.drive_tables.drive_tables`).

    A refusal of ``ls_drive_init`` (the C library's own checks, the last line) names the one field
    at fault, its scenario key, the value and the limit.

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    model_motor : Motor
        The motor the controller believes in.
    known : dict
        Motor values the controller uses.
    v : Values
        The drive values.
    d : cffi ``ls_drive_cfg *``
        The configuration (:func:`linsense.sim.drive_cfg.fill` from ``v``).
    user_keys : set of str
        The dotted keys the file gives.
    stamp_motor : Motor or None, optional
        The motor a measured table's stamp must name (default ``model_motor``).
    learn_points : int or None, optional
        ``control.mode = "commission"``: the table the drive learns has this many points, starting
        from the drive's own table resampled (a :class:`~linsense.ctrl.LearnedLut`, the drive's
        ``comp``, ``cfg.cal.table`` and ``cfg.cal.learn``).

    Returns
    -------
    Drive
        The initialised drive.

    Raises
    ------
    linsense.errors.InputError
        The configuration refused by the controller library.
    """
    try:
        t = drive_tables(sc, model_motor, known["R_s"], v, stamp_motor)
        comp = t.comp
        if learn_points is not None and comp is not None:
            comp = LearnedLut(_resampled(comp.table, learn_points))
            comp.attach(d)
        return Drive(d, comp=comp, gain_table=t.gain_table, comp_r=t.comp_r, gain_r=t.gain_r)
    except ConfigError as exc:
        told = explain(d, user_keys, lambda k: value_of(sc.spec, k))
        if told is not None:
            raise InputError(sc.source, *told) from None
        sections = sorted({_SECTION.get(k.split(".")[0] if k != "pos.speed" else k, k) for k in exc.fields})
        raise InputError(sc.source, ",".join(sections), f"refused by the controller library: {exc}") from None


def _resampled(table, points: int):
    """A periodic table (values at ``2 pi k / N``) at ``points`` points by its linear interpolation
    (the drive's, ``ls_lut.h``)."""
    import numpy as np

    t = np.asarray(table, dtype=float)
    u = np.arange(points) * (t.size / points)
    k = np.floor(u).astype(int) % t.size
    f = u - np.floor(u)
    return (1.0 - f) * t[k] + f * t[(k + 1) % t.size]


def start_drive(sc: Scenario, drive: Drive, motor: Motor, setup: PlantSetup) -> None:
    """Tell the drive where the mover starts, the load it starts balanced with, and the scenario's mode.

    The start-up does not know where the mover starts: its estimate starts at
    ``startup.guess_mm``.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    drive : Drive
        The drive.
    motor : Motor
        The plant's motor (its pole pitch).
    setup : PlantSetup
        The plant's set-up (the start position).

    Raises
    ------
    linsense.errors.InputError
        The mode refused (naming ``control.mode``).
    linsense.errors.ConfigError
        The start position or load refused by the C library.
    """
    s = sc.spec
    ctl = s.control
    x_known = s.startup.guess_mm * 1e-3 if ctl.mode == "startup" else setup.x0
    drive.set_position(2.0 * math.pi * x_known / motor.pole_pitch)
    if s.initial.load_balanced:
        drive.set_load(initial_load(sc, motor))
    try:
        drive.set_mode(ctl.mode)
    except ConfigError as exc:
        raise InputError(sc.source, "control.mode", f"{ctl.mode!r} refused: {exc}") from None


# ------------------------------------------------------------------ the motors, the design, the reference
def plant_saturation(sc: Scenario, motor: Motor) -> Saturation | None:
    """The saturation of the plant a scenario runs (None: the linear plant).

    The motor file's ``[saturation]`` with the scenario's ``[saturation]`` keys over it, when
    ``saturation.enabled``.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    motor : Motor
        The plant's motor.

    Returns
    -------
    Saturation or None
        The saturation data.

    Raises
    ------
    linsense.errors.InputError
        Saturation enabled for a motor without any, or ``q_drop`` given for tabulated saturation.
    """
    ss = sc.spec.saturation
    if not ss.enabled:
        return None
    over = {k: getattr(ss, k) for k in ("polarity", "magnet_current", "q_drop", "q_current")
            if getattr(ss, k) is not None}
    if motor.saturation is None and not over:
        raise InputError(sc.source, "saturation.enabled",
                         f"motor {motor.name!r} has no [saturation] section: give saturation.polarity "
                         "and/or q_drop here, or a [saturation] section in the motor file")
    base = motor.saturation if motor.saturation is not None else Saturation(source=sc.source)
    if base.tables and over.get("q_drop"):
        raise InputError(sc.source, "saturation.q_drop",
                         f"motor {motor.name!r} has saturation tables (they give the q-axis), "
                         f"got {over['q_drop']!r}")
    return dataclasses.replace(base, **over)


def _load_motor_file_cached(path: Path, check: bool) -> Motor:
    st = os.stat(path)  # its path, time and size (one stat; an edited file reloads)
    stamp = (os.fspath(path), st.st_mtime_ns, st.st_size)
    return memo(("motor", check) + stamp, lambda: load_motor(path, check=check))


def resolve_motor(sc: Scenario, spec: str | None = None, key: str = "motor", check: bool = True) -> Motor:
    """The scenario's motor, or the motor ``spec`` given at ``key``.

    A preset name or a file path relative to the scenario file (loaded once per process).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    spec : str or None, optional
        The motor (None: the scenario's ``motor``).
    key : str, optional
        The key that gave it, for messages.
    check : bool, optional
        False skips :func:`~linsense.model.motor.check_motor` (for a motor the controller only
        believes in: its tables need not describe a realisable winding).

    Returns
    -------
    Motor
        The motor.

    Raises
    ------
    linsense.errors.InputError
        An unknown preset or a missing file.
    linsense.errors.ModelError
        A motor unusable for HF sensorless control (``check``).
    """
    spec = sc.spec.motor if spec is None else spec
    if not names_a_path(spec):
        if spec in preset_names():
            return memo(("motor", check, "preset", spec), lambda: load_motor(spec, check=check))
        if motor_path(spec) == spec:  # (else a packaged example motor's name: its file)
            raise InputError(sc.source, key, f"unknown preset {spec!r} (presets: "
                             f"{', '.join(preset_names())}; examples: {', '.join(examples.names('motors'))}; "
                             "or a path to a .toml motor file, relative to the scenario)")
    p = Path(motor_path(spec))
    where = ""
    if not p.is_absolute():
        p = sc.base_dir / p
        folder = "the working folder" if sc.source == "<stdin>" else "the scenario's folder"
        where = f" (a path is taken relative to {folder}, {str(sc.base_dir.resolve())!r})"
    if not p.is_file():
        raise InputError(sc.source, key, f"no such motor file {spec!r}: {str(p.resolve())!r} does not "
                         f"exist{where}")
    return _load_motor_file_cached(p, check)


def _sat_template(linear, motor: Motor, sat: Saturation):
    """A copy of the (linear) plant template switched to the saturated plant."""
    c = ffi.new("ls_sim_cfg *")
    ffi.memmove(c, linear, ffi.sizeof("ls_sim_cfg"))
    fill_saturation(c, motor, sat)
    return c


def trapezoid_time(distance: float, v_max: float, a_max: float) -> float:
    """Duration of a minimum-time move, as ``ls_traj`` plans it.

    Parameters
    ----------
    distance : float
        m (its sign ignored).
    v_max : float
        Speed limit, m/s.
    a_max : float
        Acceleration limit, m/s^2.

    Returns
    -------
    float
        s.
    """
    d = abs(distance)
    if d <= v_max * v_max / a_max:
        return 2.0 * math.sqrt(d / a_max)
    return d / v_max + v_max / a_max


def reference_commands(sc: Scenario) -> tuple[list, list]:
    """Commands for :func:`~linsense.sim.core.run_closed_loop` and the planned moves of a scenario.

    Parameters
    ----------
    sc : Scenario
        The scenario.

    Returns
    -------
    commands : list of (float, float, bool)
        ``(t [s], x [m], move)``.
    moves : list of (float, float, float, float)
        ``(t0, t1, x0, x1)``, s and m.
    """
    ref = sc.spec.reference
    x0 = sc.spec.initial.position_mm * 1e-3
    if ref.type == "hold":
        return [], []
    if ref.type == "step":
        x1 = ref.position_mm * 1e-3
        return [(ref.at, x1, False)], [(ref.at, ref.at, x0, x1)]
    f_pwm = sc.spec.inverter.f_pwm
    cmds, moves = [], []
    t, x = ref.at, x0
    for w in ref.waypoints_mm:
        x1 = w * 1e-3
        dur = trapezoid_time(x1 - x, ref.v_max, ref.a_max)
        # the C core issues a command at the first period start >= t and the profile advances one
        # sample per period: allow two periods so a move is never cut by the next command
        cmds.append((t, x1, True))
        moves.append((t, t + dur, x, x1))
        t = t + dur + 2.0 / f_pwm + ref.dwell
        x = x1
    return cmds, moves


def initial_load(sc: Scenario, motor: Motor) -> float:
    """The load force at t = 0, as the plant applies it.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    motor : Motor
        The motor (its mass, for an incline).

    Returns
    -------
    float
        N, opposing positive motion when > 0.
    """
    ld = sc.spec.load
    if ld.type == "step":
        return ld.force_after if ld.time <= 0.0 else ld.force
    if ld.type == "incline":
        return ld.force + motor.mass * 9.81 * math.sin(math.radians(ld.incline_deg))
    return ld.force


#: an input of the design (DriveData's names, :func:`drive_data`) -> the scenario key it is read from;
#: the design names the input at fault (linsense.tune.design.DRIVE_RULES), the refusal its key
DESIGN_KEYS = {"v_dc": "inverter.v_dc", "f_pwm": "inverter.f_pwm", "dead_time": "inverter.dead_time",
                "i_max": "controller.i_max", "v_max": "reference.v_max", "a_max": "reference.a_max",
                "v_inj": "injection.amplitude", "f_inj": "injection.frequency",
                "quad": "injection.quadrature", "shape": "injection.shape",
                "d_current": "injection.d_current", "load": "controller.rated_load", "motor": "motor"}


def _design_refusal(sc: Scenario, exc: InputError) -> InputError:
    """The design's refusal ``exc`` (naming an input by its DriveData name) as the scenario's: the
    same message at the scenario key the input is read from."""
    return InputError(sc.source, DESIGN_KEYS.get(exc.key, exc.key), exc.message)


def _check_cal_window(sc: Scenario, t_max: float, t_hold: float, given: set) -> None:
    """Refuse a calibration whose points trip before one acceptance window is over.

    A point is accepted at the end of a window of ``t_hold``; one not accepted after ``t_max`` of
    adapting trips (the observer fault, ls_drive_calibration.c): with ``t_max < t_hold`` none can be,
    and the run stopped on "fault observer"."""
    if t_max >= t_hold:
        return
    if "t_hold" in given and "t_max" not in given:
        raise InputError(sc.source, "calibration.t_hold", f"{t_hold:g} s: one acceptance window is longer "
                         f"than calibration.t_max = {t_max:g} s, after which a point trips: no point can be "
                         f"accepted; at most {t_max:g} s")
    raise InputError(sc.source, "calibration.t_max", f"{t_max:g} s is shorter than one acceptance window, "
                     f"calibration.t_hold = {t_hold:g} s: every point trips (the observer fault) before it "
                     f"can be accepted; at least {t_hold:g} s")


def drive_data(sc: Scenario) -> DriveData:
    """The drive a scenario describes, as the design takes it.

    The injection's amplitude and frequency only where the file gives them.

    Parameters
    ----------
    sc : Scenario
        The scenario.

    Returns
    -------
    DriveData
        The drive.
    """
    s = sc.spec
    inj, given = s.injection, s.injection.model_fields_set
    return DriveData(v_dc=s.inverter.v_dc, f_pwm=s.inverter.f_pwm, dead_time=s.inverter.dead_time,
                     i_max=s.controller.i_max, v_max=s.reference.v_max, a_max=s.reference.a_max,
                     load=s.controller.rated_load,
                     v_inj=inj.amplitude if "amplitude" in given else None,
                     # (the square wave's f_pwm / 2 is not a design choice: the other gains are
                     # designed as for the default frequency)
                     f_inj=inj.frequency if "frequency" in given and inj.shape != "square" else None,
                     quad=inj.quadrature, shape=inj.shape, d_current=inj.d_current)


#: the calibration's own timings follow the drive (docs/simulator.md, "Calibration"): its
#: adaptation rate k_int 15 times below the dither (the ripple the dither leaves on the angle) and 30
#: times below the demodulator's low-pass (the loop it closes through it); its window t_hold about
#: CAL_HOLD_TAUS adaptation time constants, in whole periods of the dither's beat with the injection;
#: its settling CAL_SETTLE_TAUS time constants 1/kp_x of the position loop after a move; a point not
#: accepted within CAL_MAX_WINDOWS windows trips (ls_cal_cfg; for ecce2010 on the paper's drive
#: about the C defaults, which are constants)
CAL_K_INT_DITHER = 15.0
CAL_K_INT_LPF = 30.0
CAL_HOLD_TAUS = 6.0
CAL_SETTLE_TAUS = 1.5
CAL_MAX_WINDOWS = 30.0


def calibration_timing(f_inj: float, dither_a: float, dither_hz: float, demod_lpf: float,
                       kp_x: float, k_int: float | None = None, t_hold: float | None = None,
                       source: str = "<calibration>") -> dict:
    """The calibration's timings for a drive.

    A ``k_int`` or ``t_hold`` given is kept, and the others follow it.

    The window is a whole number of periods of the dither and of its beats with the injection
    (``1 / gcd(dither_hz, f_inj)`` where the two are commensurate, else of the dither): their
    ripple in the demodulated error then averages out of the window's mean, which the acceptance
    compares with ``tol`` (a window of 7.5 dither periods never accepts: the ripple's remainder
    stays above it).

    Parameters
    ----------
    f_inj : float
        Injection frequency, Hz.
    dither_a : float
        q-current dither amplitude, A.
    dither_hz : float
        Dither frequency, Hz.
    demod_lpf : float
        Demodulator low-pass corner, Hz.
    kp_x : float
        Position-loop gain, 1/s.
    k_int : float or None, optional
        Adaptation rate, 1/s (None: designed).
    t_hold : float or None, optional
        Acceptance window, s (None: designed).
    source : str, optional
        Named in messages.

    Returns
    -------
    dict
        ``k_int`` (1/s), ``t_hold``, ``t_settle``, ``t_max`` (s).

    Raises
    ------
    InputError
        Naming ``calibration.dither_hz`` or ``calibration.k_int`` (in ``source``) when the window
        they make is not a finite number of periods (a subnormal dither frequency or adaptation
        rate was a ZeroDivisionError or an OverflowError traceback).
    """
    given_k = k_int is not None
    if k_int is None:
        k_int = 2.0 * math.pi * min(dither_hz / CAL_K_INT_DITHER, demod_lpf / CAL_K_INT_LPF)
        if not k_int > 0.0:
            raise InputError(source, "calibration.dither_hz",
                             f"{dither_hz:g} Hz makes the adaptation rate k_int = 2 pi dither_hz / "
                             f"{CAL_K_INT_DITHER:g} = 0: a calibration would never converge")
    if t_hold is None:
        period = 1.0 / f_inj
        if dither_a > 0.0:
            ratio = Fraction(dither_hz / f_inj).limit_denominator(64)
            exact = abs(float(ratio) * f_inj - dither_hz) <= 1e-9 * dither_hz
            period = ratio.denominator / f_inj if exact else 1.0 / dither_hz
        windows = CAL_HOLD_TAUS / k_int / period - 1e-9  # (range-checked before the integer count)
        if not (math.isfinite(period) and math.isfinite(windows)):
            key, value = (("calibration.k_int", f"{k_int:g} 1/s") if given_k and math.isfinite(period)
                          else ("calibration.dither_hz", f"{dither_hz:g} Hz"))
            raise InputError(source, key, f"{value} makes the hold window {CAL_HOLD_TAUS:g} / k_int "
                             f"more periods of the dither than a float holds: give calibration.t_hold, "
                             f"or a k_int and dither_hz a calibration can wait for")
        t_hold = math.ceil(windows) * period
    return {"k_int": k_int, "t_hold": t_hold, "t_settle": CAL_SETTLE_TAUS / kp_x,
            "t_max": CAL_MAX_WINDOWS * t_hold}


#: the keys :func:`designed` sets where the scenario leaves them unset, by section
#: (:meth:`linsense.tune.drive_design.DriveDesign.scenario_keys`); the observer's load-estimate clamp
#: at the force the drive can make
DESIGNED = {
    "injection": ("amplitude", "frequency", "ramp_rate"),
    "observer": ("demod_lpf_hz", "gain_schedule", "hf_delay_s", "omega_max", "type", "bandwidth_hz",
                 "force_max", *(k.split(".", 1)[1] for k in HANDOVER_KEYS)),
    "controller": ("speed_bandwidth_hz", "current_bandwidth_hz", "friction_coulomb", "friction_viscous",
                   "friction_band", "ripple_order", "ripple_cos", "ripple_sin", "v_max", "step_a_max",
                   "kp_x"),
    "calibration": ("dither_a", "dither_hz"),
    "protection": ("omega_max", "i_max"),
}


def _drive_design(motor: Motor, dd: DriveData, source: str, no_table: bool) -> tuple:
    """The drive's design for a scenario (no start-up: the scenario's or the C library's) and its keys."""
    made = design_drive(motor, dd, source=source, analyse=False, startup=False, uncompensated=no_table)
    return made, made.scenario_keys()


def _check_band_used(sc: Scenario, made, emf: bool, given_obs: set) -> None:
    """Refuse hand-over keys the file gives where the design leaves the EMF estimate off (the file
    does not say ``observer.emf``; the schema refuses them beside an explicit ``emf = false``): they
    would be silently ignored (a band given with the default 0.2 m/s ran the HF drive)."""
    h = made.handover
    keys = [k.split(".", 1)[1] for k in HANDOVER_KEYS if k != "observer.emf"]
    given = [k for k in keys if k in given_obs]
    if not given or "emf" in given_obs or emf:
        return
    why = h.limit if h is not None else "the design has no hand-over"
    raise InputError(sc.source, f"observer.{given[0]}",
                     f"{getattr(sc.spec.observer, given[0]):g} has no effect: the design leaves the EMF "
                     f"estimate off ({why}); set observer.emf = true, or leave the band out")


def _check_band_trusted(sc: Scenario, made, emf: bool, given_obs: set) -> None:
    """Refuse a hand-over band given by hand, in a mode where the estimate closes the loop, whose top
    the EMF estimate's error bound cannot trust: below the design's ``v_trust``
    (:data:`linsense.tune.handover.EPS_TRUST`), the EMF error there can take the estimate anywhere (a
    band at 2-4 mm/s on ecce2010 ran to 180 deg and an over-speed fault)."""
    h = made.handover
    steers = sc.spec.control.mode in ("sensorless_lut", "sensorless_nolut", "commission")
    if h is None or not emf or not steers or "handover_v_hi" not in given_obs:
        return
    if sc.spec.observer.handover_v_hi >= h.v_trust:
        return
    from linsense.tune.handover import EPS_HAND_DEG, EPS_TRUST

    v = sc.spec.observer.handover_v_hi
    raise InputError(sc.source, "observer.handover_v_hi",
                     f"{v:g} m/s is below {h.v_trust:.3g} m/s, where the EMF estimate's error bound at the "
                     f"drive's current is within {math.degrees(EPS_TRUST):g} deg: above the band the EMF "
                     "error alone drives the observer, and below that speed it can take the estimate "
                     "anywhere "
                     f"(the design's band ends at {h.v_emf:.3g} m/s, where the bound is within "
                     f"{EPS_HAND_DEG:g} deg): at least {h.v_trust:.3g} m/s, or leave the band to the design")


def designed(sc: Scenario, motor: Motor) -> Scenario:
    """``sc`` with every gain it leaves unset taken from the design for its motor and drive.

    :func:`linsense.tune.drive_design.design_drive` and its scenario keys, docs/tuning.md; what the
    file gives is kept.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    motor : Motor
        The motor the controller believes in.

    Returns
    -------
    Scenario
        The designed scenario.

    Raises
    ------
    linsense.errors.InputError
        The design's refusal, naming the scenario's key.
    """
    s = sc.spec
    con = s.controller
    sections = ("injection", "observer", "controller", "calibration", "protection")
    given = {sec: getattr(s, sec).model_fields_set for sec in sections}
    try:
        dd = drive_data(sc)
        if dd.v_inj == 0.0:  # an explicit 0, sensored without injection: the other gains still designed
            dd.v_inj = None
        # the limits with their margins over the application (reference.v_max, a_max); the trips act
        # on the estimate, which without a table moves up to max(1 + de*/dtheta) times the mover
        no_table = compensation_of(s.control.mode, s.observer.compensation) == "none"
        made, keys = memo(("drive_design", motor_key(motor), tuple(vars(dd).values()), no_table),
                          lambda: _drive_design(motor, dd, sc.source, no_table))
    except InputError as exc:  # the design's drive-data names -> the scenario's keys
        raise _design_refusal(sc, exc) from None
    dz = made.design
    want = {sec: {k: keys[f"{sec}.{k}"] for k in names} for sec, names in DESIGNED.items()}
    # the observer's bandwidth for its type (designed: mech for the pulsating and elliptical
    # injections)
    obs_type = s.observer.type if "type" in given["observer"] else dz.observer_type
    want["observer"]["bandwidth_hz"] = made.observer_bw(obs_type)
    if con.position_type != "p":
        want["controller"].pop("kp_x")
    if "k1" in given["observer"]:
        want["observer"].pop("bandwidth_hz")
    for k in ("speed_kp", "current_kp"):
        if k in given["controller"]:
            want["controller"].pop(k.replace("_kp", "_bandwidth_hz"))
    changes = {sec: {k: v for k, v in vals.items() if k not in given[sec]} for sec, vals in want.items()}
    emf = changes.get("observer", {}).get("emf", s.observer.emf)  # (as the run will have it)
    _check_band_used(sc, made, emf, given["observer"])
    _check_band_trusted(sc, made, emf, given["observer"])
    if s.control.mode == "calibration":  # its own timings follow the drive as it runs
        def run(sec: str, key: str):
            return changes.get(sec, {}).get(key, getattr(getattr(s, sec), key))

        f_run = s.inverter.f_pwm / 2.0 if s.injection.shape == "square" else run("injection", "frequency")
        kp_x = run("controller", "kp_x") if con.position_type == "p" else dz.kp_x
        cal = s.calibration
        timing = calibration_timing(f_run, run("calibration", "dither_a"), run("calibration", "dither_hz"),
                                    run("observer", "demod_lpf_hz"), kp_x,
                                    cal.k_int if "k_int" in given["calibration"] else None,
                                    cal.t_hold if "t_hold" in given["calibration"] else None, sc.source)
        changes["calibration"].update({k: v for k, v in timing.items() if k not in given["calibration"]})
        _check_cal_window(sc, run("calibration", "t_max"), run("calibration", "t_hold"), given["calibration"])
    # the designed values are valid by construction (the design keeps the injection within the bus
    # and f_pwm / 4): set them without validating the whole scenario again (a sweep builds thousands)
    update = {sec: getattr(s, sec).model_copy(update=vals) for sec, vals in changes.items() if vals}
    out = Scenario(s.model_copy(update=update), sc.source, sc.base_dir)
    if "final_window_s" not in s.metrics.model_fields_set:
        # the default end window widened to see a cycle of the slowest designed loop (half its period:
        # check_final_window, which refuses a window the file gives too short); metrics.json's
        # final_window_s says the window the verdict read
        least = 0.5 / slowest_loop(out, motor.mass)[2]
        if least > s.metrics.final_window_s:
            metrics = out.spec.metrics.model_copy(update={"final_window_s": least})
            out = Scenario(out.spec.model_copy(update={"metrics": metrics}), sc.source, sc.base_dir)
    return out

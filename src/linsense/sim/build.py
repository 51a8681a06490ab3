"""From a validated scenario to the C objects of one run: plant, drive, commands.

The drive starts from ``ls_drive_default_cfg`` and gets the scenario's values; the motor
parameters the controller uses (mean L_d and L_q over a period for the decoupling and the
demodulator gain, psi_pm, mass, force constant, R_s) come from the motor model unless
``[controller.model]`` overrides them. The compensation table and the optional gain table are
:class:`linsense.ctrl.Lut` objects kept alive by the :class:`Built` that owns the drive.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np

from linsense.analysis.hf import end_anisotropy
from linsense.compensation.lut import build_lut, lut_r_slope
from linsense.ctrl import ConfigError, Drive, drive_default_cfg, ffi, lib, make_lut
from linsense.errors import InputError, LinsenseError, ModelError
from linsense.limits import MAX_STEPS, MAX_TRACE_BYTES, MAX_TRACE_FILE_BYTES
from linsense.model.motor import Motor, load_motor, names_a_path, preset_names
from linsense.model.saturation import Saturation
from linsense.sim.core import BLOCKS, SIGNALS, PlantSetup, SimulationError, plant_template, sim_cfg
from linsense.sim.plant import fill_saturation, lab_fourier
from linsense.sim.refusal import explain, given_keys
from linsense.sim.scenario import Scenario, compensation_of
from linsense.tune.design import (
    DriveData,
    current_gains,
    design,
    gain_r_slope,
    gain_schedule,
    mean_dq,
    speed_gains,
    startup_lock_gain,
    uncompensated_speed_factor,
)
from linsense.tune.injection import (
    SQUARE_DTC_BAND,
    SQUARE_DTC_LEAD,
    SQUARE_SEP_FRACTION,
    injection_tables,
    rotating_design,
    rotating_r_slopes,
    square_current_schedule,
    square_d_current,
)

#: drive sub-configuration -> scenario section (for messages)
_SECTION = {"inject": "injection", "bpf": "injection", "sep": "injection", "demod": "observer",
            "obs": "observer", "enc_obs": "sensors", "current": "controller", "pos": "controller",
            "pos.speed": "controller", "traj": "reference", "mod": "inverter", "prot": "protection",
            "startup": "startup"}


@dataclass
class Built:
    """Everything one run needs; keeps the cffi objects (drive, tables) alive together."""

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


# ---------------------------------------------------------------------- caches
# A sweep builds thousands of scenarios of a few motors: loading and checking a motor file, the
# design and the controller's tables are pure functions of the motor and a few numbers, kept here
# (bounded, thread-safe: sweeps run in worker threads). Cached values are never mutated.
_CACHE: OrderedDict = OrderedDict()
_CACHE_LOCK = threading.Lock()
_CACHE_SIZE = 256


def _memo(key: tuple, fn):
    with _CACHE_LOCK:
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key]
    value = fn()
    with _CACHE_LOCK:
        _CACHE[key] = value
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
    return value


def motor_key(motor: Motor) -> str:
    """A fingerprint of everything that defines ``motor`` (parameters and inductance series)."""
    hit = _memo(("key", id(motor)), lambda: (motor, _fingerprint(motor)))
    if hit[0] is motor:  # (the cache keeps the motor alive, so its id is not reused meanwhile)
        return hit[1]
    return _fingerprint(motor)


def _fingerprint(motor: Motor) -> str:
    h = hashlib.sha256(repr((motor.name, motor.R_s, motor.pole_pitch, motor.force_constant, motor.mass,
                             motor.friction, motor.pm_harmonics)).encode())
    h.update(np.ascontiguousarray(motor.inductance.a).tobytes())
    h.update(np.ascontiguousarray(motor.inductance.b).tobytes())
    if motor.saturation is not None:
        h.update(repr(motor.saturation.key()).encode())
    return h.hexdigest()


def plant_saturation(sc: Scenario, motor: Motor) -> Saturation | None:
    """The saturation of the plant ``sc`` runs (None: the linear plant): the motor file's
    ``[saturation]`` with the scenario's ``[saturation]`` keys over it, when ``saturation.enabled``."""
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
    return _memo(("motor", check) + stamp, lambda: load_motor(path, check=check))


def resolve_motor(sc: Scenario, spec: str | None = None, key: str = "motor", check: bool = True) -> Motor:
    """The scenario's motor (or the motor ``spec`` given at ``key``): a preset name or a file path
    relative to the scenario file. ``check = False`` skips :func:`check_motor` (for a motor the
    controller only believes in: its tables need not describe a realisable winding)."""
    spec = sc.spec.motor if spec is None else spec
    if not names_a_path(spec):
        if spec not in preset_names():
            raise InputError(sc.source, key, f"unknown preset {spec!r} "
                             f"(presets: {', '.join(preset_names())}; "
                             "or a path to a .toml motor file, relative to the scenario)")
        return _memo(("motor", check, "preset", spec), lambda: load_motor(spec, check=check))
    p = Path(spec)
    if not p.is_absolute():
        p = sc.base_dir / p
    if not p.is_file():
        raise InputError(sc.source, key, f"no such motor file {str(p)!r} (value {spec!r})")
    return _load_motor_file_cached(p, check)


def _sat_template(plant, motor: Motor, sat: Saturation):
    """A copy of the plant template switched to the saturated plant."""
    c = ffi.new("ls_sim_cfg *")
    ffi.memmove(c, plant, ffi.sizeof("ls_sim_cfg"))
    fill_saturation(c, motor, sat)
    return c


def trapezoid_time(distance: float, v_max: float, a_max: float) -> float:
    """Duration (s) of a minimum-time move over ``distance`` (m), as ``ls_traj`` plans it."""
    d = abs(distance)
    if d <= v_max * v_max / a_max:
        return 2.0 * math.sqrt(d / a_max)
    return d / v_max + v_max / a_max


def reference_commands(sc: Scenario) -> tuple[list, list]:
    """Commands ``(t, x, move)`` for run_closed_loop and the planned moves ``(t0, t1, x0, x1)``."""
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


def check_positions(sc: Scenario, tau: float) -> None:
    """Refuse a position the drive cannot hold: beyond ``LS_POS_PERIOD_MAX`` pole pitches either
    side (``ls_pos``, docs/firmware.md), before it is converted to a count of periods.

    The start (``initial.position_mm``, and ``startup.guess_mm`` of a start-up) was an OverflowError
    traceback in the conversion, or a one-line ls_pos message naming no key; a reference there was
    silently refused by the drive's setter (the run held still and reported no fault, issue 23).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    tau : float
        m, the motor's pole pitch.

    Raises
    ------
    InputError
        Naming the key, its value and the range in mm on this motor.
    """
    s = sc.spec
    limit = int(lib.LS_POS_PERIOD_MAX)
    keys = [("initial.position_mm", s.initial.position_mm)]
    if s.control.mode == "startup":
        keys.append(("startup.guess_mm", s.startup.guess_mm))
    if s.reference.position_mm is not None:
        keys.append(("reference.position_mm", s.reference.position_mm))
    keys += [(f"reference.waypoints_mm[{i}]", w) for i, w in enumerate(s.reference.waypoints_mm or [])]
    for key, x_mm in keys:
        if not abs(x_mm * 1e-3 / tau) < limit:
            raise InputError(sc.source, key, f"{x_mm:g} mm is beyond the drive's position range of "
                             f"+-{limit:,} pole pitches (+-{limit * tau * 1e3:.6g} mm on this motor, "
                             "docs/firmware.md)")


def initial_load(sc: Scenario, motor: Motor) -> float:
    """The load force at t = 0 (N, opposing positive motion when > 0), as the plant applies it."""
    ld = sc.spec.load
    if ld.type == "step":
        return ld.force_after if ld.time <= 0.0 else ld.force
    if ld.type == "incline":
        return ld.force + motor.mass * 9.81 * math.sin(math.radians(ld.incline_deg))
    return ld.force


def _value_of(spec, key: str):
    """The value of the dotted scenario ``key`` in ``spec`` (given, designed or default)."""
    obj = spec
    for part in key.split("."):
        obj = getattr(obj, part, None)
    return obj


#: injection.shape -> the C library's ls_inject_shape
_SHAPE = {"pulsating": lib.LS_INJ_PULSATING, "rotating": lib.LS_INJ_ROTATING, "square": lib.LS_INJ_SQUARE}

#: a key of the design's refusals -> the scenario keys its rule reads, the one to name first: the
#: first the file gives is named (none given: the first, a default)
_DESIGN_KEYS = {"v_dc": ("inverter.v_dc", "controller.i_max", "injection.amplitude"),
                "f_pwm": ("inverter.f_pwm",), "i_max": ("controller.i_max",),
                "v_max": ("reference.v_max", "reference.a_max"),
                "a_max": ("reference.a_max", "reference.v_max"),
                "v_inj": ("injection.amplitude", "inverter.v_dc"),
                "f_inj": ("injection.frequency", "inverter.f_pwm"),
                "quad": ("injection.quadrature",), "shape": ("injection.shape",),
                "dead_time": ("inverter.dead_time", "inverter.f_pwm", "inverter.v_dc", "controller.i_max"),
                "load": ("reference.a_max", "controller.i_max"), "motor": ("motor",)}


def _design_refusal(sc: Scenario, exc: InputError) -> InputError:
    """The design's refusal ``exc`` (keys of DriveData) as the scenario's: naming the key the file
    gives that the rule reads, with its value."""
    keys = _DESIGN_KEYS.get(exc.key, (exc.key,))
    given = given_keys(sc.given())
    key = next((k for k in keys if k in given), keys[0])
    value = _value_of(sc.spec, key)
    shown = f"{value:g}" if isinstance(value, float) else repr(value)
    if key == "motor" or (key == keys[0] and shown in exc.message):
        return InputError(sc.source, key, exc.message)
    return InputError(sc.source, key, f"{shown} refused by the design ({exc.key}: {exc.message})")


def drive_data(sc: Scenario) -> DriveData:
    """The drive a scenario describes, as the design takes it: the injection's amplitude and
    frequency only where the file gives them."""
    s = sc.spec
    inj, given = s.injection, s.injection.model_fields_set
    return DriveData(v_dc=s.inverter.v_dc, f_pwm=s.inverter.f_pwm, dead_time=s.inverter.dead_time,
                     i_max=s.controller.i_max, v_max=s.reference.v_max, a_max=s.reference.a_max,
                     v_inj=inj.amplitude if "amplitude" in given else None,
                     # (the square wave's f_pwm / 2 is not a design choice: the other gains are
                     # designed as for the default frequency)
                     f_inj=inj.frequency if "frequency" in given and inj.shape != "square" else None,
                     quad=inj.quadrature, shape=inj.shape)


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
    """The calibration's ``k_int`` (1/s), ``t_hold``, ``t_settle`` and ``t_max`` (s) for a drive
    injecting at ``f_inj`` (Hz) with a q-current dither of ``dither_a`` (A) at ``dither_hz`` (Hz),
    the demodulator's low-pass at ``demod_lpf`` (Hz) and the position loop's ``kp_x`` (1/s).
    A ``k_int`` or ``t_hold`` given is kept, and the others follow it.

    The window is a whole number of periods of the dither and of its beats with the injection
    (``1 / gcd(dither_hz, f_inj)`` where the two are commensurate, else of the dither): their
    ripple in the demodulated error then averages out of the window's mean, which the acceptance
    compares with ``tol`` (a window of 7.5 dither periods never accepts: the ripple's remainder
    stays above it).

    Raises
    ------
    InputError
        Naming ``calibration.dither_hz`` or ``calibration.k_int`` (in ``source``) when the window
        they make is not a finite number of periods (a subnormal dither frequency or adaptation
        rate was a ZeroDivisionError or an OverflowError traceback, issue 23).
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


def designed(sc: Scenario, motor: Motor) -> Scenario:
    """``sc`` with every gain it leaves unset taken from the design for its motor and drive
    (:func:`linsense.tune.design`, docs/tuning.md); what the file gives is kept."""
    s = sc.spec
    con = s.controller
    sections = ("injection", "observer", "controller", "calibration", "protection")
    given = {sec: getattr(s, sec).model_fields_set for sec in sections}
    try:
        dd = drive_data(sc)
        if dd.v_inj == 0.0:  # an explicit 0, sensored without injection: the other gains still designed
            dd.v_inj = None
        dz = _memo(("design", motor_key(motor), tuple(vars(dd).values())),
                   lambda: design(motor, dd, sc.source, analyse=False))
    except InputError as exc:  # the design's drive-data names -> the scenario's keys
        raise _design_refusal(sc, exc) from None
    no_table = compensation_of(s.control.mode, s.observer.compensation) == "none"
    k_est = _memo(("k_est", motor_key(motor)), lambda: uncompensated_speed_factor(motor)) if no_table else 1.0
    want = {
        "injection": {"amplitude": dz.v_inj, "frequency": dz.f_inj, "ramp_rate": dz.inj_ramp_rate},
        "observer": {"demod_lpf_hz": dz.demod_lpf, "gain_schedule": True, "hf_delay_s": dz.hf_delay},
        "controller": {"speed_bandwidth_hz": dz.speed_bw, "current_bandwidth_hz": dz.current_bw},
        "calibration": {"dither_a": dz.dither_a, "dither_hz": dz.dither_hz},
        # the limits with their margins over the application (reference.v_max, a_max); the trips act
        # on the estimate, which without a table moves up to max(1 + de*/dtheta) times the mover
        "protection": {"omega_max": dz.omega_trip * k_est, "i_max": dz.i_trip},
    }
    want["observer"]["omega_max"] = dz.omega_obs * k_est
    # the observer's type (mech for the pulsating and elliptical injections) and its bandwidth; the
    # load estimate's clamp at the force the drive can make
    want["observer"]["type"] = dz.observer_type
    obs_type = s.observer.type if "type" in given["observer"] else dz.observer_type
    want["observer"]["bandwidth_hz"] = dz.observer_bw_mech if obs_type == "mech" else dz.observer_bw_pll
    want["observer"]["force_max"] = dz.force_max
    want["controller"]["v_max"] = dz.v_cap
    want["controller"]["step_a_max"] = dz.a_step
    if con.position_type == "p":
        want["controller"]["kp_x"] = dz.kp_x
    if "k1" in given["observer"]:
        want["observer"].pop("bandwidth_hz")
    for k in ("speed_kp", "current_kp"):
        if k in given["controller"]:
            want["controller"].pop(k.replace("_kp", "_bandwidth_hz"))
    changes = {sec: {k: v for k, v in vals.items() if k not in given[sec]} for sec, vals in want.items()}
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
    # the designed values are valid by construction (the design keeps the injection within the bus
    # and f_pwm / 4): set them without validating the whole scenario again (a sweep builds thousands)
    update = {sec: getattr(s, sec).model_copy(update=vals) for sec, vals in changes.items() if vals}
    return Scenario(s.model_copy(update=update), sc.source, sc.base_dir)


def check_sensors(source: str, gain: list, offset: list, noise: float, i_trip: float,
                  trip_given: bool = False) -> None:
    """Refuse current sensors the drive cannot run with: a gain of 0 or below (the current not
    measured, or a phase reversed), an offset or an rms noise at the over-current trip
    ``protection.i_max`` or beyond (the drive trips on the sensor alone, at t = 0; issue 23: the
    message named protection.i_max where the file gave only the sensor). ``trip_given``: the file
    gives protection.i_max, which is then named, with the sensor's value as its limit."""
    for g in gain:
        if not g > 0.0:
            raise InputError(source, "sensors.current_gain", f"must be above 0 (0 measures no current, "
                             f"a negative gain reverses the phase), got {g!r}")
    for key, v, what in [("sensors.current_offset", max(abs(o) for o in offset), "offset"),
                         ("sensors.current_noise", noise, "rms noise")]:
        if v < i_trip:
            continue
        if trip_given:
            raise InputError(source, "protection.i_max", f"{i_trip:g} A is at or below {key} = {v:g} A: "
                             f"the drive would trip at t = 0 on the sensor's {what} alone; it must be above "
                             f"{v:g} A")
        raise InputError(source, key, f"{v!r} A reaches the over-current trip protection.i_max = "
                         f"{i_trip:g} A: the drive would trip at t = 0 on the {what} alone; it must be below "
                         f"{i_trip:g} A")


def run_steps(source: str, duration: float, fs: float) -> int:
    """The PWM periods of a run of ``duration`` s at ``fs`` Hz, range-checked before the conversion to
    an integer (issue 23: a product beyond a float, ``scenario.duration = 1e308``, was an
    OverflowError traceback).

    Parameters
    ----------
    source : str
        The scenario's file, named in a refusal.
    duration, fs : float
        ``scenario.duration`` (s) and ``inverter.f_pwm`` (Hz), positive and finite.

    Returns
    -------
    int
        ``round(duration * fs)``, 1 .. :data:`~linsense.limits.MAX_STEPS`.

    Raises
    ------
    InputError
        Naming ``scenario.duration``, its value, the rate and the limit: beyond MAX_STEPS periods
        (or a product that overflows), or shorter than one period.
    """
    periods = duration * fs
    if not periods <= MAX_STEPS + 0.5:  # (also inf and NaN)
        count = (f"{periods:.3g} PWM periods" if math.isfinite(periods)
                 else "more PWM periods than a float holds")
        raise InputError(source, "scenario.duration",
                         f"{duration:g} s at {fs:g} Hz is {count}, beyond the limit "
                         f"of {MAX_STEPS:.3g} (duration x inverter.f_pwm, docs/limits.md)")
    n_steps = int(round(periods))
    if n_steps < 1:
        raise InputError(source, "scenario.duration", f"shorter than one PWM period, got {duration!r}")
    return n_steps


def check_run_size(source: str, n_steps: int, decimate: int, fs: float, trace_in_memory: bool = True) -> None:
    """Refuse (``trace_in_memory``) a run of ``n_steps`` periods (:func:`run_steps`, which bounds
    them by :data:`~linsense.limits.MAX_STEPS`) whose trace would not fit in
    :data:`~linsense.limits.MAX_TRACE_BYTES`, before anything is allocated. A run streamed in
    chunks (``linsense simulate``) keeps no trace in memory."""
    if not trace_in_memory:
        return
    # with decimate > 1 every sample also keeps its block statistics (linsense.sim.run.simulate)
    with_blocks = 8 * (sum(SIGNALS.values()) + sum(BLOCKS.values())) + 4
    per_sample = with_blocks if decimate > 1 else 8 * sum(SIGNALS.values()) + 4
    n_rec = math.ceil(n_steps / decimate) + 2
    if n_rec * per_sample > MAX_TRACE_BYTES:
        need = math.ceil(n_steps * with_blocks / MAX_TRACE_BYTES)
        gib = n_rec * per_sample / 2**30
        raise InputError(source, "record.decimate",
                         f"= {decimate} keeps {n_rec:.3g} samples of the {n_steps / fs:g} s run in memory "
                         f"({gib:.3g} GiB), beyond the limit of {MAX_TRACE_BYTES / 2**30:g} GiB: set "
                         f"record.decimate to at least {need} or shorten scenario.duration (docs/limits.md)")


def check_trace_file(b: Built) -> None:
    """Refuse a streamed run whose trace file would exceed :data:`~linsense.limits.MAX_TRACE_FILE_BYTES`
    (144 B per sample), before it starts."""
    from linsense.sim.trace import COLUMNS

    s = b.scenario.spec
    per_sample = 8 * len(COLUMNS)
    dec = int(b.cfg.decimate)
    n_rec = math.ceil(b.n_steps / dec)
    if n_rec * per_sample > MAX_TRACE_FILE_BYTES:
        need = math.ceil(b.n_steps * per_sample / MAX_TRACE_FILE_BYTES)
        gib = n_rec * per_sample / 2**30
        raise InputError(
            b.scenario.source, "record.decimate",
            f"= {dec} writes {n_rec:.3g} samples of the {s.scenario.duration:g} s run to the trace file "
            f"(about "
            f"{gib:.3g} GiB), beyond the limit of {MAX_TRACE_FILE_BYTES / 2**30:g} GiB: set record.decimate "
            f"(--decimate) to at least {need}, shorten scenario.duration or write no trace (--trace none) "
            "(docs/limits.md)")


def build(sc: Scenario, motor: Motor | None = None, trace_in_memory: bool = True) -> Built:
    """Configure the plant and the drive of ``sc``; bad values end in :class:`InputError` naming
    the scenario file. ``motor`` replaces the scenario's motor (a Motor object from Python). Gains
    the scenario leaves unset are designed for its motor (:func:`designed`). ``trace_in_memory``
    False: the run is streamed in chunks (:mod:`linsense.sim.stream`), its trace not kept, so the
    limit on the trace kept in memory does not apply."""
    motor = resolve_motor(sc) if motor is None else motor
    # the motor the controller believes in (its tables, gains and feed-forwards): the plant's unless
    # controller.model.motor names another (e.g. one with a parameter off, to test the LUT's robustness)
    ov = sc.spec.controller.model
    model_motor = motor if ov.motor is None else resolve_motor(sc, ov.motor, "controller.model.motor",
                                                               check=False)
    if not math.isclose(model_motor.pole_pitch, motor.pole_pitch, rel_tol=1e-9):
        raise InputError(sc.source, "controller.model.motor",
                         f"pole pitch {model_motor.pole_pitch:g} m differs from the motor's "
                         f"{motor.pole_pitch:g} m: a controller cannot believe in another pole pitch")
    user_keys = given_keys(sc.given())  # (the keys the file gives: designed() sets the others)
    sc = designed(sc, model_motor)
    s = sc.spec
    inv, ctl, inj, obs, con, prot = s.inverter, s.control, s.injection, s.observer, s.controller, s.protection
    fs = inv.f_pwm
    tau = motor.pole_pitch

    # --- what the controller knows about the motor
    model_key = motor_key(model_motor)
    L_d, L_q = _memo(("mean_dq", model_key), lambda: mean_dq(model_motor))
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
    else:
        if known["L_q"] == known["L_d"]:
            raise InputError(sc.source, "controller.model.L_q",
                             "equals L_d: no saliency, no demodulator gain")
        known["demod_gain"] = known["L_q"] / (known["L_q"] - known["L_d"])

    # --- plant
    tr = s.travel
    load_f0 = s.load.force
    sens = s.sensors
    gain = sens.current_gain if isinstance(sens.current_gain, list) else [sens.current_gain] * 3
    offs = sens.current_offset if isinstance(sens.current_offset, list) else [sens.current_offset] * 3
    check_sensors(sc.source, gain, offs, sens.current_noise, prot.i_max, "protection.i_max" in user_keys)
    setup = PlantSetup(
        fidelity=inv.fidelity, v_dc=inv.v_dc, f_pwm=fs, dead_time=inv.dead_time,
        i_gain=tuple(gain), i_offset=tuple(offs), i_noise=sens.current_noise, adc_bits=sens.adc_bits,
        adc_range=sens.adc_range, enc_counts=sens.encoder_counts_per_period, seed=s.scenario.seed,
        motion="free", x0=s.initial.position_mm * 1e-3, v0=0.0,
        x_min=tr.min_mm * 1e-3, x_max=tr.max_mm * 1e-3,
        load=s.load.type, load_f0=load_f0, load_f1=s.load.force_after, load_t=s.load.time,
        load_incline=math.radians(s.load.incline_deg), decimate=s.record.decimate, i_abort=prot.i_abort,
    )
    sat = plant_saturation(sc, motor)
    try:
        plant = _memo(("plant", motor_key(motor)),
                      lambda: plant_template(motor, lab_fourier(motor.inductance, 1e-12)))
        if sat is not None:
            lin = plant
            plant = _memo(("plant_sat", motor_key(motor), sat.key()),
                          lambda: _sat_template(lin, motor, sat))
        cfg = sim_cfg(motor, setup, template=plant)
    except ModelError as exc:  # (the saturated plant's data: the scenario's key, or the motor file's)
        key = exc.key if exc.key == "saturation.polarity" else ""
        raise InputError(sc.source, key, f"saturated plant refused: {exc}") from None
    except (SimulationError, LinsenseError) as exc:
        raise InputError(sc.source, "", f"simulator configuration refused: {exc}") from None

    # --- drive
    d = drive_default_cfg()
    d.fs = fs
    d.pole_pitch = tau
    d.force_constant = known["force_constant"]
    d.i_max = con.i_max
    d.delay_comp = ctl.delay_comp
    d.enc_counts = sens.encoder_counts_per_period
    d.inject_sensored = ctl.inject_sensored
    shape = inj.shape
    f_inj = fs / 2.0 if shape == "square" else inj.frequency
    d.inject.shape = _SHAPE[shape]
    # (the square wave's d-current keeps the phase currents off zero, docs/firmware.md)
    d.i_d_inj = (inj.d_current if inj.d_current is not None
                 else square_d_current(con.i_max) if shape == "square" else 0.0)
    d.inject.amplitude = inj.amplitude
    d.inject.freq = f_inj
    d.inject.ramp_rate = inj.ramp_rate
    d.inject.quad = inj.quadrature
    d.bpf.f0 = d.sep.f0 = inj.frequency
    d.bpf.q = d.sep.q = inj.filter_q
    d.demod.method = lib.LS_DEMOD_PRODUCT if obs.demod_method == "product" else lib.LS_DEMOD_HETERODYNE
    d.demod.f_lpf = obs.demod_lpf_hz
    d.hf_delay = obs.hf_delay_s
    # the low-pass's zeros at 2 f_inj, where that is below fs / 2 (f_inj < f_pwm / 4)
    d.demod.f_notch = 2.0 * inj.frequency if obs.demod_notch and 4.0 * inj.frequency < fs else 0.0
    d.demod.gain = known["demod_gain"]
    d.demod.min_level = obs.min_level
    if shape == "rotating":
        rot = rotating_design(model_motor, known["R_s"], inj.amplitude, f_inj, fs, ctl.delay_comp)
        d.demod.method = lib.LS_DEMOD_ROTATING
        d.demod.gain = 1.0  # the error is the angle itself (docs/theory.md)
        d.demod.ref_phase = rot["ref_phase"]
        if "min_level" not in obs.model_fields_set:
            d.demod.min_level = rot["min_level"]
    elif shape == "square":
        # the fundamental: a low-pass whose zeros at fs / 2 remove the square wave; the
        # demodulator's low-pass keeps its zeros at fs / 2 too, where the products' ripple is
        d.bpf.type = lib.LS_BIQUAD_DIFF  # the current's change over one period
        d.sep.type = lib.LS_BIQUAD_LOWPASS
        d.sep.f0 = SQUARE_SEP_FRACTION * fs
        d.sep.q = 0.5 ** 0.5
        d.demod.f_notch = 0.0
        # the current change reverses every period: the dead-time compensation's sign is taken
        # from the middle of the next period, i - (i - i_prev) / 2 (ls_modulator.h)
        d.mod.dtc_lead = SQUARE_DTC_LEAD
        # against the dead time where a phase current is small (docs/theory.md, "The dead time and
        # the square wave"): the compensation with the edges' ripple, and the d-current schedule
        if inj.dead_time_measures:
            l_avg = 0.5 * (known["L_d"] + known["L_q"])
            d.mod.l_ripple = l_avg
            sched = square_current_schedule(l_avg, known["R_s"], inj.amplitude, fs, d.i_d_inj)
            if sched is not None:
                d.i_d_near, d.near_in, d.near_out = sched["i_d_near"], sched["near_in"], sched["near_out"]
    d.obs.type = lib.LS_OBS_PLL if obs.type == "pll" else lib.LS_OBS_MECH
    load_ff = obs.type == "mech" if obs.load_feedforward is None else obs.load_feedforward
    if load_ff and obs.type != "mech":
        raise InputError(sc.source, "observer.load_feedforward",
                         "needs observer.type = \"mech\" (the load estimate is the mechanical observer's)")
    d.load_ff = load_ff
    d.obs.pole_pitch = tau
    d.obs.mass = known["mass"]
    d.obs.omega_max = obs.omega_max
    d.obs.force_max = obs.force_max
    lib.ls_observer_gains(ffi.addressof(d, "obs"), obs.bandwidth_hz)
    if obs.k1 is not None:
        d.obs.k1, d.obs.k2 = obs.k1, obs.k2
        if obs.k3 is not None:
            d.obs.k3 = obs.k3
    d.enc_obs.pole_pitch = tau
    # the gain rules of the design (linsense.tune.design), unless the file gives the gains
    kp_i, ki_i = current_gains(con.current_bandwidth_hz, known["L_d"], known["L_q"], known["R_s"])
    d.current.kp = con.current_kp if con.current_kp is not None else kp_i
    d.current.ki = con.current_ki if con.current_ki is not None else ki_i
    d.current.l_d, d.current.l_q = known["L_d"], known["L_q"]
    d.current.psi_pm = known["psi_pm"]
    d.current.decouple = con.decouple
    d.pos.type = lib.LS_POSCTRL_P if con.position_type == "p" else lib.LS_POSCTRL_PD
    d.pos.kp_x = con.kp_x
    d.pos.kd_x = con.kd_x
    d.pos.v_max = con.v_max
    d.pos.mass = known["mass"]
    d.pos.force_max = known["force_constant"] * con.i_max
    kp_v, ki_v = speed_gains(con.speed_bandwidth_hz, known["mass"])
    d.pos.speed.kp = con.speed_kp if con.speed_kp is not None else kp_v
    d.pos.speed.ki = con.speed_ki if con.speed_ki is not None else ki_v
    d.pos.speed.out_min, d.pos.speed.out_max = -d.pos.force_max, d.pos.force_max
    d.traj.v_max, d.traj.a_max = s.reference.v_max, s.reference.a_max
    d.traj.v_step, d.traj.a_step = con.v_max, con.step_a_max
    d.traj.a_lpf = min(obs.demod_lpf_hz, fs)  # (the force feed-forward as fast as the demodulator sees)
    d.traj.pole_pitch = tau
    d.mod.f_pwm = fs
    d.mod.dead_time = inv.dead_time
    d.mod.dtc = inv.dead_time_compensation
    d.mod.i_band = (SQUARE_DTC_BAND if shape == "square" and inj.dead_time_measures
                    and "dtc_current_band" not in inv.model_fields_set else inv.dtc_current_band)
    d.hf_dtres = obs.dead_time_residual
    d.dtres.r_s, d.dtres.l_d, d.dtres.l_q = known["R_s"], known["L_d"], known["L_q"]
    d.dtres.forward = obs.dead_time_model == "forward"
    d.dtres.adapt = obs.dead_time_adapt
    d.dtres.adapt_r = obs.dead_time_adapt and obs.resistance_adapt
    # (the interpolated model is the former one: its response without the end effect)
    d.dtres.l_ea, d.dtres.l_eb = (_memo(("end_anisotropy", model_key), lambda: end_anisotropy(model_motor))
                                  if d.dtres.forward else (0.0, 0.0))
    d.prot.i_max, d.prot.v_dc_min, d.prot.v_dc_max = prot.i_max, prot.v_dc_min, prot.v_dc_max
    d.prot.err_max, d.prot.err_time, d.prot.omega_max = prot.err_max, prot.err_time, prot.omega_max
    check_positions(sc, tau)
    d.cal.period = int(math.floor(s.initial.position_mm * 1e-3 / tau))
    cal_table = None
    if ctl.mode == "calibration":
        cs = s.calibration
        cal_table = ffi.new("float[]", cs.points)  # caller-owned: kept alive by Built.extra
        d.cal.points, d.cal.table = cs.points, cal_table
        d.cal.k_int, d.cal.t_settle, d.cal.t_hold = cs.k_int, cs.t_settle, cs.t_hold
        d.cal.tol, d.cal.t_max = math.radians(cs.tol_deg), cs.t_max
        d.cal.dither_amp, d.cal.dither_freq = cs.dither_a, cs.dither_hz
    su = s.startup
    d.startup.t_lock, d.startup.err_lock = su.t_lock, math.radians(su.err_lock_deg)
    d.startup.t_quiet = su.t_quiet
    d.startup.v_pulse, d.startup.t_pulse, d.startup.t_rest = su.v_pulse, su.t_pulse, su.t_rest
    d.startup.pairs, d.startup.i_min, d.startup.t_settle = su.pairs, su.i_min, su.t_settle
    d.startup.lock_gain = startup_lock_gain(obs.type, obs.bandwidth_hz, obs.demod_lpf_hz)
    for sub in ("inject", "bpf", "sep", "demod", "obs", "enc_obs", "current", "traj", "prot", "dtres",
                "startup"):
        getattr(d, sub).fs = fs
    d.pos.speed.fs = fs

    # the table for sensorless_lut, and for the HF observer beside the encoder in sensored mode
    compensation = compensation_of(ctl.mode, obs.compensation)
    # the tables the controller can know, from the motor model with the resistance it believes (as
    # cached ls_lut objects: the drive only reads them, through const pointers)
    def lut_motor() -> Motor:
        return dataclasses.replace(model_motor, R_s=known["R_s"])

    def shape_tables(f: float | None):
        """The rotating or square wave's (table, gain) at ``f``, computed once for both."""
        return _memo(("shape_tables", shape, model_key, known["R_s"], obs.lut_points, f),
                     lambda: injection_tables(lut_motor(), shape, obs.lut_points, f))

    try:
        comp = comp_r = None
        # the tables follow the resistance the drive measures (ls_dtres_adapt, with the forward
        # residual model): their slopes in it, for the resistance-aware tables
        r_slopes = obs.resistance_adapt and d.hf_dtres and d.dtres.forward and d.dtres.adapt
        rot_r = None
        if compensation == "lut" and shape != "pulsating":
            f_lut = f_inj if obs.lut_model == "resistive" else None
            comp = _memo(("lut", shape, model_key, known["R_s"], obs.lut_points, f_lut),
                         lambda: make_lut(shape_tables(f_lut)[0]))
            if shape == "rotating" and f_lut and r_slopes:
                rot_r = _memo(("rot_r", model_key, known["R_s"], obs.lut_points, f_inj, fs, ctl.delay_comp,
                               inj.amplitude),
                              lambda: tuple(make_lut(t) for t in rotating_r_slopes(
                                  lut_motor(), obs.lut_points, f_inj, fs, ctl.delay_comp, inj.amplitude)))
                comp_r = rot_r[0]
        elif compensation == "lut":
            f_lut = inj.frequency if obs.lut_model == "resistive" else None
            quad = inj.quadrature if f_lut else 0.0
            comp = _memo(("lut", model_key, known["R_s"], obs.lut_points, f_lut, quad),
                         lambda: make_lut(build_lut(lut_motor(), obs.lut_points, f_inj=f_lut, quad=quad)))
            if f_lut and r_slopes:
                # the table's slope in R_s, for the resistance the drive measures (ls_dtres_adapt)
                comp_r = _memo(("lut_r", model_key, known["R_s"], obs.lut_points, f_lut, quad),
                               lambda: make_lut(lut_r_slope(lut_motor(), obs.lut_points, f_lut, quad)))
        gain_table = gain_r = None
        if obs.gain_schedule and shape != "pulsating":
            gain_table = _memo(("gain_table", shape, model_key, known["R_s"], f_inj, obs.lut_points),
                               lambda: make_lut(shape_tables(f_inj)[1]))
            if rot_r is not None:
                gain_r = rot_r[1]
        elif obs.gain_schedule:
            # the demodulator gain that makes the error's local slope 1 everywhere (the saliency and,
            # with the elliptical injection and R_s, its phase set it; docs/tuning.md)
            gain_table = _memo(
                ("gain_table", model_key, known["R_s"], inj.frequency, inj.quadrature, obs.lut_points),
                lambda: make_lut(gain_schedule(lut_motor(), inj.frequency, inj.quadrature, obs.lut_points)))
            if comp_r is not None:  # (it follows the measured resistance as the table does)
                gain_r = _memo(
                    ("gain_r", model_key, known["R_s"], inj.frequency, inj.quadrature, obs.lut_points),
                    lambda: make_lut(gain_r_slope(lut_motor(), inj.frequency, inj.quadrature,
                                                  obs.lut_points)))
        drive = Drive(d, comp=comp, gain_table=gain_table, comp_r=comp_r, gain_r=gain_r)
    except ConfigError as exc:
        # the one field at fault, its scenario key, the value and the C library's limit
        told = explain(d, user_keys, lambda k: _value_of(s, k))
        if told is not None:
            raise InputError(sc.source, *told) from None
        sections = sorted({_SECTION.get(k.split(".")[0] if k != "pos.speed" else k, k) for k in exc.fields})
        key = ",".join(sections)
        raise InputError(sc.source, key, f"refused by the controller library: {exc}") from None
    # (the start-up does not know where the mover is: its estimate starts at startup.guess_mm)
    x_known = s.startup.guess_mm * 1e-3 if ctl.mode == "startup" else setup.x0
    drive.set_position(2.0 * math.pi * x_known / tau)
    if s.initial.load_balanced:
        drive.set_load(initial_load(sc, motor))
    try:
        drive.set_mode(ctl.mode)
    except ConfigError as exc:
        raise InputError(sc.source, "control.mode", f"{ctl.mode!r} refused: {exc}") from None
    cmds, moves = reference_commands(sc)
    n_steps = run_steps(sc.source, s.scenario.duration, fs)
    check_run_size(sc.source, n_steps, s.record.decimate, fs, trace_in_memory)
    return Built(sc, motor, setup, cfg, drive, cmds, n_steps, moves, known,
                 extra={} if cal_table is None else {"cal_table": cal_table})

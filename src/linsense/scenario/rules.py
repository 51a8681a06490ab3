"""The rules between the keys of a scenario file, one function per section or concern.

Each takes the whole file (:class:`~linsense.scenario.sections.ScenarioSchema`, its keys validated one by
one) and raises :class:`~linsense.validation.KeyProblem` naming the key it refuses; some fill in a key
the file leaves to another (the bus limits follow the bus). :data:`CHECKS` is their order, the order
their refusals take: :class:`linsense.scenario.load.ScenarioFile` runs it after the keys.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from pydantic import BaseModel

from linsense.ctrl import (
    REAL,
    RIPPLE_MAX,
    STARTUP_PULSE_STEPS_MIN,
    STARTUP_REST_STEPS_MIN,
    V_INJ_SHARE_MAX,
    injection_fits,
)
from linsense.plausible import implausible, slip
from linsense.scenario.bounds import DEAD_TIME_SHARE_MAX, F_INJ_PWM_DIV, V_DC_MAX_FRACTION, V_DC_MIN_FRACTION
from linsense.scenario.sections import ScenarioSchema
from linsense.validation import KeyProblem


def _check_rates(f: ScenarioSchema) -> None:
    """The controller's rate is the PWM rate; the dead time a small share of the PWM period."""
    inv, ctl = f.inverter, f.control
    if ctl.fs is not None and ctl.fs != inv.f_pwm:
        raise KeyProblem("control.fs", f"must equal inverter.f_pwm = {inv.f_pwm:g} Hz "
                        f"(the controller runs "
                        f"once per PWM period), got {ctl.fs:g}")
    if inv.dead_time * inv.f_pwm >= DEAD_TIME_SHARE_MAX:
        share = f"{DEAD_TIME_SHARE_MAX * 100:g} % of the PWM period"
        if _named(inv, ("dead_time", "f_pwm")) == "f_pwm":  # (the rate given, the dead time the default)
            hint = slip("pwm_frequency", inv.f_pwm, ok=lambda v: inv.dead_time * v < DEAD_TIME_SHARE_MAX)
            raise KeyProblem("inverter.f_pwm", f"{inv.f_pwm:g} Hz makes the dead time "
                             f"({inv.dead_time:g} s) {share} or more: at most "
                             f"{DEAD_TIME_SHARE_MAX / inv.dead_time:g} Hz with this dead time"
                             + (f"; {hint}" if hint else ""))
        hint = slip("dead_time", inv.dead_time, ok=lambda v: v * inv.f_pwm < DEAD_TIME_SHARE_MAX)
        raise KeyProblem("inverter.dead_time", f"must be below {share} "
                        f"({DEAD_TIME_SHARE_MAX / inv.f_pwm:g} s), got {inv.dead_time!r}"
                        + (f"; {hint}" if hint else ""))


def _check_lut_file(f: ScenarioSchema) -> None:
    """A measured table needs its file."""
    if f.observer.lut_model == "measured" and f.observer.lut_file is None:
        raise KeyProblem("observer.lut_file", "missing: observer.lut_model = \"measured\" reads the "
                         "table from this file (the lut_measured.json of linsense calibrate, relative to "
                         "the scenario file)")


def _check_injection(f: ScenarioSchema) -> None:
    """The injection's shape and the keys it uses or derives (q-axis share, demodulation,
    dead-time residual, frequency); the d-axis current below the current limit."""
    inv = f.inverter
    inj = f.injection
    wrong = implausible("pwm_frequency", inv.f_pwm) if "f_pwm" in inv.model_fields_set else None
    if wrong is not None:  # (before the injection's rules, which read it: f_pwm = 20 said "f_inj <= 5 Hz")
        raise KeyProblem("inverter.f_pwm", wrong)
    if inj.shape != "pulsating":
        if "quadrature" in inj.model_fields_set and inj.quadrature != 0.0:
            raise KeyProblem("injection.quadrature", f"only with shape = \"pulsating\" (the {inj.shape} "
                            f"injection has no q-axis share), got {inj.quadrature!r}")
        inj.quadrature = 0.0  # (derived: not counted as given)
        inj.__pydantic_fields_set__.discard("quadrature")
        if f.observer.demod_method != "product" or (
                inj.shape == "rotating" and "demod_method" in f.observer.model_fields_set):
            raise KeyProblem("observer.demod_method",
                            f"only with shape = \"pulsating\" (the {inj.shape} injection has its own "
                            f"demodulation), got {f.observer.demod_method!r}")
    if inj.d_current is not None and not (math.isfinite(inj.d_current)
                                          and abs(inj.d_current) < f.controller.i_max):
        raise KeyProblem("injection.d_current", f"must be finite and below controller.i_max = "
                        f"{f.controller.i_max:g} A in magnitude, got {inj.d_current!r}")
    if inj.shape == "square":
        obs = f.observer
        if "dead_time_residual" in obs.model_fields_set and obs.dead_time_residual:
            raise KeyProblem("observer.dead_time_residual", "not with shape = \"square\" (its current "
                            "change is not a band-passed current; injection.d_current keeps the phase "
                            "currents off zero instead)")
        obs.dead_time_residual = False  # (derived: not counted as given)
        obs.__pydantic_fields_set__.discard("dead_time_residual")
        if "frequency" in inj.model_fields_set and inj.frequency != inv.f_pwm / 2.0:
            raise KeyProblem("injection.frequency",
                             f"the square wave is at f_pwm / 2 = {inv.f_pwm / 2:g} Hz "
                            f"(leave the key out), got {inj.frequency:g}")
    elif "dead_time_measures" in inj.model_fields_set:
        raise KeyProblem("injection.dead_time_measures", f"only with shape = \"square\", got shape = "
                        f"{inj.shape!r}")
    elif "frequency" in f.injection.model_fields_set and f.injection.frequency > inv.f_pwm / F_INJ_PWM_DIV:
        raise KeyProblem("injection.frequency", f"must be <= f_pwm / {F_INJ_PWM_DIV:g} = "
                        f"{inv.f_pwm / F_INJ_PWM_DIV:g} Hz, got {f.injection.frequency:g}")


def _check_startup(f: ScenarioSchema) -> None:
    """The start-up sequence's times and what its pulses need (the saturated plant, a polarity
    signal); only for ``control.mode = "startup"``."""
    inv, su = f.inverter, f.startup
    for k in ("t_lock", "t_quiet", "t_pulse", "t_rest", "t_settle"):  # (before the periods)
        if getattr(su, k) > 60.0:
            hint = slip("time", getattr(su, k), ok=lambda v: v <= 60.0)
            raise KeyProblem(f"startup.{k}", f"at most 60 s, got {getattr(su, k):g}"
                             + (f"; {hint}" if hint else ""))
    for k, least in (("t_pulse", STARTUP_PULSE_STEPS_MIN), ("t_rest", STARTUP_REST_STEPS_MIN)):
        if _periods(getattr(su, k), inv.f_pwm) < least:  # (ls_startup_init's limits)
            raise KeyProblem(f"startup.{k}", f"must be at least {least} PWM periods "
                             f"({least / inv.f_pwm:g} s), got {getattr(su, k):g}")
    if su.err_lock_deg > 90.0:
        raise KeyProblem("startup.err_lock_deg", f"at most 90 deg, got {su.err_lock_deg:g}")
    t_ramp = f.injection.amplitude / f.injection.ramp_rate
    for k in ("t_quiet", "t_settle"):
        if getattr(su, k) < t_ramp:
            raise KeyProblem(f"startup.{k}", f"must cover the injection's ramp, amplitude / "
                             f"ramp_rate = {t_ramp:g} s, got {getattr(su, k):g}")
    # (the pulses find the magnet by the d-axis saturation: the linear plant has none, and the
    # start-up tripped "observer" at 0.15 s)
    if not f.saturation.enabled:
        raise KeyProblem("control.mode", "\"startup\" needs the saturated plant (its pulses "
                         "find the magnet by the saturation of the d-axis, which the linear plant "
                         "has not): set saturation.enabled = true")
    if f.saturation.polarity == 0.0:
        raise KeyProblem("saturation.polarity", "0 leaves the pulses of control.mode = \"startup\" "
                         "no magnet-polarity signal to find: give a polarity > 0 (1/A), or leave the "
                         "key out for the motor file's")


def _check_mode(f: ScenarioSchema) -> None:
    """The observer's compensation and the start-up keys against ``control.mode``."""
    ctl = f.control
    comp = f.observer.compensation
    if ctl.mode in ("sensorless_lut", "startup", "commission") and comp == "none":
        raise KeyProblem("observer.compensation",
                         f"\"none\" contradicts control.mode = \"{ctl.mode}\" "
                         "(use mode = \"sensorless_nolut\")")
    su = f.startup
    if ctl.mode != "startup" and su.model_fields_set:
        raise KeyProblem(f"startup.{sorted(su.model_fields_set)[0]}",
                         "only used by control.mode = \"startup\"")
    if ctl.mode == "startup":
        _check_startup(f)
    if ctl.mode == "commission" and not f.observer.emf:
        raise KeyProblem("control.mode", "\"commission\" learns the table at speed against the EMF estimate: "
                         "it needs observer.emf = true")
    if ctl.mode not in ("sensorless_lut", "sensored", "startup", "commission") and comp == "lut":
        raise KeyProblem("observer.compensation", f"\"lut\" is only used by control.mode = "
                        f"\"sensorless_lut\" (or \"sensored\", for the HF observer beside the encoder), "
                        f"got mode = {ctl.mode!r}")


def _check_observer_gains(f: ScenarioSchema) -> None:
    """The observer's explicit gains come together."""
    if f.observer.type == "mech" and (f.observer.k1 is not None) != (f.observer.k3 is not None):
        raise KeyProblem("observer.k3",
                        "give k1, k2 and k3 together for the mech observer (or bandwidth_hz)")
    if (f.observer.k1 is None) != (f.observer.k2 is None):
        raise KeyProblem("observer.k2" if f.observer.k2 is None else "observer.k1",
                        "give k1 and k2 together (or only bandwidth_hz)")


def _check_controller(f: ScenarioSchema) -> None:
    """The controller's ripple feed-forward, position loop, explicit gains and demodulator gain."""
    c = f.controller
    if abs(c.ripple_cos) + abs(c.ripple_sin) > RIPPLE_MAX:
        raise KeyProblem("controller.ripple_cos", "|ripple_cos| + |ripple_sin| must be at most "
                         f"{RIPPLE_MAX:g}, got "
                         f"{abs(c.ripple_cos) + abs(c.ripple_sin):g}")
    if c.position_type == "pd" and c.kp_x is None:
        raise KeyProblem("controller.kp_x", "missing required key for position_type = \"pd\" (N/m)")
    if c.position_type == "p" and c.kd_x != 0.0:
        raise KeyProblem("controller.kd_x", f"only used with position_type = \"pd\", got {c.kd_x!r}")
    if (c.speed_kp is None) != (c.speed_ki is None):
        raise KeyProblem("controller.speed_ki" if c.speed_ki is None else "controller.speed_kp",
                        "give speed_kp and speed_ki together (or speed_bandwidth_hz)")
    if (c.current_kp is None) != (c.current_ki is None):
        raise KeyProblem("controller.current_ki" if c.current_ki is None else "controller.current_kp",
                        "give current_kp and current_ki together (or current_bandwidth_hz)")
    g = c.model.demod_gain
    if g is not None and g == 0.0:
        raise KeyProblem("controller.model.demod_gain", "must be non-zero, got 0.0")
    if g is not None and f.observer.gain_schedule:
        # (it was accepted and changed nothing, the gain table replacing it)
        raise KeyProblem("controller.model.demod_gain", f"{g!r} has no effect with "
                         "observer.gain_schedule = true (the gain table replaces it): set "
                         "observer.gain_schedule = false to use it")


def _check_travel(f: ScenarioSchema) -> None:
    """The travel is an interval and holds the initial position."""
    tr = f.travel
    if not tr.min_mm < tr.max_mm:
        raise KeyProblem("travel.max_mm",
                        f"must be above travel.min_mm = {tr.min_mm:g}, got {tr.max_mm:g}")
    x0 = f.initial.position_mm
    if not tr.min_mm <= x0 <= tr.max_mm:
        raise KeyProblem("initial.position_mm", f"outside the travel [{tr.min_mm:g}, {tr.max_mm:g}] mm, "
                        f"got {x0:g}")


def _check_bus(f: ScenarioSchema) -> None:
    """The protection's bus limits (those not given follow the bus) hold the bus voltage."""
    inv = f.inverter
    p = f.protection
    # bus limits not given follow the bus: 5/9 and 5/4 of it (40 and 90 V at the paper's 72 V)
    # (derived, not given: taken out of the fields set again, so given() does not carry them)
    if "v_dc_min" not in p.model_fields_set:
        p.v_dc_min = round(inv.v_dc * V_DC_MIN_FRACTION, 6)
        p.__pydantic_fields_set__.discard("v_dc_min")
    if "v_dc_max" not in p.model_fields_set:
        p.v_dc_max = round(inv.v_dc * V_DC_MAX_FRACTION, 6)
        p.__pydantic_fields_set__.discard("v_dc_max")
    if not p.v_dc_min < p.v_dc_max:
        if not {"v_dc_min", "v_dc_max"} & p.model_fields_set:  # (both follow the bus)
            raise KeyProblem("inverter.v_dc", f"{inv.v_dc:g} V is too small: the bus limits that follow "
                             f"it ({V_DC_MIN_FRACTION:.3g} and {V_DC_MAX_FRACTION:.3g} of it, to 1 uV) "
                             "are equal")
        raise KeyProblem("protection.v_dc_max",
                        f"must be above v_dc_min = {p.v_dc_min:g}, got {p.v_dc_max:g}")
    if not p.v_dc_min <= inv.v_dc <= p.v_dc_max:
        raise KeyProblem("inverter.v_dc", f"outside the protection's bus range [{p.v_dc_min:g}, "
                        f"{p.v_dc_max:g}] V (protection.v_dc_min, protection.v_dc_max; the drive would "
                        f"trip at t = 0), got {inv.v_dc:g}")


def _check_amplitude(f: ScenarioSchema) -> None:
    """The injection's amplitude: within the bus, a number of the drive, non-zero for the
    sensorless modes."""
    ctl, p = f.control, f.protection
    # (an amplitude the file does not give is designed for the bus, and checked there)
    if ("amplitude" in f.injection.model_fields_set and p.v_dc_min > 0
            and not injection_fits(f.injection.amplitude, p.v_dc_min)):
        hint = slip("voltage", f.injection.amplitude, ok=lambda v: injection_fits(v, p.v_dc_min))
        raise KeyProblem("injection.amplitude",
                         "too large for the bus: amplitude * sqrt(3) must be below "
                         f"{V_INJ_SHARE_MAX:g} protection.v_dc_min = {V_INJ_SHARE_MAX * p.v_dc_min:g} V, "
                         f"got {f.injection.amplitude:g}" + (f"; {hint}" if hint else ""))
    amp = f.injection.amplitude
    if amp != 0.0 and REAL.type(amp) == 0.0:  # (its designed ramp_rate was named, refused by the drive)
        raise KeyProblem("injection.amplitude", f"{amp!r} V is 0 in the drive's {REAL} numbers: give 0 "
                         f"(no injection) or at least {float(np.finfo(REAL).smallest_subnormal):g} V")
    if amp == 0.0 and ctl.mode != "sensored":
        raise KeyProblem("injection.amplitude", "the sensorless modes need an HF injection, got 0")


def _periods(t: float, fs: float) -> float:
    """``round(t * fs)``, PWM periods of ``t`` s, or inf where the product overflows (``round(inf)``
    was an OverflowError traceback)."""
    n = t * fs
    return round(n) if math.isfinite(n) else math.inf


def _given(section: BaseModel, key: str) -> bool:
    return key in section.model_fields_set


def _named(section: BaseModel, keys: tuple[str, ...]) -> str:
    """Of the keys of ``section`` that a rule reads, the one its refusal names: the first the file
    gives with a value other than the default, else the first it gives, else the first (the
    design's rule alike, :func:`linsense.tune.design.check_drive`)."""
    fields = type(section).model_fields
    given = [k for k in keys if _given(section, k)]
    changed = [k for k in given if getattr(section, k) != fields[k].default]
    return (changed or given or list(keys))[0]


def _check_overrides(f: ScenarioSchema) -> None:
    """Refuse a key the file gives that another key (or the mode, the injection's shape, the
    observer's type) makes meaningless: it would be silently ignored or overridden.
    The message names both keys."""
    inj, obs, con, ref, ld, sens = f.injection, f.observer, f.controller, f.reference, f.load, f.sensors
    mode, shape = f.control.mode, inj.shape
    # (the EMF estimate runs with the pulsating shape, where the file or the design turns it on)
    emf_off = shape != "pulsating" or (_given(obs, "emf") and not obs.emf)
    emf_by = "observer.emf = false" if shape == "pulsating" else f"injection.shape = {shape!r}"
    # (the observer's type where the file does not give it: the design's, linsense.tune.design)
    obs_type = obs.type if _given(obs, "type") else ("mech" if shape == "pulsating" else "pll")
    pairs = [  # (key given, the key/setting that overrides it, why)
        (obs, "bandwidth_hz", obs.k1 is not None, "observer.k1", "the explicit gains replace it"),
        (con, "speed_bandwidth_hz", con.speed_kp is not None, "controller.speed_kp",
         "the explicit gains replace it"),
        (con, "current_bandwidth_hz", con.current_kp is not None, "controller.current_kp",
         "the explicit gains replace it"),
        (obs, "k3", obs_type == "pll", f"observer.type = {obs_type!r}", "only the mech observer has k3"),
        (obs, "force_max", obs_type == "pll", f"observer.type = {obs_type!r}",
         "it clamps the mech observer's load estimate; the PLL has none"),
        (obs, "hf_delay_s", shape != "pulsating" and obs.hf_delay_s != 0.0, f"injection.shape = {shape!r}",
         "the delay advances the pulsating and elliptical estimate only"),
        (obs, "demod_notch", shape == "square", "injection.shape = 'square'",
         "the square wave's demodulator has no notch"),
        (inj, "filter_q", shape == "square", "injection.shape = 'square'",
         "the square wave's filters are a difference and a fixed low-pass"),
        (obs, "lut_model", compensation_of(mode, obs.compensation) == "none",
         f"observer.compensation = 'none' (control.mode = {mode!r})", "there is no table"),
        (obs, "lut_file", obs.lut_model != "measured", f"observer.lut_model = {obs.lut_model!r}",
         "only the measured table is read from a file"),
        (obs, "lut_points", compensation_of(mode, obs.compensation) == "none" and not obs.gain_schedule,
         "observer.compensation = 'none' and observer.gain_schedule = false", "there is no table"),
        (obs, "dead_time_model", not obs.dead_time_residual, "observer.dead_time_residual = false",
         "the model is the residual's"),
        (obs, "dead_time_adapt", not obs.dead_time_residual, "observer.dead_time_residual = false",
         "it adapts the residual's model"),
        (obs, "resistance_adapt", not (obs.dead_time_residual and obs.dead_time_adapt),
         "observer.dead_time_residual or dead_time_adapt = false", "it adapts with the residual's model"),
        (ref, "dwell", ref.type != "trajectory", f"reference.type = {ref.type!r}",
         "the dwell is the pause between a trajectory's moves"),
        (ref, "at", ref.type == "hold", "reference.type = 'hold'", "a hold commands nothing"),
        (ld, "force_after", ld.type != "step", f"load.type = {ld.type!r}", "only a step load changes"),
        (ld, "time", ld.type != "step", f"load.type = {ld.type!r}", "only a step load changes"),
        (ld, "force", ld.type == "step" and ld.time == 0.0, "load.type = 'step' at load.time = 0",
         "force_after acts from the start"),
        (ld, "incline_deg", ld.type != "incline", f"load.type = {ld.type!r}",
         "only the incline adds m g sin"),
        (sens, "adc_range", sens.adc_bits == 0, "sensors.adc_bits = 0 (ideal)", "nothing is quantised"),
        (f.control, "inject_sensored", mode != "sensored", f"control.mode = {mode!r}",
         "it is the sensored mode's setting"),
        (f.inverter, "dtc_current_band", not f.inverter.dead_time_compensation,
         "inverter.dead_time_compensation = false", "it is the compensation's band"),
        (obs, "dead_time_adapt", obs.dead_time_model == "interpolated",
         "observer.dead_time_model = 'interpolated'", "only the forward model adapts"),
        (obs, "resistance_adapt", obs.dead_time_model == "interpolated",
         "observer.dead_time_model = 'interpolated'", "only the forward model adapts"),
        (f.calibration, "slope", mode != "commission", f"control.mode = {mode!r}",
         "it is the commissioning's learning slope"),
        *((obs, key, emf_off, emf_by, "the EMF estimate and its hand-over are off")
          for key in ("emf_lpf_hz", "handover_v_lo", "handover_v_hi", "inject_v_on", "inject_v_off",
                      "handover_settle_s")),
    ]
    sections = {id(getattr(f, name)): name for name in type(f).model_fields}
    sections[id(con.model)] = "controller.model"
    for sec, key, overridden, by, why in pairs:
        if overridden and _given(sec, key):
            name = f"{sections[id(sec)]}.{key}"
            raise KeyProblem(name, f"{getattr(sec, key)!r} has no effect with {by} ({why}): leave it out")
    if con.model.demod_gain is not None and shape != "pulsating":
        raise KeyProblem("controller.model.demod_gain", f"{con.model.demod_gain!r} has no effect with "
                         f"injection.shape = {shape!r} (its error is the angle itself, gain 1): leave it out")


def compensation_of(mode: str, compensation: str | None) -> str:
    """The compensation a drive runs.

    ``observer.compensation`` where the scenario gives it, else the table (``"lut"``) in the modes
    that use one (sensorless_lut; sensored and startup for the HF estimate) and ``"none"`` in the
    others.

    Parameters
    ----------
    mode : str
        ``control.mode``.
    compensation : str or None
        ``observer.compensation`` (None: not given).

    Returns
    -------
    str
        ``"lut"`` or ``"none"``.
    """
    if compensation is not None:
        return compensation
    return "lut" if mode in ("sensorless_lut", "sensored", "startup", "commission") else "none"


#: the rules between keys, section by section, in the order their refusals take
def _check_handover(f: ScenarioSchema) -> None:
    """The EMF estimate's shape and the hand-over's order: ``handover_v_lo < handover_v_hi <=
    inject_v_on < inject_v_off`` (ls_fuse_init's, named by key)."""
    obs = f.observer
    if obs.emf and f.injection.shape != "pulsating":
        raise KeyProblem("observer.emf", f"only with shape = \"pulsating\" (the {f.injection.shape} "
                         "injection's step has no EMF estimate), got true")
    # a speed in mm/s first, on its own key: the order below would blame the next key
    for key in ("handover_v_lo", "handover_v_hi", "inject_v_on", "inject_v_off"):
        wrong = implausible("speed", getattr(obs, key)) if _given(obs, key) else None
        if wrong is not None:
            raise KeyProblem(f"observer.{key}", wrong)
    # (key, the key it must exceed, equal allowed: the injection may fade back in at the band's top)
    order = (("handover_v_hi", "handover_v_lo", False), ("inject_v_on", "handover_v_hi", True),
             ("inject_v_off", "inject_v_on", False))
    for key, below, equal in order:
        v, lo = getattr(obs, key), getattr(obs, below)
        if v > lo or (v == lo and equal):
            continue
        if _given(obs, below) and not _given(obs, key):  # (the key given is the one named)
            raise KeyProblem(f"observer.{below}", f"must be {'at most' if equal else 'below'} "
                             f"observer.{key} = {v:g} m/s (not given: the design's; give it too), got {lo:g}")
        raise KeyProblem(f"observer.{key}", f"must be {'at least' if equal else 'above'} "
                         f"observer.{below} = {lo:g} m/s, got {v:g}")


CHECKS: tuple[Callable[[ScenarioSchema], None], ...] = (
    _check_rates, _check_overrides, _check_lut_file, _check_injection, _check_handover, _check_mode,
    _check_observer_gains, _check_controller, _check_travel, _check_bus, _check_amplitude)

"""Scenario files of the closed-loop simulator (TOML), validated like motor files.

A scenario names a motor (preset or path, relative to the scenario file), the inverter, the
controller mode and gains, the observer, the reference, the load, the sensors and the run
settings. SI units inside; millimetres and degrees only where a person types them (keys ending in
``_mm`` and ``_deg``). Every key has a default (docs/simulator.md) except ``motor`` and
``scenario.duration``; the defaults are the firmware's (``ls_drive_default_cfg``) and the paper's
drive (72 V, 16 kHz, 0.8 us, 12 V / 1 kHz).

Validation is pydantic in strict mode: unknown or missing keys, wrong types, non-finite numbers and
out-of-range values end in :class:`~linsense.errors.InputError` naming the file, the dotted key and
the value.
The models below are the one home of each key: docs/simulator.md's table of keys is written from
them by ``tools/gen_docs.py``. A field's ``description`` is its meaning (Markdown); its
``json_schema_extra`` may hold ``unit`` (absent: ``bool`` for a boolean, else ``-``),
``default_note`` (the docs' default in words, where the field's default is not what a run uses:
designed, derived or required by another key; ``{ecce2010}`` in it stands for the designed value
for the reference motor, ``{default}`` for the field's default, ``{mm}`` and ``{pitch_mm}`` for
an electrical angle as the distance it is on the reference motor and that motor's pole pitch) and
``doc_after`` (the docs list the field after the one it names). None of them affects validation.
"""

from __future__ import annotations

import datetime
import math
import re
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, model_validator

from linsense._check import path_arg
from linsense.ctrl import (
    REAL,
    RIPPLE_MAX,
    STARTUP_PAIRS_MAX,
    V_INJ_SHARE_MAX,
    drive_default_cfg,
    injection_fits,
    observer_gains,
)
from linsense.errors import InputError
from linsense.io import folder_of, read_toml, working_folder
from linsense.plausible import implausible, slip
from linsense.tune.design import (
    DEAD_TIME_SHARE_MAX,
    RATIO_LPF_MECH,
    RATIO_LPF_OBS,
    RATIO_PWM_INJ,
    SPEED_CAP_MARGIN,
    V_DC_MAX_FRACTION,
    V_DC_MIN_FRACTION,
    DriveData,
)
from linsense.tune.injection import SQUARE_D_FRACTION
from linsense.validation import KeyProblem, to_input_error

_BRANCH = re.compile(r"^(float|int|bool|str|list\[.*\]|constrained-.*|function-.*)$")
_STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

#: the firmware's defaults (ls_drive_default_cfg), the one source of the drive defaults below
_C = drive_default_cfg()


def _c(value) -> float:
    """A C default as a Python float, rounded to the 7 digits a float holds (0.01, not 0.009999999776)."""
    return float(f"{float(value):.7g}")


Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]
Triple = Annotated[list[float], Field(min_length=3, max_length=3)]


class CalibrationSection(BaseModel):
    """The firmware's LUT calibration (paper Fig. 9), control.mode = "calibration" (ls_cal_cfg)."""

    model_config = _STRICT
    points: int = Field(default=int(_C.cal.points), ge=4, le=4096,
                        description="positions over one period")
    k_int: Positive = Field(
        _c(_C.cal.k_int), description="adaptation rate of the compensation angle",
        json_schema_extra={"unit": "1/s", "default_note": "follows the drive in calibration mode "
                           "({ecce2010} for ecce2010; \"Calibration\" below)"})
    t_settle: NonNegative = Field(
        _c(_C.cal.t_settle), description="wait after each move",
        json_schema_extra={"unit": "s", "default_note": "follows the drive in calibration mode "
                           "({ecce2010} for ecce2010)"})
    t_hold: Positive = Field(
        _c(_C.cal.t_hold), description="window over which a point must have converged",
        json_schema_extra={"unit": "s", "default_note": "follows the drive in calibration mode "
                           "({ecce2010} for ecce2010)"})
    # deg, acceptance (see ls_drive.h); an electrical angle error is at most 180 deg
    tol_deg: float = Field(default=round(math.degrees(float(_C.cal.tol)), 6), gt=0.0, le=180.0,
                           description="acceptance: a point is accepted after a window `t_hold` whose mean "
                           "demodulated error is below it",
                           json_schema_extra={"unit": "electrical deg"})
    t_max: Positive = Field(
        _c(_C.cal.t_max), description="a point not accepted by then trips the observer fault; at least "
        "`t_hold` (one acceptance window)",
        json_schema_extra={"unit": "s", "default_note": "follows the drive in calibration mode "
                           "({ecce2010} for ecce2010)"})
    dither_a: NonNegative = Field(
        _c(_C.cal.dither_amp), description="q-current dither while adapting (0: none)",
        json_schema_extra={"kind": "current", "unit": "A",
                           "default_note": "designed ({ecce2010} for ecce2010)"})
    dither_hz: Positive = Field(
        _c(_C.cal.dither_freq), description="frequency of the dither",
        json_schema_extra={"unit": "Hz", "default_note": "designed ({ecce2010} for ecce2010)"})


class StartupSection(BaseModel):
    """Start-up from an unknown position with the magnet polarity, control.mode = "startup"
    (ls_startup_cfg, docs/firmware.md): HF lock, d-axis pulse pairs, then sensorless_lut."""

    model_config = _STRICT
    guess_mm: float = Field(0.0, description="the drive's initial estimate (the start-up does not know "
                            "`initial.position_mm`)", json_schema_extra={"unit": "mm"})
    t_lock: Positive = Field(_c(_C.startup.t_lock), description="HF lock before the pulses (at most 60)",
                             json_schema_extra={"unit": "s"})
    err_lock_deg: Positive = Field(round(math.degrees(float(_C.startup.err_lock)), 4),
                                   description="the lock is accepted within it (at most 90)",
                                   json_schema_extra={"unit": "electrical deg"})
    t_quiet: NonNegative = Field(_c(_C.startup.t_quiet), description="injection ramp-down before the "
                                 "pulses (at least the injection's ramp, at most 60)",
                                 json_schema_extra={"unit": "s"})
    v_pulse: Positive = Field(_c(_C.startup.v_pulse), description="pulse amplitude on the estimated d-axis",
                              json_schema_extra={"kind": "voltage", "unit": "V"})
    t_pulse: Positive = Field(_c(_C.startup.t_pulse), description="pulse length (at least 2 PWM periods, "
                              "at most 60)", json_schema_extra={"unit": "s"})
    t_rest: Positive = Field(_c(_C.startup.t_rest), description="zero voltage before each pulse (at least "
                             "3 PWM periods, at most 60)", json_schema_extra={"unit": "s"})
    pairs: int = Field(default=int(_C.startup.pairs), ge=1, le=STARTUP_PAIRS_MAX,
                       description="(+, -) pulse pairs")
    i_min: Positive = Field(_c(_C.startup.i_min), description="smallest `|i_diff|` accepted as a decision",
                            json_schema_extra={"unit": "A"})
    t_settle: NonNegative = Field(_c(_C.startup.t_settle), description="HF relock after the pulses (at "
                                  "least the injection's ramp, at most 60)", json_schema_extra={"unit": "s"})


class ScenarioSection(BaseModel):
    """The ``[scenario]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    name: str = Field(default="scenario", min_length=1, description="name in outputs")
    duration: Positive = Field(description="simulated time", json_schema_extra={"unit": "s"})
    seed: int = Field(default=0, ge=0, lt=2**63, description="current-noise seed")


class InverterSection(BaseModel):
    """The ``[inverter]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    fidelity: Literal["average", "switching"] = Field("average", description="`average` or `switching` "
                                                      "(see \"Fidelity\")")
    # (the design's default drive; the C library has no bus)
    v_dc: Positive = Field(_c(DriveData().v_dc), description="DC bus",
                           json_schema_extra={"kind": "voltage", "unit": "V"})
    f_pwm: Positive = Field(_c(_C.fs), description="PWM frequency = control rate",
                            json_schema_extra={"kind": "pwm_frequency", "unit": "Hz"})
    dead_time: NonNegative = Field(_c(_C.mod.dead_time), description="< 10 % of the PWM period",
                                   json_schema_extra={"kind": "dead_time", "unit": "s"})
    dead_time_compensation: bool = Field(bool(_C.mod.dtc), description="the modulator's compensation")
    dtc_current_band: Positive = Field(
        _c(_C.mod.i_band), description="smooth-sign band of the compensation (a trade-off under dead "
        "time: see \"Dead time and the closed loop\")", json_schema_extra={"kind": "current", "unit": "A"})


class ControlSection(BaseModel):
    """The ``[control]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    mode: Literal["sensorless_lut", "sensorless_nolut", "sensored", "calibration", "startup"] = Field(
        "sensorless_lut", description="`sensorless_lut`, `sensorless_nolut`, `sensored`, `calibration` (the "
        "firmware's LUT calibration; `linsense calibrate` runs it), `startup` (start-up from an unknown "
        "position with the magnet polarity, then `sensorless_lut`; `[startup]` below)")
    fs: Positive | None = Field(None, description="must equal `inverter.f_pwm` (one controller step per PWM "
                                "period)", json_schema_extra={"unit": "Hz", "default_note": "= `f_pwm`"})
    delay_comp: NonNegative = Field(_c(_C.delay_comp), description="voltage-angle advance",
                                    json_schema_extra={"unit": "periods"})
    inject_sensored: bool = Field(
        bool(_C.inject_sensored), description="keep injecting in sensored mode, on the encoder's d-axis (the "
        "HF current dithers the dead time: no hunting), and estimate beside the encoder: the estimate is "
        "the encoder's position plus the error demodulated there, where a sensorless observer would settle")


class InjectionSection(BaseModel):
    """The ``[injection]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    amplitude: NonNegative = Field(
        _c(_C.inject.amplitude), description="peak, on the estimated d-axis; `amplitude * sqrt(3) < "
        f"{V_INJ_SHARE_MAX:g} protection.v_dc_min`",
        json_schema_extra={"unit": "V", "default_note": "designed ({ecce2010} for ecce2010)"})
    frequency: Positive = Field(_c(_C.inject.freq), description="<= f_pwm / 4",
                                json_schema_extra={"kind": "injection_frequency",
                                                   "unit": "Hz",
                                                   "default_note": f"designed (f_pwm / {RATIO_PWM_INJ:g})"})
    ramp_rate: Positive = Field(_c(_C.inject.ramp_rate), description="the injection's ramp",
                                json_schema_extra={"unit": "V/s", "default_note": "designed ({ecce2010} for "
                                                   "ecce2010)"})
    quadrature: float = Field(
        default=_c(_C.inject.quad), ge=0.0, lt=1.0, description="kappa: `kappa amplitude sin` on the "
        "estimated q-axis (elliptical injection, docs/theory.md); 0: the paper's pulsating injection",
        json_schema_extra={"kind": "share", "doc_after": "frequency"})
    # quality factor of the HF band-pass and the fundamental notch
    filter_q: Positive = Field(_c(_C.bpf.q), description="Q of the HF band-pass and of the fundamental notch")
    # pulsating (the paper's, on the estimated d-axis), rotating (stationary frame, negative-sequence
    # demodulation) or square (+-amplitude every PWM period on the estimated d-axis, f = f_pwm / 2)
    shape: Literal["pulsating", "rotating", "square"] = Field(
        "pulsating", description="`rotating`: a rotating vector of `amplitude` in the stationary frame, "
        "negative-sequence demodulation, its own table and gain schedule; `square`: `+-amplitude` every PWM "
        "period on the estimated d-axis (`frequency` is then f_pwm / 2: leave it out), difference "
        "demodulation. Both refuse a non-zero `quadrature` and a given `observer.demod_method`; `square` "
        "refuses `observer.dead_time_residual = true` (docs/firmware.md, \"Injection shapes\")")
    # A, d-current reference while injecting (default: the design's, 0 except for the square wave,
    # whose current change the dead time would bias at zero current; docs/firmware.md)
    d_current: float | None = Field(
        None, description="d-current reference while injecting (keeps the phase currents off zero, where the "
        "dead time acts on the square wave); `|d_current| < i_max`",
        json_schema_extra={"unit": "A",
                           "default_note": f"0; `square`: {SQUARE_D_FRACTION:g} `controller.i_max`"})
    # the square wave's measures against the dead time where a phase current is small: the
    # compensation with the edges' PWM ripple and the d-current schedule near the positions where
    # the d-axis is normal to a phase axis (docs/theory.md, "The dead time and the square wave")
    dead_time_measures: bool = Field(
        True, description="`square` only: the dead-time compensation with each leg's edges apart by the PWM "
        "ripple (`inverter.dtc_current_band` then 10 mA unless given) and the d-current schedule near the "
        "six positions where d is normal to a phase axis (docs/theory.md, \"The dead time and the square "
        "wave: the relay band\"); false: the plain compensation and `d_current` everywhere")


class ObserverSection(BaseModel):
    """The ``[observer]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    compensation: Literal["lut", "none"] | None = Field(
        None, description="a contradiction with the mode is refused",
        json_schema_extra={"default_note": "`lut` in `sensorless_lut`, `startup` and `sensored` (for the HF "
                           "estimate beside the encoder), else `none`"})
    lut_model: Literal["resistive", "eq12", "measured"] = Field(
        "resistive", description="`resistive`: `build_lut(motor, lut_points, f_inj=frequency, "
        "quad=quadrature)` with the R_s the controller believes; `eq12`: paper eq. 12; `measured`: the "
        "table of `lut_file` (\"Measured tables\" below), its slope in R_s and the gain table the model's")
    # a stamped measured table (linsense calibrate's lut_measured.json), relative to the scenario file
    lut_file: str | None = Field(
        None, min_length=1, description="the measured table (`lut_measured.json` of `linsense calibrate`), "
        "a path relative to the scenario file; its stamp must be this drive's (the controller's model "
        "motor, the injection's shape, frequency and kappa), a table of another length is resampled to "
        "`lut_points` (\"Measured tables\" below)",
        json_schema_extra={"default_note": "required with `lut_model = \"measured\"`, refused otherwise"})
    lut_points: int = Field(default=256, ge=4, le=65536, description="table length (also of the gain table)")
    # "mech": the mechanical observer (mass, force, load estimate); "pll": the type-2 tracking loop
    type: Literal["pll", "mech"] = Field(
        "mech" if _C.obs.type == 1 else "pll",
        description="`mech`: the mechanical model (mass, force reference) with a load estimate; `pll`: the "
        "type-2 tracking loop (the paper's; `linsense reproduce` pins it). docs/tuning.md, \"The observer\"",
        json_schema_extra={"default_note": "designed: `\"mech\"` (the pulsating and elliptical injections), "
                           "`\"pll\"` (rotating, square)"})
    # Hz, all poles at -2 pi f (ls_observer_gains)
    bandwidth_hz: Positive = Field(
        _c(_C.obs.k1 / observer_gains(1.0, _C.obs.type == 1)[0]),  # (k1 grows with the bandwidth)
        description="k1..k3 from `ls_observer_gains` (all poles at -2 pi f)",
        json_schema_extra={"kind": "bandwidth",
                           "unit": "Hz",
                           "default_note": f"designed: `mech` `f_lpf / {RATIO_LPF_MECH:g}`, `pll` "
                           f"`f_lpf / {RATIO_LPF_OBS:g}` "
                           "({ecce2010} for ecce2010, `mech`)"})
    # the mechanical observer's load estimate fed forward into the force reference (ls_drive_cfg.load_ff;
    # the speed loop's designed integral gain is then 0); default: on with type = "mech"
    load_feedforward: bool | None = Field(
        None, description="the mechanical observer's load estimate fed forward into the force reference, the "
        "speed PI's integrator held at 0 in the sensorless modes (`ls_drive_cfg.load_ff`); true with `pll` "
        "is refused",
        json_schema_extra={"unit": "bool", "default_note": "on with `mech`", "doc_after": "type"})
    k1: Positive | None = Field(None, description="explicit gain, overrides `bandwidth_hz` (k1 and k2 "
                                "together; k3 for mech)", json_schema_extra={"unit": "1/s"})
    k2: Positive | None = Field(None, description="explicit gain (with k1)",
                                json_schema_extra={"unit": "1/s^2"})
    k3: Positive | None = Field(None, description="explicit gain (with k1 and k2; mech only)",
                                json_schema_extra={"unit": "1/s^3"})
    gain_schedule: bool = Field(
        True, description="demodulator gain table that makes the error's local slope 1 at every position, "
        "from the model for the injection in use (docs/tuning.md)",
        json_schema_extra={"default_note": "true (designed)"})
    demod_method: Literal["product", "heterodyne"] = Field("product",
                                                           description="`product` (paper) or `heterodyne`")
    demod_lpf_hz: Positive = Field(_c(_C.demod.f_lpf), description="demodulator low-pass",
                                   json_schema_extra={"kind": "bandwidth",
                                                      "unit": "Hz", "default_note": "designed ({ecce2010} "
                                                      "for ecce2010)"})
    # s, the HF path's delay: the pulsating/elliptical estimate is advanced by omega times it (designed)
    hf_delay_s: float = Field(
        default=_c(_C.hf_delay), ge=0.0, le=0.1,
        description="the HF path's delay: the pulsating and elliptical estimate's demodulated "
        "error is advanced by the speed times it (docs/tuning.md, \"The HF path's delay\")",
        json_schema_extra={"kind": "time", "unit": "s", "default_note": "designed (`1 / f_inj`; 0 for the "
                           "rotating vector and the square wave)"})
    demod_notch: bool = Field(bool(_C.demod.f_notch > 0), description="the low-pass's zeros at twice the "
                              "injection frequency (the products' ripple)")
    min_level: NonNegative = Field(_c(_C.demod.min_level), description="HF level below which the error is "
                                   "held", json_schema_extra={"unit": "A^2", "doc_after": "resistance_adapt"})
    dead_time_residual: bool = Field(bool(_C.hf_dtres), description="take the current the dead-time residual "
                                     "drove out of the HF path (docs/firmware.md, ls_dtres.h)")
    # the residual's model: "forward" (the period run edge by edge from its start current, with the
    # saliency at the estimated angle and the end effect) or "interpolated" (the edge currents
    # between the period's end samples: cheaper, needs no angle; the former model)
    dead_time_model: Literal["forward", "interpolated"] = Field(
        "forward" if _C.dtres.forward else "interpolated",
        description="the residual's model (docs/firmware.md): `forward` runs the period edge by edge from "
        "its start current through the inductance model at the estimated angle (saliency and the end "
        "effect's stationary anisotropy), so each edge's current carries the losses of the edges before it; "
        "`interpolated` (the former model, cheaper, needs no angle) reads each edge's current between the "
        "period's two samples. Without the table (`sensorless_nolut`) the estimate is up to 20 deg off and "
        "the forward model's saliency axis with it: the paper's uncompensated runs in `linsense reproduce` "
        "use `interpolated`")
    dead_time_adapt: bool = Field(
        bool(_C.dtres.adapt), description="the forward model measures the scale of its inductance online "
        "from every period's current change (`ls_dtres_adapt`), so that a motor 10 % off its file does not "
        "bring the dead time's bias back")
    # with dead_time_adapt, the resistance's scale too, which corrects the resistance-aware table
    resistance_adapt: bool = Field(
        bool(_C.dtres.adapt_r), description="with `dead_time_adapt`: the scale of the phase resistance too "
        "(`ls_dtres_adapt`), which the forward model's drop, the resistance-aware table and the gain "
        "schedule follow (`ls_demod_cfg.comp_r`, `gain_r`; docs/tuning.md, \"The hot winding\")")
    omega_max: Positive = Field(
        _c(_C.obs.omega_max), description="clamp of the observer's speed estimate",
        json_schema_extra={"kind": "angular_speed",
                           "unit": "rad/s electrical", "default_note": "designed: the limits' margins "
                           "({ecce2010} for ecce2010 with its table)"})
    force_max: Positive = Field(
        _c(_C.obs.force_max), description="clamp of the observer's load estimate (mech)",
        json_schema_extra={"unit": "N", "default_note": "designed: `K_f i_max` ({ecce2010} for ecce2010)"})


class ModelOverride(BaseModel):
    """What the controller believes about the motor (default: the motor model itself)."""

    model_config = _STRICT
    motor: str | None = Field(
        default=None, min_length=1, description="preset or motor file (relative to the scenario) the "
        "controller's tables and gains are built from; the keys below override single values of it",
        json_schema_extra={"default_note": "the scenario's `motor`"})
    L_d: Positive | None = Field(
        None, description="what the controller believes (parameter mismatch studies): decoupling",
        json_schema_extra={"kind": "inductance",
                           "unit": "H", "default_note": "the motor's mean L_d over a period"})
    L_q: Positive | None = Field(None, description="what the controller believes", json_schema_extra={
        "kind": "inductance", "unit": "H", "default_note": "the motor's mean L_q over a period"})
    R_s: NonNegative | None = Field(None, description="what the controller believes: current-loop integral "
                                    "gain", json_schema_extra={"kind": "resistance",
                                                               "unit": "ohm", "default_note": "the motor's"})
    psi_pm: NonNegative | None = Field(None, description="what the controller believes: back-EMF "
                                       "feed-forward", json_schema_extra={"unit": "Wb",
                                                                          "default_note": "`K_f tau/(3 pi)`"})
    mass: Positive | None = Field(None, description="what the controller believes: feed-forward, speed-loop "
                                  "gains, mech observer", json_schema_extra={"kind": "mass", "unit": "kg",
                                                                             "default_note": "the motor's"})
    force_constant: Positive | None = Field(None, description="what the controller believes: force -> i_q",
                                            json_schema_extra={"kind": "force_constant",
                                                               "unit": "N/A", "default_note": "the motor's"})
    demod_gain: float | None = Field(
        None, description="what the controller believes: the demodulator's gain; refused with "
        "`observer.gain_schedule = true`, whose table replaces it",
        json_schema_extra={"default_note": "`L_q/(L_q - L_d)` of the means"})


class ControllerSection(BaseModel):
    """The ``[controller]`` section of a scenario file; its keys are in docs/simulator.md.

    Attributes
    ----------
    model : ModelOverride
        ``[controller.model]``: what the controller believes about the motor.
    """
    model_config = _STRICT
    position_type: Literal["p", "pd"] = Field("p", description="`p` (P -> speed PI) or `pd` (PD -> force)")
    kp_x: Positive | None = Field(
        None, description="position gain",
        json_schema_extra={"unit": "1/s (p), N/m (pd)",
                           "default_note": "designed ({ecce2010} for ecce2010); required for pd"})
    kd_x: NonNegative = Field(0.0, description="pd only", json_schema_extra={"unit": "N s/m"})
    v_max: Positive = Field(
        _c(_C.pos.v_max), description="speed-reference limit (p), and a step command's speed",
        json_schema_extra={"kind": "speed",
                           "unit": "m/s",
                           "default_note": f"designed ({SPEED_CAP_MARGIN:g} times the application's, "
                           "`reference.v_max`: {ecce2010} for ecce2010)"})
    # m/s^2, a step command's acceleration (a minimum-time move at v_max); 0: the reference jumps
    step_a_max: float = Field(
        default=_c(_C.traj.a_step), ge=0.0, le=1.0e4,
        description="a step command runs as a minimum-time move at `v_max` and this acceleration "
        "(docs/tuning.md, \"Steps\"); 0: the reference jumps (the paper's step)",
        json_schema_extra={"unit": "m/s^2", "default_note": "designed "
                           "(`min(v_cap w_v / 3, 0.5 K_f i_max / m)`: "
                           "{ecce2010} for ecce2010)"})
    # Hz: kp = m w, ki = m w^2 / 4 (the C default's w)
    speed_bandwidth_hz: Positive = Field(
        _c(_C.pos.speed.kp / _C.pos.mass / (2.0 * math.pi)), description="kp = m w, ki = m w^2 / 4 (held at "
        "0 in the sensorless modes with `load_feedforward`)",
        json_schema_extra={"kind": "bandwidth",
                           "unit": "Hz", "default_note": "designed ({ecce2010} for ecce2010)"})
    speed_kp: Positive | None = Field(None, description="explicit, with `speed_ki`; overrides the bandwidth",
                                      json_schema_extra={"unit": "N s/m"})
    speed_ki: NonNegative | None = Field(None, description="explicit, with `speed_kp`",
                                         json_schema_extra={"unit": "N/m"})
    # Hz: ki = w R_s
    current_bandwidth_hz: Positive = Field(
        _c(_C.current.ki / _C.dtres.r_s / (2.0 * math.pi)), description="kp = w (L_d + L_q)/2, ki = w R_s",
        json_schema_extra={"kind": "bandwidth",
                           "unit": "Hz", "default_note": "designed ({ecce2010} for ecce2010)"})
    current_kp: Positive | None = Field(None, description="explicit, with `current_ki`; overrides the "
                                        "bandwidth", json_schema_extra={"unit": "V/A"})
    current_ki: NonNegative | None = Field(None, description="explicit, with `current_kp`",
                                           json_schema_extra={"unit": "V/(A s)"})
    decouple: bool = Field(True, description="dq decoupling and back-EMF feed-forward")
    i_max: Positive = Field(_c(_C.i_max), description="current-reference limit; force limit = K_f i_max",
                            json_schema_extra={"kind": "current", "unit": "A"})
    friction_coulomb: NonNegative = Field(
        0.0, description="Coulomb friction fed forward at the speed reference and in the mech observer's "
        "model, linear below `friction_band` (docs/tuning.md, \"Friction and thrust ripple\")",
        json_schema_extra={"unit": "N", "default_note": "designed: the motor file's `[friction] coulomb`"})
    friction_viscous: NonNegative = Field(
        0.0, description="viscous friction fed forward at the speed reference and in the mech observer's "
        "model", json_schema_extra={"unit": "N s/m",
                                    "default_note": "designed: the motor file's `[friction] viscous`"})
    friction_band: Positive = Field(
        1.0e-3, description="the speed below which the Coulomb friction is linear (the injection's dither "
        "averages the relay into that slope)",
        json_schema_extra={"kind": "speed",
                           "unit": "m/s", "default_note": "designed: pi/2 times the q-current dither's "
                           "velocity amplitude"})
    ripple_order: int = Field(
        0, ge=0, le=64, description="order n of the force constant's ripple the current reference divides "
        "out, K_f (1 + `ripple_cos` cos(n theta) + `ripple_sin` sin(n theta)); 0: none",
        json_schema_extra={"default_note": "designed: the largest of the motor file's `[pm_flux]` "
                           "harmonics' (6 for the 5th and 7th)"})
    ripple_cos: float = Field(
        0.0, ge=-0.5, le=0.5, description="the ripple's cosine share of K_f (|`ripple_cos`| + |`ripple_sin`| "
        "<= 0.5)", json_schema_extra={"default_note": "designed from `[pm_flux]`"})
    ripple_sin: float = Field(
        0.0, ge=-0.5, le=0.5, description="the ripple's sine share of K_f",
        json_schema_extra={"default_note": "designed from `[pm_flux]`"})
    model: ModelOverride = Field(default_factory=ModelOverride)


class ReferenceSection(BaseModel):
    """The ``[reference]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    type: Literal["step", "trajectory", "hold"] = Field("step", description="`step`, `trajectory` or `hold`")
    position_mm: float | None = Field(None, description="step target", json_schema_extra={
        "unit": "mm", "default_note": "required for step"})
    at: NonNegative = Field(0.1, description="step time, or start of the first move; within the run "
                            "(\"Events and the end window\")", json_schema_extra={"unit": "s"})
    waypoints_mm: list[float] | None = Field(default=None, max_length=10_000, description="targets in order",
                                             json_schema_extra={"unit": "mm", "default_note": "required for "
                                                                "trajectory, non-empty"})
    v_max: Positive = Field(_c(_C.traj.v_max), description="trajectory speed limit (the firmware's "
                            "`ls_traj`)", json_schema_extra={"kind": "speed", "unit": "m/s"})
    a_max: Positive = Field(_c(_C.traj.a_max), description="trajectory acceleration limit (the firmware's "
                            "`ls_traj`)", json_schema_extra={"unit": "m/s^2"})
    dwell: float = Field(0.2, description="pause after each move, >= 0", json_schema_extra={"unit": "s"})

    @model_validator(mode="after")
    def _check(self) -> ReferenceSection:
        if self.type == "step":
            if self.position_mm is None:
                raise KeyProblem("position_mm", "missing required key for type = \"step\"")
            if self.waypoints_mm is not None:
                raise KeyProblem("waypoints_mm", "only valid with type = \"trajectory\"")
        elif self.type == "trajectory":
            if self.waypoints_mm is None:
                raise KeyProblem("waypoints_mm", "missing required key for type = \"trajectory\"")
            if not self.waypoints_mm:
                raise KeyProblem("waypoints_mm", "needs at least one waypoint, got []")
            if self.position_mm is not None:
                raise KeyProblem("position_mm", "only valid with type = \"step\" (use waypoints_mm)")
        else:
            for k in ("position_mm", "waypoints_mm"):
                if getattr(self, k) is not None:
                    raise KeyProblem(k, "not valid with type = \"hold\"")
        if self.dwell < 0:
            raise KeyProblem("dwell", f"must be >= 0 s, got {self.dwell!r}")
        return self


class LoadSection(BaseModel):
    """The ``[load]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    type: Literal["constant", "step", "incline"] = Field("constant", description="`constant`, `step`, "
                                                         "`incline`")
    force: float = Field(0.0, description="opposes positive motion when > 0 (step: before `time`)",
                         json_schema_extra={"unit": "N"})
    force_after: float = Field(0.0, description="step load: after `time`", json_schema_extra={"unit": "N"})
    time: NonNegative = Field(0.0, description="step load: step time, within the run",
                              json_schema_extra={"unit": "s"})
    incline_deg: float = Field(default=0.0, ge=-90.0, le=90.0, description="incline: adds m g sin",
                               json_schema_extra={"unit": "deg"})


class SensorsSection(BaseModel):
    """The ``[sensors]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    current_gain: float | Triple = Field(1.0, description="one value or `[a, b, c]`")
    current_offset: float | Triple = Field(0.0, description="one value or `[a, b, c]`",
                                           json_schema_extra={"unit": "A"})
    current_noise: NonNegative = Field(0.0, description="Gaussian", json_schema_extra={"unit": "A rms"})
    adc_bits: int = Field(default=0, ge=0, le=24, description="quantisation over +- `adc_range`; 0: ideal")
    adc_range: Positive = Field(10.0, description="+- full scale of the quantisation",
                                json_schema_extra={"kind": "current", "unit": "A"})
    encoder_counts_per_period: int = Field(default=int(_C.enc_counts), ge=1, lt=2**31,
                                           description="sensored mode")


class InitialSection(BaseModel):
    """The ``[initial]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    position_mm: float = Field(0.0, description="the mover starts here at rest; the sensorless observer is "
                               "told this position", json_schema_extra={"unit": "mm"})
    load_balanced: bool = Field(
        False, description="start in equilibrium with the load acting at t = 0 (`ls_drive_set_load`: speed "
        "integrator and mechanical observer preset; position type `p`), so a loaded drive does not sag "
        "before its integrators catch up; a load beyond `K_f controller.i_max` has no equilibrium and is "
        "refused")


class TravelSection(BaseModel):
    """The ``[travel]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    min_mm: float = Field(-1000.0, description="leaving the travel stops the run (fault `travel`)",
                          json_schema_extra={"unit": "mm"})
    max_mm: float = Field(1000.0, description="leaving the travel stops the run (fault `travel`)",
                          json_schema_extra={"unit": "mm"})


class ProtectionSection(BaseModel):
    """The ``[protection]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    i_max: Positive = Field(_c(_C.prot.i_max), description="phase over-current trip", json_schema_extra={
        "kind": "current", "unit": "A", "default_note": "designed ({ecce2010} for ecce2010)"})
    v_dc_min: NonNegative = Field(_c(_C.prot.v_dc_min), description="under-voltage trip", json_schema_extra={
        "unit": "V", "default_note": "5/9 `v_dc` ({ecce2010} at the default bus)"})
    v_dc_max: Positive = Field(_c(_C.prot.v_dc_max), description="over-voltage trip", json_schema_extra={
        "unit": "V", "default_note": "5/4 `v_dc` ({ecce2010} at the default bus)"})
    err_max: Positive = Field(_c(_C.prot.err_max), description="observer-loss trip: error-signal limit",
                              json_schema_extra={"kind": "angle_error", "unit": "rad"})
    err_time: Positive = Field(_c(_C.prot.err_time), description="observer-loss trip: time over `err_max`",
                               json_schema_extra={"unit": "s"})
    omega_max: Positive = Field(_c(_C.prot.omega_max), description="over-speed trip", json_schema_extra={
        "kind": "angular_speed", "unit": "rad/s electrical", "default_note": "designed: the limits' margins "
        "({ecce2010} for ecce2010 with its table)"})
    i_abort: Positive = Field(20.0, description="the simulator stops the run as `diverged` beyond this",
                              json_schema_extra={"unit": "A"})


class RecordSection(BaseModel):
    """The ``[record]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    decimate: int = Field(default=1, ge=1, le=1_000_000, description="record every n-th period (with `> 1`, "
                          "also the block statistics of every period: see \"Block statistics\"); what is "
                          "kept, not what the metrics read: every period")


class SaturationSection(BaseModel):
    """The saturated plant (docs/simulator.md, "Saturation"): off by default (the linear plant).
    ``enabled`` uses the motor file's ``[saturation]``; the other keys give or override its
    parametric keys (so that a preset such as ecce2010 can saturate)."""

    model_config = _STRICT
    enabled: bool = Field(False, description="the saturated plant (see \"Saturation\"): the motor file's "
                          "`[saturation]`, with the keys below over it")
    polarity: NonNegative | None = Field(
        None, description="magnet-polarity signal `(L_d(-I) - L_d(+I)) / L_d` per A of d pulse; needs "
        "`enabled`", json_schema_extra={"unit": "1/A", "default_note": "the motor's"})
    magnet_current: Positive | None = Field(
        None, description="`i_m`, the d current equivalent to the magnets; needs `enabled`",
        json_schema_extra={"unit": "A", "default_note": "`psi_pm / L_d` (mean L_d)"})
    q_drop: Annotated[float, Field(ge=0.0, lt=1.0)] | None = Field(
        None, description="parametric q-axis saturation: `L_q` falls by `q_drop` at `q_current` (quadratic); "
        "not with saturation tables; needs `enabled`", json_schema_extra={"default_note": "the motor's (0)"})
    q_current: Positive | None = Field(None, description="the current of `q_drop`; needs `enabled`",
                                       json_schema_extra={"unit": "A", "default_note": "the motor's (1)"})

    @model_validator(mode="after")
    def _check(self) -> SaturationSection:
        keys = ("polarity", "magnet_current", "q_drop", "q_current")
        given = [k for k in keys if getattr(self, k) is not None]
        if given and not self.enabled:
            raise KeyProblem(given[0], "only used by the saturated plant: set saturation.enabled = true")
        for k in ("magnet_current", "q_current"):  # (16000 for 16 A was blamed on saturation.polarity)
            msg = None if getattr(self, k) is None else implausible("current", getattr(self, k))
            if msg is not None:
                raise KeyProblem(k, msg)
        return self


#: the bounds of the metrics, each given in electrical degrees (``<name>_deg``) or, as older files
#: do, in mm (``<name>_mm``): one form per bound
METRIC_BOUNDS = ("tolerance", "bound", "settle_band", "settling_band")
#: the docs' unit and default of a bound in electrical degrees (with its distance on the reference motor)
_BOUND = {"unit": "electrical deg", "default_note": "{default} ({mm} mm at {pitch_mm} mm)"}


class MetricsSection(BaseModel):
    """How a run is judged (docs/simulator.md, "Metrics"). The bounds are electrical degrees, fractions
    of the pole pitch (``theta = 360 deg * x / pole_pitch``), so that ``stable`` means the same on
    every motor; the defaults are 3.5, 0.023, 0.16 and 0.47 mm at the 56 mm pitch of ecce2010. A
    bound may be given in mm instead (``bound_mm``...: older files), converted with the motor's pole
    pitch (:meth:`bounds_deg`); never in both forms."""

    model_config = _STRICT
    convergence_s: NonNegative = Field(
        0.1, description="start of the transient and steady error windows (`max_abs_err_deg` covers the "
        "whole run)", json_schema_extra={"unit": "s"})
    settle_s: NonNegative = Field(0.3, description="transient window after a step or the end of a move",
                                  json_schema_extra={"unit": "s"})
    tolerance_deg: Positive = Field(3.0, description="`max |x - target|` over the end window for `accurate`",
                                    json_schema_extra=_BOUND)
    bound_deg: Positive = Field(22.5, description="`max |x - target|` over the end window for `stable` "
                                "(bounded)", json_schema_extra=_BOUND)
    settle_band_deg: Positive = Field(0.15, description="limit-cycle tolerance: peak to peak of the true "
                                      "position over the end window, for `stable` (settled)",
                                      json_schema_extra=_BOUND)
    settling_band_deg: Positive = Field(
        1.0, description="band around the target that defines `settling_time_s`",
        json_schema_extra=_BOUND)
    tolerance_mm: Positive | None = Field(None, description="`tolerance_deg` in mm (older files), converted "
                                          "with the motor's pole pitch: give each bound in one form only "
                                          "(both is an error naming the two keys)",
                                          json_schema_extra={"unit": "mm", "default_note": "none"})
    bound_mm: Positive | None = Field(None, description="`bound_deg` in mm (as `tolerance_mm`)",
                                      json_schema_extra={"unit": "mm", "default_note": "none"})
    settle_band_mm: Positive | None = Field(None, description="`settle_band_deg` in mm (as `tolerance_mm`)",
                                            json_schema_extra={"unit": "mm", "default_note": "none"})
    settling_band_mm: Positive | None = Field(None, description="`settling_band_deg` in mm (as "
                                              "`tolerance_mm`)", json_schema_extra={"unit": "mm",
                                                                                    "default_note": "none"})
    final_window_s: Positive = Field(0.3, description="end window of `stable`, `bias_deg`, `limit_cycle_deg` "
                                     "(clipped to the run); at least half the period of the drive's slowest "
                                     "loop (\"Events and the end window\"): one the file gives shorter is "
                                     "refused, the default widened to it", json_schema_extra={"unit": "s"})

    @model_validator(mode="after")
    def _check(self) -> MetricsSection:
        for name in METRIC_BOUNDS:
            mm = getattr(self, f"{name}_mm")
            if mm is not None and f"{name}_deg" in self.model_fields_set:
                raise KeyProblem(f"{name}_deg", f"give metrics.{name}_deg or metrics.{name}_mm, not both "
                                 f"(got {getattr(self, f'{name}_deg')!r} deg and {mm!r} mm)")
        return self

    def bounds_deg(self, pole_pitch: float) -> dict[str, float]:
        """The bounds in electrical degrees on a motor of pole pitch ``pole_pitch``.

        Parameters
        ----------
        pole_pitch : float
            m, one electrical period of the motor.

        Returns
        -------
        dict
            ``tolerance_deg``, ``bound_deg``, ``settle_band_deg``, ``settling_band_deg``: the keys
            given in degrees (or their defaults) as they are, those given in mm converted
            (``360 deg * x / pole_pitch``).
        """
        out = {}
        for name in METRIC_BOUNDS:
            mm = getattr(self, f"{name}_mm")
            deg = getattr(self, f"{name}_deg") if mm is None else 360.0 * (mm * 1e-3) / pole_pitch
            out[f"{name}_deg"] = deg
        return out


class ScenarioFile(BaseModel):
    """A whole scenario file, validated: the motor and one model per section (docs/simulator.md).

    Attributes
    ----------
    scenario : ScenarioSection
        ``[scenario]`` (required: ``duration``).
    inverter : InverterSection
        ``[inverter]``.
    control : ControlSection
        ``[control]``.
    injection : InjectionSection
        ``[injection]``.
    observer : ObserverSection
        ``[observer]``.
    controller : ControllerSection
        ``[controller]``.
    reference : ReferenceSection
        ``[reference]``.
    load : LoadSection
        ``[load]``.
    sensors : SensorsSection
        ``[sensors]``.
    initial : InitialSection
        ``[initial]``.
    travel : TravelSection
        ``[travel]``.
    protection : ProtectionSection
        ``[protection]``.
    record : RecordSection
        ``[record]``.
    metrics : MetricsSection
        ``[metrics]``.
    calibration : CalibrationSection
        ``[calibration]``.
    saturation : SaturationSection
        ``[saturation]``.
    startup : StartupSection
        ``[startup]``.
    """
    model_config = _STRICT
    motor: str = Field(min_length=1, description="preset name (`ecce2010`) or motor-file path, relative to "
                       "the scenario file")
    scenario: ScenarioSection
    inverter: InverterSection = Field(default_factory=InverterSection)
    control: ControlSection = Field(default_factory=ControlSection)
    injection: InjectionSection = Field(default_factory=InjectionSection)
    observer: ObserverSection = Field(default_factory=ObserverSection)
    controller: ControllerSection = Field(default_factory=ControllerSection)
    reference: ReferenceSection = Field(default_factory=ReferenceSection)
    load: LoadSection = Field(default_factory=LoadSection)
    sensors: SensorsSection = Field(default_factory=SensorsSection)
    initial: InitialSection = Field(default_factory=InitialSection)
    travel: TravelSection = Field(default_factory=TravelSection)
    protection: ProtectionSection = Field(default_factory=ProtectionSection)
    record: RecordSection = Field(default_factory=RecordSection)
    metrics: MetricsSection = Field(default_factory=MetricsSection)
    calibration: CalibrationSection = Field(default_factory=CalibrationSection)
    saturation: SaturationSection = Field(default_factory=SaturationSection,
                                          json_schema_extra={"doc_after": "record"})
    startup: StartupSection = Field(default_factory=StartupSection)

    @model_validator(mode="after")
    def _check(self) -> ScenarioFile:
        """The rules between keys, section by section, in the order their refusals take."""
        for check in (_check_rates, _check_overrides, _check_lut_file, _check_injection, _check_mode,
                      _check_observer_gains, _check_controller, _check_travel, _check_bus,
                      _check_amplitude):
            check(self)
        return self


def _check_rates(f: ScenarioFile) -> None:
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


def _check_lut_file(f: ScenarioFile) -> None:
    """A measured table needs its file."""
    if f.observer.lut_model == "measured" and f.observer.lut_file is None:
        raise KeyProblem("observer.lut_file", "missing: observer.lut_model = \"measured\" reads the "
                         "table from this file (the lut_measured.json of linsense calibrate, relative to "
                         "the scenario file)")


def _check_injection(f: ScenarioFile) -> None:
    """The injection's shape and the keys it uses or derives (q-axis share, demodulation,
    dead-time residual, frequency); the d-axis current below the current limit."""
    inv = f.inverter
    inj = f.injection
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
    elif "frequency" in f.injection.model_fields_set and f.injection.frequency * 4 > inv.f_pwm:
        raise KeyProblem("injection.frequency", f"must be <= f_pwm / 4 = {inv.f_pwm / 4:g} Hz, "
                        f"got {f.injection.frequency:g}")


def _check_startup(f: ScenarioFile) -> None:
    """The start-up sequence's times and what its pulses need (the saturated plant, a polarity
    signal); only for ``control.mode = "startup"``."""
    inv, su = f.inverter, f.startup
    for k in ("t_lock", "t_quiet", "t_pulse", "t_rest", "t_settle"):  # (before the periods)
        if getattr(su, k) > 60.0:
            hint = slip("time", getattr(su, k), ok=lambda v: v <= 60.0)
            raise KeyProblem(f"startup.{k}", f"at most 60 s, got {getattr(su, k):g}"
                             + (f"; {hint}" if hint else ""))
    if _periods(su.t_pulse, inv.f_pwm) < 2:
        raise KeyProblem("startup.t_pulse", f"must be at least 2 PWM periods ({2 / inv.f_pwm:g} s), "
                         f"got {su.t_pulse:g}")
    if _periods(su.t_rest, inv.f_pwm) < 3:
        raise KeyProblem("startup.t_rest", f"must be at least 3 PWM periods ({3 / inv.f_pwm:g} s), "
                         f"got {su.t_rest:g}")
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


def _check_mode(f: ScenarioFile) -> None:
    """The observer's compensation and the start-up keys against ``control.mode``."""
    ctl = f.control
    comp = f.observer.compensation
    if ctl.mode in ("sensorless_lut", "startup") and comp == "none":
        raise KeyProblem("observer.compensation",
                         f"\"none\" contradicts control.mode = \"{ctl.mode}\" "
                         "(use mode = \"sensorless_nolut\")")
    su = f.startup
    if ctl.mode != "startup" and su.model_fields_set:
        raise KeyProblem(f"startup.{sorted(su.model_fields_set)[0]}",
                         "only used by control.mode = \"startup\"")
    if ctl.mode == "startup":
        _check_startup(f)
    if ctl.mode not in ("sensorless_lut", "sensored", "startup") and comp == "lut":
        raise KeyProblem("observer.compensation", f"\"lut\" is only used by control.mode = "
                        f"\"sensorless_lut\" (or \"sensored\", for the HF observer beside the encoder), "
                        f"got mode = {ctl.mode!r}")


def _check_observer_gains(f: ScenarioFile) -> None:
    """The observer's explicit gains come together."""
    if f.observer.type == "mech" and (f.observer.k1 is not None) != (f.observer.k3 is not None):
        raise KeyProblem("observer.k3",
                        "give k1, k2 and k3 together for the mech observer (or bandwidth_hz)")
    if (f.observer.k1 is None) != (f.observer.k2 is None):
        raise KeyProblem("observer.k2" if f.observer.k2 is None else "observer.k1",
                        "give k1 and k2 together (or only bandwidth_hz)")


def _check_controller(f: ScenarioFile) -> None:
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


def _check_travel(f: ScenarioFile) -> None:
    """The travel is an interval and holds the initial position."""
    tr = f.travel
    if not tr.min_mm < tr.max_mm:
        raise KeyProblem("travel.max_mm",
                        f"must be above travel.min_mm = {tr.min_mm:g}, got {tr.max_mm:g}")
    x0 = f.initial.position_mm
    if not tr.min_mm <= x0 <= tr.max_mm:
        raise KeyProblem("initial.position_mm", f"outside the travel [{tr.min_mm:g}, {tr.max_mm:g}] mm, "
                        f"got {x0:g}")


def _check_bus(f: ScenarioFile) -> None:
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


def _check_amplitude(f: ScenarioFile) -> None:
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


def _check_overrides(f: ScenarioFile) -> None:
    """Refuse a key the file gives that another key (or the mode, the injection's shape, the
    observer's type) makes meaningless: it would be silently ignored or overridden.
    The message names both keys."""
    inj, obs, con, ref, ld, sens = f.injection, f.observer, f.controller, f.reference, f.load, f.sensors
    mode, shape = f.control.mode, inj.shape
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
        (ld, "incline_deg", ld.type != "incline", f"load.type = {ld.type!r}",
         "only the incline adds m g sin"),
        (sens, "adc_range", sens.adc_bits == 0, "sensors.adc_bits = 0 (ideal)", "nothing is quantised"),
        (f.control, "inject_sensored", mode != "sensored", f"control.mode = {mode!r}",
         "it is the sensored mode's setting"),
        (f.inverter, "dtc_current_band", not f.inverter.dead_time_compensation,
         "inverter.dead_time_compensation = false", "it is the compensation's band"),
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
    return "lut" if mode in ("sensorless_lut", "sensored", "startup") else "none"


class Scenario:
    """A validated scenario: the parsed file plus where it came from.

    Parameters
    ----------
    spec : ScenarioFile
        Every key, defaults filled in.
    source : str
        File name (or ``"<dict>"``) used in error messages.
    base_dir : Path
        Folder against which a relative motor path is resolved.
    """

    def __init__(self, spec: ScenarioFile, source: str, base_dir: Path) -> None:
        self.spec = spec
        self.source = source
        self.base_dir = Path(base_dir)

    @property
    def name(self) -> str:
        """The scenario's name (``scenario.name``)."""
        return self.spec.scenario.name

    def to_dict(self) -> dict:
        """Plain data (every key, defaults filled in; ``None`` for unset optional keys dropped).

        Returns
        -------
        dict
            Section to keys.
        """
        return self.spec.model_dump(exclude_none=True)

    def given(self) -> dict:
        """The keys the file (or dict) gave, without the defaults (the rest is designed or defaulted
        when the scenario is built).

        Returns
        -------
        dict
            Section to the keys given.
        """
        return self.spec.model_dump(exclude_unset=True, exclude_none=True)

    def replace(self, **sections) -> Scenario:
        """A copy with some keys changed, validated again.

        E.g. ``replace(inverter={"fidelity": "switching"})``. Keys left unset stay unset (their gains
        are still designed).

        Parameters
        ----------
        **sections : dict or object
            Section name to the keys to change (a dict, merged), or a top-level key to its value.

        Returns
        -------
        Scenario
            The new scenario, same source and folder.

        Raises
        ------
        linsense.errors.InputError
            When the changed scenario is invalid.
        """
        data = self.given()
        for sec, vals in sections.items():
            if isinstance(vals, dict):
                data.setdefault(sec, {}).update(vals)
            else:
                data[sec] = vals
        return scenario_from_dict(data, self.source, self.base_dir)

    def __reduce__(self):  # picklable for simulate_many (the pydantic model re-validates on load)
        return (scenario_from_dict, (self.given(), self.source, str(self.base_dir)))

    def __repr__(self) -> str:
        return f"Scenario({self.name!r}, source={self.source!r})"


def _sections(model: type[BaseModel], prefix: str = "") -> dict[str, tuple[str, type[BaseModel]]]:
    """Every section below ``model`` by the name of its model class: its dotted path and its class
    (``{"ReferenceSection": ("reference", ReferenceSection), "ModelOverride": ("controller.model",
    ModelOverride), ...}``)."""
    out = {}
    for name, field in model.model_fields.items():
        sub = field.annotation
        if isinstance(sub, type) and issubclass(sub, BaseModel):
            out[sub.__name__] = (f"{prefix}{name}", sub)
            out.update(_sections(sub, f"{prefix}{name}."))
    return out


#: a section's model class name -> its dotted path in a scenario file and its class
_SECTIONS = _sections(ScenarioFile)


def unit_kinds() -> dict[str, str]:
    """The scenario keys that hold a quantity of a kind of the table of plausible values
    (:data:`linsense.plausible.KINDS`), each with its kind: the fields whose ``json_schema_extra``
    names one (``{"inverter.dead_time": "dead_time", "controller.model.L_d": "inductance", ...}``).

    Returns
    -------
    dict
        Dotted key to kind, in the file's order of sections.
    """
    out = {}
    for path, model in _SECTIONS.values():
        for name, field in model.model_fields.items():
            extra = field.json_schema_extra if isinstance(field.json_schema_extra, dict) else {}
            if "kind" in extra:
                out[f"{path}.{name}"] = extra["kind"]
    return out


#: pydantic's errors of a value beyond its field's bounds
_RANGE_ERRORS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")


def _slip_of(key: str, data: dict) -> str:
    """The slip of unit that makes the value ``data`` gives at ``key`` one its field accepts
    (``injection.quadrature = 90``: "did you type %? (90 % is 0.9)"), or ``""``."""
    kind = unit_kinds().get(key)
    value = data
    for part in key.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    if kind is None or isinstance(value, bool) or not isinstance(value, int | float):
        return ""
    path, _, name = key.rpartition(".")
    model = next(m for p, m in _SECTIONS.values() if p == path)
    field = model.model_fields[name]
    ann = Annotated[field.annotation, *field.metadata] if field.metadata else field.annotation
    adapter = TypeAdapter(ann)

    def accepted(v: float) -> bool:
        try:
            adapter.validate_python(v, strict=True)
        except ValidationError:
            return False
        return True

    return slip(kind, float(value), ok=accepted)


def _has_path(data: dict, dotted: str) -> bool:
    """Whether ``data`` has the (dotted) section ``dotted``."""
    for part in dotted.split("."):
        if not isinstance(data, dict) or part not in data:
            return False
        data = data[part]
    return True


#: the values a TOML file can hold (a date, a time and a date-time among them)
_TOML_SCALARS = (str, bool, int, float, datetime.date, datetime.time)


def toml_values(data, source: str, key: str = ""):
    """``data`` (a dict of sections from Python) with only the values a TOML file can hold, so that
    a dict is validated as the same file would be: a numpy scalar of a real or boolean
    dtype becomes the Python float, int or bool it stands for (``np.True_`` is a boolean, refused
    where a number belongs as ``true`` is in a file); ``None`` (TOML has no null: it set an optional
    key to None, a TypeError in the build) and any other object (a tuple, bytes, a set, a complex
    number, an array) end in :class:`InputError` naming the dotted key.

    Parameters
    ----------
    data : object
        The value at ``key`` (the whole scenario at first).
    source : str
        Named in the message (``"<dict>"``).
    key : str
        Dotted key of ``data``.

    Returns
    -------
    object
        A copy of ``data`` with every value a TOML value.
    """
    if isinstance(data, dict):
        out = {}
        for k, v in data.items():
            if not isinstance(k, str):
                raise InputError(source, key, f"a key is a string, got {k!r} ({type(k).__name__})")
            out[k] = toml_values(v, source, f"{key}.{k}" if key else k)
        return out
    if isinstance(data, list):
        return [toml_values(v, source, f"{key}[{i}]") for i, v in enumerate(data)]
    if isinstance(data, np.generic) and data.dtype.kind in "biuf":
        return data.item()  # (np.float64 also is a float: a plain float either way)
    if isinstance(data, _TOML_SCALARS):
        return data
    if data is None:
        hint = "" if key.endswith("]") else ": leave the key out for its default"
        raise InputError(source, key, f"None is not a value of a scenario (TOML has no null){hint}")
    shown = " ".join(repr(data).split())
    raise InputError(source, key, f"expected a TOML value (a string, number, boolean, date, list or table), "
                     f"got {type(data).__name__} {shown}")


def scenario_from_dict(data: dict, source: str = "<dict>", base_dir: str | Path | None = None) -> Scenario:
    """Validate parsed scenario data.

    ``data`` from Python is held to what a TOML file can hold (:func:`toml_values`). A missing
    required key is named with its full dotted path, also when its whole section is missing
    (``reference.position_mm``: a scenario without ``[reference]`` steps to it by default).

    Parameters
    ----------
    data : dict
        Section name to keys, as parsed from TOML.
    source : str, optional
        Named in messages.
    base_dir : str or Path or None, optional
        Folder a relative motor path is resolved against (None: the working folder).

    Returns
    -------
    Scenario
        The validated scenario.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, the dotted key and the value.
    """
    if not isinstance(data, dict):
        raise InputError(source, "", f"a scenario is a table of sections, got {type(data).__name__}")
    data = toml_values(data, source)
    try:
        spec = ScenarioFile.model_validate(data)
    except ValidationError as exc:
        # a section the data leaves out is built from its defaults, which its own rule can refuse
        # (pydantic then raises the section's error, located in the section)
        section, root = _SECTIONS.get(exc.title, ("", ScenarioFile))
        err = to_input_error(exc, source, root)
        # drop the union-branch names pydantic puts into the location ("current_gain.float")
        key = ".".join(p for p in err.key.split(".") if not _BRANCH.match(p))
        key = f"{section}.{key}" if section and key else section or key
        message = err.message
        # a whole section missing ("scenario"): named by its first required key
        missing = next((v for v in _SECTIONS.values() if v[0] == key), None)
        if missing is not None and message == "missing required key":
            section = key
            key += "." + next(k for k, f in missing[1].model_fields.items() if f.is_required())
        if section and not _has_path(data, section):
            message = f"{message} (the file has no [{section}] section)"
        # (a value out of its field's range: the slip of unit that brings it in, e.g. a kappa of 90)
        errors = exc.errors(include_url=False)
        first = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
        hint = _slip_of(key, data) if first["type"] in _RANGE_ERRORS else ""
        raise InputError(source, key, message + (f"; {hint}" if hint else "")) from None
    return Scenario(spec, source, Path(base_dir) if base_dir is not None else working_folder())


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    Parameters
    ----------
    path : str or Path
        The file; a relative motor path in it is resolved against its folder.

    Returns
    -------
    Scenario
        The validated scenario.

    Raises
    ------
    linsense.errors.InputError
        An unreadable file, bad TOML or an invalid key, naming the file and the key; ``path`` not a
        path (``load_scenario(None)`` was a TypeError).
    """
    path = path_arg(path, "linsense.sim.load_scenario", "path", "a scenario file")
    return scenario_from_dict(read_toml(path, "scenario file"), str(path), folder_of(path))


def as_scenario(obj, caller: str = "simulate") -> Scenario:
    """A :class:`Scenario` from a Scenario, a path (str or Path) or a dict.

    Parameters
    ----------
    obj : Scenario, str, Path or dict
        The scenario.
    caller : str
        The API function named when ``obj`` is none of these.

    Returns
    -------
    Scenario
        The scenario.

    Raises
    ------
    InputError
        ``obj`` is none of these (naming ``caller`` and the argument ``scenario``), or the scenario
        it gives is invalid.
    """
    if isinstance(obj, Scenario):
        return obj
    if isinstance(obj, dict):
        return scenario_from_dict(obj)
    if isinstance(obj, str | Path):
        from linsense import examples

        return load_scenario(examples.named("scenarios", obj))  # (a packaged example's name: its file)
    shown = " ".join(repr(obj).split())
    raise InputError(caller, "scenario", f"expected a Scenario, a path of a TOML file or a dict of sections, "
                     f"got {type(obj).__name__} {shown}")

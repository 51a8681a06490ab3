"""The keys of a scenario file (TOML) of the closed-loop simulator: one pydantic model per section.

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
an electrical angle as the distance it is on the reference motor and that motor's pole pitch,
``{linsense.tune.design.NAME}`` for a constant of the design, which lives above this package: the
docs read it from its one home) and ``doc_after`` (the docs list the field after the one it
names). None of them affects validation.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from linsense.ctrl import (
    CAL_SLOPE_MAX,
    STARTUP_PAIRS_MAX,
    STARTUP_PULSE_STEPS_MIN,
    STARTUP_REST_STEPS_MIN,
    V_INJ_SHARE_MAX,
    drive_default_cfg,
    observer_gains,
)
from linsense.plausible import implausible
from linsense.scenario.bounds import F_INJ_PWM_DIV, V_DC_MAX_FRACTION, V_DC_MIN_FRACTION
from linsense.validation import KeyProblem

_STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

#: the firmware's defaults (ls_drive_default_cfg), the one source of the drive defaults below
_C = drive_default_cfg()


def _c(value) -> float:
    """A C default as a Python float, rounded to the 7 digits a float holds (0.01, not 0.009999999776)."""
    return float(f"{float(value):.7g}")


def _ratio(x: float) -> str:
    """A bound's fraction of the bus as the docs write it (5/9), read from its home."""
    return str(Fraction(x).limit_denominator(16))


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
    slope: float = Field(
        _c(_C.cal.slope), gt=0.0, le=CAL_SLOPE_MAX, description="`commission` only: the demodulated "
        "ratio's change per rad of the table's error, -d ratio / d psi (1 for the pulsating injection, "
        "0.2-0.5 for the elliptical one at kappa 0.9)",
        json_schema_extra={"unit": "-", "default_note": "`linsense commission` designs it "
                           "(`linsense.studies.commission.ratio_slope`)"})


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
    t_pulse: Positive = Field(_c(_C.startup.t_pulse), description="pulse length (at least "
                              f"{STARTUP_PULSE_STEPS_MIN} PWM periods, at most 60)",
                              json_schema_extra={"unit": "s"})
    t_rest: Positive = Field(_c(_C.startup.t_rest), description="zero voltage before each pulse (at least "
                             f"{STARTUP_REST_STEPS_MIN} PWM periods, at most 60)",
                             json_schema_extra={"unit": "s"})
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
    # (the design's default drive, whose bus the firmware's under-voltage trip follows: the C library
    # has no bus)
    v_dc: Positive = Field(_c(_C.prot.v_dc_min / V_DC_MIN_FRACTION), description="DC bus",
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
    mode: Literal["sensorless_lut", "sensorless_nolut", "sensored", "calibration", "startup",
                  "commission"] = Field(
        "sensorless_lut", description="`sensorless_lut`, `sensorless_nolut`, `sensored`, `calibration` (the "
        "firmware's LUT calibration; `linsense calibrate` runs it), `startup` (start-up from an unknown "
        "position with the magnet polarity, then `sensorless_lut`; `[startup]` below), `commission` (the "
        "table learned without a sensor at speed against the EMF estimate, `observer.emf = true`; "
        "`[calibration]`'s `points`, `k_int` and `t_hold`; `linsense commission` runs it)")
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
    frequency: Positive = Field(_c(_C.inject.freq), description=f"<= f_pwm / {F_INJ_PWM_DIV:g}",
                                json_schema_extra={"kind": "injection_frequency",
                                                   "unit": "Hz",
                                                   "default_note": "designed (f_pwm / "
                                                   "{linsense.tune.design.RATIO_PWM_INJ})"})
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
    # A, d-current reference while injecting (default: the design's, 0 except for the square wave and
    # the rotating vector, whose HF current the dead time would bias at zero current; docs/tuning.md)
    d_current: float | None = Field(
        None, description="d-current reference while injecting (keeps the phase currents off zero, where the "
        "dead time acts on the square wave's and the rotating vector's HF current; the drive's force "
        "constant follows it); `|d_current| < i_max`",
        json_schema_extra={"unit": "A",
                           "default_note": "0; `square`, `rotating`: "
                                           "{linsense.tune.injection.INJECTION_D_FRACTION} "
                                           "`controller.i_max`"})
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
                           "default_note": "designed: `mech` `f_lpf / "
                           "{linsense.tune.design.RATIO_LPF_MECH}`, "
                           "`pll` "
                           "`f_lpf / {linsense.tune.design.RATIO_LPF_OBS}` "
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
        json_schema_extra={"unit": "N", "default_note": "designed: the force at `i_max`, `K_f i_max` less "
                           "the rotating or square injection's d-current's share ({ecce2010} for ecce2010)"})
    # the EMF estimate beside the HF one, handed over on the speed (ls_drive_cfg.emf_on, emf, fuse)
    emf: bool = Field(
        bool(_C.emf_on), description="the EMF estimate beside the HF one: the observer's error moves from "
        "the HF error to the EMF error across the hand-over band and the injection fades out above it "
        "(docs/theory.md, \"The hand-over\"); pulsating and elliptical injections only",
        json_schema_extra={"unit": "bool", "default_note": "designed: on when the speed cap reaches "
                           "`handover_v_lo`"})
    emf_lpf_hz: Positive = Field(
        _c(_C.emf.f_lpf), description="the EMF's low-pass in the estimated frame",
        json_schema_extra={"kind": "bandwidth", "unit": "Hz",
                           "default_note": "designed: `demod_lpf_hz`, at most "
                           "{linsense.ctrl.EMF_FLPF_FS_MAX} `f_pwm`"})
    handover_v_lo: Positive = Field(
        _c(_C.fuse.v_lo), description="the speed up to which the HF error alone drives the observer",
        json_schema_extra={"kind": "speed", "unit": "m/s", "default_note": "designed: `handover_v_hi` / "
                           "{linsense.tune.handover.BAND_RATIO}"})
    handover_v_hi: Positive = Field(
        _c(_C.fuse.v_hi), description="the speed from which the EMF error alone does (> `handover_v_lo`; "
        "refused below the speed where the EMF's error bound is within `linsense.tune.handover.EPS_TRUST`: "
        "the estimate ran away there)",
        json_schema_extra={"kind": "speed", "unit": "m/s", "default_note": "designed: where the EMF's error "
                           "bound is within {linsense.tune.handover.EPS_HAND_DEG} deg"})
    inject_v_on: Positive = Field(
        _c(_C.fuse.v_on), description="the injection fades back in below this speed (>= `handover_v_hi`)",
        json_schema_extra={"kind": "speed", "unit": "m/s", "default_note": "designed: `handover_v_hi` + "
                           "`a_max` (ramp + settling)"})
    inject_v_off: Positive = Field(
        _c(_C.fuse.v_off), description="the injection fades out above this speed (> `inject_v_on`)",
        json_schema_extra={"kind": "speed", "unit": "m/s", "default_note": "designed: "
                           "{linsense.tune.handover.HYSTERESIS} `inject_v_on`"})
    handover_settle_s: float = Field(
        _c(_C.fuse.t_settle), ge=0.0, lt=1.0, description="after a fade, the time at full injection "
        "amplitude before the HF error counts again (the demodulator's filters refilled)",
        json_schema_extra={"kind": "time", "unit": "s", "default_note": "designed: "
                           "{linsense.tune.handover.SETTLE_TAUS} / (2 pi `demod_lpf_hz`)"})


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
                           "default_note": "designed ({linsense.tune.design.SPEED_CAP_MARGIN} times the "
                           "application's, "
                           "`reference.v_max`: {ecce2010} for ecce2010)"})
    # m/s^2, a step command's acceleration (a minimum-time move at v_max); 0: the reference jumps
    step_a_max: float = Field(
        default=_c(_C.traj.a_step), ge=0.0, le=1.0e4,
        description="a step command runs as a minimum-time move at `v_max` and this acceleration "
        "(docs/tuning.md, \"Steps\"); 0: the reference jumps (the paper's step)",
        json_schema_extra={"unit": "m/s^2", "default_note": "designed "
                           "(`min(v_cap w_v / 3, 0.5 F_max / m)`, F_max the force at `i_max`: "
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
    rated_load: Positive | None = Field(
        None, description="the application's rated load the design takes: its speed limit on "
        "`reference.v_max` (the current the load and `m a_max` need) and its force check (`linsense tune "
        "--load` writes it)", json_schema_extra={"kind": "force", "unit": "N",
                                                 "default_note": "half the force at `i_max` (less the "
                                                 "rotating or square injection's d-current's share)"})
    decouple: bool = Field(True, description="dq decoupling and back-EMF feed-forward")
    i_max: Positive = Field(_c(_C.i_max),
                            description="current-reference limit; force limit = K_f i_max, less the "
                                        "rotating or square injection's d-current's share (docs/tuning.md, "
                                        "\"The force at `i_max`\")",
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

    @property
    def bounded(self) -> bool:
        """Whether the file gives a bound (``min_mm`` or ``max_mm``), not the simulator's defaults."""
        return bool({"min_mm", "max_mm"} & self.model_fields_set)


class ProtectionSection(BaseModel):
    """The ``[protection]`` section of a scenario file; its keys are in docs/simulator.md."""
    model_config = _STRICT
    i_max: Positive = Field(_c(_C.prot.i_max), description="phase over-current trip", json_schema_extra={
        "kind": "current", "unit": "A", "default_note": "designed ({ecce2010} for ecce2010)"})
    v_dc_min: NonNegative = Field(_c(_C.prot.v_dc_min), description="under-voltage trip", json_schema_extra={
        "unit": "V", "default_note": f"{_ratio(V_DC_MIN_FRACTION)} `v_dc` ({{ecce2010}} at the default bus)"})
    v_dc_max: Positive = Field(_c(_C.prot.v_dc_max), description="over-voltage trip", json_schema_extra={
        "unit": "V", "default_note": f"{_ratio(V_DC_MAX_FRACTION)} `v_dc` ({{ecce2010}} at the default bus)"})
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


class ScenarioSchema(BaseModel):
    """The keys of a whole scenario file: the motor and one model per section (docs/simulator.md);
    :class:`linsense.scenario.load.ScenarioFile` adds the rules between them.

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

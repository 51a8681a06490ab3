"""The scenario -> ``ls_drive_cfg`` mapping, written once.

Each :class:`Row` names one field of the firmware's ``ls_drive_cfg`` (its struct path), the
scenario keys that set it (in order of precedence: a refusal names the first the file gives), the
field's unit and the rule from the keys' values to the field's (a plain copy, a unit conversion, or
a computed value). The table is read by:

- the simulator (:func:`linsense.sim.drive_cfg.fill`): every row with ``sim`` set, in table order,
  over ``ls_drive_default_cfg``;
- ``linsense tune --format c`` (:func:`linsense.tune.export.c_header`): every row with ``c`` set,
  in table order (the order of the lines of the header);
- the refusal search (:mod:`linsense.sim.refusal`): the rows with ``blame`` set, which a refused
  configuration is searched in;
- the docs' table of keys (docs/firmware.md, written by ``tools/gen_docs.py``).

Rules read their inputs from a :class:`Values`: the scenario's keys (dotted, in the scenario's
units; ``controller.model.*`` hold what the controller believes: the override or the motor model's
value) and a few derived values the simulator and the tune exporter each supply (``motor.pole_pitch``,
``model.end_anisotropy``, ...). Of the C library it reads only the EMF block's count of harmonic slots
(``EMF_ARRAYS``); enums are written as their C names.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from linsense.analysis.emf import ERR_L as HANDOVER_ERR_L
from linsense.analysis.emf import ERR_R as HANDOVER_ERR_R
from linsense.analysis.emf import I_NOISE as HANDOVER_I_NOISE
from linsense.analysis.emf import inverter_voltage_error
from linsense.ctrl import EMF_ARRAYS
from linsense.tune.design import current_gains, speed_gains, startup_lock_gain
from linsense.tune.handover import DT_RESIDUAL_DTC
from linsense.tune.injection import (
    SQUARE_DTC_BAND,
    SQUARE_DTC_LEAD,
    SQUARE_SEP_FRACTION,
    d_current_force_share,
    deliverable_force,
    injection_d_current,
    square_current_schedule,
)

#: unit conversions from a key's unit to its field's: name -> (function, factor for messages)
CONVERSIONS: dict[str, tuple[Callable[[float], float], float]] = {
    "deg": (math.radians, math.pi / 180.0),
}


@dataclass(frozen=True)
class Row:
    """One field of ``ls_drive_cfg`` and where its value comes from.

    Attributes
    ----------
    field : str
        The struct path in ``ls_drive_cfg`` (``"pos.speed.kp"``).
    keys : tuple of str
        The scenario keys that set it, in order of precedence.
    unit : str
        The field's unit.
    rule : callable or None
        ``rule(values)``: the field's value; None: the first key's value (converted by ``conv``).
    conv : str or None
        A conversion of :data:`CONVERSIONS` applied to the first key's value (``rule`` None).
    scale : float or None
        The factor from the first key's unit to the field's (refusal messages show the limit in the
        key's unit); None where the field is computed from the keys.
    kind : str
        ``real``, ``count`` (an unsigned integer), ``bool``, ``enum`` (the value is a C name), ``fs``
        (a module's sampling rate: ``inverter.f_pwm``) or ``gains`` (``ls_observer_gains`` unless the
        file gives the gain).
    sim : bool
        Whether the simulator sets it.
    c : bool or str
        Whether ``tune --format c`` writes it (``"startup"``: when the design has a start-up).
    when : callable or None
        ``when(values)``: the simulator sets the field only then (else it keeps the default).
    blame : bool
        Whether a refusal of ``ls_drive_init`` is searched for in this field.
    doc : str
        The rule in words, for the docs' table (plain copies need none).
    """

    field: str
    keys: tuple[str, ...]
    unit: str
    rule: Callable[[Values], object] | None = None
    conv: str | None = None
    scale: float | None = 1.0
    kind: str = "real"
    sim: bool = True
    c: bool | str = True
    when: Callable[[Values], bool] | None = None
    blame: bool = True
    doc: str = ""

    def value(self, v: Values):
        """The field's value in the context ``v``.

        Parameters
        ----------
        v : Values
            The scenario keys and derived values.

        Returns
        -------
        object
            The value, in the field's unit.
        """
        if self.rule is not None:
            return self.rule(v)
        if self.conv is None:
            return v[self.keys[0]]
        return CONVERSIONS[self.conv][0](v[self.keys[0]])


class Values:
    """The inputs of the rules: scenario keys and derived values, each evaluated once.

    Parameters
    ----------
    get : callable
        ``get(key)``: the value of a dotted scenario key.
    derived : dict
        Values that shadow ``get``: a constant, or ``fn(values)`` evaluated on first use.
    fields : dict, optional
        Field values given directly, in the field's unit (a design that computes one in SI).
    given : callable, optional
        ``given(key)``: whether the scenario sets the dotted key itself (else designed or default).
    """

    def __init__(self, get: Callable[[str], object], derived: dict | None = None, fields: dict | None = None,
                 given: Callable[[str], bool] | None = None):
        self._get = get
        derived = derived or {}
        self._lazy = {k: d for k, d in derived.items() if callable(d)}
        self._cache: dict = {k: d for k, d in derived.items() if not callable(d)}
        self._fields = dict(fields or {})
        self._given = given

    def __getitem__(self, key: str):
        cache = self._cache
        if key in cache:
            return cache[key]
        fn = self._lazy.get(key)
        value = cache[key] = fn(self) if fn is not None else self._get(key)
        return value

    def field(self, path: str):
        """The value of the field ``path`` in this context (computed once).

        Parameters
        ----------
        path : str
            The struct path in ``ls_drive_cfg``.

        Returns
        -------
        object
            The value, in the field's unit.
        """
        fields = self._fields
        if path in fields:
            return fields[path]
        value = fields[path] = ROW[path].value(self)
        return value

    def given(self, key: str) -> bool:
        """Whether the scenario sets the dotted key itself (else designed or default).

        Parameters
        ----------
        key : str
            The dotted scenario key.

        Returns
        -------
        bool
            False when no ``given`` was passed.
        """
        return self._given is not None and self._given(key)


def real(x: float) -> float:
    """``x`` as an ``LS_REAL`` field holds it (single precision), read back.

    Parameters
    ----------
    x : float
        The value.

    Returns
    -------
    float
        ``x`` rounded to single precision.
    """
    return float(np.float32(x))


# ------------------------------------------------------------------ the rules
def _square(v: Values) -> bool:
    return v["injection.shape"] == "square"


def _rotating(v: Values) -> bool:
    return v["injection.shape"] == "rotating"


def _calibrating(v: Values) -> bool:
    return v["control.mode"] in ("calibration", "commission")


def _measures(v: Values) -> bool:
    return _square(v) and bool(v["injection.dead_time_measures"])


def _f_inj(v: Values) -> float:
    return v["inverter.f_pwm"] / 2.0 if _square(v) else v["injection.frequency"]


def _i_d_inj(v: Values) -> float:
    # (the square wave's and the rotating vector's d-current keeps the phase currents off zero)
    d = v["injection.d_current"]
    return d if d is not None else injection_d_current(v["controller.i_max"], v["injection.shape"])


def _f_notch(v: Values) -> float:
    # the low-pass's zeros at 2 f_inj, where that is below fs / 2 (f_inj < f_pwm / 4); the square
    # wave's low-pass keeps its zeros at fs / 2, where the products' ripple is
    if _square(v):
        return 0.0
    f = v["injection.frequency"]
    return 2.0 * f if v["observer.demod_notch"] and 4.0 * f < v["inverter.f_pwm"] else 0.0


def _demod_method(v: Values) -> str:
    if _rotating(v):
        return "LS_DEMOD_ROTATING"
    return "LS_DEMOD_PRODUCT" if v["observer.demod_method"] == "product" else "LS_DEMOD_HETERODYNE"


def _min_level(v: Values) -> float:
    if _rotating(v) and not v.given("observer.min_level"):
        return v["model.rotating"]["min_level"]
    return v["observer.min_level"]


def _l_avg(v: Values) -> float:
    return 0.5 * (v["controller.model.L_d"] + v["controller.model.L_q"])


def square_schedule(v: Values) -> dict | None:
    """The square wave's d-current schedule (docs/theory.md, "The dead time and the square wave").

    Parameters
    ----------
    v : Values
        The scenario keys and derived values.

    Returns
    -------
    dict or None
        :func:`linsense.tune.injection.square_current_schedule`'s result.
    """
    return square_current_schedule(_l_avg(v), v["controller.model.R_s"], v["injection.amplitude"],
                                   v["inverter.f_pwm"], real(v.field("i_d_inj")))


def _scheduled(v: Values) -> bool:
    return _measures(v) and v["model.square_schedule"] is not None


def _load_ff(v: Values) -> bool:
    ff = v["observer.load_feedforward"]
    return v["observer.type"] == "mech" if ff is None else ff


def _current_gain(i: int) -> Callable[[Values], float]:
    key = ("controller.current_kp", "controller.current_ki")[i]

    def rule(v: Values) -> float:
        g = v[key]
        if g is not None:
            return g
        return current_gains(v["controller.current_bandwidth_hz"], v["controller.model.L_d"],
                             v["controller.model.L_q"], v["controller.model.R_s"])[i]
    return rule


def _speed_gain(i: int) -> Callable[[Values], float]:
    key = ("controller.speed_kp", "controller.speed_ki")[i]

    def rule(v: Values) -> float:
        g = v[key]
        if g is not None:
            return g
        return speed_gains(v["controller.speed_bandwidth_hz"], v["controller.model.mass"])[i]
    return rule


#: what the force at i_max reads (pos.force_max and the speed PI's limits)
_FORCE_KEYS = ("controller.i_max", "controller.model.force_constant", "injection.shape",
               "injection.d_current", "controller.model.L_d", "controller.model.L_q",
               "controller.model.psi_pm", "injection.dead_time_measures", "injection.amplitude",
               "inverter.f_pwm", "controller.model.R_s")  # (the last four: the square wave's i_d_near)


def _i_d_near(v: Values) -> float:
    return v["model.square_schedule"]["i_d_near"] if _scheduled(v) else 0.0


def _force_max(v: Values) -> float:
    # (the d-currents' reluctance force: the least force constant of the modes, as ls_drive_init's)
    model = (v["controller.model.L_d"], v["controller.model.L_q"], v["controller.model.psi_pm"])
    share = min(d_current_force_share(*model, i_d) for i_d in (_i_d_inj(v), _i_d_near(v)))
    return deliverable_force(v["controller.model.force_constant"], v["controller.i_max"], share)


def _i_band(v: Values) -> float:
    if _measures(v) and not v.given("inverter.dtc_current_band"):
        return SQUARE_DTC_BAND
    return v["inverter.dtc_current_band"]


def _forward(v: Values) -> bool:
    return v["observer.dead_time_model"] == "forward"


def _end(i: int) -> Callable[[Values], float]:
    # (the interpolated model is the former one: its response without the end effect)
    return lambda v: v["model.end_anisotropy"][i] if _forward(v) else 0.0


def _harmonic(k: str, i: int, unit: str) -> Row:
    # the EMF block's slot i of the magnets' flux harmonics (linsense.analysis.emf.emf_pm_compensation)
    return Row(f"emf.{k}[{i}]", ("controller.model.motor",), unit, lambda v: v["model.emf_pm"][k][i],
               scale=None, kind="count" if k == "harm_order" else "real", blame=False,
               doc="the motor file's `[pm_flux]` harmonics (`emf_pm_compensation`)")


def _fs(field: str) -> Row:
    return Row(field, ("inverter.f_pwm",), "Hz", kind="fs", blame=field == "fs")


def _pitch(field: str) -> Row:
    return Row(field, ("motor",), "m", lambda v: v["motor.pole_pitch"], scale=None, blame=False,
               doc="the motor's pole pitch")


def _startup(field: str, key: str, unit: str, conv: str | None = None) -> Row:
    return Row(field, (key,), unit, conv=conv, scale=CONVERSIONS[conv][1] if conv else 1.0, c="startup")


def _cal(field: str, keys: tuple[str, ...], unit: str, conv: str | None = None, c: bool = False,
         kind: str = "real") -> Row:
    return Row(field, keys, unit, conv=conv, scale=CONVERSIONS[conv][1] if conv else 1.0, c=c, kind=kind,
               when=_calibrating)


_SQ = "with `injection.shape = \"square\"`"
_CM = ("controller.model.L_d", "controller.model.L_q", "controller.model.motor")

#: the table, in the order ``tune --format c`` writes its fields
ROWS: tuple[Row, ...] = (
    _fs("fs"),
    _pitch("pole_pitch"),
    Row("force_constant", ("controller.model.force_constant", "motor"), "N/A"),
    Row("i_max", ("controller.i_max",), "A"),
    Row("delay_comp", ("control.delay_comp",), "periods", c=False),
    Row("enc_counts", ("sensors.encoder_counts_per_period",), "counts", kind="count", c=False),
    Row("inject_sensored", ("control.inject_sensored",), "-", kind="bool", c=False, blame=False),
    Row("inject.shape", ("injection.shape",), "-", lambda v: "LS_INJ_" + v["injection.shape"].upper(),
        scale=None, kind="enum", c=False, blame=False, doc="`LS_INJ_PULSATING`, `_ROTATING`, `_SQUARE`"),
    Row("i_d_inj", ("injection.d_current", "controller.i_max"), "A", _i_d_inj, scale=None, c=False,
        doc="`d_current`; not given: `injection_d_current(i_max, shape)`: 0.4 `i_max` with "
        "`injection.shape = \"square\"` or `\"rotating\"`, else 0"),
    Row("inject.amplitude", ("injection.amplitude",), "V"),
    Row("inject.freq", ("injection.frequency", "inverter.f_pwm"), "Hz", _f_inj,
        doc="`frequency`; f_pwm / 2 " + _SQ),
    _fs("inject.fs"),
    Row("inject.quad", ("injection.quadrature",), "-"),
    Row("inject.ramp_rate", ("injection.ramp_rate",), "V/s"),
    Row("bpf.type", ("injection.shape",), "-", lambda v: "LS_BIQUAD_DIFF", scale=None, kind="enum", c=False,
        when=_square, blame=False, doc="the difference over one period " + _SQ),
    Row("bpf.f0", ("injection.frequency", "inverter.f_pwm"), "Hz"),
    Row("bpf.q", ("injection.filter_q",), "-", c=False),
    _fs("bpf.fs"),
    Row("sep.type", ("injection.shape",), "-", lambda v: "LS_BIQUAD_LOWPASS", scale=None, kind="enum",
        c=False, when=_square, blame=False, doc="a low-pass " + _SQ),
    Row("sep.f0", ("injection.frequency", "inverter.f_pwm"), "Hz",
        lambda v: SQUARE_SEP_FRACTION * v["inverter.f_pwm"] if _square(v) else v["injection.frequency"],
        doc=f"`frequency`; {SQUARE_SEP_FRACTION:g} f_pwm " + _SQ),
    Row("sep.q", ("injection.filter_q",), "-",
        lambda v: 0.5 ** 0.5 if _square(v) else v["injection.filter_q"], c=False,
        doc="`filter_q`; 1/sqrt(2) " + _SQ),
    _fs("sep.fs"),
    Row("demod.method", ("observer.demod_method", "injection.shape"), "-", _demod_method, scale=None,
        kind="enum", c=False, blame=False,
        doc="`demod_method`; the rotating demodulator with the rotating shape"),
    Row("demod.f_lpf", ("observer.demod_lpf_hz",), "Hz"),
    Row("demod.f_notch", ("injection.frequency", "observer.demod_notch"), "Hz", _f_notch, scale=None,
        doc="2 `frequency` with `demod_notch` where 4 `frequency` < f_pwm, else 0 (0 " + _SQ + ")"),
    _fs("demod.fs"),
    Row("demod.gain", ("controller.model.demod_gain", "controller.model.L_q", "controller.model.L_d",
                       "controller.model.motor"), "-",
        lambda v: 1.0 if _rotating(v) else v["controller.model.demod_gain"], scale=None,
        doc="`demod_gain`, else L_q / (L_q - L_d); 1 with the rotating shape"),
    Row("demod.min_level", ("observer.min_level",), "A^2", _min_level, c=False,
        doc="`min_level`; not given with the rotating shape: the rotating design's"),
    Row("demod.ref_phase", ("injection.shape",), "rad", lambda v: v["model.rotating"]["ref_phase"],
        scale=None, c=False, when=_rotating, blame=False, doc="the rotating design's (rotating shape only)"),
    Row("mod.dtc_lead", ("injection.shape",), "periods", lambda v: SQUARE_DTC_LEAD, scale=None, c=False,
        when=_square, blame=False, doc=f"{SQUARE_DTC_LEAD:g} " + _SQ),
    Row("mod.l_ripple", _CM, "H", _l_avg, scale=None, c=False, when=_measures,
        doc="(L_d + L_q) / 2 " + _SQ + " and `dead_time_measures`"),
    Row("i_d_near", ("injection.dead_time_measures",), "A", lambda v: v["model.square_schedule"]["i_d_near"],
        scale=None, c=False, when=_scheduled, blame=False, doc="the square wave's d-current schedule"),
    Row("near_in", ("injection.dead_time_measures",), "rad", lambda v: v["model.square_schedule"]["near_in"],
        scale=None, c=False, when=_scheduled, blame=False, doc="the square wave's d-current schedule"),
    Row("near_out", ("injection.dead_time_measures",), "rad",
        lambda v: v["model.square_schedule"]["near_out"],
        scale=None, c=False, when=_scheduled, blame=False, doc="the square wave's d-current schedule"),
    Row("obs.type", ("observer.type",), "-",
        lambda v: "LS_OBS_PLL" if v["observer.type"] == "pll" else "LS_OBS_MECH", scale=None, kind="enum",
        c=False, blame=False, doc="`LS_OBS_PLL`, `LS_OBS_MECH` (`tune -c` writes it after the fields)"),
    Row("load_ff", ("observer.load_feedforward", "observer.type"), "-", _load_ff, scale=None, kind="bool",
        c=False, blame=False,
        doc="`load_feedforward`; not given: on with the mech observer (`tune -c`: after the fields)"),
    _fs("obs.fs"),
    _pitch("obs.pole_pitch"),
    Row("obs.mass", ("controller.model.mass", "motor"), "kg"),
    Row("obs.force_max", ("observer.force_max",), "N"),
    Row("obs.k1", ("observer.k1", "observer.bandwidth_hz"), "1/s", scale=None, kind="gains", c=False,
        doc="`k1`; not given: `ls_observer_gains(bandwidth_hz)`"),
    Row("obs.k2", ("observer.k2", "observer.bandwidth_hz"), "1/s^2", scale=None, kind="gains", c=False,
        doc="`k2`; not given: `ls_observer_gains(bandwidth_hz)`"),
    Row("obs.k3", ("observer.k3", "observer.bandwidth_hz"), "1/s^3", scale=None, kind="gains", c=False,
        doc="`k3`; not given: `ls_observer_gains(bandwidth_hz)`"),
    _fs("enc_obs.fs"),
    _pitch("enc_obs.pole_pitch"),
    Row("enc_obs.mass", ("controller.model.mass", "motor"), "kg", sim=False, blame=False,
        doc="the key (the simulator keeps the default)"),
    Row("current.kp", ("controller.current_kp", "controller.current_bandwidth_hz", "controller.model.L_d",
                       "controller.model.L_q"), "V/A", _current_gain(0), scale=None,
        doc="`current_kp`; not given: `current_gains(current_bandwidth_hz, L_d, L_q, R_s)`"),
    Row("current.ki", ("controller.current_ki", "controller.model.R_s", "controller.current_bandwidth_hz"),
        "V/(A s)", _current_gain(1), scale=None,
        doc="`current_ki`; not given: `current_gains(current_bandwidth_hz, L_d, L_q, R_s)`"),
    Row("current.l_d", ("controller.model.L_d", "controller.model.motor"), "H"),
    Row("current.l_q", ("controller.model.L_q", "controller.model.motor"), "H"),
    Row("current.psi_pm", ("controller.model.psi_pm", "controller.model.motor"), "Wb"),
    Row("current.decouple", ("controller.decouple",), "-", kind="bool", c=False, blame=False),
    _fs("current.fs"),
    Row("pos.type", ("controller.position_type",), "-",
        lambda v: "LS_POSCTRL_P" if v["controller.position_type"] == "p" else "LS_POSCTRL_PD", scale=None,
        kind="enum", c=False, blame=False, doc="`LS_POSCTRL_P`, `LS_POSCTRL_PD`"),
    Row("pos.kp_x", ("controller.kp_x",), "1/s"),
    Row("pos.kd_x", ("controller.kd_x",), "N s/m", c=False),
    Row("pos.v_max", ("controller.v_max",), "m/s"),
    Row("obs.omega_max", ("observer.omega_max",), "rad/s"),
    Row("enc_obs.omega_max", ("observer.omega_max",), "rad/s", sim=False, blame=False,
        doc="the key (the simulator keeps the default)"),
    Row("prot.omega_max", ("protection.omega_max",), "rad/s"),
    Row("prot.i_max", ("protection.i_max",), "A"),
    Row("traj.v_max", ("reference.v_max",), "m/s"),
    Row("traj.v_step", ("controller.v_max",), "m/s"),
    Row("traj.a_step", ("controller.step_a_max",), "m/s^2"),
    Row("traj.a_lpf", ("observer.demod_lpf_hz",), "Hz",
        lambda v: min(v["observer.demod_lpf_hz"], v["inverter.f_pwm"]), scale=None,
        doc="min(`demod_lpf_hz`, f_pwm): the force feed-forward as fast as the demodulator sees"),
    Row("startup.lock_gain", ("observer.bandwidth_hz", "observer.demod_lpf_hz"), "-",
        lambda v: startup_lock_gain(v["observer.type"], v["observer.bandwidth_hz"],
                                    v["observer.demod_lpf_hz"]),
        scale=None, doc="`startup_lock_gain(type, bandwidth_hz, demod_lpf_hz)`"),
    Row("traj.a_max", ("reference.a_max",), "m/s^2"),
    Row("pos.mass", ("controller.model.mass", "motor"), "kg"),
    Row("pos.force_max", _FORCE_KEYS, "N", _force_max, scale=None,
        doc="K_f `i_max`, times min(1, 1 + (L_d - L_q) i_d / psi_pm) over the d-currents `i_d_inj`, "
            "`i_d_near` (their reluctance force)"),
    Row("pos.speed.kp", ("controller.speed_kp", "controller.speed_bandwidth_hz", "controller.model.mass"),
        "N s/m", _speed_gain(0), scale=None,
        doc="`speed_kp`; not given: `speed_gains(speed_bandwidth_hz, mass)`"),
    Row("pos.speed.ki", ("controller.speed_ki", "controller.speed_bandwidth_hz", "controller.model.mass"),
        "N/m", _speed_gain(1), scale=None,
        doc="`speed_ki`; not given: `speed_gains(speed_bandwidth_hz, mass)`"),
    Row("pos.speed.out_min", _FORCE_KEYS, "N",
        lambda v: -v.field("pos.force_max"), scale=None, doc="-`pos.force_max`"),
    Row("pos.speed.out_max", _FORCE_KEYS, "N",
        lambda v: v.field("pos.force_max"), scale=None, doc="`pos.force_max`"),
    _fs("pos.speed.fs"),
    Row("pos.fric_c", ("controller.friction_coulomb",), "N"),
    Row("pos.fric_v", ("controller.friction_viscous",), "N s/m"),
    Row("pos.fric_band", ("controller.friction_band",), "m/s"),
    Row("obs.fric_c", ("controller.friction_coulomb",), "N"),
    Row("obs.fric_v", ("controller.friction_viscous",), "N s/m"),
    Row("obs.fric_band", ("controller.friction_band",), "m/s"),
    Row("ripple_c", ("controller.ripple_cos",), "-"),
    Row("ripple_s", ("controller.ripple_sin",), "-"),
    _pitch("traj.pole_pitch"),
    _fs("traj.fs"),
    _fs("mod.f_pwm"),
    Row("mod.dead_time", ("inverter.dead_time",), "s"),
    Row("mod.dtc", ("inverter.dead_time_compensation",), "-", kind="bool", c=False, blame=False),
    Row("mod.i_band", ("inverter.dtc_current_band",), "A", _i_band, c=False,
        doc=f"`dtc_current_band`; not given: {SQUARE_DTC_BAND:g} " + _SQ + " and `dead_time_measures`"),
    Row("prot.v_dc_min", ("protection.v_dc_min", "inverter.v_dc"), "V", scale=None),
    Row("prot.v_dc_max", ("protection.v_dc_max", "inverter.v_dc"), "V", scale=None),
    Row("prot.err_max", ("protection.err_max",), "rad", c=False),
    Row("prot.err_time", ("protection.err_time",), "s", c=False),
    _fs("prot.fs"),
    _fs("dtres.fs"),
    Row("hf_dtres", ("observer.dead_time_residual",), "-", kind="bool", c=False, blame=False),
    Row("dtres.forward", ("observer.dead_time_model",), "-", _forward, scale=None, kind="bool", c=False,
        blame=False, doc="`dead_time_model = \"forward\"`"),
    Row("dtres.adapt", ("observer.dead_time_adapt",), "-", kind="bool", c=False, blame=False),
    Row("dtres.adapt_r", ("observer.resistance_adapt", "observer.dead_time_adapt"), "-",
        lambda v: v["observer.dead_time_adapt"] and v["observer.resistance_adapt"], scale=None, kind="bool",
        c=False, blame=False, doc="`dead_time_adapt` and `resistance_adapt`"),
    Row("dtres.r_s", ("controller.model.R_s", "controller.model.motor"), "ohm"),
    Row("dtres.l_d", ("controller.model.L_d", "controller.model.motor"), "H"),
    Row("dtres.l_q", ("controller.model.L_q", "controller.model.motor"), "H"),
    Row("hf_delay", ("observer.hf_delay_s",), "s"),
    Row("emf_on", ("observer.emf",), "-", kind="bool", c=False, blame=False,
        doc="the key (`tune -c` writes it after the fields)"),
    _fs("emf.fs"),
    Row("emf.r_s", ("controller.model.R_s", "controller.model.motor"), "ohm"),
    Row("emf.l_d", ("controller.model.L_d", "controller.model.motor"), "H"),
    Row("emf.l_q", ("controller.model.L_q", "controller.model.motor"), "H"),
    Row("emf.f_lpf", ("observer.emf_lpf_hz",), "Hz"),
    Row("emf.omega_max", ("observer.omega_max",), "rad/s"),
    Row("emf.err_r", ("observer.emf",), "-", lambda v: HANDOVER_ERR_R, scale=None, blame=False,
        doc="`linsense.analysis.emf.ERR_R`"),
    Row("emf.err_l", ("observer.emf",), "-", lambda v: HANDOVER_ERR_L, scale=None, blame=False,
        doc="`linsense.analysis.emf.ERR_L`"),
    Row("emf.u_err", ("inverter.v_dc", "inverter.f_pwm", "inverter.dead_time"), "V",
        lambda v: inverter_voltage_error(v["inverter.v_dc"], v["inverter.f_pwm"], v["inverter.dead_time"],
                                         DT_RESIDUAL_DTC), scale=None,
        doc="`inverter_voltage_error(v_dc, f_pwm, dead_time, DT_RESIDUAL_DTC)`"),
    Row("emf.i_noise", ("observer.emf",), "A", lambda v: HANDOVER_I_NOISE, scale=None, blame=False,
        doc="`linsense.analysis.emf.I_NOISE`"),
    *(Row(f"emf.{k}", ("controller.model.motor",), u, (lambda v, k=k: v["model.emf_pm"][k]), scale=None,
          blame=False, doc="the motor file's `[pm_flux]` (`emf_pm_compensation`)")
      for k, u in (("psi_pm", "Wb"), ("pm_shift", "rad"), ("neg_re", "-"), ("neg_im", "-"))),
    *(_harmonic(k, i, u) for i in range(EMF_ARRAYS["harm_order"]) for k, u in (("harm_re", "Wb"),
                                                                                ("harm_im", "Wb"))),
    _fs("fuse.fs"),
    _pitch("fuse.pole_pitch"),
    Row("fuse.v_lo", ("observer.handover_v_lo",), "m/s"),
    Row("fuse.v_hi", ("observer.handover_v_hi",), "m/s"),
    Row("fuse.v_on", ("observer.inject_v_on",), "m/s"),
    Row("fuse.v_off", ("observer.inject_v_off",), "m/s"),
    Row("fuse.t_settle", ("observer.handover_settle_s",), "s"),
    Row("dtres.l_ea", ("observer.dead_time_model", "controller.model.motor"), "H", _end(0), scale=None,
        blame=False, doc="the model's end anisotropy with the forward model, else 0"),
    Row("dtres.l_eb", ("observer.dead_time_model", "controller.model.motor"), "H", _end(1), scale=None,
        blame=False, doc="the model's end anisotropy with the forward model, else 0"),
    Row("cal.period", ("initial.position_mm",), "periods",
        lambda v: int(math.floor(v["initial.position_mm"] * 1e-3 / v["motor.pole_pitch"])), scale=None,
        kind="count", c=False, blame=False, doc="floor(`position_mm` / pole pitch)"),
    _cal("cal.points", ("calibration.points",), "-", kind="count"),
    _cal("cal.k_int", ("calibration.k_int",), "1/s"),
    _cal("cal.t_settle", ("calibration.t_settle", "controller.kp_x"), "s"),
    _cal("cal.t_hold", ("calibration.t_hold", "calibration.k_int"), "s"),
    _cal("cal.slope", ("calibration.slope",), "-"),
    _cal("cal.tol", ("calibration.tol_deg",), "rad", conv="deg"),
    _cal("cal.t_max", ("calibration.t_max", "calibration.t_hold", "calibration.k_int"), "s"),
    _cal("cal.dither_amp", ("calibration.dither_a",), "A", c=True),
    _cal("cal.dither_freq", ("calibration.dither_hz",), "Hz", c=True),
    _fs("startup.fs"),
    _startup("startup.t_lock", "startup.t_lock", "s"),
    _startup("startup.err_lock", "startup.err_lock_deg", "rad", conv="deg"),
    _startup("startup.t_quiet", "startup.t_quiet", "s"),
    _startup("startup.v_pulse", "startup.v_pulse", "V"),
    _startup("startup.t_pulse", "startup.t_pulse", "s"),
    _startup("startup.t_rest", "startup.t_rest", "s"),
    Row("startup.pairs", ("startup.pairs",), "-", kind="count", c="startup"),
    _startup("startup.i_min", "startup.i_min", "A"),
    _startup("startup.t_settle", "startup.t_settle", "s"),
    # (counts last: tune -c writes them after the reals)
    Row("ripple_order", ("controller.ripple_order",), "-", kind="count"),
    *(_harmonic("harm_order", i, "-") for i in range(EMF_ARRAYS["harm_order"])),
)

#: field -> its row
ROW: dict[str, Row] = {r.field: r for r in ROWS}

#: the fields that hold the sampling rate (``inverter.f_pwm``)
FS_FIELDS: tuple[str, ...] = tuple(r.field for r in ROWS if r.kind == "fs")


def header_rows(startup: bool) -> list[Row]:
    """The rows ``tune --format c`` writes, in the header's order.

    Parameters
    ----------
    startup : bool
        Include the start-up design's rows.

    Returns
    -------
    list of Row
        The rows.
    """
    return [r for r in ROWS if r.c is True or (r.c == "startup" and startup)]


def docs_table() -> str:
    """The docs' table of the fields and the scenario keys that set them (Markdown).

    Returns
    -------
    str
        The Markdown table.
    """
    out = ["| `ls_drive_cfg` field | scenario keys (the first given is named in a refusal) | unit | rule | "
           "simulate | tune -c |", "|---|---|---|---|---|---|"]
    for r in ROWS:
        keys = ", ".join(f"`{k}`" for k in r.keys)
        if r.kind == "fs":
            rule = "`inverter.f_pwm`"
        elif r.conv is not None:
            rule = f"{r.doc or 'the key'} ({r.conv} -> rad)"
        else:
            rule = r.doc or ("the key" if r.rule is None else "")
        if r.when is _calibrating:
            rule += " (in `control.mode = \"calibration\"`)"
        c = "yes" if r.c is True else "with a start-up" if r.c == "startup" else "-"
        out.append(f"| `{r.field}` | {keys} | {r.unit} | {rule} | {'yes' if r.sim else '-'} | {c} |")
    return "\n".join(out) + "\n"

"""Every public function with a hostile argument: the exported functions of linsense, its
analysis, compensation, model, examples, tune and the C binding, each argument in turn given None,
NaN, an infinity, a complex number, a boolean, a string, a dict, an empty or ragged array, a huge
int or an object, the others valid. The oracle: a value that is not of the argument's kind (a motor,
positions in rad, one real number, a count, a name of a known set, a path, a table) is refused with
one :class:`~linsense.errors.InputError` naming the argument; a value of its kind gives a finite
result or an error of the project's hierarchy. Never Python's own AttributeError, TypeError,
IndexError or KeyError, never a NaN, never an imaginary part dropped without a word.

Found before the fix (:data:`FOUND`, each now refused naming the argument): ``psi_lut(m, None)`` and
``equilibrium_error(m, None)`` NaN, a complex theta's imaginary part dropped, a string theta read as a
number, ``psi_lut("x", theta)`` an AttributeError, an empty table's ``interpolate`` an IndexError,
``examples.names("nope")`` a KeyError, ``ctrl.Drive("x")`` a TypeError, and the rest of the list.
"""

from __future__ import annotations

import math
import numbers
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from prop_strategies import attempt, prop_settings

from linsense.errors import ConfigError, InputError, LinsenseError

THETA = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)


def _motor():
    from linsense.model.motor import load_motor

    return load_motor("ecce2010")


# ------------------------------------------------------------------ kinds of argument and their oracle
def _real_scalar(v) -> bool:
    if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:
        return False


def _real_array(v, min_size: int = 0) -> bool:
    if v is None or isinstance(v, str | bytes | dict | set):
        return False
    try:
        a = np.asarray(v)
    except (TypeError, ValueError, OverflowError):
        return False
    return a.dtype.kind in "iuf" and a.size >= min_size and bool(np.all(np.isfinite(a.astype(float))))


def _is_motor(v) -> bool:
    """A Motor, or a name or path (resolved as load_motor resolves it: an unknown one is refused)."""
    from linsense.model.motor import Motor

    return isinstance(v, Motor) or (isinstance(v, str | os.PathLike) and bool(str(v).strip()))


#: kind -> whether a value is of that kind (else it must be refused naming the argument)
KINDS = {
    "motor": _is_motor,
    "model": lambda v: _is_motor(v) or type(v).__name__ == "InductanceModel",
    "positions": _real_array,
    "table": lambda v: _real_array(v, 1) and np.ndim(v) == 1,
    "real": _real_scalar,
    "real?": lambda v: v is None or _real_scalar(v),
    "number": lambda v: _real_scalar(v) or (isinstance(v, float) and not math.isfinite(v)),
    "count": lambda v: isinstance(v, numbers.Integral) and not isinstance(v, bool | np.bool_),
    "path": lambda v: isinstance(v, str | os.PathLike) and bool(str(v).strip()) and "\0" not in str(v),
    "str": lambda v: isinstance(v, str),
    "bool": lambda v: isinstance(v, bool),
    "lut": lambda v: type(v).__name__ == "Lut",
    "cfg": lambda v: v is None or type(v).__name__ == "_CDataBase" or "cdata" in repr(v),
    "drive": lambda v: v is None or type(v).__name__ == "DriveData",
}


def choice(*names: str):
    """A kind: one of ``names``."""
    return lambda v: isinstance(v, str) and v in names


# ------------------------------------------------------------------ the functions
def _hf(name):
    from linsense.analysis import hf

    return getattr(hf, name)


def _mod(module: str, name: str):
    import importlib

    return getattr(importlib.import_module(module), name)


def _lut():
    from linsense.compensation.lut import build_lut

    return build_lut(_motor(), 8)


def _lut_file() -> str:
    import tempfile

    from linsense.compensation.lut import to_csv

    path = Path(tempfile.mkdtemp(prefix="linsense-prop-")) / "lut.csv"
    path.write_text(to_csv(_lut()))
    return str(path)


def _drive_method(method: str):
    def call(**kw):
        from linsense import ctrl

        d = ctrl.Drive()
        return getattr(d, method)(**kw)

    return call


def _motor_ctor(**kw):
    import linsense

    m = _motor()
    base = dict(name="m", R_s=m.R_s, pole_pitch=m.pole_pitch, force_constant=m.force_constant, mass=m.mass,
                inductance=m.inductance)
    return linsense.Motor(**{**base, **kw})


def _entries(**kw):
    return _motor().inductance.entries(**kw)


def _ind_from_table(**kw):
    return _mod("linsense.model.inductance", "InductanceModel").from_table(**kw)


def _ind_from_params(**kw):
    return _mod("linsense.model.inductance", "InductanceModel").from_params(**kw)


M = "motor"
MOT, MOD, TH, F1K, V12 = ("motor", M), ("model", M), ("positions", THETA), ("real", 1000.0), ("real", 12.0)
#: function: (the call, {argument: (kind, a valid value)}); a valid value "M" is the ecce2010 motor
FUNCS = {
    # linsense.analysis.hf
    "hf.dq_components": (_hf("dq_components"), {"model": MOD, "theta": TH}),
    "hf.saliency": (_hf("saliency"), {"model": MOD, "theta": TH}),
    "hf.psi_lut": (_hf("psi_lut"), {"model": MOD, "theta": TH}),
    "hf.equilibrium_error": (_hf("equilibrium_error"), {"model": MOD, "theta": TH}),
    "hf.loop_gain_factor": (_hf("loop_gain_factor"), {"model": MOD, "theta": TH}),
    "hf.psi": (_hf("psi"), {"model": MOD, "theta": TH,
                            "theta_err": ("positions", 0.1)}),
    "hf.hf_current_est": (_hf("hf_current_est"), {"model": MOD, "theta": TH,
                                                  "theta_err": ("positions", 0.1)}),
    "hf.psi_compensated": (_hf("psi_compensated"), {
        "model": MOD, "theta": TH, "theta_err": ("positions", 0.1),
        "lut_at": (choice("estimated", "actual"), "actual")}),
    "hf.mean_dq": (_hf("mean_dq"), {"motor": MOD, "n": ("count", 36)}),
    "hf.end_anisotropy": (_hf("end_anisotropy"), {"motor": MOD, "n": ("count", 36)}),
    "hf.table_model": (_hf("table_model"), {"motor": MOT, "f_inj": ("real?", 1000.0)}),
    "hf.psi_lut_resistive": (_hf("psi_lut_resistive"), {
        "motor": MOT, "theta": TH, "f_inj": F1K, "quad": ("real", 0.5)}),
    "hf.demod_ratio": (_hf("demod_ratio"), {
        "motor": MOT, "theta": TH, "theta_err": ("positions", 0.1),
        "v_inj": V12, "f_inj": F1K, "psi_comp": ("positions", 0.05), "quad": ("real", 0.0)}),
    "hf.hf_current": (_hf("hf_current"), {
        "motor": MOT, "theta": TH, "v_inj": V12, "f_inj": F1K,
        "theta_err": ("positions", 0.0), "quad": ("real", 0.2)}),
    "hf.hf_current_amplitude": (_hf("hf_current_amplitude"), {
        "motor": MOT, "theta": TH, "v_inj": V12, "f_inj": F1K}),
    # linsense.analysis.rotating, square, stability, summary, tables
    "rotating.negative_sequence": (_mod("linsense.analysis.rotating", "negative_sequence"), {
        "motor": MOT, "theta": TH, "v_inj": V12, "f_inj": F1K}),
    "rotating.negative_sequence_numeric": (_mod("linsense.analysis.rotating", "negative_sequence_numeric"), {
        "motor": MOT, "theta": TH, "v_inj": V12, "f_inj": F1K}),
    "rotating.reference_phase": (_mod("linsense.analysis.rotating", "reference_phase"), {
        "motor": MOT, "f_inj": F1K}),
    "rotating.psi_rotating": (_mod("linsense.analysis.rotating", "psi_rotating"), {
        "motor": MOT, "theta": TH, "f_inj": F1K}),
    "rotating.rotating_lut": (_mod("linsense.analysis.rotating", "rotating_lut"), {
        "motor": MOT, "theta_est": TH, "f_inj": ("real?", 1000.0), "n": ("count", 360)}),
    "rotating.reference_phase_sampled": (_mod("linsense.analysis.rotating", "reference_phase_sampled"), {
        "motor": MOT, "f_inj": F1K, "f_pwm": ("real", 16000.0), "delay": ("real", 1.0)}),
    "rotating.psi_rotating_sampled": (_mod("linsense.analysis.rotating", "psi_rotating_sampled"), {
        "motor": MOT, "theta": TH, "f_inj": F1K, "f_pwm": ("real", 16000.0)}),
    "square.delta_current": (_mod("linsense.analysis.square", "delta_current"), {
        "motor": MOT, "theta": TH, "f_inj": ("real", 8000.0), "v_inj": ("real", 1.0),
        "theta_err": ("positions", 0.0)}),
    "square.delta_current_numeric": (_mod("linsense.analysis.square", "delta_current_numeric"), {
        "motor": MOT, "theta": ("real", 0.3), "f_inj": ("real", 8000.0), "v_inj": ("real", 1.0),
        "theta_err": ("real", 0.0), "steps": ("count", 50), "periods": ("count", 20)}),
    "square.psi_square": (_mod("linsense.analysis.square", "psi_square"), {
        "motor": MOT, "theta": TH, "f_inj": ("real", 8000.0)}),
    "stability.nolut_error_gain": (_mod("linsense.analysis.stability", "nolut_error_gain"), {
        "motor": MOT, "theta": TH, "f_inj": F1K, "quad": ("real", 0.0),
        "h": ("real", 1e-4)}),
    "summary.summarize": (_mod("linsense.analysis.summary", "summarize"), {
        "motor": MOT, "v_inj": V12, "f_inj": F1K}),
    "tables.model_table": (_mod("linsense.analysis.model_table", "model_table"), {
        "motor": MOT, "points": ("count", 16)}),
    # linsense.compensation.lut
    "lut.interpolate": (_mod("linsense.compensation.lut", "interpolate"), {
        "table": ("table", [0.0, 1.0, 2.0, 3.0]), "theta": TH}),
    "lut.build_lut": (_mod("linsense.compensation.lut", "build_lut"), {
        "motor": MOT, "points": ("count", 16), "quad": ("real", 0.0),
        "injection": (choice("pulsating", "rotating", "square"), "rotating")}),
    "lut.lut_r_slope": (_mod("linsense.compensation.lut", "lut_r_slope"), {
        "motor": MOT, "points": ("count", 16), "f_inj": F1K, "quad": ("real", 0.0)}),
    "lut.Lut": (_mod("linsense.compensation.lut", "Lut"), {
        "values": ("table", [0.0, 0.1, 0.2, 0.1]), "name": ("str", "m")}),
    "lut.export": (_mod("linsense.compensation.lut", "export"), {
        "lut": ("lut", "LUT"), "fmt": (choice("csv", "json", "c"), "json")}),
    "lut.to_csv": (_mod("linsense.compensation.lut", "to_csv"), {"lut": ("lut", "LUT")}),
    "lut.to_c_header": (_mod("linsense.compensation.lut", "to_c_header"), {"lut": ("lut", "LUT")}),
    "lut.read_lut": (_mod("linsense.compensation.lut", "read_lut"), {"path": ("path", "LUTFILE")}),
    "measured.end_effect_fit": (_mod("linsense.compensation.measured", "end_effect_fit"), {
        "motor": MOT, "values": ("table", "LUT16"), "injection": (choice("pulsating", "rotating", "square"),
                                                                   "pulsating"),
        "f_inj": F1K, "quad": ("real", 0.0)}),
    "sim.load_scenario": (_mod("linsense.sim", "load_scenario"), {"path": ("path", "SCENARIO")}),
    # linsense.model
    "Motor": (_motor_ctor, {"R_s": ("real", 9.0), "pole_pitch": ("real", 0.056), "mass": ("real", 1.5),
                            "force_constant": ("real", 20.0), "name": ("str", "m")}),
    "Friction": (_mod("linsense.model.motor", "Friction"), {"viscous": ("real", 1.0),
                                                            "coulomb": ("real", 0.5)}),
    "PmHarmonic": (_mod("linsense.model.motor", "PmHarmonic"), {
        "order": ("count", 5), "amplitude": ("real", 0.02), "phase": ("real", 0.1)}),
    "InductanceModel.from_params": (_ind_from_params, {
        "L0": ("real", 2.75e-3), "L2": ("real", -0.3e-3), "M0": ("real", -0.9e-3), "M2": ("real", -0.3e-3),
        "dM0": ("real", -0.47e-3)}),
    "InductanceModel.from_table": (_ind_from_table, {
        "theta": TH, "entries": ("positions", np.full((12, 6), 1e-3))}),
    "InductanceModel.entries": (_entries, {"theta": TH, "derivative": ("count", 1)}),
    "tolerance.perturbed": (_mod("linsense.model.tolerance", "perturbed"), {
        "motor": MOT, "k_inductance": ("real", 1.1), "k_resistance": ("real", 1.3),
        "k_end_effect": ("real", 0.9), "label": ("str", "x")}),
    "load_motor": (_mod("linsense", "load_motor"), {
        "spec": (lambda v: isinstance(v, str | os.PathLike), "ecce2010")}),
    "frames.rot": (_mod("linsense.model.frames", "rot"), {"theta": TH}),
    # linsense.examples
    "examples.names": (_mod("linsense.examples", "names"), {
        "kind": (choice("motors", "scenarios", "sweeps", "fea", "bench", "firmware"), "motors")}),
    "examples.path": (_mod("linsense.examples", "path"), {
        "kind": (choice("motors", "scenarios", "sweeps", "fea", "bench", "firmware"), "motors"),
        "name": ("str", "small30")}),
    # linsense.ctrl
    "ctrl.Drive": (_mod("linsense.ctrl", "Drive"), {"cfg": ("cfg", None)}),
    "ctrl.to_pos": (_mod("linsense.ctrl", "to_pos"), {"theta": ("real", 3.0)}),
    "ctrl.from_pos": (_mod("linsense.ctrl", "from_pos"), {"p": (lambda v: "ls_pos" in repr(v), "POS")}),
    "ctrl.Drive.set_mode": (_drive_method("set_mode"), {"mode": (lambda v: choice(
        "off", "sensored", "sensorless_nolut", "calibration", "startup", "sensorless_lut")(v)
        or (KINDS["count"](v) and 0 <= v <= 5), "sensored")}),
    "ctrl.Drive.set_position": (_drive_method("set_position"), {"theta": ("real", 1.0)}),
    "ctrl.Drive.set_load": (_drive_method("set_load"), {"f_load": ("real", 1.0)}),
    # linsense.tune
    "tune.DriveData": (_mod("linsense.tune", "DriveData"), {
        "v_dc": ("number", 72.0), "f_pwm": ("number", 16000.0), "i_max": ("number", 2.5),
        "dead_time": ("number", 1e-6), "shape": (choice("pulsating", "rotating", "square"), "pulsating")}),
    "tune.design": (lambda **kw: _mod("linsense.tune", "design")(analyse=False, **kw), {
        "motor": MOT, "drive": ("drive", None), "source": ("str", "<tune>")}),
}
#: the valid values drawn instead of their placeholder
SPECIAL = {M: _motor, "LUT": _lut, "LUTFILE": _lut_file,
           "LUT16": lambda: _mod("linsense.compensation.lut", "build_lut")(_motor(), 16, 1000.0).values,
           "SCENARIO": lambda: str(_mod("linsense.examples", "path")("scenarios", "step3_lut")),
           "POS": lambda: _mod("linsense.ctrl", "to_pos")(1.0)}

#: values of every kind: the hostile ones and some valid ones
HOSTILE = [None, math.nan, math.inf, -math.inf, 1 + 2j, np.complex128(0.5j), True, np.True_, "x", "", "0.3",
           b"1", {"a": 1}, set(), [], np.array([]), [[1.0, 2.0], [3.0]], ["1", 2.0], np.zeros((2, 2)),
           np.array([0.1, np.nan]), np.array([1j, 2.0]), 10**400, -1, 0, 3, 2.5, -1e308, 5e-324, 1e300,
           np.int64(7), np.float32(0.2), object(), Path("no-such-file.toml"), "ecce2010", "motors", "json",
           "\0"]


def _finite(obj) -> bool:
    if isinstance(obj, dict):
        return all(_finite(v) for v in obj.values())
    if isinstance(obj, list | tuple):
        return all(_finite(v) for v in obj)
    values = getattr(obj, "values", None)
    if isinstance(values, np.ndarray):
        return _finite(values)
    if isinstance(obj, np.ndarray) and obj.dtype.kind in "iufc":
        return bool(np.all(np.isfinite(obj)))
    if isinstance(obj, float | complex | np.floating | np.complexfloating):
        return bool(np.isfinite(obj))
    return True


def check_call(name: str, arg: str | None, value) -> str:
    """Call ``name`` with ``value`` for ``arg`` (None: all valid); the oracle. Returns the outcome."""
    fn, args = FUNCS[name]
    kw = {a: (SPECIAL[v]() if isinstance(v, str) and v in SPECIAL else v) for a, (_, v) in args.items()}
    if arg is not None:
        kw[arg] = value
    status, out = attempt(fn, **kw)
    if arg is None:
        assert status == "ok", f"{name} refused its valid arguments: {out}"
        return status
    kind = args[arg][0]
    of_kind = (KINDS[kind] if isinstance(kind, str) else kind)(value)
    if status == "refused":
        if not of_kind:
            named = arg in out.key if isinstance(out, InputError) else \
                isinstance(out, ConfigError) and any(arg in k for k in out.fields)
            assert named, f"{name}({arg}={value!r}) refused without naming {arg!r}: {out!r}"
        return status
    assert of_kind, f"{name}({arg}={value!r}) accepted a value that is not a {kind}"
    assert _finite(out), f"{name}({arg}={value!r}) gave a non-finite result"
    return status


@pytest.mark.parametrize("name", sorted(FUNCS))
def test_every_function_runs_on_its_valid_arguments(name):
    check_call(name, None, None)


@prop_settings(scale=6)
@given(name=st.sampled_from(sorted(FUNCS)), data=st.data())
def test_a_hostile_argument_is_refused_naming_it_or_gives_a_finite_result(name, data):
    arg = data.draw(st.sampled_from(sorted(FUNCS[name][1])), label="arg")
    value = data.draw(st.one_of(st.sampled_from(HOSTILE), st.floats(), st.integers(-10**6, 10**6),
                                st.text(max_size=6)), label="value")
    try:
        status = check_call(name, arg, value)
    except LinsenseError:  # (a refusal's message that is not one line: attempt's own check)
        raise
    event(f"{name}: {status}")


#: what the property (and a new user) found, each now one InputError naming the argument
FOUND = [
    ("hf.psi_lut", "theta", None), ("hf.equilibrium_error", "theta", None),
    ("hf.psi_lut", "theta", np.array([0.1 + 0.5j, 0.2])), ("hf.psi_lut", "theta", {"a": 1}),
    ("hf.psi_lut", "theta", "0.3"), ("hf.psi_lut", "model", "nope"), ("hf.psi_lut", "model", 42),
    ("hf.saliency", "theta", np.array([np.nan])), ("hf.mean_dq", "n", 2.5), ("hf.mean_dq", "n", None),
    ("hf.psi_compensated", "lut_at", "true"), ("hf.psi", "theta_err", np.zeros(5)),
    ("hf.table_model", "f_inj", -1.0), ("hf.demod_ratio", "psi_comp", None),
    ("lut.interpolate", "table", []), ("lut.interpolate", "theta", "0.3"), ("lut.build_lut", "motor", None),
    ("lut.Lut", "values", [0.0, np.nan, 0.0, 0.0]), ("lut.Lut", "values", np.zeros((4, 4))),
    ("lut.export", "fmt", "cvs"), ("lut.to_csv", "lut", None), ("lut.read_lut", "path", 3),
    ("Motor", "R_s", 1e6), ("Motor", "pole_pitch", -1.0), ("Motor", "mass", math.nan), ("Motor", "name", 3),
    ("Friction", "viscous", -1.0), ("Friction", "coulomb", "x"), ("PmHarmonic", "order", 2.5),
    ("PmHarmonic", "phase", None), ("InductanceModel.from_params", "L0", math.nan),
    ("InductanceModel.from_table", "theta", None), ("InductanceModel.entries", "derivative", -1),
    ("examples.names", "kind", "nope"), ("examples.path", "kind", None), ("examples.path", "name", None),
    ("ctrl.Drive", "cfg", "x"), ("rotating.psi_rotating", "theta", None), ("square.psi_square", "theta", 1j),
    ("rotating.rotating_lut", "n", 2.5), ("square.delta_current_numeric", "steps", None),
    ("stability.nolut_error_gain", "h", math.nan), ("tolerance.perturbed", "k_resistance", None),
    ("tolerance.perturbed", "motor", "x"), ("ctrl.to_pos", "theta", None),
    ("ctrl.Drive.set_load", "f_load", "1"), ("ctrl.Drive.set_mode", "mode", None),
    ("tune.DriveData", "v_dc", "72"), ("tune.DriveData", "shape", "sine"),
    ("tune.design", "motor", "nope"), ("tune.design", "drive", {"v_dc": 72.0}),
    ("frames.rot", "theta", None), ("load_motor", "spec", None), ("sim.load_scenario", "path", None),
    ("ctrl.from_pos", "p", 3.0), ("measured.end_effect_fit", "values", [1j, 0.0, 0.0, 0.0]),
    # (the long profile's: NaN of a step's matrix exponential, an infinite current, a two-line refusal)
    ("square.delta_current_numeric", "f_inj", 1.1192980226760248e-213),
    ("rotating.negative_sequence", "v_inj", 2.8611174857570284e+304), ("ctrl.Drive.set_mode", "mode", "\n"),
    ("lut.read_lut", "path", "0\n"),
]


@pytest.mark.parametrize("name, arg, value", FOUND, ids=[f"{n}-{a}-{v!r}"[:60] for n, a, v in FOUND])
def test_what_was_found_is_refused_naming_the_argument(name, arg, value):
    fn, args = FUNCS[name]
    kw = {a: (SPECIAL[v]() if isinstance(v, str) and v in SPECIAL else v) for a, (_, v) in args.items()}
    kw[arg] = value
    with pytest.raises(LinsenseError) as e:
        fn(**kw)
    err = e.value
    assert "\n" not in str(err), str(err)
    if isinstance(err, ConfigError):  # (the C binding's refusal: the field named)
        assert any(arg in k for k in err.fields), str(err)
    else:  # (or, for a path, the file it names)
        assert isinstance(err, InputError) and (arg in err.key or err.source == repr(value)[1:-1]), str(err)

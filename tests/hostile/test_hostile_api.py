"""The Python API without the command line's checks: each case a call a new user made,
the error of the project's hierarchy it must end in, the argument it must name and words its one
line must contain.

* ``linsense.Motor(R_s=1e6, pole_pitch=-1, ...)`` was built (``build_lut`` on it gave an all-zero
  table): a Motor is validated by its constructor with the motor file's checks and limits;
* ``psi_lut(m, None)`` and ``equilibrium_error(m, None)`` returned NaN, a complex theta lost its
  imaginary part without a word, ``psi_lut("ecce2010", x)`` (an AttributeError) now resolves the
  preset as ``load_motor`` does, ``psi_lut(m, {"a": 1})`` was a TypeError, ``interpolate`` of an
  empty table an IndexError, ``sweep("injection", out=123)`` a TypeError, ``examples.names("nope")``
  a bare KeyError and ``ctrl.Drive("x")`` a TypeError: each now one InputError naming the argument.
"""

from __future__ import annotations

import numpy as np
import pytest

import linsense
from linsense.errors import InputError, LinsenseError
from linsense.model.motor import load_motor

THETA = np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)


@pytest.fixture(scope="module")
def ecce():
    return load_motor("ecce2010")


def motor_kw(ecce, **over) -> dict:
    kw = dict(name="m", R_s=ecce.R_s, pole_pitch=ecce.pole_pitch, force_constant=ecce.force_constant,
              mass=ecce.mass, inductance=ecce.inductance)
    return {**kw, **over}


def _hf(name):
    from linsense.analysis import hf

    return getattr(hf, name)


def _sweep(*a, **k):
    from linsense.sweep import sweep

    return sweep(*a, **k)


def _interpolate(*a):
    from linsense.compensation.lut import interpolate

    return interpolate(*a)


def _names(kind):
    from linsense import examples

    return examples.names(kind)


def _drive(cfg):
    from linsense import ctrl

    return ctrl.Drive(cfg)


# name: (call on the ecce2010 motor, the key the error names, words its message contains)
CASES = {
    "Motor R_s 1e6": (lambda m: linsense.Motor(**motor_kw(m, R_s=1e6)), "motor.R_s",
                      ["linsense.Motor: motor.R_s", "1e+06", "[0, 100] ohm", "milliohm"]),
    "Motor pole_pitch -1": (lambda m: linsense.Motor(**motor_kw(m, pole_pitch=-1.0)), "motor.pole_pitch",
                            ["greater than 0", "-1"]),
    "Motor mass nan": (lambda m: linsense.Motor(**motor_kw(m, mass=float("nan"))), "motor.mass", ["finite"]),
    "Motor mass str": (lambda m: linsense.Motor(**motor_kw(m, mass="1.5")), "motor.mass", ["'1.5'"]),
    "Motor inductance None": (lambda m: linsense.Motor(**motor_kw(m, inductance=None)), "inductance",
                              ["InductanceModel", "None"]),
    "psi_lut None": (lambda m: _hf("psi_lut")(m, None), "theta", ["finite positions in rad", "None"]),
    "equilibrium_error None": (lambda m: _hf("equilibrium_error")(m, None), "theta", ["None"]),
    "psi_lut complex": (lambda m: _hf("psi_lut")(m, np.array([0.1 + 0.5j, 0.2])), "theta",
                        ["complex numbers"]),
    "psi_lut complex scalar": (lambda m: _hf("psi_lut")(m, 0.3 + 1j), "theta", ["complex"]),
    "psi_lut dict": (lambda m: _hf("psi_lut")(m, {"a": 1}), "theta", ["{'a': 1}"]),
    "psi_lut nan": (lambda m: _hf("psi_lut")(m, [0.1, float("nan")]), "theta[1]", ["nan"]),
    "psi_lut bad motor": (lambda m: _hf("psi_lut")("ecce2011", THETA), "model",
                          ["ecce2011", "did you mean 'ecce2010'?"]),
    "psi_lut motor int": (lambda m: _hf("psi_lut")(42, THETA), "model", ["a Motor", "42"]),
    "interpolate empty": (lambda m: _interpolate([], 0.3), "table", ["at least 1", "got 0"]),
    "interpolate theta str": (lambda m: _interpolate([0.0, 1.0, 2.0, 3.0], "0.3"), "theta", ["'0.3'"]),
    "sweep out 123": (lambda m: _sweep("injection", out=123), "out", ["a str or os.PathLike", "123"]),
    "examples.names nope": (lambda m: _names("nope"), "kind", ["'nope'", "motors"]),
    "examples.names motor": (lambda m: _names("motor"), "kind", ["did you mean 'motors'?"]),
    "ctrl.Drive x": (lambda m: _drive("x"), "cfg", ["ls_drive_cfg", "'x'"]),
}


@pytest.mark.parametrize("name", list(CASES))
def test_the_api_refuses_naming_the_argument(ecce, name):
    call, key, words = CASES[name]
    with pytest.raises(LinsenseError) as e:
        call(ecce)
    err = e.value
    assert isinstance(err, InputError), f"{type(err).__name__}: {err}"
    msg = str(err)
    assert err.key == key, msg
    assert "\n" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


def test_a_preset_name_is_a_motor_everywhere(ecce):
    # psi_lut("ecce2010", x) was an AttributeError: a preset (or example) name is resolved as load_motor does
    from linsense.analysis.hf import equilibrium_error, psi_lut
    from linsense.compensation.lut import build_lut

    np.testing.assert_array_equal(psi_lut("ecce2010", THETA), psi_lut(ecce, THETA))
    np.testing.assert_array_equal(equilibrium_error("ecce2010", THETA), equilibrium_error(ecce, THETA))
    np.testing.assert_array_equal(build_lut("ecce2010", 8).values, build_lut(ecce, 8).values)


def test_a_valid_motor_is_built_and_equal_to_the_preset(ecce):
    m = linsense.Motor(**motor_kw(ecce, name="ecce2010"))
    assert m.R_s == ecce.R_s and m.inductance is ecce.inductance

"""Motor files: presets, TOML round-trip, harmonics, tables and optional sections."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from conftest import ECCE, theta_grid
from linsense.analysis.model_table import model_table, table_to_csv
from linsense.errors import InputError, ModelError
from linsense.model.motor import check_motor, load_motor, motor_to_toml, preset_names

BASE = """
[motor]
name = "m1"
R_s = 9
pole_pitch = 0.056
force_constant = 20.0
mass = 1.5
"""


def test_preset(ecce):
    assert "ecce2010" in preset_names()
    assert ecce.inductance.params == ECCE
    assert ecce.R_s == 9.0 and ecce.pole_pitch == 0.056 and ecce.mass == 1.5
    # F = 3/2 * 2pi/tau * psi_pm * i_q = force_constant * i_q
    assert 1.5 * 2 * math.pi / ecce.pole_pitch * ecce.psi_pm == pytest.approx(20.0)
    assert ecce.theta_of_x(0.001) == pytest.approx(math.radians(6.43), abs=1e-4)


def test_toml_round_trip(ecce, tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(motor_to_toml(ecce))
    m = load_motor(f)
    assert m.inductance.params == ecce.inductance.params
    np.testing.assert_array_equal(m.inductance.a, ecce.inductance.a)


def test_harmonics_friction_and_pm_flux(tmp_path):
    f = tmp_path / "h.toml"
    f.write_text(BASE + """
[inductance]
L0 = 2.75e-3
L2 = -0.317e-3
M0 = -0.92e-3
M2 = -0.317e-3
dM0 = -0.47e-3
L4 = 0.05e-3
M6 = -0.01e-3

[friction]
viscous = 5.0
coulomb = 2

[pm_flux]
harmonics = [ { order = 5, amplitude = 0.03, phase_deg = 10.0 } ]
""")
    m = load_motor(f)
    assert m.inductance.params["L4"] == 0.05e-3 and m.inductance.params["M4"] == 0.0
    assert m.inductance.params["M6"] == -0.01e-3 and m.inductance.max_order == 6
    assert m.friction.viscous == 5.0 and m.friction.coulomb == 2.0
    assert m.pm_harmonics[0].order == 5 and m.pm_harmonics[0].phase == pytest.approx(math.radians(10))
    back = tmp_path / "back.toml"
    back.write_text(motor_to_toml(m))
    m2 = load_motor(back)
    np.testing.assert_allclose(m2.inductance.a, m.inductance.a)
    assert m2.friction == m.friction and m2.pm_harmonics == m.pm_harmonics


# ---------------------------------------------------------------------- the magnets' flux per phase
_IND = "\n[inductance]\nL0 = 2.75e-3\nL2 = -0.317e-3\nM0 = -0.92e-3\nM2 = -0.317e-3\ndM0 = -0.47e-3\n"


def test_pm_flux_per_phase_loads_writes_and_defaults_to_balanced(tmp_path):
    """``[pm_flux] scale_abc`` and ``shift_deg_abc`` (the end effect on the magnets' flux): read in
    degrees, held in rad, written back; absent, the motor is balanced (exactly 1 and 0)."""
    from linsense.model.motor import PmPhases

    f = tmp_path / "u.toml"
    f.write_text(BASE + _IND + "\n[pm_flux]\nscale_abc = [1, 0.96, 1.02]\nshift_deg_abc = [0.0, 1.5, -2]\n"
                 "harmonics = [ { order = 5, amplitude = 0.03, phase_deg = 10.0 } ]\n")
    m = load_motor(f)
    assert m.pm_phases.scale == (1.0, 0.96, 1.02) and not m.pm_phases.balanced
    assert m.pm_phases.shift == pytest.approx((0.0, math.radians(1.5), math.radians(-2.0)), abs=1e-15)
    back = tmp_path / "back.toml"
    back.write_text(motor_to_toml(m))
    m2 = load_motor(back)
    assert m2.pm_phases.scale == m.pm_phases.scale and m2.pm_harmonics == m.pm_harmonics
    np.testing.assert_allclose(m2.pm_phases.shift, m.pm_phases.shift, rtol=1e-14)
    # the per-phase fundamental: phase B's peak flux is 0.96 psi_pm, reached 1.5 deg early
    th = np.radians(np.arange(0.0, 360.0, 0.01))
    one = dataclasses.replace(m, pm_harmonics=())
    b = one.psi_pm_abc(th)[:, 1]
    assert b.max() == pytest.approx(0.96 * m.psi_pm, rel=1e-8)
    assert math.degrees(th[np.argmax(b)]) == pytest.approx(120.0 - 1.5, abs=0.01)
    # absent: balanced, and written as before (no per-phase keys)
    plain = tmp_path / "p.toml"
    plain.write_text(BASE + _IND)
    p = load_motor(plain)
    assert p.pm_phases == PmPhases() and p.pm_phases.balanced
    assert "scale_abc" not in motor_to_toml(p) and "[pm_flux]" not in motor_to_toml(p)


@pytest.mark.parametrize("section, key, words", [
    ("scale_abc = [1, 96, 1]", "pm_flux.scale_abc[1]", ["phase B", "96", "[0.5, 1.5]", "did you type %?"]),
    ("scale_abc = [0.3, 1, 1]", "pm_flux.scale_abc[0]", ["phase A", "0.3", "[0.5, 1.5]"]),
    ("shift_deg_abc = [0, 0, 45]", "pm_flux.shift_deg_abc[2]", ["phase C", "45 deg", "[-30, 30] deg"]),
    ("scale_abc = [1, 0.96]", "pm_flux.scale_abc", ["at least 3"]),
    ("shift_deg_abc = [0, 0, 0, 1]", "pm_flux.shift_deg_abc", ["at most 3"]),
    # (the schema's own refusals name the item as pydantic does)
    ("scale_abc = [1, \"0.9\", 1]", "pm_flux.scale_abc.1", ["number"]),
    ("scale_abc = [1, nan, 1]", "pm_flux.scale_abc.1", ["finite"]),
])
def test_pm_flux_per_phase_refusals(tmp_path, section, key, words):
    f = tmp_path / "u.toml"
    f.write_text(BASE + _IND + f"\n[pm_flux]\n{section}\n")
    with pytest.raises(InputError) as exc:
        load_motor(f)
    assert exc.value.key == key, str(exc.value)
    assert str(f) in str(exc.value)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))


def test_pm_phases_from_python_are_held_to_the_file_rules(ecce):
    from linsense.model.motor import PmPhases

    with pytest.raises(InputError, match="shift"):
        PmPhases((1.0, 1.0, 1.0), (0.0, float("nan"), 0.0))
    with pytest.raises(InputError, match="scale"):
        PmPhases((1.0, 1.0))
    with pytest.raises(InputError, match=r"pm_flux.scale_abc\[2\]"):
        dataclasses.replace(ecce, pm_phases=PmPhases((1.0, 1.0, 2.0)))
    with pytest.raises(InputError, match="pm_phases"):
        dataclasses.replace(ecce, pm_phases=(1.0, 1.0, 1.0))


def test_table_motor_from_model_csv(ecce, tmp_path):
    """The CSV written by `linsense model` plugs in as a tabulated inductance model."""
    (tmp_path / "tab.csv").write_text(table_to_csv(model_table(ecce, 72)))
    f = tmp_path / "t.toml"
    f.write_text(BASE + '\n[inductance]\ntable = "tab.csv"\n')
    m = load_motor(f)
    th = theta_grid(333)
    np.testing.assert_allclose(m.inductance.L_dq(th), ecce.inductance.L_dq(th), atol=1e-12)
    assert "table" in motor_to_toml(m, table="tab.csv")


def test_check_motor_accepts_preset(ecce):
    check_motor(ecce)


def test_errors_are_linsense_errors(tmp_path):
    with pytest.raises(InputError):
        load_motor("nope")
    f = tmp_path / "z.toml"
    f.write_text(BASE + "\n[inductance]\nL0 = 2e-3\nL2 = 0.0\nM0 = -0.5e-3\nM2 = 0.0\ndM0 = 0.0\n")
    with pytest.raises(ModelError):
        load_motor(f)


@pytest.mark.parametrize("path", sorted((Path(__file__).parents[1] / "src/linsense/examples/motors")
                                         .glob("*.toml")))
def test_shipped_examples_load(path):
    m = load_motor(path)
    check_motor(m)


# ---------------------------------------------------------------------- long tables, slips of unit
def test_a_long_table_is_fitted_up_to_the_order_limit(ecce):
    """8,000 positions (interpolated exactly, minutes and GBs) are fitted to order 63 in blocks: the
    same series as lstsq, the motor's within 1e-15 H; scattered positions too."""
    from linsense.limits import MAX_TABLE_ORDER
    from linsense.model.inductance import InductanceModel, _design

    theta = np.linspace(0.0, 2.0 * np.pi, 8000, endpoint=False)
    tab = InductanceModel.from_table(theta, ecce.inductance.entries(theta))
    assert tab.max_order == MAX_TABLE_ORDER
    th = theta_grid(997)
    np.testing.assert_allclose(tab.entries(th), ecce.inductance.entries(th), atol=1e-15)
    rng = np.random.default_rng(3)
    scattered = np.sort(rng.uniform(0.0, 2.0 * np.pi, 6000))
    y = ecce.inductance.entries(scattered) + rng.normal(0.0, 1e-6, (6000, 6))
    tab = InductanceModel.from_table(scattered, y)
    ref, *_ = np.linalg.lstsq(_design(scattered, MAX_TABLE_ORDER), y, rcond=None)
    np.testing.assert_allclose(tab.a, ref[:MAX_TABLE_ORDER + 1].T, atol=1e-12)


@pytest.mark.parametrize("edits, key, words", [
    ([("L0 = 2.75e-3", "L0 = 1")], "inductance.L0", ["L0 = 1 H", "Did you type mH?"]),
    ([("L0 = 2.75e-3", "L0 = 0.6")], "inductance.L0", ["L0 = 0.6 H", "Did you type mH?"]),
    ([("L0 = 2.75e-3", "L0 = 0.2"), ("R_s = 9", "R_s = 1")], "inductance.L0",
     ["time constant of 0.2 s", "Did you type mH?"]),
    ([("L0 = 2.75e-3", "L0 = 0.2")], None, []),  # 0.2 H / 9 ohm = 22 ms: a large motor's
    ([("R_s = 9", "R_s = 0")], None, []),  # (no time constant)
    ([("R_s = 9", "R_s = 150")], "motor.R_s", ["150 ohm", "Did you type milliohm?"]),
])
def test_slips_of_unit(edits, key, words):
    from linsense.model.motor import check_plausible, motor_from_toml

    text = BASE + ("\n[inductance]\nL0 = 2.75e-3\nL2 = -0.317e-3\nM0 = -0.92e-3\nM2 = -0.317e-3\n"
                   "dM0 = -0.47e-3\n")
    for old, new in edits:
        assert old in text
        text = text.replace(old, new)
    if key is None:
        check_plausible(motor_from_toml(text, "m.toml"))
        return
    with pytest.raises(InputError) as exc:  # (by the Motor's constructor: one validated path)
        motor_from_toml(text, "m.toml")
    assert exc.value.key == key
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))


# ------------------------------------------------------------------- one spelling per harmonic key
PRESET_TEXT = (Path(__file__).resolve().parents[1] / "src/linsense/model/presets/ecce2010.toml").read_text()


@pytest.mark.parametrize("line, key, meant", [
    ("L04 = 0.3e-3", "inductance.L04", "L4"),
    ("M04 = 0.3e-3", "inductance.M04", "M4"),
    ("L0006 = 1e-5", "inductance.L0006", "L6"),
    ("L00 = 1e-3", "inductance.L00", "L0"),
    ("M02 = 1e-5", "inductance.M02", "M2"),
])
def test_a_harmonic_key_with_a_leading_zero_is_refused(line, key, meant):
    """``L04`` was accepted and its value dropped (the model got L4 = 0): refused naming the key and
    the key it stands for (docs/motor-files.md: L4, M4, L6 ...)."""
    from linsense.model.motor import motor_from_toml

    text = PRESET_TEXT.replace("dM0 =", f"{line}\ndM0 =", 1)
    with pytest.raises(InputError) as e:
        motor_from_toml(text, "m.toml")
    assert e.value.key == key and f"did you mean '{meant}'?" in str(e.value), str(e.value)


def test_a_harmonic_key_with_other_digits_than_ascii_is_refused():
    """``"L\u0664"`` (an Arabic-Indic 4: int() reads it as 4) was accepted and dropped like L04."""
    from linsense.model.motor import motor_from_toml

    text = PRESET_TEXT.replace("dM0 =", '"L\u0664" = 0.3e-3\ndM0 =', 1)
    with pytest.raises(InputError) as e:
        motor_from_toml(text, "m.toml")
    assert e.value.key == "inductance.L\u0664", str(e.value)


def test_a_harmonic_key_as_documented_is_read():
    from linsense.model.motor import motor_from_toml

    m = motor_from_toml(PRESET_TEXT.replace("dM0 =", "L4 = 0.01e-3\nM6 = 0.02e-3\ndM0 =", 1), "m.toml")
    assert m.inductance.params["L4"] == 0.01e-3 and m.inductance.params["M6"] == 0.02e-3


# ---------------------------------------------------------------------- plain numbers
def test_numpy_scalars_are_written_as_plain_numbers(ecce, tmp_path):
    """A motor whose values are numpy scalars (as a fit gives them) wrote ``R_s = np.float64(9.0)``, not
    TOML: plain numbers, and the file loads back to the same motor."""
    import dataclasses

    from linsense.model.motor import Friction, PmHarmonic

    m = dataclasses.replace(ecce, R_s=np.float64(9.0), mass=np.float32(1.5), pole_pitch=np.float64(0.056),
                            friction=Friction(np.float64(1.0), np.float64(0.5)),
                            pm_harmonics=(PmHarmonic(np.int64(5), np.float64(0.02), np.float64(0.1)),))
    text = motor_to_toml(m)
    assert "np." not in text and "float64" not in text, text
    path = tmp_path / "m.toml"
    path.write_text(text)
    back = load_motor(str(path))
    assert back.R_s == 9.0 and back.mass == 1.5 and back.friction.viscous == 1.0
    assert back.pm_harmonics[0].order == 5


def test_a_duplicate_position_is_named_as_a_plain_number(ecce, tmp_path):
    theta = np.array([45.0 * k for k in range(8)] + [360.0])
    e = ecce.inductance.entries(np.radians(theta))
    rows = ["theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA"] + [
        ",".join(str(v) for v in [t, *r]) for t, r in zip(theta, e, strict=True)]
    (tmp_path / "t.csv").write_text("\n".join(rows) + "\n")
    from linsense.model.motor import read_inductance_table

    with pytest.raises(InputError) as err:
        read_inductance_table(tmp_path / "t.csv")
    msg = str(err.value)
    assert "duplicate position 360.0 deg" in msg and "row 2 has 0.0 deg" in msg and "np." not in msg, msg


@pytest.mark.parametrize("name", ['a "quoted" name', "back\\slash", "both \\\" ends \\"])
def test_motor_to_toml_writes_any_name_as_a_string(ecce, tmp_path, name):
    """A name with a quote or a backslash wrote a motor file that did not load
    back: it is a TOML string now, and reads back as it was."""
    import dataclasses

    path = tmp_path / "m.toml"
    path.write_text(motor_to_toml(dataclasses.replace(ecce, name=name)))
    assert load_motor(str(path)).name == name

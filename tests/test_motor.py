"""Motor files: presets, TOML round-trip, harmonics, tables and optional sections."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from conftest import ECCE, theta_grid
from linsense.analysis.tables import model_table, table_to_csv
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


@pytest.mark.parametrize("path", sorted((Path(__file__).parents[1] / "examples" / "motors").glob("*.toml")))
def test_shipped_examples_load(path):
    m = load_motor(path)
    check_motor(m)


# ---------------------------------------------------------------------- issue 23: long tables, slips of unit
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
    m = motor_from_toml(text, "m.toml")
    if key is None:
        check_plausible(m)
        return
    with pytest.raises(InputError) as exc:
        check_plausible(m)
    assert exc.value.key == key
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))

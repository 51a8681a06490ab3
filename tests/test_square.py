"""Square-wave injection with the end-effect: the closed form of the current change over a half
period against an exact integration of the 2x2 model, its R_s = 0 identity with eq. (12), and
the compensation table (docs/theory.md)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from linsense.analysis.hf import psi_lut
from linsense.analysis.square import delta_current, delta_current_numeric, psi_square
from linsense.compensation.lut import build_lut
from linsense.model.motor import load_motor


@pytest.mark.parametrize("theta,err", [(0.3, 0.0), (1.0, 0.2), (2.2, -0.3), (4.0, 0.05)])
@pytest.mark.parametrize("f_inj", [1000.0, 8000.0])
def test_closed_form_equals_the_integrated_model(theta, err, f_inj):
    m = load_motor("ecce2010")
    closed = delta_current(m, theta, f_inj, 12.0, err)
    # (from rest, 60 ms: the slowest decay L/R_s is about 0.5 ms, so the steady state is reached)
    num = delta_current_numeric(m, theta, f_inj, 12.0, err, steps=20, periods=int(0.06 * f_inj))
    assert np.max(np.abs(closed - num)) <= 1e-10 * np.max(np.abs(num))


def test_without_resistance_the_table_is_eq12():
    m = dataclasses.replace(load_motor("ecce2010"), R_s=0.0)
    th = np.linspace(0.0, 2.0 * np.pi, 721)
    assert np.max(np.abs(psi_square(m, th, 8000.0) - psi_lut(m, th))) < 1e-12
    d = delta_current(m, th, 8000.0)
    T = 0.5 / 8000.0
    expect = T * np.linalg.inv(m.inductance.L_dq(th))[..., :, 0]
    assert np.max(np.abs(d - expect)) < 1e-15


def test_table_zeroes_the_q_change_and_resistance_matters_at_low_frequency():
    """Rotated by the table, the change has no q component at zero error; at f_pwm / 2 the table is
    within 0.05 deg of eq. (12), at 1 kHz R_s moves it by more than 0.3 deg."""
    m = load_motor("ecce2010")
    th = np.linspace(0.0, 2.0 * np.pi, 361)
    for f in (8000.0, 1000.0):
        d = delta_current(m, th, f)
        p = psi_square(m, th, f)
        q = -np.sin(p) * d[:, 0] + np.cos(p) * d[:, 1]
        assert np.max(np.abs(q)) < 1e-15
    assert np.degrees(np.max(np.abs(psi_square(m, th, 8000.0) - psi_lut(m, th)))) < 0.05
    assert np.degrees(np.max(np.abs(psi_square(m, th, 1000.0) - psi_lut(m, th)))) > 0.3


def test_build_lut_square(run_cli, tmp_path):
    m = load_motor("ecce2010")
    lut = build_lut(m, 72, 8000.0, injection="square")
    assert lut.provenance["injection"] == "square"
    assert np.allclose(lut.values, psi_square(m, lut.theta, 8000.0))
    r = run_cli("lut", "--motor", "ecce2010", "--injection", "square", "--f-inj", "8000",
                "--out", tmp_path / "s.h", "--format", "c")
    assert r.code == 0, r.err

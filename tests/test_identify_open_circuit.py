"""The end effect on the magnets' flux from an open-circuit back-EMF (linsense.identify.open_circuit):
emulated from the motor model at a constant speed, phase-to-star and line-to-line, with noise."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from linsense.errors import InputError
from linsense.identify.open_circuit import phase_values_of_line, pm_phases_from_emf
from linsense.model.frames import T_CLARKE_INV
from linsense.model.motor import PmHarmonic, PmPhases
from linsense.sim import core
from linsense.sim.plant import fill_plant
from test_sim_accuracy import UNBALANCED, motor

V = 0.5  # m/s


def _emf(m, periods=2.0, n=720):
    """Open-circuit phase voltages (n, 3) of ``m`` at V over ``periods`` electrical periods."""
    theta = np.linspace(0.3, 0.3 + 2 * np.pi * periods, n, endpoint=False)
    omega = 2 * np.pi * V / m.pole_pitch
    return theta, omega * m.psi_pm_abc(theta, 1), omega


def _sequences(p: PmPhases):
    c = np.array(p.scale) * np.exp(1j * np.array(p.shift))
    a = np.exp(2j * np.pi / 3)
    return c.sum() / 3, (c * a ** np.arange(3)).sum() / 3


@pytest.mark.parametrize("periods", [1.0, 2.0])
def test_phase_to_star_gives_each_phase(periods):
    m = motor("unbalanced")  # (with a 5th harmonic: whole periods average it out)
    theta, e, omega = _emf(m, periods)
    got = pm_phases_from_emf(theta, e, omega, m.psi_pm)
    np.testing.assert_allclose(got.scale, UNBALANCED.scale, rtol=1e-12)
    np.testing.assert_allclose(got.shift, UNBALANCED.shift, atol=1e-12)


def test_line_to_line_gives_the_sequences_the_plant_sees():
    """Without the star point the zero sequence is lost; the positive and negative sequences (all
    that acts on the plant, docs/theory.md section 10) are exact, and a set without zero sequence is
    recovered phase by phase."""
    m = motor("unbalanced")
    theta, e, omega = _emf(m)
    line = e - np.roll(e, -1, axis=1)  # e_AB, e_BC, e_CA
    got = pm_phases_from_emf(theta, line, omega, m.psi_pm, line_to_line=True)
    for x, y in zip(_sequences(got), _sequences(UNBALANCED), strict=True):
        assert abs(x - y) < 1e-12
    assert max(abs(g - s) for g, s in zip(got.scale, UNBALANCED.scale, strict=True)) > 1e-3  # (Z lost)
    np.testing.assert_allclose(phase_values_of_line(line), e - e.mean(axis=1, keepdims=True), atol=1e-12)


def test_noise_and_a_varying_speed():
    """1 % voltage noise and a speed varying by 20 % along the run: within 0.1 % and 0.1 deg."""
    m = dataclasses.replace(motor("harmonic"), pm_phases=UNBALANCED,
                            pm_harmonics=(PmHarmonic(5, 0.03, 0.2), PmHarmonic(7, 0.01, -1.0)))
    theta = np.linspace(0.0, 6 * np.pi, 3000, endpoint=False)
    omega = 2 * np.pi * V / m.pole_pitch * (1.0 + 0.2 * np.sin(theta / 3))
    e = omega[:, None] * m.psi_pm_abc(theta, 1)
    e += np.random.default_rng(5).normal(0.0, 0.01 * np.abs(e).max(), e.shape)
    got = pm_phases_from_emf(theta, e, omega, m.psi_pm)
    np.testing.assert_allclose(got.scale, UNBALANCED.scale, atol=1e-3)
    np.testing.assert_allclose(got.shift, UNBALANCED.shift, atol=math.radians(0.1))


def test_round_trip_through_the_c_plant():
    """A motor file's imbalance (every phase off, A included) -> the C plant's open-circuit back-EMF
    (``omega`` times its alpha-beta PM flux derivative, as the simulator configures it) -> its
    line-to-line voltages -> the identification: the positive and negative sequences come back, so
    the motor file, the plant and the identification agree on the keys' signs and phases."""
    keys = PmPhases((0.95, 1.0, 1.04), (math.radians(2.0), math.radians(-1.0), math.radians(0.5)))
    m = dataclasses.replace(motor("harmonic"), pm_phases=keys)
    cfg = core.sim_cfg(m, core.PlantSetup())
    fill_plant(cfg, m)
    theta = np.linspace(-1.0, -1.0 + 4 * np.pi, 720, endpoint=False)
    omega = -2 * np.pi * V / m.pole_pitch  # (moving backwards: the EMF's sign follows)
    e_ab = omega * np.array([core.plant_eval(cfg, t)["dlambda_pm"] for t in theta])
    e = e_ab @ T_CLARKE_INV.T
    got = pm_phases_from_emf(theta, e - np.roll(e, -1, axis=1), omega, m.psi_pm, line_to_line=True)
    for x, y in zip(_sequences(got), _sequences(keys), strict=True):
        assert abs(x - y) < 1e-9
    assert abs(_sequences(keys)[1]) > 0.01  # (an imbalance the check sees)


@pytest.mark.parametrize("change, key, words", [
    (dict(omega=0.0), "omega", ["moving"]),
    (dict(periods=0.5), "theta", ["179.8", "gap of 180", "360 deg"]),
    (dict(psi_scale=10.0), "e", ["phase A", "0.1", "[0.5, 1.5]"]),
    (dict(e_rows=-1), "e", ["shape"]),
])
def test_refusals(change, key, words):
    m = motor("unbalanced")
    theta, e, omega = _emf(m, periods=change.get("periods", 2.0))
    if "e_rows" in change:
        e = e[:-1]
    with pytest.raises(InputError) as exc:
        pm_phases_from_emf(theta, e, change.get("omega", omega), m.psi_pm * change.get("psi_scale", 1.0))
    assert exc.value.key == key
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))

"""psi, Psi_LUT, the Fig. 8b property, the uncompensated observer and the brief's numbers."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings

from conftest import ECCE, make_motor, salient_params, theta_grid
from linsense.analysis.hf import (
    demod_ratio,
    dq_components,
    equilibrium_error,
    hf_current,
    hf_current_amplitude,
    hf_current_est,
    loop_gain_factor,
    psi,
    psi_compensated,
    psi_lut,
    psi_lut_resistive,
    saliency,
)
from linsense.analysis.summary import summarize
from linsense.model.inductance import InductanceModel

DEG = np.pi / 180


def eq11(L_d, L_q, L_dq, e):
    """Paper eq. (11), written with atan2 so the quadrant is kept."""
    num = (L_d - L_q) * np.sin(2 * e) - 2 * L_dq * np.cos(2 * e)
    den = (L_d + L_q) - (L_d - L_q) * np.cos(2 * e) - 2 * L_dq * np.sin(2 * e)
    return np.arctan2(num, den)


@settings(max_examples=40, deadline=None)
@given(salient_params())
def test_psi_from_inverse_model_matches_eq11_and_eq12(p):
    m = InductanceModel.from_params(**p)
    th = theta_grid(181)[:, None]
    e = np.radians(np.linspace(-30, 30, 13))[None, :]
    L_d, L_q, L_dq = dq_components(m, th)
    np.testing.assert_allclose(psi(m, th, e), eq11(L_d, L_q, L_dq, e), atol=1e-12)
    # psi(theta, 0) == Psi_LUT == atan(-L_dq / L_q)
    np.testing.assert_allclose(psi(m, th[:, 0], 0.0), psi_lut(m, th[:, 0]), atol=1e-14)
    np.testing.assert_allclose(psi_lut(m, th[:, 0]), np.arctan(-L_dq[:, 0] / L_q[:, 0]), atol=1e-14)


def test_hf_current_est_is_eq10():
    """The operator R of eq. (10), term by term."""
    m = InductanceModel.from_params(**ECCE)
    th = theta_grid(90)[:, None]
    e = np.radians([-12.0, 3.0, 20.0])[None, :]
    L_d, L_q, L_dq = dq_components(m, th)
    D = L_d * L_q - L_dq**2
    re = (L_d + L_q) / (2 * D) - (L_d - L_q) / (2 * D) * np.cos(2 * e) - L_dq / D * np.sin(2 * e)
    im = (L_d - L_q) / (2 * D) * np.sin(2 * e) - L_dq / D * np.cos(2 * e)
    i = hf_current_est(m, th, e)
    np.testing.assert_allclose(i[..., 0], re, rtol=1e-12)
    np.testing.assert_allclose(i[..., 1], im, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("lut_at", ["estimated", "actual"])
def test_fig8b_sign_depends_only_on_error_sign(ecce, lut_at):
    """In the compensated frame sign(psi - Psi_LUT) = -sign(theta_err) at every position,
    for 0 < |theta_err| <= 15 deg (saliency L_q > L_d)."""
    th = theta_grid(1440)[:, None]
    e = np.radians(np.concatenate([np.linspace(-15, -0.05, 60), np.linspace(0.05, 15, 60)]))[None, :]
    d = psi_compensated(ecce, th, e, lut_at=lut_at)
    assert np.all(np.sign(d) == -np.sign(e))
    np.testing.assert_allclose(psi_compensated(ecce, th[:, 0], 0.0, lut_at=lut_at), 0.0, atol=1e-14)


def test_fig8a_uncompensated_sign_is_ambiguous(ecce):
    """Without the LUT the same test fails: psi has both signs for a given error (Fig. 8a)."""
    th = theta_grid(1440)
    for e_deg in (-5.0, 5.0, 10.0):
        y = psi(ecce, th, np.radians(e_deg))
        assert (y > 0).any() and (y < 0).any()


@settings(max_examples=30, deadline=None)
@given(salient_params())
def test_fig8b_property_for_random_motors(p):
    m = InductanceModel.from_params(**p)
    th = theta_grid(360)[:, None]
    e = np.radians([-15, -7, -1, -0.1, 0.1, 1, 7, 15])[None, :]
    assert np.all(np.sign(psi_compensated(m, th, e)) == -np.sign(e))


@settings(max_examples=30, deadline=None)
@given(salient_params())
def test_equilibrium_zeroes_psi_and_is_stable(p):
    m = InductanceModel.from_params(**p)
    th = theta_grid(360)
    e_star = equilibrium_error(m, th)
    np.testing.assert_allclose(psi(m, th, e_star), 0.0, atol=1e-12)
    assert np.all(np.abs(e_star) < np.pi / 4)
    # stable root: psi decreases through zero as the error grows (same sign as at e = 0 without
    # end-effect, where psi ~ (L_d - L_q)/L_q * e)
    h = 1e-5
    assert np.all(psi(m, th, e_star + h) - psi(m, th, e_star - h) < 0)


def test_equilibrium_negative_saliency_motor():
    """For L_d > L_q the same formula picks the root within 45 deg and still zeroes psi."""
    m = InductanceModel.from_params(L0=2.75e-3, L2=0.317e-3, M0=-0.92e-3, M2=0.317e-3, dM0=-0.2e-3)
    th = theta_grid(360)
    assert np.all(saliency(m, th) < 0)
    e_star = equilibrium_error(m, th)
    np.testing.assert_allclose(psi(m, th, e_star), 0.0, atol=1e-12)
    assert np.all(np.abs(e_star) < np.pi / 4)


def test_loop_gain_factor_is_derivative_of_equilibrium(ecce):
    th = theta_grid(3600)
    e = np.unwrap(2 * equilibrium_error(ecce, th)) / 2
    num = 1 + np.gradient(e, th)
    np.testing.assert_allclose(loop_gain_factor(ecce, th)[5:-5], num[5:-5], atol=2e-3)


def test_hf_current_with_zero_resistance_is_inverse_model():
    m = make_motor(InductanceModel.from_params(**ECCE))
    m0 = replace(m, R_s=0.0)
    th = theta_grid(50)
    w = 2 * np.pi * 1000.0
    i = hf_current(m0, th, 12.0, 1000.0, np.radians(7.0))
    ref = hf_current_est(m0, th, np.radians(7.0)) * 12.0 / (1j * w)
    np.testing.assert_allclose(i, ref, rtol=1e-12)


def test_brief_section6_numbers(ecce):
    """The ecce2010 preset reproduces every number the brief quotes for it."""
    s = summarize(ecce)
    assert s["psi_lut_peak_deg"] == pytest.approx(4.03, abs=0.005)
    # peaks at about 17 and 103 deg (period 180 deg)
    assert min(abs(s["psi_lut_min_at_deg"] - 17), abs(s["psi_lut_min_at_deg"] - 197)) < 1.0
    assert min(abs(s["psi_lut_max_at_deg"] - 103), abs(s["psi_lut_max_at_deg"] - 283)) < 1.0
    assert s["L_d_range_H"] == pytest.approx([3.19e-3, 3.82e-3], abs=0.006e-3)
    assert s["L_q_range_H"] == pytest.approx([4.15e-3, 4.77e-3], abs=0.006e-3)
    assert s["L_dq_abs_max_H"] == pytest.approx(0.313e-3, abs=0.001e-3)
    assert s["saliency_range_H"] == pytest.approx([0.32e-3, 1.58e-3], abs=0.006e-3)
    assert s["saliency_min_at_deg"] == pytest.approx([60.0, 240.0], abs=0.2)
    assert s["hf_current_mean_A"] == pytest.approx(0.50, abs=0.02)
    assert s["err_nolut_max_deg"] == pytest.approx(20.6, abs=0.05)
    assert s["gain_nolut_min"] == pytest.approx(0.60, abs=0.01)
    assert s["gain_nolut_max"] == pytest.approx(2.93, abs=0.01)
    assert s["gain_nolut_max_at_deg"] % 180 == pytest.approx(60.0, abs=0.2)


def test_hf_current_amplitude_scales_with_voltage(ecce):
    th = theta_grid(36)
    np.testing.assert_allclose(hf_current_amplitude(ecce, th, 24.0), 2 * hf_current_amplitude(ecce, th, 12.0))


def test_resistive_lut_zeroes_the_demodulated_error(ecce):
    """With R_s the eq. (12) LUT leaves a demodulated error at theta_err = 0 (a position bias of
    up to ~2 deg for ecce2010 at 1 kHz); psi_lut_resistive removes it, and reduces to eq. (12)
    when R_s = 0."""
    th = theta_grid(720)
    lut_r = psi_lut_resistive(ecce, th, 1000.0)
    np.testing.assert_allclose(demod_ratio(ecce, th, 0.0, 12.0, 1000.0, lut_r), 0.0, atol=1e-14)
    biased = demod_ratio(ecce, th, 0.0, 12.0, 1000.0, psi_lut(ecce, th))
    assert np.abs(biased).max() > 3e-3  # clearly non-zero: ~0.2 deg of current phase
    ideal = replace(ecce, R_s=0.0)
    np.testing.assert_allclose(psi_lut_resistive(ideal, th, 1000.0), psi_lut(ecce, th), atol=1e-14)
    np.testing.assert_allclose(demod_ratio(ideal, th, 0.0, 12.0, 1000.0, psi_lut(ecce, th)), 0.0, atol=1e-14)
    # position bias of the eq. (12) LUT: the error at which the demodulated signal vanishes
    from scipy.optimize import brentq

    bias = [
        brentq(lambda e, t=t: demod_ratio(ecce, t, e, 12.0, 1000.0, psi_lut(ecce, t + e)), -0.2, 0.2)
        for t in np.radians([0.0, 15.0, 30.0, 60.0, 90.0])
    ]
    np.testing.assert_allclose(np.degrees(bias), [1.63, 1.95, 1.75, 0.0, -1.75], atol=0.02)


def test_resistive_lut_sign_property(ecce):
    th = theta_grid(720)[:, None]
    e = np.radians([-15, -5, -0.5, 0.5, 5, 15])[None, :]
    r = demod_ratio(ecce, th, e, 12.0, 1000.0, psi_lut_resistive(ecce, th + e, 1000.0))
    assert np.all(np.sign(r) == -np.sign(e))

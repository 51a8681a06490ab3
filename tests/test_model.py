"""The inductance model: eq. (3), the numeric abc -> dq transform against the closed forms of
the brief, harmonics, tables and derivatives."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import ECCE, salient_params, theta_grid
from linsense.errors import InputError
from linsense.model.frames import T_CLARKE, T_CLARKE_INV, ab_to_abc, abc_to_ab
from linsense.model.inductance import InductanceModel

T3 = 2 * np.pi / 3


def closed_form_dq(p, theta):
    """Brief section 3 (derived symbolically; the paper's eq. 7 agrees)."""
    c = np.cos(2 * theta - T3)
    s = np.sin(2 * theta - T3)
    L_d = p["L0"] + p["L2"] / 2 - p["M0"] + p["M2"] - 2 / 3 * p["dM0"] * (1 + c)
    L_q = p["L0"] - p["L2"] / 2 - p["M0"] - p["M2"] - 2 / 3 * p["dM0"] * (1 - c)
    L_dq = 2 / 3 * p["dM0"] * s
    return L_d, L_q, L_dq


def test_eq3_entries():
    """from_params reproduces paper eq. (3) literally."""
    th = theta_grid()
    p = ECCE
    e = InductanceModel.from_params(**p).entries(th)
    expected = [
        p["L0"] + p["L2"] * np.cos(2 * th),
        p["L0"] + p["L2"] * np.cos(2 * th + T3),
        p["L0"] + p["L2"] * np.cos(2 * th - T3),
        p["M0"] + p["M2"] * np.cos(2 * th - T3),
        p["M0"] + p["M2"] * np.cos(2 * th) + p["dM0"],
        p["M0"] + p["M2"] * np.cos(2 * th + T3) + p["dM0"],
    ]
    np.testing.assert_allclose(e, np.array(expected).T, rtol=0, atol=1e-15)


@settings(max_examples=60, deadline=None)
@given(salient_params(), st.floats(-10.0, 10.0))
def test_numeric_transform_matches_closed_forms(p, theta):
    L = InductanceModel.from_params(**p).L_dq(np.array([theta, theta + 1.0]))
    L_d, L_q, L_dq = closed_form_dq(p, np.array([theta, theta + 1.0]))
    scale = p["L0"]
    np.testing.assert_allclose(L[:, 0, 0], L_d, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(L[:, 1, 1], L_q, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(L[:, 0, 1], L_dq, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(L[:, 1, 0], L_dq, rtol=0, atol=1e-12 * scale)


def test_printed_eq5_has_sign_errors():
    """The paper's printed eq. (5) disagrees with the transform in the dM0 terms (brief sec. 3)."""
    th = theta_grid()
    p = ECCE
    L = InductanceModel.from_params(**p).L_dq(th)
    c, s = np.cos(2 * th - T3), np.sin(2 * th - T3)
    printed_L_d = p["L0"] + p["L2"] / 2 - p["M0"] + p["M2"] + 2 / 3 * p["dM0"] * (1 - c)
    printed_L_dq = -2 / 3 * p["dM0"] * s
    assert np.abs(L[:, 0, 0] - printed_L_d).max() > 0.5e-3
    assert np.abs(L[:, 0, 1] - printed_L_dq).max() > 0.5e-3


def test_no_end_effect_gives_constant_dq():
    """dM0 = 0: L_dq = 0 and constant L_d, L_q (paper eq. 6 / Fig. 5)."""
    p = dict(ECCE, dM0=0.0)
    L = InductanceModel.from_params(**p).L_dq(theta_grid())
    np.testing.assert_allclose(L[:, 0, 1], 0.0, atol=1e-17)
    np.testing.assert_allclose(L[:, 0, 0], p["L0"] + p["L2"] / 2 - p["M0"] + p["M2"], rtol=1e-12)
    np.testing.assert_allclose(L[:, 1, 1], p["L0"] - p["L2"] / 2 - p["M0"] - p["M2"], rtol=1e-12)
    assert np.ptp(L[:, 0, 0]) < 1e-15 and np.ptp(L[:, 1, 1]) < 1e-15


def test_without_end_effect_removes_only_dM0():
    m = InductanceModel.from_params(**ECCE, harmonics={4: (0.05e-3, -0.02e-3)})
    ideal = m.without_end_effect()
    diff = m.entries(theta_grid()) - ideal.entries(theta_grid())
    np.testing.assert_allclose(diff[:, :4], 0.0, atol=1e-18)
    np.testing.assert_allclose(diff[:, 4:], ECCE["dM0"], rtol=1e-12)


def test_clarke_pair_and_symmetry():
    np.testing.assert_allclose(T_CLARKE @ T_CLARKE_INV, np.eye(2), atol=1e-15)
    x = np.array([1.0, -0.3, -0.7])
    np.testing.assert_allclose(ab_to_abc(abc_to_ab(x)), x, atol=1e-15)
    L_ab = InductanceModel.from_params(**ECCE).L_ab(theta_grid())
    np.testing.assert_allclose(L_ab[:, 0, 1], L_ab[:, 1, 0], atol=1e-18)


def test_flux_in_dq_equals_transformed_abc_flux():
    """L_dq i_dq equals the Park transform of L_abc i_abc for zero-sequence-free currents."""
    m = InductanceModel.from_params(**ECCE)
    rng = np.random.default_rng(1)
    for theta in rng.uniform(-4, 4, 10):
        i_dq = rng.normal(size=2)
        c, s = np.cos(theta), np.sin(theta)
        i_ab = np.array([[c, -s], [s, c]]) @ i_dq
        lam_abc = m.L_abc(theta) @ ab_to_abc(i_ab)
        lam_dq = np.array([[c, s], [-s, c]]) @ abc_to_ab(lam_abc)
        np.testing.assert_allclose(m.L_dq(theta) @ i_dq, lam_dq, atol=1e-15)


@pytest.mark.parametrize("harm", [None, {4: (0.08e-3, -0.05e-3), 6: (-0.02e-3, 0.01e-3)}])
def test_three_phase_symmetry_of_harmonics(harm):
    """L_B(theta) = L_A(theta - 2pi/3), L_C(theta) = L_A(theta + 2pi/3); same for the mutuals
    apart from the end-effect offset."""
    m = InductanceModel.from_params(**ECCE, harmonics=harm)
    th = theta_grid()
    e = m.entries(th)
    eB = m.entries(th - T3)
    eC = m.entries(th + T3)
    np.testing.assert_allclose(e[:, 1], eB[:, 0], atol=1e-17)
    np.testing.assert_allclose(e[:, 2], eC[:, 0], atol=1e-17)
    np.testing.assert_allclose(e[:, 4], eB[:, 3] + ECCE["dM0"], atol=1e-17)  # M_BC from M_AB
    np.testing.assert_allclose(e[:, 5], eC[:, 3] + ECCE["dM0"], atol=1e-17)  # M_CA from M_AB
    # each mutual is even about the axis midway between its phases (A-B midway at pi/3)
    np.testing.assert_allclose(m.entries(np.pi / 3 + th)[:, 3], m.entries(np.pi / 3 - th)[:, 3], atol=1e-17)


def test_harmonic_orders_validated():
    with pytest.raises(InputError, match="even"):
        InductanceModel.from_params(**ECCE, harmonics={3: (1e-4, 0.0)})


@pytest.mark.parametrize("harm", [None, {4: (0.08e-3, -0.05e-3)}])
def test_table_fit_interpolates_exactly(harm):
    ref = InductanceModel.from_params(**ECCE, harmonics=harm)
    th_tab = np.linspace(0, 2 * np.pi, 36, endpoint=False)
    tab = InductanceModel.from_table(th_tab, ref.entries(th_tab))
    th = theta_grid(997)
    np.testing.assert_allclose(tab.entries(th), ref.entries(th), atol=1e-15)
    np.testing.assert_allclose(tab.L_dq(th), ref.L_dq(th), atol=1e-15)


def test_derivatives_match_finite_differences():
    m = InductanceModel.from_params(**ECCE, harmonics={4: (0.08e-3, -0.05e-3)})
    th = theta_grid(200)
    h = 1e-6
    fd = (m.L_dq(th + h) - m.L_dq(th - h)) / (2 * h)
    np.testing.assert_allclose(m.dL_dq(th), fd, atol=1e-10)
    fd_e = (m.entries(th + h) - m.entries(th - h)) / (2 * h)
    np.testing.assert_allclose(m.entries(th, 1), fd_e, atol=1e-10)


@pytest.mark.parametrize("L4, M4", [(1e-4, 0.0), (0.0, 1e-4), (1e-4, -0.5e-4), (-2e-4, 3e-4)])
def test_4theta_harmonics_appear_as_6theta_ripple(L4, M4):
    """Mirror-symmetric 4 theta harmonics reach the currents only as k = L4/2 + M4, as a 6 theta
    ripple of L_d, L_q and a 6 theta cross-coupling L_dq = -k sin(6 theta): even a balanced motor
    then needs a (6 theta) LUT. M4 = -L4/2 is pure zero sequence and invisible."""
    base = InductanceModel.from_params(**dict(ECCE, dM0=0.0))
    m = InductanceModel.from_params(**dict(ECCE, dM0=0.0), harmonics={4: (L4, M4)})
    th = theta_grid()
    d = m.L_dq(th) - base.L_dq(th)
    k = L4 / 2 + M4
    np.testing.assert_allclose(d[:, 0, 0], k * np.cos(6 * th), atol=1e-17)
    np.testing.assert_allclose(d[:, 1, 1], -k * np.cos(6 * th), atol=1e-17)
    np.testing.assert_allclose(d[:, 0, 1], -k * np.sin(6 * th), atol=1e-17)


# ---------------------------------------------------------------------- an even number of positions
@pytest.mark.parametrize("n", [8, 10, 12, 36, 64, 124, 126])
def test_an_even_table_is_interpolated_with_its_nyquist_cosine(n):
    """N equally spaced positions, N even, are passed through as by a real DFT: the orders up to N / 2,
    the last the cosine alone with its half weight ``sum y_i (-1)^i / N`` (the fit dropped it: 8
    positions of a motor with L4 were off by L4 at every point)."""
    rng = np.random.default_rng(n)
    theta = 2 * np.pi * np.arange(n) / n
    y = 1e-3 * rng.normal(size=(n, 6))
    tab = InductanceModel.from_table(theta, y)
    assert tab.max_order == n // 2
    np.testing.assert_allclose(tab.entries(theta), y, rtol=0, atol=1e-15)
    sign = (-1.0) ** np.arange(n)
    np.testing.assert_allclose(tab.a[:, n // 2], sign @ y / n, rtol=0, atol=1e-17)
    assert np.all(tab.b[:, n // 2] == 0.0)
    # the other orders are the DFT's (weight 2 / N)
    k = 3
    np.testing.assert_allclose(tab.a[:, k], 2 / n * np.cos(k * theta) @ y, rtol=0, atol=1e-17)
    np.testing.assert_allclose(tab.b[:, k], 2 / n * np.sin(k * theta) @ y, rtol=0, atol=1e-17)


def test_an_even_table_of_a_motor_with_its_nyquist_harmonic():
    """8 positions of eq. 3 with L4 = 0.1 mH: the model through every position (it was 1e-4 H off)."""
    ref = InductanceModel.from_params(**ECCE, harmonics={4: (0.1e-3, 0.0)})
    theta = 2 * np.pi * np.arange(8) / 8
    tab = InductanceModel.from_table(theta, ref.entries(theta))
    np.testing.assert_allclose(tab.entries(theta), ref.entries(theta), rtol=0, atol=1e-16)


@pytest.mark.parametrize("n, order, want", [
    (127, None, 63),  # (odd: exact up to 127 positions)
    (128, None, 63),  # (N / 2 = 64 beyond the limit: least squares to 63, no Nyquist term)
    (16, 5, 5),       # (table_max_order below N / 2: least squares, sines kept)
    (16, 8, 8),       # (table_max_order = N / 2: the Nyquist cosine)
    (16, 20, 8),
])
def test_the_order_of_a_table_fit(n, order, want):
    theta = 2 * np.pi * np.arange(n) / n
    y = np.random.default_rng(1).normal(size=(n, 6))
    tab = InductanceModel.from_table(theta, y, order)
    assert tab.max_order == want
    if 2 * want >= n - 1:  # (as many coefficients as positions: through them)
        np.testing.assert_allclose(tab.entries(theta), y, rtol=0, atol=1e-12)
    if order == 5:
        assert np.any(tab.b[:, 5] != 0.0)


def test_an_even_table_with_jittered_positions_is_still_passed_through():
    """Positions not equally spaced (a bench), an even number: N coefficients for N positions."""
    rng = np.random.default_rng(7)
    theta = np.sort(2 * np.pi * (np.arange(10) + rng.uniform(-0.2, 0.2, 10)) / 10)
    ref = InductanceModel.from_params(**ECCE, harmonics={4: (0.1e-3, 0.05e-3)})
    tab = InductanceModel.from_table(theta, ref.entries(theta))
    np.testing.assert_allclose(tab.entries(theta), ref.entries(theta), rtol=0, atol=1e-15)

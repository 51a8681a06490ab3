"""The EMF observer block (``ls_emf``, ``linsense/ls_emf.h``) through the binding, against the Python
motor model's equations (docs/theory.md, "The EMF observer at speed").

The plant is the continuous model ``v_ab = R i_ab + d(L_ab(theta) i_ab)/dt + omega psi_pm (-sin,
cos)`` with ``L_ab`` from :mod:`linsense.model.inductance`, the period's mean voltage by Gauss-Legendre
quadrature; the block must recover the estimate's error within the period model's bound (no end
effect) and within the end effect's own bound (with it); its refusals name the field; the low-speed
limit of :mod:`linsense.analysis.emf` is the speed at which the running block's bound is the design's.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from linsense import ctrl
from linsense.analysis.emf import emf_pm_compensation, emf_speed_limit
from linsense.errors import ConfigError, InputError
from linsense.model.motor import load_motor

FS = 16000.0
CLASS = Path(__file__).resolve().parents[1] / "src" / "linsense" / "examples" / "motors" / "class"
GL_X, GL_W = np.polynomial.legendre.leggauss(8)


def _cfg(l_d: float, l_q: float, r_s: float, **kw) -> dict:
    return {"fs": FS, "r_s": r_s, "l_d": l_d, "l_q": l_q, "f_lpf": 200.0, "omega_max": 2000.0, "err_r": 0.05,
            "err_l": 0.1, "u_err": 0.3, "i_noise": 0.01, "psi_pm": 0.0, "pm_shift": 0.0, "neg_re": 0.0,
            "neg_im": 0.0, "harm_order": [0, 0], "harm_re": [0.0, 0.0], "harm_im": [0.0, 0.0]} | kw


def _means(model) -> tuple[float, float]:
    th = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    ldq = model.L_dq(th)
    return float(ldq[:, 0, 0].mean()), float(ldq[:, 1, 1].mean())


def _run(motor, model, omega: float, err: float, i_dq: tuple[float, float], n: int = 1600,
         pm: dict | None = None, per_phase: bool = False):
    """The block on the model's steady state (a constant rotor-frame current) with the estimate
    leading by ``err``; returns the state. ``pm``: the block's imbalance fields; ``per_phase``: the
    magnets' EMF from ``Motor.psi_pm_abc`` (Clarke-transformed) instead of the balanced one."""
    from linsense.model.frames import T_CLARKE

    l_d, l_q = _means(model)
    state, _ = ctrl.emf_init(_cfg(l_d, l_q, motor.R_s) | (pm or {}))
    psi, T = motor.psi_pm, 1.0 / FS
    i_rot = np.array(i_dq)

    def i_ab(th):
        c, s = np.cos(th), np.sin(th)
        return np.stack([c * i_rot[0] - s * i_rot[1], s * i_rot[0] + c * i_rot[1]], axis=-1)

    def v_ab(th):
        # R i + dL/dtheta omega i + L di/dt + omega psi (-sin, cos); di/dt = omega J i
        i = i_ab(th)
        di = omega * np.stack([-i[..., 1], i[..., 0]], axis=-1)
        L, dL = model.L_ab(th), model.L_ab(th, derivative=1)
        mv = "...ij,...j->...i"
        emf = (omega * motor.psi_pm_abc(th, derivative=1) @ T_CLARKE.T if per_phase
               else omega * psi * np.stack([-np.sin(th), np.cos(th)], axis=-1))
        return motor.R_s * i + omega * np.einsum(mv, dL, i) + np.einsum(mv, L, di) + emf

    v, i2, e2 = ctrl.ffi.new("LS_REAL[2]"), ctrl.ffi.new("LS_REAL[2]"), []
    k = np.arange(n)
    th_end = 1.0 + omega * T * k
    # the period's mean voltage: Gauss-Legendre over [t_k - T, t_k]
    th_q = th_end[:, None] - 0.5 * omega * T * (1.0 - GL_X[None, :])
    vm = np.einsum("kqj,q->kj", v_ab(th_q), 0.5 * GL_W)
    im = i_ab(th_end)
    for j in range(n):
        v[0], v[1] = vm[j]
        i2[0], i2[1] = im[j]
        ctrl.lib.ls_emf_step(state, v, i2, math.cos(th_end[j] + err), math.sin(th_end[j] + err), omega, 1.0)
        e2.append(float(state.eps))
    return state, np.array(e2), th_end


@pytest.mark.parametrize("name", ["ecce2010", "m30_low", "m90_heavy"])
@pytest.mark.parametrize("speed, err", [(0.8, 0.2), (-0.5, -0.1), (2.0, -0.3)])
def test_recovers_the_error_on_the_model_without_end_effect(name, speed, err):
    motor = load_motor(name if name == "ecce2010" else str(CLASS / f"{name}.toml"))
    model = motor.inductance.without_end_effect()
    omega = 2.0 * np.pi * speed / motor.pole_pitch
    state, eps, _ = _run(motor, model, omega, err, (0.0, 2.0))
    # the period model's error (docs/theory.md): (w T)^2 / 6 of the impedance drop against the EMF,
    # and the float arithmetic's floor
    wt = omega / FS
    l_d, l_q = _means(model)
    tol = wt**2 / 6.0 * (motor.R_s + abs(omega) * l_q) * 2.0 / abs(omega * motor.psi_pm) + 3e-4
    assert abs(eps[-1] + err) < tol
    assert abs(float(state.mag) - abs(omega) * motor.psi_pm) < 1e-3 * abs(omega) * motor.psi_pm


def test_the_end_effect_costs_its_anisotropy():
    """With the end effect, the inductance's stationary anisotropy (docs/theory.md: |L_e| i / psi at
    most, turning at 2 theta) is the error left; measured and bounded."""
    motor = load_motor("ecce2010")
    model = motor.inductance
    omega = 2.0 * np.pi * 1.0 / motor.pole_pitch
    th = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    # the stationary part: the anisotropy of L_ab's mean over the period (the saliency averages out)
    mean = model.L_ab(th).mean(axis=0)
    l_e = float(np.hypot(0.5 * (mean[0, 0] - mean[1, 1]), mean[0, 1]))
    _, eps, _ = _run(motor, model, omega, 0.0, (0.0, 2.0), n=2400)
    peak = float(np.max(np.abs(eps[800:])))
    bound = l_e * 2.0 / motor.psi_pm
    print(f"ecce2010 at 1 m/s, 2 A: end-effect error peak {np.degrees(peak):.3f} deg, "
          f"bound {np.degrees(bound):.3f}")
    assert 0.2 * bound < peak <= bound * 1.05


@pytest.mark.parametrize("field, value", [("fs", 0.0), ("r_s", -1.0), ("l_d", 0.0), ("l_q", float("nan")),
                                          ("f_lpf", 1000.0), ("omega_max", 5000.0), ("err_r", 0.95),
                                          ("err_l", -0.1), ("u_err", -1.0), ("i_noise", float("inf")),
                                          ("psi_pm", -0.1), ("pm_shift", 0.6), ("neg_re", 0.5),
                                          ("neg_im", float("nan"))])
def test_init_refuses_each_bad_field(field, value):
    with pytest.raises(ConfigError, match=rf"ls_emf: {field} = .*allowed: ") as exc:
        ctrl.emf_init(_cfg(3e-3, 4e-3, 9.0) | {field: value})
    assert exc.value.status == ctrl.lib.LS_ERR_PARAM
    if field == "f_lpf":
        assert f"{float(ctrl.lib.LS_EMF_FLPF_FS_MAX):g} fs" in str(exc.value)
    if field == "neg_re":
        assert "not a three-phase motor" in str(exc.value)


def test_init_names_an_imbalance_without_a_flux():
    """A negative sequence with ``psi_pm`` 0: neither field alone is wrong, the pair is; both named."""
    with pytest.raises(ConfigError, match=r"ls_emf: psi_pm = 0.*neg_im = 0.01") as exc:
        ctrl.emf_init(_cfg(3e-3, 4e-3, 9.0) | {"neg_im": 0.01})
    assert "neg_re" not in str(exc.value).split("allowed")[0]


def test_speed_limit_is_the_running_blocks_bound():
    """At the design's speed the block's bound, run on the model, is the design's eps_max; above
    it lower, below higher; and more dead time raises the speed."""
    motor = load_motor("ecce2010")
    kw = {"v_dc": 72.0, "f_pwm": FS, "dead_time": 0.8e-6, "i_mag": 2.0, "f_lpf": 200.0, "dt_residual": 0.25}
    lim = emf_speed_limit(motor, **kw)
    assert 0.1 < lim.v_min < 2.0
    assert emf_speed_limit(motor, **(kw | {"dt_residual": 1.0})).v_min > lim.v_min
    model = motor.inductance.without_end_effect()
    bounds = []
    for k in (0.8, 1.0, 1.25):
        state, _ = ctrl.emf_init({"fs": FS, "r_s": motor.R_s, "l_d": lim.l_d, "l_q": lim.l_q, "f_lpf": 200.0,
                                  "omega_max": float(ctrl.lib.LS_EMF_OMEGA_TS_MAX) * FS, "err_r": 0.05,
                                  "err_l": 0.1, "u_err": lim.u_err, "i_noise": 0.01}
                                 | emf_pm_compensation(motor).cfg())
        st, _, _ = _run(motor, model, k * lim.omega_min, 0.0, (0.0, 2.0))
        # the running block's bound at the design's (mean) inductances: its own state's bound recomputed
        b = ctrl.lib.ls_emf_bound(state, st.mag, math.hypot(st.i_d, st.i_q), 0.0, k * lim.omega_min, 1.0)
        bounds.append(float(b))
    assert bounds[0] > math.radians(3.0) > bounds[2]
    assert bounds[1] == pytest.approx(math.radians(3.0), rel=2e-3)


@pytest.mark.parametrize("r_s, l_d", [(9.0, 1e-9), (0.0, 3.5e-3)])
def test_noise_bound_is_the_low_passed_noise(r_s, l_d):
    """``b_noise`` is three standard deviations of the low-passed EMF from a white current noise
    (docs/theory.md, "The bound and the low-speed limit"): each of its two terms alone (the
    resistive drop with a negligible inductance, the inductive one without resistance) against the
    block run on pure noise (no voltage, standstill, the estimate at 0)."""
    sigma = 0.01
    state, _ = ctrl.emf_init(_cfg(l_d, l_d, r_s, i_noise=sigma))
    noise = np.random.default_rng(11).normal(0.0, sigma, (60000, 2))
    v, i = ctrl.ffi.new("LS_REAL[2]", [0.0, 0.0]), ctrl.ffi.new("LS_REAL[2]")
    e_d = np.empty(len(noise))
    for k, (a, b) in enumerate(noise):
        i[0], i[1] = a, b
        ctrl.lib.ls_emf_step(state, v, i, 1.0, 0.0, 0.0, 1.0)
        e_d[k] = state.e_d
    got = float(e_d[2000:].std())
    assert got == pytest.approx(state.b_noise / 3.0, rel=0.04)


@pytest.mark.parametrize("kw, name", [({"eps_max": math.pi / 2}, "eps_max"), ({"eps_max": 0.0}, "eps_max"),
                                      ({"i_mag": -1.0}, "i_mag"), ({"k_r": 0.0}, "k_r")])
def test_speed_limit_refuses_arguments_the_c_function_reads_as_never(kw, name):
    """``ls_emf_omega_min`` answers "no speed" (LS_REAL_MAX) for a bound of pi/2 or more, a negative
    current or a zero resistance scale: the design must hear a refusal, not an infinite speed."""
    args = {"i_mag": 2.0, "eps_max": math.radians(3.0), "k_r": 1.0} | kw
    with pytest.raises(InputError, match=name):
        emf_speed_limit("ecce2010", v_dc=72.0, f_pwm=FS, dead_time=0.8e-6, f_lpf=200.0, **args)


@pytest.mark.parametrize("v0", [1.0, -1.0])
def test_on_the_c_plant_both_directions(v0):
    """The block on the C plant (average model, ecce2010 with its end effect, the mover prescribed
    at +-1 m/s, the voltages of a 2 A q current applied open loop): with the estimate leading by
    0.01 rad it reads eps = -0.01 rad in both directions (the sign of the EMF, the estimated frame
    and the half-period correction, which alone is worth 0.2 deg here, against the simulator's own
    conventions), the end effect's ripple within its 0.3 deg peak."""
    from linsense.model.frames import T_CLARKE, T_CLARKE_INV
    from linsense.sim import core

    motor = load_motor("ecce2010")
    l_d, l_q = _means(motor.inductance)
    setup = core.PlantSetup(fidelity="average", v_dc=300.0, f_pwm=FS, dead_time=0.0, i_noise=0.0, adc_bits=0,
                            motion="prescribed", v0=v0, x0=0.01, x_min=-10.0, x_max=10.0)
    cfg = core.sim_cfg(motor, setup)
    n, T, err = 3200, 1.0 / FS, 0.01
    w = 2 * np.pi * v0 / motor.pole_pitch
    thm = 2 * np.pi * 0.01 / motor.pole_pitch + w * T * (np.arange(n) + 0.5)
    vd, vq = -w * l_q * 2.0, motor.R_s * 2.0 + w * motor.psi_pm
    v_ab = math.sin(w * T / 2) / (w * T / 2) * np.stack([np.cos(thm) * vd - np.sin(thm) * vq,
                                                         np.sin(thm) * vd + np.cos(thm) * vq], axis=1)
    run = core.run_open_loop(cfg, np.full(n, T), v_ab @ T_CLARKE_INV.T + 150.0)
    i_ab = run.arrays["i_abc"] @ T_CLARKE.T
    theta = 2 * np.pi * run.arrays["x"] / motor.pole_pitch + err
    state, _ = ctrl.emf_init(_cfg(l_d, l_q, motor.R_s, u_err=0.0, i_noise=0.0))
    v, i = ctrl.ffi.new("LS_REAL[2]"), ctrl.ffi.new("LS_REAL[2]")
    eps = []
    for j in range(n + 1):
        if j:
            v[0], v[1] = v_ab[j - 1]
        i[0], i[1] = i_ab[j]
        eps.append(ctrl.lib.ls_emf_step(state, v, i, math.cos(theta[j]), math.sin(theta[j]), w, 1.0))
    eps = np.array(eps[n // 2:])
    assert abs(np.hypot(*i_ab[-1]) - 2.0) < 0.1
    assert abs(eps.mean() + err) < 1e-3
    assert np.abs(eps + err).max() < math.radians(0.35)


def _unbalanced(motor, scale, shift_deg):
    import dataclasses

    from linsense.model.motor import PmPhases

    shift = tuple(math.radians(d) for d in shift_deg)
    return dataclasses.replace(motor, pm_phases=PmPhases(tuple(scale), shift))


def _lowpass_gain(state, omega: float) -> float:
    """The block's first-order low-pass at the frequency ``2 |omega|`` (the negative sequence's in
    the estimated frame)."""
    a, x = float(state.alpha), 2.0 * abs(omega) / FS
    return a / math.sqrt(1.0 - 2.0 * (1.0 - a) * math.cos(x) + (1.0 - a) ** 2)


@pytest.mark.parametrize("name", ["ecce2010", "m60_pos20k"])
@pytest.mark.parametrize("scale, shift", [((1.0, 0.96, 1.0), (0.0, 0.0, 0.0)),
                                          ((0.95, 1.0, 0.98), (1.0, -1.5, 0.0))])
@pytest.mark.parametrize("speed, err", [(1.0, 0.0), (-0.7, 0.15)])
def test_imbalance_compensated_on_the_model(name, scale, shift, speed, err):
    """The magnets' per-phase flux (``Motor.psi_pm_abc``, docs/theory.md section 10) on the model
    without end effect: configured by :func:`emf_pm_compensation`, the block recovers the error
    within the balanced tolerance plus the second-order ``|n| |err|`` (the negative sequence
    predicted at the estimated angle); unconfigured it reads the offset ``arg P`` and the ripple
    ``2 |n|`` peak to peak through its low-pass at ``2 omega``."""
    motor = _unbalanced(load_motor(name if name == "ecce2010" else str(CLASS / f"{name}.toml")), scale, shift)
    model = motor.inductance.without_end_effect()
    comp = emf_pm_compensation(motor)
    omega = 2.0 * np.pi * speed / motor.pole_pitch
    n_per = int(np.ceil(2.0 * np.pi / abs(omega) * FS))
    _, l_q = _means(model)
    tol = (omega / FS) ** 2 / 6.0 * (motor.R_s + abs(omega) * l_q) * 2.0 / abs(omega * motor.psi_pm) + 3e-4
    st, eps, _ = _run(motor, model, omega, err, (0.0, 2.0), n=1600 + n_per, pm=comp.cfg(), per_phase=True)
    after = eps[1600:]
    assert np.abs(after + err).max() < tol + comp.neg_mag * abs(err)
    st, eps, _ = _run(motor, model, omega, err, (0.0, 2.0), n=1600 + n_per, per_phase=True)
    before = eps[1600:]
    ripple = 2.0 * comp.neg_mag * _lowpass_gain(st, omega)
    assert np.ptp(before) == pytest.approx(ripple, rel=0.1)
    assert before.mean() + err == pytest.approx(comp.pm_shift, abs=0.1 * comp.neg_mag + tol)


def _plant_eps(motor, v0: float, err: float, pm: dict | None, n: int = 3200):
    """The block on the C plant (average model, the motor's end effect and magnets, the mover
    prescribed at ``v0``, the voltages of a 2 A q current applied open loop), the estimate leading
    by ``err``; eps over the second half and the currents."""
    from linsense.model.frames import T_CLARKE, T_CLARKE_INV
    from linsense.sim import core

    l_d, l_q = _means(motor.inductance)
    setup = core.PlantSetup(fidelity="average", v_dc=300.0, f_pwm=FS, dead_time=0.0, i_noise=0.0, adc_bits=0,
                            motion="prescribed", v0=v0, x0=0.01, x_min=-10.0, x_max=10.0)
    cfg = core.sim_cfg(motor, setup)
    T = 1.0 / FS
    w = 2 * np.pi * v0 / motor.pole_pitch
    thm = 2 * np.pi * 0.01 / motor.pole_pitch + w * T * (np.arange(n) + 0.5)
    vd, vq = -w * l_q * 2.0, motor.R_s * 2.0 + w * motor.psi_pm
    v_ab = math.sin(w * T / 2) / (w * T / 2) * np.stack([np.cos(thm) * vd - np.sin(thm) * vq,
                                                         np.sin(thm) * vd + np.cos(thm) * vq], axis=1)
    run = core.run_open_loop(cfg, np.full(n, T), v_ab @ T_CLARKE_INV.T + 150.0)
    i_ab = run.arrays["i_abc"] @ T_CLARKE.T
    theta = 2 * np.pi * run.arrays["x"] / motor.pole_pitch + err
    state, _ = ctrl.emf_init(_cfg(l_d, l_q, motor.R_s, u_err=0.0, i_noise=0.0) | (pm or {}))
    v, i = ctrl.ffi.new("LS_REAL[2]"), ctrl.ffi.new("LS_REAL[2]")
    eps = []
    for j in range(n + 1):
        if j:
            v[0], v[1] = v_ab[j - 1]
        i[0], i[1] = i_ab[j]
        eps.append(ctrl.lib.ls_emf_step(state, v, i, math.cos(theta[j]), math.sin(theta[j]), w, 1.0))
    return np.array(eps[n // 2:]), i_ab


@pytest.mark.parametrize("v0", [1.0, -1.0])
def test_imbalance_on_the_c_plant(v0):
    """ecce2010 with its end effect and one phase linking 4 % less magnet flux (``[pm_flux] scale
    [1, 0.96, 1]``) on the C plant at +-1 m/s: uncompensated, eps carries the 2 theta ripple
    (``2 |n|`` p-p through the low-pass, on top of the end effect's own); compensated from the
    motor file, eps is the balanced motor's within 0.02 deg (the second-order residual and the
    current's own ripple, which the negative sequence drives)."""
    base = load_motor("ecce2010")
    motor = _unbalanced(base, (1.0, 0.96, 1.0), (0.0, 0.0, 0.0))
    comp = emf_pm_compensation(motor)
    err = 0.01
    bal, _ = _plant_eps(base, v0, err, None)
    before, _ = _plant_eps(motor, v0, err, None)
    after, i_ab = _plant_eps(motor, v0, err, comp.cfg())
    d_before, d_after = np.degrees(np.ptp(before - bal)), np.degrees(np.ptp(after - bal))
    print(f"ecce2010 [1, 0.96, 1] at {v0:+.0f} m/s: eps p-p balanced {np.degrees(np.ptp(bal)):.3f} deg, "
          f"unbalanced {np.degrees(np.ptp(before)):.3f} deg, "
          f"compensated {np.degrees(np.ptp(after)):.3f} deg; "
          f"against the balanced: {d_before:.3f} -> {d_after:.4f} deg p-p")
    assert abs(np.hypot(*i_ab[-1]) - 2.0) < 0.1
    state, _ = ctrl.emf_init(_cfg(3e-3, 4e-3, 9.0))
    ripple = np.degrees(2.0 * comp.neg_mag * _lowpass_gain(state, 2 * np.pi * v0 / base.pole_pitch))
    assert d_before == pytest.approx(ripple, rel=0.15)
    assert d_after < 0.02
    assert abs(after.mean() + err) < 1e-3

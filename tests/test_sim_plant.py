"""The C plant (``csrc/sim/ls_sim_plant.c``): one model, one source of truth, and closed-loop behaviour.

* The maps the C plant evaluates (``ls_sim_plant_eval``: L_ab, dL_ab/dtheta, the alpha-beta PM
  flux and its derivative) equal the Python model (``InductanceModel.L_ab``, the Clarke transform
  of the ABC PM flux with its harmonics) to 1e-12, and the derivatives agree with numerical ones;
* the C force (``ls_sim_force``, alpha-beta with 3/2) equals the ABC co-energy force;
* the end effect on the magnets' flux (per-phase PM flux amplitude and phase) reaches the C plant,
  harmonics included, and the model's own ``Motor.psi_pm_abc`` and ``Motor.force_abc`` equal the
  reference;
* the drive of the firmware library closed around the plant: a sensored 3 mm step, sensorless
  hold with the resistance-aware LUT in both inverter fidelities;
* absurd settings stop the run cleanly with the right fault bit and finite recorded data.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from linsense import ctrl
from linsense.compensation.lut import build_lut
from linsense.model.frames import T_CLARKE, T_CLARKE_INV
from linsense.model.motor import PmHarmonic, PmPhases
from linsense.sim import core
from linsense.sim.plant import fill_plant
from test_sim_accuracy import MOTORS, UNBALANCED, force_abc, motor, pm_abc

DEG = math.pi / 180.0
FS = 16000.0


def motors():
    """The three example motors plus one with triplen and 6k +- 1 PM harmonics at odd phases."""
    out = {name: motor(name) for name in MOTORS}
    rich = (PmHarmonic(3, 0.05, 0.3), PmHarmonic(5, 0.02, -0.7), PmHarmonic(7, 0.01, 1.1),
            PmHarmonic(9, 0.004, 0.2), PmHarmonic(11, 0.003, 2.0), PmHarmonic(13, 0.002, -2.5))
    out["pm_rich"] = dataclasses.replace(motor("harmonic"), pm_harmonics=rich)
    # and the same with the end effect on the magnets' flux: the triplen harmonics no longer cancel
    out["pm_rich_unbalanced"] = dataclasses.replace(out["pm_rich"], pm_phases=UNBALANCED)
    return out


MOTOR_SET = motors()
THETAS = np.concatenate([np.linspace(-2 * np.pi, 4 * np.pi, 181), [0.0, np.pi / 3, 1e-9, 2 * np.pi - 1e-9]])


# ---------------------------------------------------------------------- maps
def _c_maps(cfg, thetas):
    ev = [core.plant_eval(cfg, th) for th in thetas]
    return {k: np.array([e[k] for e in ev]) for k in ev[0]}


def _entries(L_ab):
    return np.stack([L_ab[..., 0, 0], L_ab[..., 1, 1], L_ab[..., 0, 1]], axis=-1)


def full_cfg(m):
    """``sim_cfg`` with every harmonic order of the model (``fill_plant`` with ``tol = 0``)."""
    cfg = core.sim_cfg(m, core.PlantSetup())
    fill_plant(cfg, m, tol=0.0)
    return cfg


@pytest.mark.parametrize("name", list(MOTOR_SET))
def test_c_maps_equal_python_model(name):
    m = MOTOR_SET[name]
    cfg = full_cfg(m)
    c = _c_maps(cfg, THETAS)
    L = _entries(m.inductance.L_ab(THETAS))
    dL = _entries(m.inductance.L_ab(THETAS, 1))
    lpm = np.array([T_CLARKE @ pm_abc(m, th) for th in THETAS])
    dlpm = np.array([T_CLARKE @ pm_abc(m, th, 1) for th in THETAS])
    for key, ref in (("L_ab", L), ("dL_ab", dL), ("lambda_pm", lpm), ("dlambda_pm", dlpm)):
        err = np.abs(c[key] - ref).max() / np.abs(ref).max()
        assert err < 1e-12, f"{name} {key}: relative error {err:.2e}"
    # the L_ab the C side sees is the Python ABC matrix transformed (not a second model)
    L_abc = m.inductance.L_abc(THETAS)
    np.testing.assert_allclose(c["L_ab"], _entries(T_CLARKE @ L_abc @ T_CLARKE_INV), rtol=0,
                               atol=1e-12 * np.abs(L).max())
    # derivatives: central differences of the Python model (4th order, h = 1e-4 rad)
    h = 1e-4

    def num(f):
        return (8 * (f(THETAS + h) - f(THETAS - h)) - (f(THETAS + 2 * h) - f(THETAS - 2 * h))) / (12 * h)

    dL_num = num(lambda t: _entries(m.inductance.L_ab(t)))
    dlpm_num = num(lambda t: np.array([T_CLARKE @ pm_abc(m, th) for th in t]))
    assert np.abs(c["dL_ab"] - dL_num).max() < 1e-7 * np.abs(dL_num).max()
    assert np.abs(c["dlambda_pm"] - dlpm_num).max() < 1e-7 * np.abs(dlpm_num).max()


@pytest.mark.parametrize("name", list(MOTOR_SET))
def test_default_truncation_is_bounded(name):
    """``sim_cfg`` drops trailing orders whose coefficients are all below 1e-12 H (a table's fit
    noise): the C maps then differ from the full model by at most that much per dropped order."""
    m = MOTOR_SET[name]
    cfg, full = core.sim_cfg(m, core.PlantSetup()), full_cfg(m)
    dropped = full.n_order - cfg.n_order
    assert dropped >= 0 and cfg.n_order >= 3
    c, f = _c_maps(cfg, THETAS), _c_maps(full, THETAS)
    k_max = full.n_order - 1
    assert np.abs(c["L_ab"] - f["L_ab"]).max() <= dropped * 1e-12 + 1e-18
    assert np.abs(c["dL_ab"] - f["dL_ab"]).max() <= dropped * k_max * 1e-12 + 1e-18
    assert (c["lambda_pm"] == f["lambda_pm"]).all()


def test_pm_harmonics_matter():
    """The PM harmonics reach the C plant (the comparison above would not see a dropped term)."""
    base = core.sim_cfg(dataclasses.replace(MOTOR_SET["pm_rich"], pm_harmonics=()), core.PlantSetup())
    rich = core.sim_cfg(MOTOR_SET["pm_rich"], core.PlantSetup())
    d = max(np.abs(core.plant_eval(rich, th)["lambda_pm"] - core.plant_eval(base, th)["lambda_pm"]).max()
            for th in THETAS)
    assert d > 0.01 * MOTOR_SET["pm_rich"].psi_pm


def test_pm_phases_matter():
    """The end effect on the magnets' flux reaches the C plant, in both the fundamental and the
    harmonics: against the balanced motor the alpha-beta PM flux differs by about the imbalance
    (8 %, 5 % and degrees of phase), and the triplen harmonics, which cancel in a balanced set, show."""
    m = MOTOR_SET["pm_rich_unbalanced"]
    bal = core.sim_cfg(dataclasses.replace(m, pm_phases=PmPhases()), core.PlantSetup())
    unb = core.sim_cfg(m, core.PlantSetup())
    assert list(unb.pm_dscale) == pytest.approx([0.0, -0.08, 0.05], abs=1e-15)
    assert list(bal.pm_dscale) == [0.0] * 3 and list(bal.pm_shift) == [0.0] * 3
    d = max(np.abs(core.plant_eval(unb, th)["lambda_pm"] - core.plant_eval(bal, th)["lambda_pm"]).max()
            for th in THETAS)
    assert d > 0.03 * m.psi_pm
    # the triplen harmonic (order 3, 5 %) alone: nothing in alpha-beta when balanced, some when not
    only3 = (PmHarmonic(3, 0.05, 0.3),)
    for phases, present in ((PmPhases(), False), (UNBALANCED, True)):
        m3 = dataclasses.replace(m, pm_harmonics=only3, pm_phases=phases)
        m1 = dataclasses.replace(m, pm_harmonics=(), pm_phases=phases)
        c3, c1 = core.sim_cfg(m3, core.PlantSetup()), core.sim_cfg(m1, core.PlantSetup())
        d3 = max(np.abs(core.plant_eval(c3, th)["lambda_pm"] - core.plant_eval(c1, th)["lambda_pm"]).max()
                 for th in THETAS)
        assert (d3 > 1e-3 * m.psi_pm) if present else (d3 < 1e-15 * m.psi_pm), (phases, d3)


def test_pm_phases_enter_the_cache_key():
    """Motors that differ only by the end effect on the magnets' flux are different motors to the
    build cache; a balanced one keeps the key it had before the per-phase flux existed."""
    import hashlib

    from linsense.sim.cache import motor_key

    m = MOTOR_SET["harmonic"]
    u = dataclasses.replace(m, pm_phases=UNBALANCED)
    assert motor_key(u) != motor_key(m)
    h = hashlib.sha256(repr((m.name, m.R_s, m.pole_pitch, m.force_constant, m.mass, m.friction,
                             m.pm_harmonics)).encode())
    h.update(np.ascontiguousarray(m.inductance.a).tobytes())
    h.update(np.ascontiguousarray(m.inductance.b).tobytes())
    assert motor_key(m) == h.hexdigest()


def test_model_pm_flux_and_force_equal_reference():
    """The model's own per-phase PM flux (``Motor.psi_pm_abc``, the back-EMF per phase per rad of
    electrical speed) and force (``Motor.force_abc``) equal the independent ABC reference of
    test_sim_accuracy, balanced or not; the line-to-line back-EMF (what a bench measures without the
    star point) is what the C plant's alpha-beta flux derivative gives."""
    rng = np.random.default_rng(3)
    for name in ("harmonic", "unbalanced"):
        m = MOTOR_SET[name]
        for d in (0, 1):
            got = m.psi_pm_abc(THETAS, d)
            ref = np.array([pm_abc(m, th, d) for th in THETAS])
            assert np.abs(got - ref).max() < 1e-14 * np.abs(ref).max(), (name, d)
        th = rng.uniform(-10, 10, 50)
        i_abc = rng.normal(0.0, 2.0, (50, 2)) @ T_CLARKE_INV.T
        ref = np.array([force_abc(m, t, i) for t, i in zip(th, i_abc, strict=True)])
        assert np.abs(m.force_abc(th, i_abc) - ref).max() < 1e-12 * np.abs(ref).max()
        cfg = full_cfg(m)
        e_ab = np.array([core.plant_eval(cfg, t)["dlambda_pm"] for t in THETAS])  # Wb/rad
        line = T_CLARKE_INV @ e_ab.T  # zero-sequence-free phase values: their differences are exact
        want = m.psi_pm_abc(THETAS, 1).T
        for j, k in ((0, 1), (1, 2), (2, 0)):
            np.testing.assert_allclose(line[j] - line[k], want[j] - want[k], rtol=0,
                                       atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("name", list(MOTOR_SET))
def test_c_force_equals_abc_coenergy(name):
    m = MOTOR_SET[name]
    cfg = full_cfg(m)
    rng = np.random.default_rng(7)
    f_c, f_ref = [], []
    for th in rng.uniform(-10, 10, 200):
        i_ab = rng.normal(0.0, 2.0, 2)
        f_c.append(core.plant_force(cfg, th, i_ab))
        f_ref.append(force_abc(m, th, T_CLARKE_INV @ i_ab))
    f_c, f_ref = np.array(f_c), np.array(f_ref)
    err = np.abs(f_c - f_ref).max() / np.abs(f_ref).max()
    assert err < 1e-12, f"{name}: force relative error {err:.2e}"
    # the force constant: without PM harmonics (and balanced), 1 A on q gives force_constant plus
    # the reluctance part
    cfg0 = full_cfg(dataclasses.replace(m, pm_harmonics=(), pm_phases=PmPhases()))
    kx = 2 * np.pi / m.pole_pitch
    for th in (0.0, 1.0, 2.5):
        i_q = np.array([-math.sin(th), math.cos(th)])
        rel = 0.75 * kx * i_q @ m.inductance.L_ab(th, 1) @ i_q
        assert core.plant_force(cfg0, th, i_q) - rel == pytest.approx(m.force_constant, rel=1e-12)


# ---------------------------------------------------------------------- closed loop
ECCE = motor("ecce2010")
TAU = ECCE.pole_pitch
# the table for the firmware's default injection (elliptical, kappa from ls_drive_default_cfg)
def _default_quad() -> float:
    """The firmware's default elliptical share (the configuration kept alive while its nested
    struct is read: a field of ``cfg.inject`` does not own ``cfg``)."""
    cfg = ctrl.drive_default_cfg()
    return float(cfg.inject.quad)


LUT_R = build_lut(ECCE, 360, f_inj=1000.0, quad=_default_quad())


def _drive(comp=None, **mod):
    cfg = ctrl.drive_default_cfg()
    for k, v in mod.items():
        setattr(cfg.mod, k, v)
    return ctrl.Drive(cfg, comp=comp)


def test_sensored_step_reaches_target():
    d = _drive()
    d.set_mode("sensored")
    x0, x1 = 0.010, 0.013
    cfg = core.sim_cfg(ECCE, core.PlantSetup(x0=x0))
    # the default keeps injecting in sensored mode: the HF current dithers the dead time, and the
    # hold is within about 1 um (without the injection it hunts by 20-40 um: docs/simulator.md)
    run = core.run_closed_loop(cfg, d.state, int(3.0 * FS), [(0.0, x1, False)])
    a = run.arrays
    assert run.fault == 0 and run.steps_done == int(3.0 * FS)
    assert a["x_ref"][-1] == pytest.approx(x1, abs=1e-9)
    late = a["x"][-int(0.1 * FS):]
    print(f"\n  sensored 3 mm step: final error {(run.x_end - x1) * 1e6:+.2f} um, "
          f"overshoot {(a['x'].max() - x1) * 1e3:.3f} mm")
    assert np.abs(late - x1).max() < 5e-6
    # it did move there (the step runs as a move at the designed step acceleration: 54 ms for 3 mm)
    assert a["x"][0] == x0 and np.abs(a["x"][: int(0.01 * FS)] - x1).min() > 1e-3
    assert np.isfinite(a["i_abc"]).all() and np.abs(a["i_abc"]).max() > 0.02


def _hold(deg, fidelity, dead_time, dtc, seconds=2.0):
    """Sensorless (resistance-aware LUT) hold at deg: mean and max |theta_err| (deg) over the last 0.5 s."""
    x0 = deg / 360.0 * TAU
    d = _drive(comp=LUT_R.values, dtc=dtc, dead_time=dead_time)  # the drive knows the inverter's dead time
    d.set_position(2 * np.pi * x0 / TAU)
    d.set_mode("sensorless_lut")
    cfg = core.sim_cfg(ECCE, core.PlantSetup(fidelity=fidelity, x0=x0, dead_time=dead_time))
    run = core.run_closed_loop(cfg, d.state, int(seconds * FS))
    assert run.fault == 0
    e = run.arrays["theta_err"][-int(0.5 * FS):] / DEG
    assert np.isfinite(e).all()
    return float(e.mean()), float(np.abs(e).max())


@pytest.mark.parametrize("fidelity", ["average", "switching"])
def test_sensorless_hold_ideal_inverter(fidelity):
    """Without dead time the resistance-aware LUT leaves no bias (C test: 0.01 deg)."""
    for deg in (20.0, 100.0, 120.0):
        mean, peak = _hold(deg, fidelity, 0.0, False)
        print(f"\n  {fidelity} hold at {deg:.0f} deg, no dead time: error mean {mean:+.3f} "
              f"max {peak:.3f} deg")
        assert abs(mean) < 0.3 and peak < 0.3


@pytest.mark.parametrize("fidelity", ["average", "switching"])
def test_dead_time_compensation_reduces_bias(fidelity):
    """The 0.8 us dead time distorts the HF voltage and biases the estimate; the drive's compensation
    removes most of what the elliptical injection and the residual correction leave (with the
    paper's pulsating injection and no correction the bias without compensation is several deg)."""
    off, _ = _hold(20.0, fidelity, 0.8e-6, False)
    on, _ = _hold(20.0, fidelity, 0.8e-6, True)
    print(f"\n  {fidelity} hold at 20 deg, dead time 0.8 us: error {off:+.3f} deg without, {on:+.3f} deg "
          "with compensation")
    assert abs(off) > 0.5  # the dead time matters ...
    assert abs(on) < 0.5 * abs(off)  # ... and the compensation acts on the simulated inverter


def test_sensorless_hold_with_dead_time_residual_bias():
    """With 0.8 us dead time and the default compensation (smooth sign, 1.5-period prediction) about
    1 deg of bias remains (the smooth sign inside +-i_band and currents crossing zero within a
    period); the paper reports < 3 deg at steady state. The two inverter fidelities, which model
    the dead time differently (per-edge events vs. the period-averaged error with the current
    predicted at both edges), must agree."""
    for deg in (0.0, 20.0, 100.0, 120.0):
        avg, _ = _hold(deg, "average", 0.8e-6, True)
        sw, _ = _hold(deg, "switching", 0.8e-6, True)
        print(f"\n  hold at {deg:.0f} deg with dead time and compensation: {avg:+.3f} deg (average), "
              f"{sw:+.3f} deg (switching)")
        assert abs(avg) < 1.2 and abs(sw) < 1.2
        assert abs(avg - sw) < 0.6


# ---------------------------------------------------------------------- faults
FINITE_SIGNALS = ("t", "x", "v", "x_est", "v_est", "x_ref", "theta_err", "i_abc", "i_dq", "force", "err_sig")


def _check_clean_stop(run, n_steps, bit):
    a = run.arrays
    n = a["t"].shape[0]
    assert run.fault & bit and run.steps_done < n_steps
    assert n == run.steps_done + 1  # every period recorded (decimate 1), plus the tripping state
    for k in FINITE_SIGNALS:
        assert np.isfinite(a[k]).all(), k
    assert np.isfinite(a["duty"][:-1]).all() and np.isnan(a["duty"][-1]).all()  # no duty after the trip
    assert (a["fault"][:-1] == 0).all() and a["fault"][-1] == run.fault
    assert a["t"][-1] == pytest.approx(run.steps_done / FS, abs=1e-12)
    assert a["x"][-1] == run.x_end


def test_tiny_i_abort_stops_as_diverged():
    d = _drive(comp=LUT_R.values)
    d.set_mode("sensorless_lut")
    n = int(0.2 * FS)
    run = core.run_closed_loop(core.sim_cfg(ECCE, core.PlantSetup(i_abort=0.05)), d.state, n)
    _check_clean_stop(run, n, core.SIM_FAULT_DIVERGED)
    assert not run.fault & core.SIM_FAULT_TRAVEL
    assert np.abs(run.arrays["i_abc"][-1]).max() >= 0.05 > np.abs(run.arrays["i_abc"][:-1]).max()


def test_tiny_travel_stops_at_the_limit():
    d = _drive()
    d.set_mode("sensored")
    n = int(0.5 * FS)
    setup = core.PlantSetup(x0=0.010, x_min=0.0099, x_max=0.0101)
    run = core.run_closed_loop(core.sim_cfg(ECCE, setup), d.state, n, [(0.0, 0.013, False)])
    _check_clean_stop(run, n, core.SIM_FAULT_TRAVEL)
    assert not run.fault & core.SIM_FAULT_DIVERGED
    x = run.arrays["x"]
    assert x[-1] > 0.0101 and (x[:-1] <= 0.0101).all()


def test_drive_fault_stops_at_its_sample():
    """A drive fault (over-current at 0.1 A) ends the run at the sample that reported it."""
    cfg = ctrl.drive_default_cfg()
    cfg.prot.i_max = 0.1
    d = ctrl.Drive(cfg, comp=LUT_R.values)
    d.set_mode("sensorless_lut")
    n = int(0.2 * FS)
    run = core.run_closed_loop(core.sim_cfg(ECCE, core.PlantSetup()), d.state, n)
    a = run.arrays
    assert run.fault == ctrl.lib.LS_FAULT_OVERCURRENT
    assert a["fault"][-1] == run.fault and (a["fault"][:-1] == 0).all()
    assert run.steps_done == a["t"].shape[0] - 1  # the faulted period is recorded, not simulated
    for k in FINITE_SIGNALS + ("duty",):
        assert np.isfinite(a[k]).all(), k
    assert np.abs(a["i_abc"][-1]).max() > 0.1

"""Accuracy of the C plant (``csrc/sim/ls_sim_plant.c``) against an independent reference.

The reference is written here, in the phase (ABC) frame, from the Python motor model only:
unknowns ``i_a, i_b, i_c`` and the star-point voltage ``v_n`` with the floating star point
``i_a + i_b + i_c = 0``::

    d/dt (L_abc(theta) i + lambda_pm(theta)) = v_pole - v_n 1 - R i

i.e. each evaluation solves the bordered system
``[L_abc, 1; 1', 0] [di/dt; v_n] = [v_pole - R i - omega (L_abc' i + lambda_pm'); 0]``
(``L_abc`` and ``L_abc' = dL_abc/dtheta`` from :meth:`InductanceModel.L_abc`, ``omega`` the
electrical speed), integrated by ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10) segment by
segment with the same piecewise-constant pole voltages. The force is the co-energy derivative in
ABC, ``F = (2 pi/tau) [i' lambda_pm' + 1/2 i' L_abc' i]`` (no 3/2: the C plant works in
alpha-beta with the 3/2 factor, and agreeing is part of the test).

The voltages are 50 ms of a 12 V / 1 kHz pulsating injection on an axis 0.2 rad off d plus a
q-axis voltage turning with the mover (so that the currents and the force are non-trivial),
sampled once per 16 kHz PWM period and modulated with min-max zero sequence, applied either as
one pole voltage per period (what the ``average`` fidelity applies) or as the centre-aligned
switching segments of 0 / V_dc pole voltages (the per-segment path). Acceptance: what README.md
and docs/simulator.md claim, phase currents and force within 1e-6 of their peak (open loop; the
first issue's acceptance was 0.5 %), at standstill and at 0.2 m/s, for the ecce2010 preset, a motor
with L4/M4 inductance and 5th PM-flux harmonics, and a tabulated motor (measured: at most 4.7e-7),
and a recorded closed-loop move within 1e-5 (measured 8.7e-6); the same for the harmonic motor with
the end effect on the magnets' flux (per-phase PM flux amplitude and phase, ``UNBALANCED``), whose
back-EMF at 0.2 m/s then drives unbalanced currents.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from linsense.model.motor import Motor, PmPhases, load_motor
from linsense.sim import core

EXAMPLES = Path(__file__).resolve().parents[1] / "src/linsense/examples" / "motors"
MOTORS = {
    "ecce2010": "ecce2010",
    "harmonic": str(EXAMPLES / "harmonic.toml"),
    "tabulated": str(EXAMPLES / "tabulated.toml"),
    "unbalanced": str(EXAMPLES / "harmonic.toml"),  # with the end effect on the magnets' flux below
}
#: the end effect on the magnets' flux of the "unbalanced" motor (the harmonic motor otherwise): the
#: end phases B and C link 8 % less and 5 % more flux, their axes 3 and -2 electrical degrees off
UNBALANCED = PmPhases((1.0, 0.92, 1.05), (0.0, math.radians(3.0), math.radians(-2.0)))
F_PWM = 16000.0
V_DC = 72.0
T_RUN = 0.050  # s of injection
ACCEPT = 1e-6  # of the peak, open loop (README.md, docs/simulator.md "Accuracy")
ACCEPT_CLOSED = 1e-5  # of the peak, the recorded closed-loop move (the same claims)
SHIFT = np.array([0.0, -2.0 * np.pi / 3.0, 2.0 * np.pi / 3.0])  # phase b lags, c leads


@functools.cache
def motor(name: str) -> Motor:
    m = load_motor(MOTORS[name])
    return dataclasses.replace(m, pm_phases=UNBALANCED) if name == "unbalanced" else m


# ---------------------------------------------------------------------- the ABC reference
def pm_abc(m: Motor, theta: float, derivative: int = 0) -> np.ndarray:
    """PM flux linkage of the three phases (Wb) or its theta-derivative (Wb/rad).

    Phase a: ``psi_pm [cos th + sum_n a_n cos(n th + phi_n)]``; b and c with ``th -+ 2 pi/3``;
    phase k's whole waveform scaled by ``scale_k`` and advanced by ``shift_k`` (the end effect on
    the magnets' flux, ``Motor.pm_phases``).
    """
    scale, shift = m.pm_phases.scale, m.pm_phases.shift
    out = np.zeros(3)
    for k in range(3):
        a = theta + SHIFT[k] + shift[k]
        if derivative == 0:
            out[k] = math.cos(a) + sum(h.amplitude * math.cos(h.order * a + h.phase) for h in m.pm_harmonics)
        else:
            out[k] = -math.sin(a) - sum(h.order * h.amplitude * math.sin(h.order * a + h.phase)
                                        for h in m.pm_harmonics)
        out[k] *= scale[k]
    return m.psi_pm * out


def force_abc(m: Motor, theta: float, i_abc: np.ndarray) -> float:
    """Co-energy force in ABC, N."""
    dL = m.inductance.L_abc(theta, 1)
    kx = 2.0 * np.pi / m.pole_pitch
    return float(kx * (i_abc @ pm_abc(m, theta, 1) + 0.5 * i_abc @ dL @ i_abc))


def _bordered(L: np.ndarray, A: np.ndarray | None = None) -> np.ndarray:
    """``[[L, 1], [1', 0]]`` (written into ``A`` if given)."""
    if A is None:
        A = np.ones((4, 4))
        A[3, 3] = 0.0
    A[:3, :3] = L
    return A


def didt_abc(m: Motor, th: float, omega: float, i: np.ndarray, vp: np.ndarray, A: np.ndarray,
             b: np.ndarray) -> np.ndarray:
    """di/dt of the phase currents at angle ``th`` (rad) and electrical speed ``omega`` (rad/s)
    for pole voltages ``vp``: the bordered system above (``A``, ``b``: 4x4 and 4 work arrays)."""
    ind = m.inductance
    b[:3] = vp - m.R_s * i - omega * (ind.L_abc(th, 1) @ i + pm_abc(m, th, 1))
    return np.linalg.solve(_bordered(ind.L_abc(th), A), b)[:3]


def reference(m: Motor, seg_t: np.ndarray, seg_v: np.ndarray, x0: float, speed: float):
    """Phase currents (n + 1, 3) and angles (n + 1) at the segment boundaries."""
    kx = 2.0 * np.pi / m.pole_pitch
    th0, omega = kx * x0, kx * speed
    ind = m.inductance
    if speed == 0.0:
        K_held = np.linalg.inv(_bordered(ind.L_abc(th0)))[:3, :3]  # theta fixed: factor once
    A, b = _bordered(np.zeros((3, 3))), np.zeros(4)

    def rhs(t, i, vp):
        if speed == 0.0:
            return K_held @ (vp - m.R_s * i)
        return didt_abc(m, th0 + omega * t, omega, i, vp, A, b)

    t_b = np.concatenate([[0.0], np.cumsum(seg_t)])
    i = np.zeros((seg_t.size + 1, 3))
    for s in range(seg_t.size):
        span = t_b[s + 1] - t_b[s]
        if not span > 0.0:  # a vanishing segment (two equal switching instants)
            i[s + 1] = i[s]
            continue
        sol = solve_ivp(rhs, (t_b[s], t_b[s + 1]), i[s], method="DOP853", rtol=1e-10, atol=1e-12,
                        first_step=span, args=(seg_v[s],))
        assert sol.success, sol.message
        i[s + 1] = sol.y[:, -1]
    return i, th0 + omega * t_b


# ---------------------------------------------------------------------- the voltages
def duties(m: Motor, x0: float, speed: float) -> np.ndarray:
    """Duty cycles (n_periods, 3): HF injection + q-axis voltage, sampled at each period start."""
    n = int(round(T_RUN * F_PWM))
    t = np.arange(n) / F_PWM
    th = 2.0 * np.pi * (x0 + speed * t) / m.pole_pitch
    v_hf = 12.0 * np.cos(2.0 * np.pi * 1000.0 * t)
    ax = th + 0.2  # injection axis: an estimate 0.2 rad off
    v_ab = np.stack([v_hf * np.cos(ax), v_hf * np.sin(ax)], axis=1)
    v_q = 11.0  # V along q (about 1.2 A, 24 N)
    v_ab += v_q * np.stack([-np.sin(th), np.cos(th)], axis=1)
    v_abc = v_ab @ np.array([[1.0, 0.0], [-0.5, math.sqrt(0.75)], [-0.5, -math.sqrt(0.75)]]).T
    v_abc -= 0.5 * (v_abc.max(axis=1) + v_abc.min(axis=1))[:, None]
    d = 0.5 + v_abc / V_DC
    assert d.min() > 0.05 and d.max() < 0.95
    return d


def average_segments(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.full(d.shape[0], 1.0 / F_PWM), V_DC * d


def switching_segments(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre-aligned PWM: leg j high for |t - T/2| < d_j T/2 within each period."""
    T = 1.0 / F_PWM
    seg_t, seg_v = [], []
    for dk in d:
        edges = np.unique(np.concatenate([[0.0, T], 0.5 * (1.0 - dk) * T, 0.5 * (1.0 + dk) * T]))
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            mid = 0.5 * (a + b)
            seg_t.append(b - a)
            seg_v.append(V_DC * (np.abs(mid - 0.5 * T) < 0.5 * dk * T))
    return np.array(seg_t), np.array(seg_v, dtype=float)


# ---------------------------------------------------------------------- the test
@pytest.mark.parametrize("fidelity", ["average", "switching"])
@pytest.mark.parametrize("speed", [0.0, 0.2], ids=["standstill", "0.2m/s"])
@pytest.mark.parametrize("name", list(MOTORS))
def test_plant_matches_abc_reference(name, speed, fidelity):
    m = motor(name)
    x0 = 0.0123  # m, an arbitrary start (about 79 electrical degrees)
    d = duties(m, x0, speed)
    seg_t, seg_v = average_segments(d) if fidelity == "average" else switching_segments(d)
    setup = core.PlantSetup(motion="held" if speed == 0.0 else "prescribed", x0=x0, v0=speed)
    run = core.run_open_loop(core.sim_cfg(m, setup), seg_t, seg_v)
    assert run.fault == 0 and run.steps_done == seg_t.size
    a = run.arrays
    assert a["i_abc"].shape == (seg_t.size + 1, 3)

    i_ref, th_ref = reference(m, seg_t, seg_v, x0, speed)
    f_ref = np.array([force_abc(m, th, i) for th, i in zip(th_ref, i_ref, strict=True)])
    x_ref = th_ref * m.pole_pitch / (2.0 * np.pi)

    i_peak, f_peak = np.abs(i_ref).max(), np.abs(f_ref).max()
    # the comparison is not trivial: amperes, tens of newtons, a clear 1 kHz ripple
    assert i_peak > 1.0 and f_peak > 10.0
    assert np.ptp(i_ref[-160:], axis=0).max() > 0.5
    np.testing.assert_allclose(a["x"], x_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a["t"], np.concatenate([[0.0], np.cumsum(seg_t)]), rtol=0, atol=1e-12)

    e_i = np.abs(a["i_abc"] - i_ref).max() / i_peak
    e_f = np.abs(a["force"] - f_ref).max() / f_peak
    print(f"\n  {name:9s} {fidelity:9s} v={speed:.1f} m/s: {seg_t.size} segments, "
          f"i peak {i_peak:.3f} A err {e_i:.2e} of peak; F peak {f_peak:.2f} N err {e_f:.2e} of peak")
    assert e_i <= ACCEPT, f"currents: max error {e_i:.3e} of their peak"
    assert e_f <= ACCEPT, f"force: max error {e_f:.3e} of its peak"


# ---------------------------------------------------------------------- the closed loop
def reference_along(m: Motor, u: np.ndarray, x: np.ndarray, v: np.ndarray, i0: np.ndarray) -> np.ndarray:
    """Phase currents (n + 1, 3) at the period boundaries for duties ``u`` (n, 3) along a recorded
    motion: within period k the mover accelerates uniformly from ``v[k]`` to ``v[k + 1]`` from
    ``x[k]`` (the simulator's trapezoidal mechanics), so theta(t) and omega(t) are exact."""
    kx, h = 2.0 * np.pi / m.pole_pitch, 1.0 / F_PWM
    A, b = _bordered(np.zeros((3, 3))), np.zeros(4)

    def rhs(tau, i, k, acc, vp):
        th = kx * (x[k] + v[k] * tau + 0.5 * acc * tau * tau)
        return didt_abc(m, th, kx * (v[k] + acc * tau), i, vp, A, b)

    out = np.zeros((u.shape[0] + 1, 3))
    out[0] = i0
    for k in range(u.shape[0]):
        sol = solve_ivp(rhs, (0.0, h), out[k], method="DOP853", rtol=1e-10, atol=1e-12, first_step=h,
                        args=(k, (v[k + 1] - v[k]) / h, V_DC * u[k]))
        assert sol.success, sol.message
        out[k + 1] = sol.y[:, -1]
    return out


def test_closed_loop_average_matches_abc_reference():
    """The time loop itself (``ls_sim_run``, average fidelity, no dead time), not only the
    open-loop path: 50 ms of a sensorless move while accelerating, the recorded duties and motion
    replayed through the ABC reference; currents within 1e-5 of their peak. This covers the
    loop's own choices: the mid-period position predicted one period back and the tracked sincos."""
    from linsense import ctrl
    from linsense.compensation.lut import build_lut

    m = motor("ecce2010")
    # the paper's pulsating injection: the default elliptical one adds about 8 N of 1 kHz force
    # (q-axis HF current), and the regression guard below was measured without it (with it the
    # error is about 4e-5 of peak)
    d_cfg = ctrl.drive_default_cfg()
    d_cfg.inject.quad = 0.0
    drive = ctrl.Drive(d_cfg, comp=build_lut(m, 360, f_inj=1000.0).values)
    drive.set_position(0.0)
    drive.set_mode("sensorless_lut")
    cfg = core.sim_cfg(m, core.PlantSetup(dead_time=0.0, load_f0=5.0))
    run = core.run_closed_loop(cfg, drive.state, int(0.2 * F_PWM), [(0.1, 0.020, True)])
    assert run.fault == 0
    a = run.arrays
    k0, n = int(0.15 * F_PWM), int(T_RUN * F_PWM)
    sl = slice(k0, k0 + n + 1)
    x, v, i_c = a["x"][sl], a["v"][sl], a["i_abc"][sl]
    acc = np.diff(v) * F_PWM
    assert v.min() > 0.02 and np.ptp(v) > 0.02 and np.abs(acc).max() > 0.5  # moving, accelerating
    i_ref = reference_along(m, a["duty"][sl][:-1], x, v, i_c[0])
    i_peak = np.abs(i_ref).max()
    assert i_peak > 0.3 and np.ptp(i_ref[-160:], axis=0).max() > 0.3
    e_i = np.abs(i_c - i_ref).max() / i_peak
    print(f"\n  closed loop, average: {n} periods while moving at {v.mean():.3f} m/s "
          f"(|a| up to {np.abs(acc).max():.1f} m/s^2): i peak {i_peak:.3f} A, err {e_i:.2e} of peak")
    # measured 8.7e-6; freezing the speed at the period start instead of mid-period gives 8e-5
    assert e_i <= ACCEPT_CLOSED, f"currents: max error {e_i:.3e} of their peak (the claimed 1e-5)"

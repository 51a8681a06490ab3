"""Linearised stability of the uncompensated drive against position (paper Fig. 12; docs/reproduce.md).

Without the LUT the observer reports ``theta + e*(theta)`` (the equilibrium error of the
uncompensated observer, brief section 4 in the notes, docs/theory.md), so the motion loop sees the
true position scaled by the loop-gain factor ``g = 1 + de*/dtheta``, and the observer's own error
gain is the local slope of the uncompensated demodulated error at ``e*``. Both change with the
position; :func:`margins_along` evaluates the linearised loops of :func:`linsense.tune.design.loops`
(the tuning command's model) with them at each angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from linsense.analysis.hf import demod_ratio, equilibrium_error, loop_gain_factor, mean_dq


@dataclass
class LoopAlong:
    """Margins of the motion loop of an uncompensated drive at each angle ``theta_deg``."""

    theta_deg: np.ndarray
    g: np.ndarray  # 1 + de*/dtheta
    k_e: np.ndarray  # local error gain of the observer (1 = nominal)
    pm_deg: np.ndarray  # phase margin (NaN: no crossover)
    gm_up_db: np.ndarray  # gain margin upward (NaN: none)
    max_pole_re: np.ndarray  # 1/s, largest real part of the closed loop's poles (> 0: unstable)

    def worst(self) -> dict | None:
        """The angle of the smallest upward gain margin and its numbers (None if no angle has one)."""
        ok = np.isfinite(self.gm_up_db)
        if not ok.any():
            return None
        k = int(np.flatnonzero(ok)[np.argmin(self.gm_up_db[ok])])
        return {"theta_deg": float(self.theta_deg[k]), "g": float(self.g[k]), "k_e": float(self.k_e[k]),
                "pm_deg": float(self.pm_deg[k]), "gm_up_db": float(self.gm_up_db[k]),
                "max_pole_re": float(self.max_pole_re[k])}

    def any_unstable(self) -> bool:
        """A negative phase or gain margin, or a closed-loop pole in the right half-plane, at any angle."""
        return bool(np.any(self.pm_deg < 0.0) or np.any(self.gm_up_db < 0.0)
                    or np.any(self.max_pole_re > 0.0))


def nolut_error_gain(motor, theta, f_inj: float, quad: float = 0.0, h: float = 1e-4) -> np.ndarray:
    """Local error gain of the uncompensated observer at its equilibrium ``e*(theta)``, relative to
    the nominal demodulator gain ``L_q / (L_q - L_d)`` of the mean inductances (no gain schedule):
    ``-G0 d ratio / d theta_err`` (:func:`linsense.analysis.hf.demod_ratio`, no compensation)."""
    theta = np.asarray(theta, dtype=float)
    L_d, L_q = mean_dq(motor)
    g0 = L_q / (L_q - L_d)
    e = equilibrium_error(motor, theta)
    up = demod_ratio(motor, theta, e + h, 1.0, f_inj, 0.0, quad=quad)
    down = demod_ratio(motor, theta, e - h, 1.0, f_inj, 0.0, quad=quad)
    return -g0 * (up - down) / (2.0 * h)


def margins_along(sc, theta_deg: np.ndarray | None = None, lut: bool = False, tick=None) -> LoopAlong:
    """The motion loop's margins of the scenario ``sc`` (the gains of its drive as built:
    :func:`linsense.sim.build.build`) run without the LUT, at each angle (default every 2 deg), with
    the loop-gain factor and the local observer gain of the uncompensated drive there; ``lut``: run
    with the resistance-aware LUT instead (``g = 1``, the compensated observer's local gain). With
    the gain schedule on (``observer.gain_schedule``) the observer gain is taken as nominal (1).
    ``tick``: called after each angle (progress)."""
    import control as ct

    from linsense.sim.build import build
    from linsense.tune.design import error_gain, loop_margins, loops

    b = build(sc)
    motor, s, d = b.motor, b.scenario.spec, b.drive.cfg
    th_deg = np.arange(0.0, 360.0, 2.0) if theta_deg is None else np.asarray(theta_deg, dtype=float)
    th = np.radians(th_deg)
    g = np.ones_like(th) if lut else loop_gain_factor(motor, th)
    if s.observer.gain_schedule:
        k_e = np.ones_like(th)
    elif lut:
        n = 720
        table = error_gain(motor, s.injection.frequency, s.injection.quadrature, b.known["demod_gain"], n=n)
        k_e = np.interp(th, 2.0 * np.pi * np.arange(n + 1) / n, np.append(table, table[0]))
    else:
        k_e = nolut_error_gain(motor, th, s.injection.frequency, s.injection.quadrature)
    pm, gm, pole = (np.full(th.shape, np.nan) for _ in range(3))
    for i in range(th.size):
        _, l_mot = loops(mass=motor.mass, kp_x=float(d.pos.kp_x), speed_kp=float(d.pos.speed.kp),
                         speed_ki=float(d.pos.speed.ki), observer_k=(float(d.obs.k1), float(d.obs.k2)),
                         current_bw=s.controller.current_bandwidth_hz, demod_lpf=s.observer.demod_lpf_hz,
                         f_inj=s.injection.frequency, f_pwm=s.inverter.f_pwm, k_e=float(k_e[i]),
                         g=float(g[i]))
        mg = loop_margins(l_mot)
        pm[i] = math.nan if mg["pm_deg"] is None else mg["pm_deg"]
        gm[i] = math.nan if mg["gm_up_db"] is None else mg["gm_up_db"]
        pole[i] = float(np.max(np.real(ct.poles(ct.feedback(l_mot, 1)))))
        if tick is not None:
            tick()
    return LoopAlong(th_deg, g, k_e, pm, gm, pole)

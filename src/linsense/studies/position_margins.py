"""The motion loop's margins along the position of the drive a scenario builds, run without the LUT
(paper Fig. 12; docs/reproduce.md): :mod:`linsense.analysis.stability`'s loop-gain factor and local
observer gain at each angle in the linearised loops of :func:`linsense.tune.design.loops`."""

from __future__ import annotations

import math

import numpy as np

from linsense.analysis.hf import loop_gain_factor
from linsense.analysis.stability import LoopAlong, nolut_error_gain
from linsense.sim.build import build
from linsense.tune.design import error_gain, loop_margins, loops


def margins_along(sc, theta_deg: np.ndarray | None = None, lut: bool = False, tick=None) -> LoopAlong:
    """The motion loop's margins of a scenario's drive run without the LUT, at each angle.

    The gains of its drive as built (:func:`linsense.sim.build.build`), with the loop-gain factor
    and the local observer gain of the uncompensated drive there. With the gain schedule on
    (``observer.gain_schedule``) the observer gain is taken as nominal (1).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    theta_deg : ndarray or None, optional
        Electrical angles, deg (default every 2 deg).
    lut : bool, optional
        Run with the resistance-aware LUT instead (``g = 1``, the compensated observer's local
        gain).
    tick : callable or None, optional
        Called after each angle (progress).

    Returns
    -------
    LoopAlong
        The margins at each angle.
    """
    import control as ct

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

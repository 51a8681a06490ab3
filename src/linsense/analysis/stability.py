"""Linearised stability of the uncompensated drive against position (paper Fig. 12; docs/reproduce.md).

Without the LUT the observer reports ``theta + e*(theta)`` (the equilibrium error of the
uncompensated observer, brief section 4 in the notes, docs/theory.md), so the motion loop sees the
true position scaled by the loop-gain factor ``g = 1 + de*/dtheta``, and the observer's own error
gain is the local slope of the uncompensated demodulated error at ``e*``. Both change with the
position; :func:`linsense.studies.position_margins.margins_along` evaluates the linearised loops of
:func:`linsense.tune.design.loops` (the tuning command's model) with them at each angle, for the drive
a scenario builds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linsense._check import real
from linsense.analysis.hf import _motor, _theta, demod_ratio, equilibrium_error, mean_dq


@dataclass
class LoopAlong:
    """Margins of the motion loop of an uncompensated drive at each angle ``theta_deg``.

    Parameters
    ----------
    theta_deg : ndarray
        Electrical positions, deg.
    g : ndarray
        Position-loop gain factor ``1 + de*/dtheta``.
    k_e : ndarray
        Local error gain of the observer (1 = nominal).
    pm_deg : ndarray
        Phase margin, deg (NaN: no crossover).
    gm_up_db : ndarray
        Upward gain margin, dB (NaN: none).
    max_pole_re : ndarray
        Largest real part of the closed loop's poles, 1/s (> 0: unstable).
    """

    theta_deg: np.ndarray
    g: np.ndarray  # 1 + de*/dtheta
    k_e: np.ndarray  # local error gain of the observer (1 = nominal)
    pm_deg: np.ndarray  # phase margin (NaN: no crossover)
    gm_up_db: np.ndarray  # gain margin upward (NaN: none)
    max_pole_re: np.ndarray  # 1/s, largest real part of the closed loop's poles (> 0: unstable)

    def worst(self) -> dict | None:
        """The angle of the smallest upward gain margin and its numbers (None if no angle has one).

        Returns
        -------
        dict or None
            ``theta_deg``, ``g``, ``k_e``, ``pm_deg``, ``gm_up_db``, ``max_pole_re`` at that angle.
        """
        ok = np.isfinite(self.gm_up_db)
        if not ok.any():
            return None
        k = int(np.flatnonzero(ok)[np.argmin(self.gm_up_db[ok])])
        return {"theta_deg": float(self.theta_deg[k]), "g": float(self.g[k]), "k_e": float(self.k_e[k]),
                "pm_deg": float(self.pm_deg[k]), "gm_up_db": float(self.gm_up_db[k]),
                "max_pole_re": float(self.max_pole_re[k])}

    def any_unstable(self) -> bool:
        """A negative phase or gain margin, or a closed-loop pole in the right half-plane, at any angle.

        Returns
        -------
        bool
            True when unstable somewhere.
        """
        return bool(np.any(self.pm_deg < 0.0) or np.any(self.gm_up_db < 0.0)
                    or np.any(self.max_pole_re > 0.0))


def nolut_error_gain(motor, theta, f_inj: float, quad: float = 0.0, h: float = 1e-4) -> np.ndarray:
    """Local error gain of the uncompensated observer at its equilibrium ``e*(theta)``.

    Relative to the nominal demodulator gain ``L_q / (L_q - L_d)`` of the mean inductances (no gain
    schedule): ``-G0 d ratio / d theta_err`` (:func:`linsense.analysis.hf.demod_ratio`, no
    compensation), by central differences.

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        True electrical position(s), rad.
    f_inj : float
        Injection frequency, Hz.
    quad : float, optional
        Quadrature ratio of the elliptical injection.
    h : float, optional
        Step of the difference, rad.

    Returns
    -------
    ndarray
        Dimensionless (1 = nominal).

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    """
    src = "linsense.analysis.stability.nolut_error_gain"
    motor, theta = _motor(motor, src), _theta(theta, src)
    h = real(h, src, "h", 0.0, 0.1, low_open=True, what="a difference step in rad")
    L_d, L_q = mean_dq(motor)
    g0 = L_q / (L_q - L_d)
    e = equilibrium_error(motor, theta)
    up = demod_ratio(motor, theta, e + h, 1.0, f_inj, 0.0, quad=quad)
    down = demod_ratio(motor, theta, e - h, 1.0, f_inj, 0.0, quad=quad)
    return -g0 * (up - down) / (2.0 * h)

"""What the model predicts of a design before any simulation (docs/tuning.md, "Margins"):

* each tolerance's cost: the hold error of a motor off by the tolerance while the drive keeps the
  nominal LUT and gain schedule (the table following the resistance the drive measures online,
  ``Psi_LUT + (k_r - 1) dPsi_LUT/dk_r``: ls_dtres_adapt, ls_demod_cfg.comp_r), from the HF model
  (paper eq. 10-11 with R_s and the injection):
  at a hold the estimate sits on the target ``T`` and the true position at ``T - e`` where the
  demodulated error read with the nominal table at ``T`` vanishes;
* the range of the local error gain the observer then sees (the schedule normalises the nominal
  motor's to 1; an off-nominal motor's departs from it, position by position): the loops'
  margins are evaluated over that range, so that they differ by motor.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from linsense.analysis.hf import demod_ratio, psi_lut_resistive
from linsense.compensation.lut import lut_r_slope
from linsense.model.motor import Motor
from linsense.model.tolerance import perturbed

#: the tolerances the design is judged against: name -> (inductance, R_s, end-effect) scale
TOLERANCES = {
    "L +10 %": (1.10, 1.0, 1.0),
    "L -10 %": (0.90, 1.0, 1.0),
    "R_s +30 % (hot)": (1.0, 1.30, 1.0),
    "dM0 +25 %": (1.0, 1.0, 1.25),
    "dM0 -25 %": (1.0, 1.0, 0.75),
}
#: the hold error (electrical deg) a tolerance may cost: the certificate's off-nominal bound
TOLERANCE_ERR_DEG = 3.0
_H = 1e-4  # rad, numerical derivatives


def _ratio(plant: Motor, target: np.ndarray, e: np.ndarray, f_inj: float, quad: float, psi_t: np.ndarray):
    """The demodulated ratio of ``plant`` with the estimate at ``target`` and the true position at
    ``target - e`` (error ``e``), the table read at the estimate."""
    return demod_ratio(plant, target - e, e, 1.0, f_inj, psi_t, quad=quad)


def hold_error(nominal: Motor, plant: Motor, f_inj: float, quad: float, n: int = 180,
               k_r: float = 1.0) -> np.ndarray:
    """The hold error ``e`` (rad, true position = target - e) at ``n`` targets over the period.

    For ``plant`` driven with ``nominal``'s resistance-aware table, corrected for the resistance's
    scale ``k_r`` the drive measured (Newton from ``e = 0``, the branch a drive starting on target
    follows); NaN where it does not converge within 0.6 rad.

    Parameters
    ----------
    nominal : Motor
        The motor whose table the drive holds.
    plant : Motor
        The motor driven.
    f_inj : float
        Injection frequency, Hz.
    quad : float
        Elliptical share on q.
    n : int, optional
        Targets over the period.
    k_r : float, optional
        The resistance's scale the drive measured.

    Returns
    -------
    ndarray, shape (n,)
        rad.
    """
    target = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    psi_t = psi_lut_resistive(nominal, target, f_inj, quad=quad)
    if k_r != 1.0:
        psi_t = psi_t + (k_r - 1.0) * lut_r_slope(nominal, n, f_inj, quad)
    e = np.zeros(n)
    bad = np.zeros(n, dtype=bool)
    for _ in range(60):
        r = _ratio(plant, target, e, f_inj, quad, psi_t)
        hi = _ratio(plant, target, e + _H, f_inj, quad, psi_t)
        d = (hi - _ratio(plant, target, e - _H, f_inj, quad, psi_t)) / (2.0 * _H)
        bad |= ~(np.abs(d) > 1e-12)  # (no slope: no restoring error there)
        step = np.where(bad, 0.0, r / np.where(bad, 1.0, d))
        e = e - np.clip(step, -0.05, 0.05)
        if np.max(np.abs(step)) < 1e-10:
            break
    # converged: the residual vanishes (against the ratio's scale) and the slope restores
    resid = np.abs(_ratio(plant, target, e, f_inj, quad, psi_t))
    e[bad | ~(resid < 1e-6) | ~(np.abs(e) < 0.6)] = np.nan
    return e


def error_gain(motor: Motor, f_inj: float, quad: float, gain: float, n: int = 180,
               table: Motor | None = None) -> np.ndarray:
    """Local slope of the demodulated error against the position error over the period (1 = nominal).

    With the resistance-aware LUT of the injection: ``-gain d ratio / d theta_est`` at the true
    position ``theta``, the table read at the estimate as the drive reads it (so its own slope,
    ``1 + de*/dtheta`` of the end-effect, is part of the observer's loop gain: 0.6-2.9 for ecce2010,
    which a schedule computed with the table read at ``theta`` left in the loop). The gain
    schedule's (:mod:`linsense.tune.design`) and the tolerances' one home.

    Parameters
    ----------
    motor : Motor
        The motor driven.
    f_inj : float
        Injection frequency, Hz.
    quad : float
        Elliptical share on q.
    gain : float
        The demodulator's gain.
    n : int, optional
        Positions over the period.
    table : Motor or None, optional
        The motor whose table the drive reads (default ``motor``; another one: a motor off by a
        tolerance driven with the nominal table, :func:`local_gain`).

    Returns
    -------
    ndarray, shape (n,)
        Dimensionless.
    """
    th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    h = 1e-3
    tm = motor if table is None else table
    psi_p, psi_m = (psi_lut_resistive(tm, th + s, f_inj, quad=quad) for s in (h, -h))
    r_p = demod_ratio(motor, th, h, 1.0, f_inj, psi_p, quad=quad)
    r_m = demod_ratio(motor, th, -h, 1.0, f_inj, psi_m, quad=quad)
    return -gain * (r_p - r_m) / (2.0 * h)


def local_gain(nominal: Motor, plant: Motor, f_inj: float, quad: float, n: int = 180) -> np.ndarray:
    """The local error gain of ``plant`` driven with ``nominal``'s table, relative to ``nominal``'s.

    The gain schedule divides ``nominal``'s out: 1 everywhere for the nominal motor. The slope
    against the estimate, as the observer sees it (:func:`error_gain`).

    Parameters
    ----------
    nominal : Motor
        The motor whose table the drive reads.
    plant : Motor
        The motor driven.
    f_inj : float
        Injection frequency, Hz.
    quad : float
        Elliptical share on q.
    n : int, optional
        Positions over the period.

    Returns
    -------
    ndarray, shape (n,)
        Dimensionless.
    """
    return (error_gain(plant, f_inj, quad, 1.0, n, table=nominal)
            / error_gain(nominal, f_inj, quad, 1.0, n))


def tolerance_costs(motor: Motor, f_inj: float, quad: float, n: int = 180, r_adapt: bool = True) -> dict:
    """Per tolerance: the predicted worst hold error and the range of the scheduled local error gain.

    Parameters
    ----------
    motor : Motor
        The nominal motor.
    f_inj : float
        Injection frequency, Hz.
    quad : float
        Elliptical share on q.
    n : int, optional
        Positions over the period.
    r_adapt : bool, optional
        The drive measures the resistance and its table follows it (the default drive:
        ``observer.resistance_adapt``).

    Returns
    -------
    dict
        Tolerance name to ``{"error_deg": deg (inf where the model finds no hold), "k_lo", "k_hi"}``.
    """
    out = {}
    for name, (k_l, k_r, k_e) in TOLERANCES.items():
        plant = perturbed(motor, k_l, k_r, k_e, label=name)
        e = hold_error(motor, plant, f_inj, quad, n, k_r=k_r if r_adapt else 1.0)
        # (the gain schedule follows the measured resistance too: the nominal motor's at k_r R_s)
        ref = dataclasses.replace(motor, R_s=motor.R_s * k_r) if r_adapt and k_r != 1.0 else motor
        g = local_gain(ref, plant, f_inj, quad, n)
        worst = math.inf if np.any(~np.isfinite(e)) else float(np.degrees(np.max(np.abs(e))))
        out[name] = {"error_deg": worst, "k_lo": float(np.min(g)), "k_hi": float(np.max(g))}
    return out

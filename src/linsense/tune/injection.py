"""The drive's tables and constants for the rotating and square-wave injections (docs/theory.md,
"Rotating-vector injection" and "Square-wave injection"; docs/firmware.md).

Inside the observer loop a compensation table is read at the estimate, which at the equilibrium
is the true position: both tables are therefore sampled against the position, ``table[k] =
psi(2 pi k / n)``, like Psi_LUT for the pulsating injection. The gain table makes the demodulated
error's local slope against the position error 1 everywhere (the loop gain of the observer):

- rotating: ``delta = theta + psi_rot(theta) - theta_est - Psi(theta_est)``, slope ``1 + Psi'``,
  gain ``1 / (1 + dpsi_rot/dtheta)``;
- square: the product demodulator's ratio ``sin(2 phi) / 2`` of the current change's angle ``phi``
  in the compensated estimated frame, differentiated numerically against ``theta_est`` (the
  saliency and the table's own slope both enter).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from linsense.analysis.hf import table_model
from linsense.analysis.rotating import negative_sequence, psi_rotating, reference_phase_sampled
from linsense.analysis.square import delta_current, psi_square
from linsense.compensation.lut import R_SLOPE_STEP
from linsense.model.motor import Motor

#: the square wave's fundamental separation: a low-pass at this fraction of f_pwm (its zeros at
#: f_pwm / 2 remove the square wave; 2 kHz at 16 kHz, well above a 250 Hz current loop)
SQUARE_SEP_FRACTION = 0.125
#: the dead-time compensation's current extrapolation with the square wave at f_pwm / 2, in periods:
#: its change reverses every period, so the next period's middle is ``i - (i - i_prev) / 2``
SQUARE_DTC_LEAD = -0.5
#: the d-current while injecting with the square wave and the rotating vector, as a fraction of the
#: current limit: it keeps the phase currents off zero, where the dead time would act on the HF
#: current (the square wave: up to 8 deg of bias without it, docs/firmware.md; the rotating vector:
#: its holds' cycles, docs/tuning.md, "Why the rotating vector and the square wave cycle")
INJECTION_D_FRACTION = 0.4
#: the dead-time compensation's current band with the square wave (A): its edge-ripple model
#: (ls_mod_step_ripple_finite) knows the sign at each edge, so the smooth sign can be narrow
SQUARE_DTC_BAND = 0.01
#: the margin (A) the square wave's d-current schedule keeps every phase current from the edges of
#: the dead time's relay band (:func:`square_current_schedule`): the force current at a no-load
#: hold and the compensation's prediction error
SQUARE_DT_MARGIN = 0.01
#: the smallest hysteresis (rad) of the schedule; a design with less is refused
SQUARE_MIN_HYSTERESIS = math.radians(1.0)
#: the rotating demodulator's validity threshold, as a fraction of the model's smallest |i_n|^2 over
#: the period (the end-effect makes it vary: 8 % to 193 % of its mean for ecce2010)
ROTATING_LEVEL_FRACTION = 0.25
_H = 1e-4  # rad, step of the numerical derivatives


def rotating_tables(motor: Motor, n: int, f_inj: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The rotating injection's compensation table and gain schedule on ``n`` positions.

    ``psi_rot`` (:func:`linsense.analysis.rotating.psi_rotating`) and ``1 / (1 + dpsi_rot/dtheta)``.

    Parameters
    ----------
    motor : Motor
        The motor.
    n : int
        Positions over the period.
    f_inj : float or None
        Injection frequency, Hz (None: the R_s = 0 limit).

    Returns
    -------
    psi_rot : ndarray
        rad.
    gain : ndarray
        Dimensionless.

    Raises
    ------
    ValueError
        When the estimate is not monotone in the position.
    """
    m, f = table_model(motor, f_inj)
    th = 2.0 * np.pi * np.arange(n) / n
    psi = psi_rotating(m, th, f)
    slope = 1.0 + (psi_rotating(m, th + _H, f) - psi_rotating(m, th - _H, f)) / (2.0 * _H)
    if np.any(slope <= 0.0):
        raise ValueError("the rotating-vector estimate is not monotone in the position: no gain schedule")
    return psi, 1.0 / slope


def rotating_r_slopes(motor: Motor, n: int, f_inj: float, fs: float, delay_comp: float,
                      v_inj: float) -> tuple[np.ndarray, np.ndarray]:
    """The rotating injection's tables' slopes in the resistance's scale ``k_r``.

    ``R_s = k_r R_s0``; central differences over :data:`~linsense.compensation.lut.R_SLOPE_STEP`,
    for ``ls_demod_cfg.comp_r`` and ``gain_r`` (docs/tuning.md, "The hot winding"): the
    compensation's is ``dpsi_rot/dk_r + (d ref_phase/dk_r) / 2``, since the demodulator compares the
    negative sequence's phase with ``2 (theta_est + Psi) + ref_phase`` and ``ref_phase`` (the motor
    without its end effect, :func:`rotating_design`) moves with the resistance too.

    Parameters
    ----------
    motor : Motor
        The motor.
    n : int
        Positions over the period.
    f_inj : float
        Injection frequency, Hz.
    fs : float
        Sampling (PWM) frequency, Hz.
    delay_comp : float
        The drive's delay compensation, periods.
    v_inj : float
        Injection amplitude, V.

    Returns
    -------
    comp_r : ndarray
        rad per unit of ``k_r`` (zeros without resistance).
    gain_r : ndarray
        Per unit of ``k_r``.
    """
    h = R_SLOPE_STEP
    if not motor.R_s > 0:
        return np.zeros(n), np.zeros(n)
    out = []
    for s in (1.0, -1.0):
        m = dataclasses.replace(motor, R_s=motor.R_s * (1.0 + s * h))
        psi, gain = rotating_tables(m, n, f_inj)
        ref = rotating_design(m, m.R_s, v_inj, f_inj, fs, delay_comp)["ref_phase"]
        out.append((psi, gain, ref))
    (p1, g1, r1), (p0, g0, r0) = out
    d_ref = math.remainder(r1 - r0, 2.0 * math.pi)
    return (p1 - p0 + 0.5 * d_ref) / (2.0 * h), (g1 - g0) / (2.0 * h)


def _square_ratio(motor: Motor, theta, theta_est, f_inj: float, psi_est) -> np.ndarray:
    """The product demodulator's ratio ``sin(2 phi) / 2`` of the square wave at the true position
    ``theta`` with the estimate ``theta_est`` and the table value ``psi_est`` read there."""
    d = delta_current(motor, theta, f_inj, 1.0, theta_err=np.asarray(theta_est) - np.asarray(theta))
    phi = np.arctan2(d[..., 1], d[..., 0]) - (np.asarray(theta_est) - np.asarray(theta)) - psi_est
    return 0.5 * np.sin(2.0 * phi)


def square_tables(motor: Motor, n: int, f_inj: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The square wave's compensation table and gain on ``n`` positions.

    ``psi_square`` (:func:`linsense.analysis.square.psi_square`) and the gain
    ``-1 / (d ratio / d theta_est)`` that makes the error's slope against ``theta - theta_est`` one.

    Parameters
    ----------
    motor : Motor
        The motor.
    n : int
        Positions over the period.
    f_inj : float or None
        Square-wave frequency, Hz (None: the R_s = 0 limit).

    Returns
    -------
    psi_square : ndarray
        rad.
    gain : ndarray
        Dimensionless.

    Raises
    ------
    ValueError
        When the error has no restoring slope somewhere.
    """
    m, f = table_model(motor, f_inj)
    th = 2.0 * np.pi * np.arange(n) / n
    psi = psi_square(m, th, f)
    r_p = _square_ratio(m, th, th + _H, f, psi_square(m, th + _H, f))
    r_m = _square_ratio(m, th, th - _H, f, psi_square(m, th - _H, f))
    slope = (r_p - r_m) / (2.0 * _H)
    if np.any(slope >= 0.0):
        raise ValueError("the square-wave error has no restoring slope somewhere over the period")
    return psi, -1.0 / slope


def injection_tables(motor: Motor, shape: str, n: int, f_inj: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The compensation and gain tables of the ``rotating`` or ``square`` injection.

    Parameters
    ----------
    motor : Motor
        The motor.
    shape : {"rotating", "square"}
        The injection.
    n : int
        Positions over the period.
    f_inj : float or None
        Injection frequency, Hz (None: the R_s = 0 limit).

    Returns
    -------
    psi : ndarray
        Compensation table, rad.
    gain : ndarray
        Gain table, dimensionless.

    Raises
    ------
    ValueError
        Another ``shape``, or tables that do not exist (see the shape's function).
    """
    if shape == "rotating":
        return rotating_tables(motor, n, f_inj)
    if shape == "square":
        return square_tables(motor, n, f_inj)
    raise ValueError(f"shape must be 'rotating' or 'square', got {shape!r}")


def injection_d_current(i_max: float, shape: str) -> float:
    """The d-current reference while injecting: ``INJECTION_D_FRACTION i_max`` with the square wave
    and the rotating vector, 0 with the pulsating (elliptical) injection.

    The drive's force constant follows it (the reluctance force of ``(L_d - L_q) i_d i_q``, the
    firmware's ``ls_drive_set_i_d_``; docs/theory.md, "The d-current's reluctance force").

    Parameters
    ----------
    i_max : float
        Current-reference limit, A.
    shape : str
        ``"pulsating"``, ``"rotating"`` or ``"square"``.

    Returns
    -------
    float
        A.
    """
    return INJECTION_D_FRACTION * i_max if shape in ("rotating", "square") else 0.0


def d_current_force_share(l_d: float, l_q: float, psi_pm: float, i_d: float) -> float:
    """The force per ampere of q-current with the d-current ``i_d``, as a share of ``K_f``:
    ``1 + (L_d - L_q) i_d / psi_pm`` (the reluctance force; the firmware's ``ls_drive_set_i_d_``,
    ``kf_id``; docs/theory.md, "The d-current's reluctance force"), 1 without magnets' flux.

    Parameters
    ----------
    l_d, l_q : float
        The model's inductances, H.
    psi_pm : float
        The magnets' flux linkage, Wb.
    i_d : float
        The d-current, A.

    Returns
    -------
    float
        -.
    """
    return 1.0 + (l_d - l_q) * i_d / psi_pm if psi_pm > 0.0 else 1.0


def deliverable_force(force_constant: float, i_max: float, share: float) -> float:
    """The force the drive makes at ``i_max`` in every mode: ``K_f i_max``, less where the
    injection's d-current takes a share of the force constant (``share`` below 1), not more where
    it adds one (the modes without the injection make ``K_f i_max``).

    Parameters
    ----------
    force_constant : float
        ``K_f``, N/A.
    i_max : float
        The current limit, A.
    share : float
        :func:`d_current_force_share` of the injection's d-current, -.

    Returns
    -------
    float
        N.
    """
    return force_constant * i_max * min(1.0, share)


def square_current_schedule(l_avg: float, R_s: float, v_inj: float, f_pwm: float, i_d_far: float,
                            margin: float = SQUARE_DT_MARGIN) -> dict | None:
    """The square wave's d-current schedule against the dead time (docs/theory.md, "The dead time
    and the square wave"): ``{"i_d_near", "near_in", "near_out"}`` (A, rad, rad), or ``None`` where
    no schedule with ``SQUARE_MIN_HYSTERESIS`` exists.

    At standstill a leg's two edges lie ``-+s`` about its mid-period current (ramp and PWM ripple,
    ``ls_mod_step_ripple_finite``); a phase current within ``s`` loses no dead time, beyond it the
    whole. Where the estimated d-axis is normal to a phase axis (``theta = pi/6 + k pi/3``) that
    phase carries no d-current and, with the square wave's d-voltage ``v = +-V + R_s i_d`` in the
    two half periods, ``s = k |v|``, ``k = sqrt(3) T / (12 L)``: a current between ``k (V - R_s
    i_d)`` and ``k (V + R_s i_d)`` loses the dead time in one half period only, in step with the
    carrier, and the demodulated error follows its sign (a relay in the loop). The schedule keeps
    the phase current out of that band, with ``margin``, at a distance ``e`` from those positions:

    - far (``e >= near_in``) with ``i_d_far``: ``i_d_far sin(e) >= k (V + R_s i_d_far) + margin``;
    - near (``e <= near_out``) with ``i_d_near``: ``i_d_near sin(e) + margin <= k (V - R_s
      i_d_near)``, while the two other phases, at ``cos(pi/6 + e)`` of the d-current, stay beyond
      their own edges' reach in either half, ``(T/L)(sqrt(3)/4)(V + R_s i_d_near) + margin``.

    ``l_avg`` (H) is the inductance of the compensation's ripple model, ``(L_d + L_q) / 2``.

    The design is that of a no-load hold, where the current vector is the d-axis; the firmware
    keys the distance ``e`` to the current reference's vector ``(i_d_inj, i_q_ref)`` (ls_drive_square.c),
    whose zeros a force turns by ``atan(i_q / i_d_inj)`` (docs/tuning.md, "Why the rotating vector
    and the square wave cycle").

    Parameters
    ----------
    l_avg : float
        Inductance of the ripple model, H.
    R_s : float
        Phase resistance, ohm.
    v_inj : float
        Square-wave amplitude, V.
    f_pwm : float
        PWM frequency, Hz.
    i_d_far : float
        d current far from the phase axes, A.
    margin : float, optional
        Margin of the current beyond the band, A.

    Returns
    -------
    dict or None
        ``{"i_d_near": A, "near_in": rad, "near_out": rad}``, or None.
    """
    T = 1.0 / f_pwm
    k = math.sqrt(3.0) * T / (12.0 * l_avg)
    k_other = (T / l_avg) * math.sqrt(3.0) / 4.0
    far = (k * (v_inj + R_s * abs(i_d_far)) + margin) / abs(i_d_far) if i_d_far else math.inf
    if not far < 1.0:
        return None
    near_in = math.asin(far)
    near_out, i_near = math.radians(10.0), 0.0
    for _ in range(50):  # the two near conditions depend on each other: a fixed point
        den = math.cos(math.pi / 6.0 + near_out) - k_other * R_s
        if not den > 0.0:
            return None
        i_near = (k_other * v_inj + margin) / den
        x = (k * (v_inj - R_s * i_near) - margin) / i_near
        if not 0.0 < x < 0.5:
            return None
        near_out = min(math.asin(x), math.pi / 6.0 - 1e-3)
    if near_out - near_in < SQUARE_MIN_HYSTERESIS or not i_near < abs(i_d_far):
        return None
    return {"i_d_near": math.copysign(i_near, i_d_far), "near_in": near_in, "near_out": near_out}


def rotating_design(motor: Motor, R_s: float, v_inj: float, f_inj: float, fs: float,
                    delay_comp: float) -> dict:
    """The rotating demodulator's constants ``ref_phase`` and ``min_level``.

    ``ref_phase`` (rad) is the phase less ``2 theta`` of the SAMPLED currents' negative sequence for
    the motor without its end-effect, against the carrier of the voltage computed at the same sample
    (:func:`~linsense.analysis.rotating.reference_phase_sampled`: the voltage acts
    ``delay_comp - 1/2`` periods later and is held over a period, exactly; the continuous
    ``c_ref + delay_comp 2 pi f_inj / fs`` is 0.54 deg off, a 0.27 deg bias, for ecce2010 at 1 kHz,
    16 kHz); ``min_level`` (A^2) is a fraction of the model's smallest ``|i_n|^2`` over the period at
    ``v_inj``.

    Parameters
    ----------
    motor : Motor
        The motor.
    R_s : float
        The resistance to design with, ohm.
    v_inj : float
        Injection amplitude, V.
    f_inj : float
        Injection frequency, Hz.
    fs : float
        Sampling (PWM) frequency, Hz.
    delay_comp : float
        The drive's delay compensation, periods.

    Returns
    -------
    dict
        ``{"ref_phase": rad, "min_level": A^2}``.
    """
    m = dataclasses.replace(motor, R_s=R_s)
    ref = math.remainder(reference_phase_sampled(m, f_inj, fs, delay_comp - 0.5), 2.0 * math.pi)
    th = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    level = float(np.min(np.abs(negative_sequence(m, th, v_inj, f_inj)) ** 2))
    return {"ref_phase": ref, "min_level": ROTATING_LEVEL_FRACTION * level}

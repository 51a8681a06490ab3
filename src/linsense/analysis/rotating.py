"""Rotating-vector HF injection with the end-effect (docs/theory.md, "Rotating-vector injection").

A rotating HF voltage ``v = V exp(j w t)`` (stationary frame, complex space vector) drives a
current with a positive-sequence part and a negative-sequence part ``i_n exp(-j w t)``; the
position is in the phase of ``i_n``, which turns at ``2 theta``. With the inductance matrix in the
true dq frame ``L = [[L_d, L_dq], [L_dq, L_q]]`` written as ``L x = S x + D conj(x)`` for a
space vector x (``S = (L_d + L_q)/2``, ``D = (L_d - L_q)/2 + j L_dq``), and ``a = R_s + j w S``,
the negative sequence is, in closed form,

    i_n = j w V D exp(j 2 theta) / (conj(a)^2 + w^2 |D|^2)

so the end-effect's ``L_dq`` turns ``arg(D)`` away from pi and, with R_s, ``|D|`` and ``S``
moving with the position add a phase through ``conj(a)^2 + w^2 |D|^2``: the estimate
``theta_est = (arg(i_n) - c_ref) / 2`` is off by :func:`psi_rotating`, the rotating-vector
counterpart of Psi_LUT (paper eq. 12) that the observer subtracts, ``theta_est - Psi(theta_est)``.
"""

from __future__ import annotations

import numpy as np

from linsense._check import integer, real
from linsense.analysis.hf import (
    _amplitude,
    _finite_currents,
    _frequency,
    _motor,
    _theta,
    dq_components,
    mean_dq,
)
from linsense.limits import MAX_POINTS

#: the module, named in the messages of its functions' argument checks
_SRC = "linsense.analysis.rotating"


def _pwm(f_pwm, f_inj: float, src: str) -> float:
    """A PWM rate, Hz: a finite real number above twice the injection's frequency (the sampled model
    of the injection), else InputError naming ``f_pwm``."""
    return real(f_pwm, src, "f_pwm", 2.0 * f_inj, low_open=True,
                what=f"a finite PWM rate in Hz above twice f_inj ({f_inj:g} Hz)")


def negative_sequence_numeric(motor, theta, v_inj: float, f_inj: float) -> np.ndarray:
    """Negative-sequence current phasor ``i_n`` of a rotating voltage, solved numerically.

    From the alpha-beta inductance matrix of the motor's 3x3 model at standstill:
    ``(R_s + j w L_ab) I = V [1, -j]``, ``i_n = (conj(I_a) + j conj(I_b))/2``.

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        Electrical position(s), rad.
    v_inj : float
        Amplitude of the rotating voltage, V.
    f_inj : float
        Its frequency, Hz.

    Returns
    -------
    ndarray
        Complex, A.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    """
    src = f"{_SRC}.negative_sequence_numeric"
    motor, theta = _motor(motor, src), _theta(theta, src)
    f_inj, v_inj = _frequency(f_inj, "f_inj", src), _amplitude(v_inj, src=src)
    w = 2.0 * np.pi * f_inj
    Z = motor.R_s * np.eye(2) + 1j * w * motor.inductance.L_ab(theta)
    V = np.broadcast_to(np.array([v_inj, -1j * v_inj]), theta.shape + (2,))
    current = np.linalg.solve(Z, V[..., None])[..., 0]
    return _finite_currents(0.5 * (np.conj(current[..., 0]) + 1j * np.conj(current[..., 1])), v_inj, f_inj)


def _i_n(R_s: float, w: float, S, D, v_inj: float):
    """``j w V D / (conj(a)^2 + w^2 |D|^2)``, ``a = R_s + j w S``: the negative sequence without its
    ``exp(j 2 theta)`` (docs/theory.md)."""
    a = R_s + 1j * w * S
    return 1j * w * v_inj * D / (np.conj(a) ** 2 + w * w * np.abs(D) ** 2)


def negative_sequence(motor, theta, v_inj: float, f_inj: float) -> np.ndarray:
    """Negative-sequence current phasor ``i_n`` of a rotating voltage, closed form (docs/theory.md).

    ``i_n = j w V D exp(j 2 theta) / (conj(a)^2 + w^2 |D|^2)`` with ``a = R_s + j w S``: with the
    alpha-beta matrix ``L_ab x = S x + D exp(j 2 theta) conj(x)``, ``Z = a + j w K`` where
    ``K^2 = |D|^2``, so ``Z^-1 = (a - j w K) / (a^2 + w^2 |D|^2)``, and only the ``K`` part has a
    negative sequence.

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        Electrical position(s), rad.
    v_inj : float
        Amplitude of the rotating voltage, V.
    f_inj : float
        Its frequency, Hz.

    Returns
    -------
    ndarray
        Complex, A.

    Raises
    ------
    linsense.errors.InputError
        A frequency or amplitude out of range.
    """
    src = f"{_SRC}.negative_sequence"
    f_inj, v_inj = _frequency(f_inj, "f_inj", src), _amplitude(v_inj, src=src)
    motor, theta = _motor(motor, src), _theta(theta, src)
    L_d, L_q, L_dq = dq_components(motor, theta)
    S = 0.5 * (L_d + L_q)
    D = 0.5 * (L_d - L_q) + 1j * L_dq
    i_n = _i_n(motor.R_s, 2.0 * np.pi * f_inj, S, D, v_inj) * np.exp(2j * theta)
    return _finite_currents(i_n, v_inj, f_inj)


def reference_phase(motor, f_inj: float) -> float:
    """The demodulator's constant phase ``c_ref`` (rad).

    ``arg(i_n exp(-j 2 theta))`` of a motor with the mean ``L_d``, ``L_q`` over the period, no
    ``L_dq`` and the same R_s (what a drive designed without the end-effect would use), so that
    ``theta_est = (arg(i_n) - c_ref) / 2``.

    Parameters
    ----------
    motor : Motor
        The motor.
    f_inj : float
        Injection frequency, Hz.

    Returns
    -------
    float
        rad.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    """
    src = f"{_SRC}.reference_phase"
    motor, f_inj = _motor(motor, src), _frequency(f_inj, "f_inj", src)
    L_d, L_q = mean_dq(motor)
    S, D = 0.5 * (L_d + L_q), 0.5 * (L_d - L_q)
    return float(np.angle(_i_n(motor.R_s, 2.0 * np.pi * f_inj, S, D, 1.0)))


def psi_rotating(motor, theta, f_inj: float) -> np.ndarray:
    """Estimation error (rad) of the rotating-vector estimate at the true position ``theta``.

    ``theta_est - theta = angle(i_n exp(-j (2 theta + c_ref))) / 2`` (the compensation table of the
    rotating injection, like Psi_LUT for the pulsating one; it does not depend on V).

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        True electrical position(s), rad.
    f_inj : float
        Injection frequency, Hz.

    Returns
    -------
    ndarray
        rad.
    """
    src = f"{_SRC}.psi_rotating"
    f_inj = _frequency(f_inj, "f_inj", src)
    motor, theta = _motor(motor, src), _theta(theta, src)
    i_n = negative_sequence(motor, theta, 1.0, f_inj)
    return 0.5 * np.angle(i_n * np.exp(-1j * (2.0 * theta + reference_phase(motor, f_inj))))


def rotating_lut(motor, theta_est, f_inj: float | None, n: int = 7200) -> np.ndarray:
    """The rotating injection's compensation table, indexed by the estimate.

    The angle to take from ``theta_est`` to get the true position,
    ``theta = theta_est - table(theta_est)``. The error :func:`psi_rotating` is a function of the
    true position, and the map ``theta -> theta + psi(theta)`` turns 1 + dpsi/dtheta as fast (0.6 to
    2.9 for ecce2010: far from a small correction), so the table is its inverse, found on ``n``
    points over the period and interpolated (the map is increasing: the factor stays positive,
    docs/theory.md).

    Parameters
    ----------
    motor : Motor
        The motor.
    theta_est : float or ndarray
        Estimated electrical position(s), rad.
    f_inj : float or None
        Injection frequency, Hz; None: the R_s = 0 limit, where psi is the uncompensated
        equilibrium error e*.
    n : int, optional
        Points over the period of the inversion.

    Returns
    -------
    ndarray
        rad.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    linsense.errors.ModelError
        When the estimate is not monotone in the position.
    """
    from linsense.analysis.hf import equilibrium_error
    from linsense.errors import ModelError

    src = f"{_SRC}.rotating_lut"
    motor, theta_est = _motor(motor, src), _theta(theta_est, src, "theta_est")
    if f_inj is not None:
        f_inj = _frequency(f_inj, "f_inj", src)
    n = integer(n, src, "n", 4, MAX_POINTS, "a number of points")
    th = 2.0 * np.pi * np.arange(n + 1) / n
    err = equilibrium_error(motor, th) if f_inj is None else psi_rotating(motor, th, f_inj)
    est = th + err
    if np.any(np.diff(est) <= 0.0):
        raise ModelError(motor.source, "inductance", "the rotating-vector estimate is not monotone in the "
                         "position: no table inverts it")
    # the estimate over one period starts at est[0]: wrap the queries into [est[0], est[0] + 2 pi)
    q = est[0] + np.mod(theta_est - est[0], 2.0 * np.pi)
    return theta_est - (np.interp(q, est, th) + (theta_est - q))


def _sampled_i_n(L_ab: np.ndarray, R_s: float, v_inj: float, f_inj: float, f_pwm: float,
                 delay: float = 1.0) -> np.ndarray:
    """Negative-sequence phasor of the currents SAMPLED at the PWM rate for the alpha-beta
    inductance matrices ``L_ab`` (..., 2, 2): the voltage held over each period and applied
    ``delay`` periods after it is computed (1: the drive's one-period delay, docs/simulator.md),
    ``x[k+1] = Phi x[k] + Gam u[k-delay]``, exact for a whole ``delay`` (matrix exponential of the
    2x2 RL model), in the periodic steady state."""
    from scipy.linalg import expm

    T = 1.0 / f_pwm
    z = np.exp(2j * np.pi * f_inj * T)
    U = np.array([v_inj, -1j * v_inj])
    flat = L_ab.reshape(-1, 2, 2)
    out = np.empty(len(flat), dtype=complex)
    for k, L in enumerate(flat):
        Li = np.linalg.inv(L)
        M = expm(np.block([[-R_s * Li, Li], [np.zeros((2, 4))]]) * T)
        I = np.linalg.solve(z * np.eye(2) - M[:2, :2], M[:2, 2:] @ U * z ** -delay)
        out[k] = 0.5 * (np.conj(I[0]) + 1j * np.conj(I[1]))
    return out.reshape(L_ab.shape[:-2])


def reference_phase_sampled(motor, f_inj: float, f_pwm: float, delay: float = 1.0) -> float:
    """:func:`reference_phase` for the sampled drive (rad).

    The phase, less ``2 theta``, of the sampled currents' negative sequence for the motor with the
    mean L_d, L_q and no L_dq, against the carrier of the voltage computed at the same sample (it
    includes the one-period delay and the hold, exactly; ``c_ref + 1.5 w T`` is its continuous
    approximation, 0.54 deg off for ecce2010 at 1 kHz and 16 kHz).

    Parameters
    ----------
    motor : Motor
        The motor.
    f_inj : float
        Injection frequency, Hz.
    f_pwm : float
        PWM (sampling) frequency, Hz.
    delay : float, optional
        Periods between a voltage's computation and the period it acts in (the drive's
        ``delay_comp`` less the half period of the hold).

    Returns
    -------
    float
        rad.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    """
    src = f"{_SRC}.reference_phase_sampled"
    motor, f_inj = _motor(motor, src), _frequency(f_inj, "f_inj", src)
    f_pwm = _pwm(f_pwm, f_inj, src)
    delay = real(delay, src, "delay", 0.0, 16.0, what="a delay in PWM periods")
    L = np.diag(mean_dq(motor))  # at theta = 0 the alpha-beta matrix is the dq one
    return float(np.angle(_sampled_i_n(L, motor.R_s, 1.0, f_inj, f_pwm, delay)))


def psi_rotating_sampled(motor, theta, f_inj: float, f_pwm: float) -> np.ndarray:
    """:func:`psi_rotating` for the sampled drive (rad).

    The estimate's error at the true position with the negative sequence of the sampled currents
    (:func:`reference_phase_sampled`).

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        True electrical position(s), rad.
    f_inj : float
        Injection frequency, Hz.
    f_pwm : float
        PWM (sampling) frequency, Hz.

    Returns
    -------
    ndarray
        rad.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    """
    src = f"{_SRC}.psi_rotating_sampled"
    motor, theta = _motor(motor, src), _theta(theta, src)
    f_inj = _frequency(f_inj, "f_inj", src)
    f_pwm = _pwm(f_pwm, f_inj, src)
    i_n = _sampled_i_n(motor.inductance.L_ab(theta), motor.R_s, 1.0, f_inj, f_pwm)
    return 0.5 * np.angle(i_n * np.exp(-1j * (2.0 * theta + reference_phase_sampled(motor, f_inj, f_pwm))))

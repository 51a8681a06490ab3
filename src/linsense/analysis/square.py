"""Square-wave HF injection with the end-effect (docs/theory.md, "Square-wave injection").

A square wave ``+-V`` on the estimated d-axis at ``f_inj`` (half a period ``T = 1/(2 f_inj)`` at each
sign; ``f_inj = f_pwm / 2`` switches every PWM period) and the difference-based demodulator: the
change of the current over each half period, sign-corrected, rotated by the compensation angle,
its q component is the error signal. At standstill in the true dq frame, ``L di/dt + R_s i = v``;
in the periodic steady state the change over a half period with ``+V`` is, in closed form,

    delta_i = (2 / R_s) tanh(R_s T L^-1 / 2) v        (R_s -> 0:  T L^-1 v)

(:func:`delta_current`). The angle that zeroes its q component at zero estimation error is the
square wave's compensation table :func:`psi_square`; without R_s it is exactly eq. (12),
``atan(-L_dq / L_q)``, because the column of ``L^-1`` along d is ``(L_q, -L_dq)/det L``.
"""

from __future__ import annotations

import numpy as np

from linsense._check import integer, real
from linsense.analysis.hf import _amplitude, _finite_currents, _frequency, _motor, _theta, _together
from linsense.errors import InputError
from linsense.model.frames import rot

#: the module, named in the messages of its functions' argument checks
_SRC = "linsense.analysis.square"
#: integration steps of :func:`delta_current_numeric` (steps x periods): about 10 s
MAX_NUMERIC_STEPS = 10_000_000


def _l_dq(motor, theta) -> np.ndarray:
    return motor.inductance.L_dq(np.asarray(theta, dtype=float))


def _v_true(theta_err, v_inj: float) -> np.ndarray:
    """The injected voltage along the estimated d-axis, in the true frame (``x_dq = R(e) x_dq_est``)."""
    return v_inj * rot(np.asarray(theta_err, dtype=float))[..., :, 0]


def delta_current(motor, theta, f_inj: float, v_inj: float = 1.0, theta_err=0.0) -> np.ndarray:
    """Change of the current (A, true dq frame, shape ``(..., 2)``) over the ``+V`` half period of a
    square wave of amplitude ``v_inj`` (V) at ``f_inj`` (Hz) in the periodic steady state, closed
    form ``(2/R_s) tanh(R_s T L^-1 / 2) v`` (``T = 1/(2 f_inj)``; the series of tanh when R_s T is
    small against L, exactly ``T L^-1 v`` for R_s = 0).

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        True electrical position(s), rad.
    f_inj : float
        Square-wave frequency, Hz.
    v_inj : float, optional
        Amplitude, V.
    theta_err : float or ndarray, optional
        Estimation error, rad.

    Returns
    -------
    ndarray, shape (..., 2)
        A, in the true dq frame.

    Raises
    ------
    linsense.errors.InputError
        A frequency or amplitude out of range.
    """
    src = f"{_SRC}.delta_current"
    f_inj, v_inj = _frequency(f_inj, "f_inj", src), _amplitude(v_inj, src=src)
    motor = _motor(motor, src)
    theta, theta_err = _together(src, _theta(theta, src), _theta(theta_err, src, "theta_err"))
    T = 0.5 / f_inj
    L_inv = np.linalg.inv(_l_dq(motor, theta))
    v = _v_true(theta_err, v_inj)
    x = 0.5 * motor.R_s * T * L_inv  # (the argument of tanh, a 2x2 matrix)
    # tanh of a symmetric-similar 2x2 matrix through its eigen-decomposition (L^-1 is symmetric
    # positive definite, so x is too: real eigenvalues, orthogonal eigenvectors)
    w, U = np.linalg.eigh(x)
    positive = w > 0.0  # (R_s = 0: w = 0, where tanh(w)/w -> 1)
    ratio = np.where(positive, np.tanh(w) / np.where(positive, w, 1.0), 1.0)  # tanh(w)/w
    f = U @ (ratio[..., :, None] * np.swapaxes(U, -1, -2))  # tanh(x) x^-1
    return _finite_currents((T * (f @ L_inv) @ v[..., None])[..., 0], v_inj, f_inj)


def delta_current_numeric(motor, theta: float, f_inj: float, v_inj: float = 1.0, theta_err: float = 0.0,
                          steps: int = 2000, periods: int = 400) -> np.ndarray:
    """The same change of the current by integrating ``L di/dt = v - R_s i`` (exact matrix
    exponential per step, ``steps`` steps per half period) for ``periods`` square-wave periods from
    rest, until the periodic steady state (the decay time L/R_s is about 0.3 ms for ecce2010).

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float
        True electrical position, rad.
    f_inj : float
        Square-wave frequency, Hz.
    v_inj : float, optional
        Amplitude, V.
    theta_err : float, optional
        Estimation error, rad.
    steps : int, optional
        Steps per half period.
    periods : int, optional
        Square-wave periods simulated.

    Returns
    -------
    ndarray, shape (2,)
        The change over the last ``+V`` half period, A, true dq frame.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range (``steps`` x ``periods`` beyond
        :data:`MAX_NUMERIC_STEPS`), naming it.
    """
    from scipy.linalg import expm

    from linsense.limits import MAX_F_INJ, MIN_F_INJ, max_angle

    src = f"{_SRC}.delta_current_numeric"
    motor = _motor(motor, src)
    theta = real(theta, src, "theta", -max_angle(), max_angle(), what="one position in rad")
    theta_err = real(theta_err, src, "theta_err", -max_angle(), max_angle(), what="one angle in rad")
    # (at least a table's lowest injection, 1 Hz: at 1e-213 Hz the step's matrix exponential was NaN)
    f_inj = real(f_inj, src, "f_inj", MIN_F_INJ, MAX_F_INJ, what="a frequency in Hz (docs/limits.md)")
    v_inj = _amplitude(v_inj, src=src)
    steps = integer(steps, src, "steps", 1, MAX_NUMERIC_STEPS, "a number of steps")
    periods = integer(periods, src, "periods", 1, MAX_NUMERIC_STEPS, "a number of periods")
    if steps * periods > MAX_NUMERIC_STEPS:
        raise InputError(src, "periods", f"{steps:,} steps x {periods:,} periods is beyond the limit of "
                         f"{MAX_NUMERIC_STEPS:,} steps")
    T = 0.5 / f_inj
    L = _l_dq(motor, theta)
    L_inv = np.linalg.inv(L)
    A = motor.R_s * L_inv
    h = T / steps
    Phi = expm(-A * h)
    # zero-order hold of a constant voltage over one step: int_0^h e^{-A s} ds L^-1 v
    Gam = (np.linalg.solve(A, np.eye(2) - Phi) if motor.R_s > 0 else h * np.eye(2)) @ L_inv
    v = _v_true(theta_err, v_inj)
    i = np.zeros(2)
    for _ in range(periods):
        start = i.copy()
        for _ in range(steps):
            i = Phi @ i + Gam @ v
        rise = i - start
        for _ in range(steps):
            i = Phi @ i - Gam @ v
    return _finite_currents(rise, v_inj, f_inj)


def psi_square(motor, theta, f_inj: float) -> np.ndarray:
    """Compensation angle (rad) of the square-wave injection: the angle of the current change over
    the ``+V`` half period at zero estimation error, ``atan2(delta_i_q, delta_i_d)`` (rotating the
    measured change by it zeroes its q component, as Psi_LUT does for the pulsating injection).

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        Electrical position(s), rad.
    f_inj : float
        Square-wave frequency, Hz.

    Returns
    -------
    ndarray
        rad.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    """
    d = delta_current(motor, theta, f_inj)
    return np.arctan2(d[..., 1], d[..., 0])

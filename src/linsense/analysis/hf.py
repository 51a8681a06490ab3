"""HF response of the end-effect model: psi maps, the compensation angle, saliency and the
equilibrium of the uncompensated observer (paper eqs. 8-13, brief section 4).

Conventions: the estimated frame leads the actual one by the error,
``theta_est = theta + theta_err`` and ``x_dq = x_dq_est * exp(j theta_err)``.
All angles in rad. Every function is vectorised and broadcasts ``theta`` against ``theta_err``.
"""

from __future__ import annotations

import math

import numpy as np

from linsense._check import choice, integer, real, reals
from linsense.errors import InputError
from linsense.limits import MAX_F_INJ, MAX_POINTS, max_angle
from linsense.model.frames import rot
from linsense.model.inductance import InductanceModel
from linsense.model.motor import Motor, as_motor

#: the functions' module, named in the messages of their arguments' checks
_SRC = "linsense.analysis.hf"


def _model(m, src: str, name: str = "model") -> InductanceModel:
    """The inductance model of a motor argument: a :class:`~linsense.model.motor.Motor`, a preset's
    or example's name or a motor file (:func:`~linsense.model.motor.as_motor`), or an
    :class:`InductanceModel`."""
    m = as_motor(m, src, name, inductance=True)
    return m if isinstance(m, InductanceModel) else m.inductance


def _motor(m, src: str) -> Motor:
    """A motor argument that must be a motor (its R_s counts): :func:`~linsense.model.motor.as_motor`."""
    return as_motor(m, src, "motor")


def _theta(v, src: str, name: str = "theta") -> np.ndarray:
    """A position argument: finite real numbers, rad, within the firmware's range of positions (None,
    NaN, a complex number, a dict or 1e308 rad refused)."""
    return reals(v, src, name, "positions in rad", bound=max_angle())


def _together(src: str, theta: np.ndarray, theta_err: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``theta`` and ``theta_err`` broadcast together, else InputError naming ``theta_err``."""
    try:
        return np.broadcast_arrays(theta, theta_err)
    except ValueError:
        raise InputError(src, "theta_err", f"shape {theta_err.shape} does not broadcast with theta's "
                         f"{theta.shape}") from None


#: the frequency at which a table without R_s is evaluated (any: without R_s it does not depend on it)
F_NO_R = 1000.0


def table_model(motor, f_inj: float | None):
    """``(motor, f)`` a table is computed for: ``f_inj`` None is the R_s = 0 limit, ``motor``
    without its resistance at :data:`F_NO_R`; else ``(motor, f_inj)`` unchanged.

    Parameters
    ----------
    motor : Motor
        The motor.
    f_inj : float or None
        Injection frequency, Hz (None: the R_s = 0 limit).

    Returns
    -------
    motor : Motor
        ``motor``, without its resistance when ``f_inj`` is None.
    f : float
        The frequency to evaluate at, Hz.
    """
    import dataclasses

    motor = _motor(motor, f"{_SRC}.table_model")
    if f_inj is None:
        return dataclasses.replace(motor, R_s=0.0), F_NO_R
    return motor, _frequency(f_inj, "f_inj", f"{_SRC}.table_model")


def dq_components(model, theta: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(L_d, L_q, L_dq)`` at ``theta`` (H), from the transformed 3x3 matrix.

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        Electrical position(s), rad.

    Returns
    -------
    L_d : ndarray
        H, of ``theta``'s shape.
    L_q : ndarray
        H.
    L_dq : ndarray
        H.
    """
    src = f"{_SRC}.dq_components"
    L = _model(model, src).L_dq(_theta(theta, src))
    return L[..., 0, 0], L[..., 1, 1], L[..., 0, 1]


def mean_dq(motor, n: int = 720) -> tuple[float, float]:
    """Mean L_d, L_q over one period (H): the motor without its end-effect.

    Parameters
    ----------
    motor : Motor or InductanceModel
        The motor.
    n : int, optional
        Positions averaged over.

    Returns
    -------
    L_d : float
        H.
    L_q : float
        H.
    """
    n = integer(n, f"{_SRC}.mean_dq", "n", 1, MAX_POINTS, "a number of positions")
    th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    L_d, L_q, _ = dq_components(_model(motor, f"{_SRC}.mean_dq", "motor"), th)
    return float(np.mean(L_d)), float(np.mean(L_q))


def end_anisotropy(motor, n: int = 720) -> tuple[float, float]:
    """The stationary anisotropy ``(l_ea, l_eb)`` (H) of the alpha-beta inductance: the traceless
    part of its mean over one period, ``[[l_ea, l_eb], [l_eb, -l_ea]]``. The saliency's part turns
    with ``2 theta`` and averages out; what stays is the end effect's (a 3x3 matrix that is not
    cyclic: docs/theory.md), which the dead-time residual's model needs (ls_dtres.h).

    Parameters
    ----------
    motor : Motor
        The motor.
    n : int, optional
        Positions averaged over.

    Returns
    -------
    l_ea : float
        H.
    l_eb : float
        H.
    """
    src = f"{_SRC}.end_anisotropy"
    n = integer(n, src, "n", 1, MAX_POINTS, "a number of positions")
    th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    L = np.asarray(_model(motor, src, "motor").L_ab(th)).mean(axis=0)
    return float(0.5 * (L[0, 0] - L[1, 1])), float(0.5 * (L[0, 1] + L[1, 0]))


def saliency(model, theta: np.ndarray | float) -> np.ndarray:
    """Saliency ``L_q - L_d`` (H).

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        Electrical position(s), rad.

    Returns
    -------
    ndarray
        H.
    """
    src = f"{_SRC}.saliency"
    L_d, L_q, _ = dq_components(_model(model, src), _theta(theta, src))
    return L_q - L_d


def hf_current_est(model, theta, theta_err) -> np.ndarray:
    """HF current per unit injected flux in the estimated frame (the operator R of eq. 10).

    Pulsating flux ``lambda_d_est = 1`` on the estimated d-axis is rotated into the true frame,
    mapped through the inverse dq model ``i_dq = L_dq^-1 lambda_dq`` (eq. 8) and rotated back.

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        True electrical position(s), rad.
    theta_err : float or ndarray
        Estimation error ``theta_est - theta``, rad.

    Returns
    -------
    ndarray, shape broadcast(theta, theta_err).shape + (2,)
        ``(i_d_est, i_q_est)`` in A per Wb (1/H).
    """
    src = f"{_SRC}.hf_current_est"
    theta, theta_err = _together(src, _theta(theta, src), _theta(theta_err, src, "theta_err"))
    Gamma = np.linalg.inv(_model(model, src).L_dq(theta))
    lam_dq = rot(theta_err)[..., :, 0]  # lambda_est = (1, 0) seen in the true frame
    i_dq = np.einsum("...ij,...j->...i", Gamma, lam_dq)
    return np.einsum("...ji,...j->...i", rot(theta_err), i_dq)  # rotate by -theta_err


def psi(model, theta, theta_err) -> np.ndarray:
    """Phase ``psi`` (rad) of the HF current relative to the injected flux, eq. (11).

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        True electrical position(s), rad.
    theta_err : float or ndarray
        Estimation error, rad.

    Returns
    -------
    ndarray
        rad.
    """
    src = f"{_SRC}.psi"
    i = hf_current_est(_model(model, src), _theta(theta, src), _theta(theta_err, src, "theta_err"))
    return np.arctan2(i[..., 1], i[..., 0])


def psi_lut(model, theta) -> np.ndarray:
    """Compensation angle ``Psi_LUT = psi(theta, 0) = atan(-L_dq / L_q)`` (rad), eq. (12).

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        Electrical position(s), rad.

    Returns
    -------
    ndarray
        rad.
    """
    src = f"{_SRC}.psi_lut"
    _, L_q, L_dq = dq_components(_model(model, src), _theta(theta, src))
    return np.arctan2(-L_dq, L_q)


def _frequency(f, name: str, src: str = _SRC) -> float:
    """``f`` as a float if it is a real, finite, positive frequency (Hz) up to the injection's limit
    (:data:`linsense.limits.MAX_F_INJ`, docs/limits.md), else InputError naming ``name`` (the API
    refuses what the CLI refuses: a negative, complex or None frequency was accepted and gave a table
    of nonsense; 1e308 Hz gave NaN angles, 1e300 Hz all-zero currents)."""
    f = real(f, src, name, 0.0, MAX_F_INJ, low_open=True,
             what="a positive finite frequency in Hz (docs/limits.md)")
    if not math.isfinite(1.0 / f):  # (5e-324 Hz: its period is infinite, the square wave's table NaN)
        raise InputError(src, name, f"{f!r} Hz is too small: its period overflows")
    return f


def _amplitude(v, name: str = "v_inj", src: str = _SRC) -> float:
    """``v`` as a float if it is a real, finite, positive voltage (V), else InputError naming ``name``."""
    return real(v, src, name, 0.0, low_open=True, what="a positive finite amplitude in V")


def _quad(v, src: str = _SRC) -> float:
    """The elliptical injection's share ``kappa`` in [0, 1), else InputError naming ``quad``."""
    return real(v, src, "quad", 0.0, 1.0, high_open=True)


def psi_lut_resistive(motor, theta, f_inj: float, quad: float = 0.0) -> np.ndarray:
    """Compensation angle (rad) that zeroes the demodulated error at theta_err = 0 with R_s.

    Eq. (12) assumes a purely inductive HF response. With the winding resistance the HF currents
    on d and q are no longer in phase: for a pulsating voltage on d at ``f_inj`` (Hz) the ratio
    ``r = i_q / i_d = -j w L_dq / (R_s + j w L_q)`` is complex. Both demodulators (the product
    ``i_d i_q`` and the synchronous one) measure ``Re(i_d' conj(i_q'))`` in the rotated frame,
    which vanishes for ``tan 2 Psi = 2 Re(i_d conj(i_q)) / (|i_d|^2 - |i_q|^2)`` (for the pulsating
    injection ``= 2 Re(r) / (1 - |r|^2)``; for ``R_s = 0`` this is eq. 12). Because the position
    error is the angle error times ``L_q / (L_q - L_d)``, the difference matters: for ecce2010 at
    1 kHz eq. (12) leaves up to 2 electrical degrees of bias.

    ``quad`` (kappa) adds ``kappa sin`` on the estimated q-axis to the ``cos`` on d (elliptical
    injection, docs/theory.md): its direct q response is in quadrature with i_d only without
    resistance, so the angle then also cancels ``kappa Im((R + j w L_d)/(R + j w L_q))``.

    Parameters
    ----------
    motor : Motor
        The motor (its ``R_s`` counts).
    theta : float or ndarray
        Electrical position(s), rad.
    f_inj : float
        Injection frequency, Hz.
    quad : float, optional
        Quadrature ratio ``kappa`` of the elliptical injection, in [0, 1) (0: pulsating).

    Returns
    -------
    ndarray
        rad.

    Raises
    ------
    linsense.errors.InputError
        A frequency, amplitude or ``quad`` out of range (:func:`hf_current`).
    """
    i = hf_current(motor, theta, 1.0, f_inj, 0.0, quad=quad)
    p = np.real(i[..., 0] * np.conj(i[..., 1]))
    return 0.5 * np.arctan2(2.0 * p, np.abs(i[..., 0]) ** 2 - np.abs(i[..., 1]) ** 2)


def demod_ratio(motor, theta, theta_err, v_inj: float, f_inj: float, psi_comp,
                quad: float = 0.0) -> np.ndarray:
    """Normalised output of the product demodulator, ``<i_d' i_q'> / <i_d'^2 + i_q'^2>``.

    HF currents from :func:`hf_current` (with R_s), rotated by ``psi_comp`` (rad) from the
    estimated frame; the time averages of products of phasors are ``Re(a conj(b)) / 2``.

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        True electrical position(s), rad.
    theta_err : float or ndarray
        Estimation error, rad.
    v_inj : float
        Injection amplitude, V.
    f_inj : float
        Injection frequency, Hz.
    psi_comp : float or ndarray
        Compensation angle, rad.
    quad : float, optional
        Quadrature ratio of the elliptical injection (0: pulsating).

    Returns
    -------
    ndarray
        Dimensionless, in [-1/2, 1/2].
    """
    src = f"{_SRC}.demod_ratio"
    psi_comp = reals(psi_comp, src, "psi_comp", "angles in rad")
    i = hf_current(motor, theta, v_inj, f_inj, theta_err, quad=quad)
    # (scaled: the ratio does not depend on the amplitude, and 1e300 V squared overflowed to NaN)
    scale = np.max(np.abs(i), axis=-1, keepdims=True)
    if not np.all(scale > 0.0):  # (5e-324 V: the currents underflow, the ratio 0 / 0)
        raise InputError(src, "v_inj", f"{v_inj!r} V at {f_inj!r} Hz gives HF currents below floating point")
    i = i / scale
    try:
        c, s = np.broadcast_arrays(np.cos(psi_comp), i[..., 0])[0], np.sin(psi_comp)
        i_d = c * i[..., 0] + s * i[..., 1]
    except ValueError:
        raise InputError(src, "psi_comp", f"shape {psi_comp.shape} does not broadcast with the positions' "
                         f"{i.shape[:-1]}") from None
    i_q = -s * i[..., 0] + c * i[..., 1]
    return np.real(i_d * np.conj(i_q)) / (np.abs(i_d) ** 2 + np.abs(i_q) ** 2)


def psi_compensated(model, theta, theta_err, lut_at: str = "estimated") -> np.ndarray:
    """Phase of the HF current in the compensated frame, ``psi - Psi_LUT`` (rad), eq. (13).

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        True electrical position(s), rad.
    theta_err : float or ndarray
        Estimation error, rad.
    lut_at : {"estimated", "actual"}
        Where the LUT is read: at ``theta_est = theta + theta_err`` as a drive does (default)
        or at the true position as drawn in the paper's Fig. 8b.

    Returns
    -------
    ndarray
        rad, wrapped to (-pi, pi].

    Raises
    ------
    linsense.errors.InputError
        Another ``lut_at``, or an argument of another type (the closest named).
    """
    src = f"{_SRC}.psi_compensated"
    lut_at = choice(lut_at, src, "lut_at", ("estimated", "actual"))
    model = _model(model, src)
    theta, theta_err = _together(src, _theta(theta, src), _theta(theta_err, src, "theta_err"))
    theta_lut = theta + (theta_err if lut_at == "estimated" else 0.0)
    d = psi(model, theta, theta_err) - psi_lut(model, theta_lut)
    return np.angle(np.exp(1j * d))


def _sal_sign(L_d, L_q) -> float:
    return 1.0 if np.mean(L_q - L_d) >= 0 else -1.0


def equilibrium_error(model, theta) -> np.ndarray:
    """Error ``e*`` (rad) at which the *uncompensated* observer settles (``psi(theta, e*) = 0``).

    From eq. (11): ``tan(2 e*) = 2 L_dq / (L_d - L_q)``; the stable root is the one within
    45 deg of zero, ``e* = atan2(-2 L_dq s, (L_q - L_d) s) / 2`` with ``s`` the saliency sign.

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        True electrical position(s), rad.

    Returns
    -------
    ndarray
        ``e*``, rad.
    """
    src = f"{_SRC}.equilibrium_error"
    L_d, L_q, L_dq = dq_components(_model(model, src), _theta(theta, src))
    s = _sal_sign(L_d, L_q)
    return 0.5 * np.arctan2(-2.0 * L_dq * s, (L_q - L_d) * s)


def loop_gain_factor(model, theta) -> np.ndarray:
    """Position-loop gain factor ``1 + de*/dtheta`` of the uncompensated observer (brief sec. 4).

    The observer reports ``theta_est = theta + e*(theta)``, so the position loop sees the plant
    gain multiplied by this factor. Computed analytically from ``dL_dq/dtheta``.

    Parameters
    ----------
    model : Motor or InductanceModel
        The motor or its inductance model.
    theta : float or ndarray
        True electrical position(s), rad.

    Returns
    -------
    ndarray
        Dimensionless.
    """
    src = f"{_SRC}.loop_gain_factor"
    model, theta = _model(model, src), _theta(theta, src)
    L = model.L_dq(theta)
    dL = model.dL_dq(theta)
    u = L[..., 1, 1] - L[..., 0, 0]
    w = -2.0 * L[..., 0, 1]
    du = dL[..., 1, 1] - dL[..., 0, 0]
    dw = -2.0 * dL[..., 0, 1]
    # d/dtheta of atan2(w, u) / 2 (the saliency sign cancels)
    return 1.0 + 0.5 * (u * dw - w * du) / (u * u + w * w)


def hf_current(
    motor, theta, v_inj: float, f_inj: float, theta_err=0.0, quad: float = 0.0
) -> np.ndarray:
    """Complex HF current phasors ``(i_d_est, i_q_est)`` (A, peak) for a pulsating voltage.

    Solves ``v = (R_s I + j omega L_dq) i`` in the true frame at standstill for a voltage of
    amplitude ``v_inj`` at ``f_inj`` on the estimated d-axis, plus ``quad v_inj sin`` on the
    estimated q-axis (phasor ``-j quad v_inj``; 0: pulsating).

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        True electrical position(s), rad.
    v_inj : float
        Injection amplitude, V.
    f_inj : float
        Injection frequency, Hz.
    theta_err : float or ndarray, optional
        Estimation error, rad.
    quad : float, optional
        Quadrature ratio, in [0, 1).

    Returns
    -------
    ndarray, shape (..., 2)
        Complex phasors, A.

    Raises
    ------
    linsense.errors.InputError
        A frequency, amplitude or ``quad`` out of range, or currents beyond floating point.
    """
    f_inj = _frequency(f_inj, "f_inj")
    v_inj = _amplitude(v_inj)
    quad = _quad(quad)
    motor = _motor(motor, _SRC)
    theta, theta_err = _together(_SRC, _theta(theta, _SRC), _theta(theta_err, _SRC, "theta_err"))
    w = 2.0 * np.pi * f_inj
    Z = motor.R_s * np.eye(2) + 1j * w * motor.inductance.L_dq(theta)
    R = rot(theta_err)
    v_dq = v_inj * (R[..., :, 0] - 1j * quad * R[..., :, 1])
    i_dq = np.linalg.solve(Z, v_dq[..., None].astype(complex))[..., 0]
    return _finite_currents(np.einsum("...ji,...j->...i", rot(theta_err), i_dq), v_inj, f_inj)


def _finite_currents(i: np.ndarray, v_inj: float, f_inj: float) -> np.ndarray:
    """``i``, or InputError naming ``v_inj`` when the currents overflow (1e308 V gave inf amperes)."""
    if not np.all(np.isfinite(i)):
        raise InputError("linsense.analysis.hf", "v_inj", f"{v_inj!r} V at {f_inj:g} Hz gives HF currents "
                         "beyond floating point")
    return i


def hf_current_amplitude(motor, theta, v_inj: float = 12.0, f_inj: float = 1000.0) -> np.ndarray:
    """Peak amplitude (A) of the HF current vector for a pulsating injection at zero error.

    Parameters
    ----------
    motor : Motor
        The motor.
    theta : float or ndarray
        Electrical position(s), rad.
    v_inj : float, optional
        Injection amplitude, V.
    f_inj : float, optional
        Injection frequency, Hz.

    Returns
    -------
    ndarray
        A.

    Raises
    ------
    linsense.errors.InputError
        As :func:`hf_current`.
    """
    i = np.abs(hf_current(motor, theta, v_inj, f_inj))
    return _finite_currents(np.hypot(i[..., 0], i[..., 1]), v_inj, f_inj)

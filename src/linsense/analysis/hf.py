"""HF response of the end-effect model: psi maps, the compensation angle, saliency and the
equilibrium of the uncompensated observer (paper eqs. 8-13, brief section 4).

Conventions: the estimated frame leads the actual one by the error,
``theta_est = theta + theta_err`` and ``x_dq = x_dq_est * exp(j theta_err)``.
All angles in rad. Every function is vectorised and broadcasts ``theta`` against ``theta_err``.
"""

from __future__ import annotations

import math

import numpy as np

from linsense.model.frames import rot
from linsense.model.inductance import InductanceModel


def _model(m) -> InductanceModel:
    """Accept a :class:`~linsense.model.motor.Motor` or an :class:`InductanceModel`."""
    return m if isinstance(m, InductanceModel) else m.inductance


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

    if f_inj is None:
        return dataclasses.replace(motor, R_s=0.0), F_NO_R
    return motor, f_inj


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
    L = _model(model).L_dq(theta)
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
    th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    L_d, L_q, _ = dq_components(motor, th)
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
    th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    L = np.asarray(motor.inductance.L_ab(th)).mean(axis=0)
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
    L_d, L_q, _ = dq_components(model, theta)
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
    theta, theta_err = np.broadcast_arrays(np.asarray(theta, float), np.asarray(theta_err, float))
    Gamma = np.linalg.inv(_model(model).L_dq(theta))
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
    i = hf_current_est(model, theta, theta_err)
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
    _, L_q, L_dq = dq_components(model, theta)
    return np.arctan2(-L_dq, L_q)


def real_arg(v, source: str, name: str, low: float = -math.inf, high: float = math.inf, *,
             low_open: bool = False, high_open: bool = False, what: str = "a finite real number",
             kind: str | None = None) -> float:
    """``v`` as a float if it is a real, finite number within ``low`` .. ``high``.

    Not a boolean, complex, string, None or array; open ends where asked. The API refuses what the
    CLI refuses (issue 23: a NaN amplitude, a string or a complex number gave tables of NaN or a
    numpy traceback).

    Parameters
    ----------
    v : object
        The argument.
    source : str
        Where it was given (the function), for the message.
    name : str
        The argument's name, for the message.
    low, high : float, optional
        The range (infinite by default).
    low_open, high_open : bool, optional
        Whether ``low`` / ``high`` themselves are refused.
    what : str, optional
        What the argument must be, for the message.
    kind : str or None, optional
        Its kind of quantity (:data:`linsense.plausible.KINDS`): a refused number gets the slip of
        unit that brings it within the range ("did you type kHz?").

    Returns
    -------
    float
        ``float(v)``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``name``, the range and the value.
    """
    import numbers

    from linsense.errors import InputError, shown

    ok = isinstance(v, numbers.Real) and not isinstance(v, bool | np.bool_) and math.isfinite(v)
    if ok:
        ok = (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    if not ok:
        lo = "" if low == -math.inf else f"{'(' if low_open else '['}{low:g}"
        hi = "" if high == math.inf else f"{high:g}{')' if high_open else ']'}"
        rng = f" in {lo or '(-inf'}, {hi or 'inf)'}" if lo or hi else ""
        hint = ""
        if kind is not None and isinstance(v, numbers.Real) and not isinstance(v, bool | np.bool_):
            from linsense.plausible import slip

            def inside(x: float) -> bool:
                return (x > low if low_open else x >= low) and (x < high if high_open else x <= high)

            hint = slip(kind, float(v), ok=inside)
        raise InputError(source, name, f"must be {what}{rng}, got {shown(v)}" + (f"; {hint}" if hint else ""))
    return float(v)


def _frequency(f, name: str) -> float:
    """``f`` as a float if it is a real, finite, positive frequency (Hz) up to the injection's limit
    (:data:`linsense.limits.MAX_F_INJ`, docs/limits.md), else InputError naming ``name`` (the API
    refuses what the CLI refuses: a negative, complex or None frequency was accepted and gave a table
    of nonsense; 1e308 Hz gave NaN angles, 1e300 Hz all-zero currents)."""
    from linsense.limits import MAX_F_INJ

    f = real_arg(f, "linsense.analysis.hf", name, 0.0, MAX_F_INJ, low_open=True,
                 what="a positive finite frequency in Hz (docs/limits.md)")
    if not math.isfinite(1.0 / f):  # (5e-324 Hz: its period is infinite, the square wave's table NaN)
        from linsense.errors import InputError

        raise InputError("linsense.analysis.hf", name, f"{f!r} Hz is too small: its period overflows")
    return f


def _amplitude(v, name: str = "v_inj") -> float:
    """``v`` as a float if it is a real, finite, positive voltage (V), else InputError naming ``name``."""
    return real_arg(v, "linsense.analysis.hf", name, 0.0, low_open=True,
                    what="a positive finite amplitude in V")


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
    i = hf_current(motor, theta, v_inj, f_inj, theta_err, quad=quad)
    c, s = np.cos(psi_comp), np.sin(psi_comp)
    i_d = c * i[..., 0] + s * i[..., 1]
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
    ValueError
        Another ``lut_at``.
    """
    if lut_at not in ("estimated", "actual"):
        raise ValueError("lut_at must be 'estimated' or 'actual'")
    theta_lut = np.asarray(theta) + (np.asarray(theta_err) if lut_at == "estimated" else 0.0)
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
    L_d, L_q, L_dq = dq_components(model, theta)
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
    model = _model(model)
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
    quad = real_arg(quad, "linsense.analysis.hf", "quad", 0.0, 1.0, high_open=True)
    theta, theta_err = np.broadcast_arrays(np.asarray(theta, float), np.asarray(theta_err, float))
    w = 2.0 * np.pi * f_inj
    Z = motor.R_s * np.eye(2) + 1j * w * motor.inductance.L_dq(theta)
    R = rot(theta_err)
    v_dq = v_inj * (R[..., :, 0] - 1j * quad * R[..., :, 1])
    i_dq = np.linalg.solve(Z, v_dq[..., None].astype(complex))[..., 0]
    return _finite_currents(np.einsum("...ji,...j->...i", rot(theta_err), i_dq), v_inj, f_inj)


def _finite_currents(i: np.ndarray, v_inj: float, f_inj: float) -> np.ndarray:
    """``i``, or InputError naming ``v_inj`` when the currents overflow (1e308 V gave inf amperes)."""
    if not np.all(np.isfinite(i)):
        from linsense.errors import InputError

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

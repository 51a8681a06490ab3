"""Reference-frame transforms (brief section 2).

Conventions
-----------
* Amplitude-invariant Clarke transform (factor 2/3): ``x_ab = T_CLARKE @ x_abc``.
* With a floating star point the zero sequence is absent and ``x_abc = T_CLARKE_INV @ x_ab``.
* Park: ``x_ab = rot(theta) @ x_dq``, i.e. the dq frame is rotated by ``theta`` from alpha-beta.
* Phase B lags A by 2 pi/3, C leads A by 2 pi/3: the axis of B sits at theta = +2 pi/3.

A matrix ``L`` mapping currents to flux linkages transforms as ``L_ab = T L_abc T_inv`` and
``L_dq = rot(theta).T L_ab rot(theta)``.
"""

from __future__ import annotations

import math

import numpy as np

from linsense._check import reals
from linsense.errors import InputError

_S3 = np.sqrt(3.0) / 2.0

#: Amplitude-invariant Clarke transform, abc -> alpha-beta (2 x 3).
T_CLARKE = (2.0 / 3.0) * np.array([[1.0, -0.5, -0.5], [0.0, _S3, -_S3]])
#: Inverse Clarke for zero-sequence-free quantities, alpha-beta -> abc (3 x 2).
T_CLARKE_INV = np.array([[1.0, 0.0], [-0.5, _S3], [-0.5, -_S3]])
#: The phases' electrical angles, rad (A, B, C): phase k's back-EMF, PM flux or balanced current is
#: a function of ``theta + PHASE_ANGLE[k]`` (B lags A by 2 pi/3, C leads it).
PHASE_ANGLE = np.array([0.0, -2.0 * np.pi / 3.0, 2.0 * np.pi / 3.0])


def phase_fundamentals(theta: np.ndarray, values: np.ndarray, derivative: bool = False, orders: int = 1
                       ) -> tuple[list[float], list[float]]:
    """Each phase's fundamental ``A_k cos(theta + PHASE_ANGLE[k] + delta_k)`` by least squares.

    The per-phase PM flux of the motor file's ``[pm_flux]`` (docs/theory.md section 10), fitted to
    the flux (the FEA) or to its derivative in theta (an open-circuit back-EMF over the speed).
    Inputs are not checked here: the callers have.

    Parameters
    ----------
    theta : ndarray, shape (N,)
        Electrical positions, rad.
    values : ndarray, shape (N, 3)
        Phases A, B, C at the positions.
    derivative : bool, optional
        ``values`` are ``d/d theta`` of the waveform.
    orders : int, optional
        With more than 1, an offset and the harmonics 2 .. ``orders`` are fitted beside the
        fundamental (and dropped), so that they do not leak into it over a part of a period; 1 fits
        the fundamental alone (exact over whole periods of equally spaced samples).

    Returns
    -------
    amplitude : list of float
        ``A_k``, in ``values``' unit.
    delta : list of float
        ``delta_k``, rad.
    """
    amplitude, delta = [], []
    n = np.arange(2, orders + 1)
    extra = [np.ones_like(theta), *np.cos(np.outer(n, theta)), *np.sin(np.outer(n, theta))]
    extra = extra if orders > 1 else []
    for k in range(3):
        u = theta + PHASE_ANGLE[k]
        basis = [-np.sin(u), -np.cos(u)] if derivative else [np.cos(u), -np.sin(u)]
        (c, s, *_), *_ = np.linalg.lstsq(np.column_stack(basis + extra), values[:, k], rcond=None)
        amplitude.append(math.hypot(c, s))
        delta.append(math.atan2(s, c))
    return amplitude, delta


def phase_sequences(scale: np.ndarray, shift: np.ndarray) -> tuple[complex, complex]:
    """The positive and negative sequences of three phases' fundamentals of unequal amplitude and
    phase (docs/theory.md section 10, "Sequences").

    Phase ``k`` is ``scale[k] cos(theta + PHASE_ANGLE[k] + shift[k])`` (times a common amplitude);
    with ``c_k = scale[k] e^{j shift[k]}`` and ``a = e^{j 2 pi/3}`` the amplitude-invariant space
    vector (:data:`T_CLARKE`) of the three is ``P e^{j theta} + conj(N) e^{-j theta}``,
    ``P = (1/3) sum c_k``, ``N = (1/3) sum c_k a^k``; the zero sequence is not in it. Inputs are not
    checked here: the callers have (:class:`linsense.model.motor.PmPhases`).

    Parameters
    ----------
    scale : array_like, shape (3,)
        Amplitudes of phases A, B, C, dimensionless (balanced: 1).
    shift : array_like, shape (3,)
        Phase advances of phases A, B, C, rad (balanced: 0).

    Returns
    -------
    P, N : complex
        The positive sequence (1 balanced) and the negative sequence (0 balanced).
    """
    c = np.asarray(scale, dtype=float) * np.exp(1j * np.asarray(shift, dtype=float))
    # a^k = exp(-j PHASE_ANGLE[k]) (B at -2 pi/3: a^1 = e^{j 2 pi/3})
    return complex(c.sum() / 3.0), complex((c * np.exp(-1j * PHASE_ANGLE)).sum() / 3.0)


#: the module, named in the messages of its functions' argument checks
_SRC = "linsense.model.frames"


def _last(x, func: str, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``x`` as real numbers whose last dimensions are ``shape`` (NaN allowed: a measurement's)."""
    a = reals(x, f"{_SRC}.{func}", name, "real numbers", finite=False)
    if a.shape[a.ndim - len(shape):] != shape or a.ndim < len(shape):
        raise InputError(f"{_SRC}.{func}", name, f"expected shape (..., {', '.join(map(str, shape))}), "
                         f"got {a.shape}")
    return a


def rot(theta: np.ndarray | float) -> np.ndarray:
    """Rotation matrices ``[[cos, -sin], [sin, cos]]`` of shape ``theta.shape + (2, 2)``.

    Parameters
    ----------
    theta : float or ndarray
        Angle(s), rad.

    Returns
    -------
    ndarray, shape theta.shape + (2, 2)
        The rotation matrices.

    Raises
    ------
    linsense.errors.InputError
        ``theta`` not finite real numbers.
    """
    theta = reals(theta, f"{_SRC}.rot", "theta", "angles in rad")
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def abc_to_ab_matrix(L_abc: np.ndarray) -> np.ndarray:
    """Transform current-to-flux matrices ``(..., 3, 3)`` from abc to alpha-beta ``(..., 2, 2)``.

    Parameters
    ----------
    L_abc : ndarray, shape (..., 3, 3)
        Phase matrices, e.g. inductances in H.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``T_CLARKE @ L_abc @ T_CLARKE_INV``, in the unit of ``L_abc``.

    Raises
    ------
    linsense.errors.InputError
        ``L_abc`` not real numbers of shape ``(..., 3, 3)``.
    """
    return T_CLARKE @ _last(L_abc, "abc_to_ab_matrix", "L_abc", (3, 3)) @ T_CLARKE_INV


def ab_to_dq_matrix(L_ab: np.ndarray, theta: np.ndarray | float) -> np.ndarray:
    """Transform ``(..., 2, 2)`` matrices from alpha-beta into the frame rotated by ``theta``.

    Parameters
    ----------
    L_ab : ndarray, shape (..., 2, 2)
        Alpha-beta matrices, e.g. inductances in H.
    theta : float or ndarray
        Electrical angle of the rotated frame, rad.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``R(theta)' L_ab R(theta)``.

    Raises
    ------
    linsense.errors.InputError
        ``L_ab`` not real numbers of shape ``(..., 2, 2)``, ``theta`` not finite real numbers.
    """
    L_ab = _last(L_ab, "ab_to_dq_matrix", "L_ab", (2, 2))
    R = rot(theta)
    return np.swapaxes(R, -1, -2) @ L_ab @ R


def abc_to_ab(x_abc: np.ndarray) -> np.ndarray:
    """Clarke transform of vectors ``(..., 3)`` -> ``(..., 2)``.

    Parameters
    ----------
    x_abc : array_like, shape (..., 3)
        Phase quantities (A, V, Wb...).

    Returns
    -------
    ndarray, shape (..., 2)
        The alpha-beta components, same unit.

    Raises
    ------
    linsense.errors.InputError
        ``x_abc`` not real numbers of shape ``(..., 3)``.
    """
    return _last(x_abc, "abc_to_ab", "x_abc", (3,)) @ T_CLARKE.T


def ab_to_abc(x_ab: np.ndarray) -> np.ndarray:
    """Inverse Clarke transform of zero-sequence-free vectors ``(..., 2)`` -> ``(..., 3)``.

    Parameters
    ----------
    x_ab : array_like, shape (..., 2)
        Alpha-beta quantities (A, V, Wb...).

    Returns
    -------
    ndarray, shape (..., 3)
        The phase components, same unit, without zero sequence.

    Raises
    ------
    linsense.errors.InputError
        ``x_ab`` not real numbers of shape ``(..., 2)``.
    """
    return _last(x_ab, "ab_to_abc", "x_ab", (2,)) @ T_CLARKE_INV.T

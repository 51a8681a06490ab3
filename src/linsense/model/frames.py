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

import numpy as np

_S3 = np.sqrt(3.0) / 2.0

#: Amplitude-invariant Clarke transform, abc -> alpha-beta (2 x 3).
T_CLARKE = (2.0 / 3.0) * np.array([[1.0, -0.5, -0.5], [0.0, _S3, -_S3]])
#: Inverse Clarke for zero-sequence-free quantities, alpha-beta -> abc (3 x 2).
T_CLARKE_INV = np.array([[1.0, 0.0], [-0.5, _S3], [-0.5, -_S3]])


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
    """
    theta = np.asarray(theta, dtype=float)
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
    """
    return T_CLARKE @ L_abc @ T_CLARKE_INV


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
    """
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
    """
    return np.asarray(x_abc) @ T_CLARKE.T


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
    """
    return np.asarray(x_ab) @ T_CLARKE_INV.T

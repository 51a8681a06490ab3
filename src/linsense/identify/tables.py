"""Outputs computed from the measured table: the ``linsense model`` columns and Psi_LUT at the
measured positions (no model, no smoothing)."""

from __future__ import annotations

import numpy as np

from linsense.analysis.hf import loop_gain_factor
from linsense.model.frames import ab_to_dq_matrix, abc_to_ab_matrix
from linsense.model.inductance import ENTRIES, InductanceModel

_INDEX = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0))


def matrices(entries: np.ndarray) -> np.ndarray:
    """Symmetric 3x3 matrices ``(N, 3, 3)`` from the six entries ``(N, 6)``.

    Parameters
    ----------
    entries : ndarray, shape (N, 6)
        ``L_A .. M_CA``, H.

    Returns
    -------
    ndarray, shape (N, 3, 3)
        H.
    """
    entries = np.asarray(entries, dtype=float)
    L = np.empty(entries.shape[:-1] + (3, 3))
    for j, (r, c) in enumerate(_INDEX):
        L[..., r, c] = entries[..., j]
        L[..., c, r] = entries[..., j]
    return L


def measured_columns(theta: np.ndarray, entries: np.ndarray) -> dict[str, np.ndarray]:
    """The ``linsense model`` columns (``linsense.analysis.tables.MODEL_COLUMNS``) at the
    measured positions.

    Inductances, the alpha-beta and dq matrices, the saliency, ``psi_lut_deg`` (eq. 12,
    ``atan(-L_dq/L_q)``) and ``err_nolut_deg`` (``tan 2e* = 2 L_dq / (L_d - L_q)``, the stable root;
    docs/theory.md section 6) come pointwise from the measured matrices. ``gain_nolut`` needs
    ``dL/dtheta``, which a table does not have: it is the derivative of the trigonometric series
    through the table (:meth:`InductanceModel.from_table`, default order), so it is as noisy as
    the measurement.

    Parameters
    ----------
    theta : ndarray, shape (N,)
        Measured electrical positions, rad.
    entries : ndarray, shape (N, 6)
        ``L_A .. M_CA`` at those positions, H.
    Returns
    -------
    dict of str to ndarray
        The columns, as ``linsense model`` writes them.
    """
    theta = np.asarray(theta, dtype=float)
    L_ab = abc_to_ab_matrix(matrices(entries))
    L_dq = ab_to_dq_matrix(L_ab, theta)
    L_d, L_q, L_x = L_dq[:, 0, 0], L_dq[:, 1, 1], L_dq[:, 0, 1]
    s = 1.0 if np.mean(L_q - L_d) >= 0 else -1.0
    cols = {"theta_deg": np.degrees(theta)}
    cols.update({name: np.asarray(entries)[:, j] for j, name in enumerate(ENTRIES)})
    cols["L_d"], cols["L_q"], cols["L_dq"] = L_d, L_q, L_x
    cols["saliency"] = L_q - L_d
    cols["psi_lut_deg"] = np.degrees(psi_of_dq(L_q, L_x))
    cols["err_nolut_deg"] = np.degrees(0.5 * np.arctan2(-2.0 * L_x * s, (L_q - L_d) * s))
    cols["gain_nolut"] = loop_gain_factor(InductanceModel.from_table(theta, entries), theta)
    cols["L_alpha"], cols["L_beta"], cols["L_alphabeta"] = L_ab[:, 0, 0], L_ab[:, 1, 1], L_ab[:, 0, 1]
    return cols


def psi_of_dq(L_q: np.ndarray, L_dq: np.ndarray) -> np.ndarray:
    """``Psi_LUT = atan(-L_dq / L_q)``, paper eq. (12), from measured dq inductances.

    Parameters
    ----------
    L_q : ndarray
        H.
    L_dq : ndarray
        H.

    Returns
    -------
    ndarray
        rad.
    """
    return np.arctan2(-np.asarray(L_dq), np.asarray(L_q))


def measured_lut_csv(theta: np.ndarray, psi: np.ndarray) -> str:
    """``theta_deg,psi_lut_deg`` at the measured positions, in the format of ``linsense lut``.

    Readable by :func:`linsense.compensation.lut.read_lut` when the positions are the equally
    spaced grid ``2 pi k / N`` (as ``bench-emulate`` writes them); otherwise it is a table at the
    measured positions for people and plots, and ``lut_fit.csv`` is the one to flash.

    Parameters
    ----------
    theta : ndarray
        Measured electrical positions, rad.
    psi : ndarray
        Compensation angle there, rad.

    Returns
    -------
    str
        The CSV text.
    """
    lines = ["theta_deg,psi_lut_deg"]
    lines += [f"{t:.12g},{p:.12g}" for t, p in zip(np.degrees(theta), np.degrees(psi), strict=True)]
    return "\n".join(lines) + "\n"

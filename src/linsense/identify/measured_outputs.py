"""Outputs computed from the measured table: the ``linsense model`` columns and Psi_LUT at the
measured positions (no model, no smoothing)."""

from __future__ import annotations

import numpy as np

from linsense.model.inductance import ENTRIES, derived_columns


def measured_columns(theta: np.ndarray, entries: np.ndarray) -> dict[str, np.ndarray]:
    """The ``linsense model`` columns (``linsense.analysis.model_table.MODEL_COLUMNS``) at the
    measured positions.

    Inductances, the alpha-beta and dq matrices, the saliency, ``psi_lut_deg`` (eq. 12,
    ``atan(-L_dq/L_q)``) and ``err_nolut_deg`` (``tan 2e* = 2 L_dq / (L_d - L_q)``, the stable root;
    docs/theory.md section 6) come pointwise from the measured matrices. ``gain_nolut`` needs
    ``dL/dtheta``, which a table does not have: it is the derivative of the trigonometric series
    through the table (:func:`linsense.model.inductance.derived_columns`, as a motor file's table
    with these columns is checked), so it is as noisy as the measurement.

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
    cols = {"theta_deg": np.degrees(theta)}
    cols.update({name: np.asarray(entries)[:, j] for j, name in enumerate(ENTRIES)})
    cols.update(derived_columns(theta, entries))
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

"""Key numbers of a motor model, compared in the demo with what the brief and the paper state."""

from __future__ import annotations

import numpy as np

from linsense.analysis.hf import (
    dq_components,
    equilibrium_error,
    hf_current_amplitude,
    loop_gain_factor,
    psi_lut,
)
from linsense.model.motor import as_motor, check_grid


def _local_minima_deg(theta: np.ndarray, y: np.ndarray, tol: float) -> list[float]:
    """Positions (deg) of the periodic local minima of ``y`` within ``tol`` of its global minimum."""
    is_min = (y <= np.roll(y, 1)) & (y < np.roll(y, -1)) & (y <= y.min() + tol)
    return [float(d) for d in np.degrees(theta[is_min])]


def summarize(motor, v_inj: float = 12.0, f_inj: float = 1000.0) -> dict:
    """Peak Psi_LUT, dq ranges, saliency minima, HF current and the uncompensated observer.

    Parameters
    ----------
    motor : Motor
        The motor.
    v_inj : float, optional
        Injection amplitude, V.
    f_inj : float, optional
        Injection frequency, Hz.

    Returns
    -------
    dict
        ``psi_lut_peak_deg``, ``L_d_range_H``... (SI units and degrees, as the keys say).

    Raises
    ------
    linsense.errors.InputError
        ``motor`` not a motor, ``v_inj`` or ``f_inj`` out of range (:func:`~linsense.analysis.hf.hf_current`).
    """
    motor = as_motor(motor, "linsense.analysis.summary.summarize")
    theta = check_grid(motor.inductance, 3600)
    L_d, L_q, L_dq = dq_components(motor, theta)
    sal = L_q - L_d
    lut = np.degrees(psi_lut(motor, theta))
    gain = loop_gain_factor(motor, theta)
    i_hf = hf_current_amplitude(motor, theta, v_inj, f_inj)
    return {
        "motor": motor.name,
        "psi_lut_peak_deg": float(np.abs(lut).max()),
        "psi_lut_max_at_deg": float(np.degrees(theta[np.argmax(lut)])),
        "psi_lut_min_at_deg": float(np.degrees(theta[np.argmin(lut)])),
        "L_d_range_H": [float(L_d.min()), float(L_d.max())],
        "L_q_range_H": [float(L_q.min()), float(L_q.max())],
        "L_dq_abs_max_H": float(np.abs(L_dq).max()),
        "saliency_range_H": [float(sal.min()), float(sal.max())],
        "saliency_min_at_deg": _local_minima_deg(theta, sal, 1e-3 * float(np.ptp(sal)) + 1e-15),
        "hf_current_mean_A": float(i_hf.mean()),
        "hf_current_range_A": [float(i_hf.min()), float(i_hf.max())],
        "hf_injection": {"voltage_V": v_inj, "frequency_Hz": f_inj},
        "err_nolut_max_deg": float(np.degrees(np.abs(equilibrium_error(motor, theta)).max())),
        "gain_nolut_min": float(gain.min()),
        "gain_nolut_max": float(gain.max()),
        "gain_nolut_max_at_deg": float(np.degrees(theta[np.argmax(gain)])),
    }

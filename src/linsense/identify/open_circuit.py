"""The end effect on the magnets' flux from an open-circuit back-EMF measurement.

The mover is driven at a known speed with the winding open; the three voltages are recorded with
the positions. Each phase's back-EMF is ``omega d psi_k / d theta`` (docs/theory.md section 10), so
the fundamental of ``e_k / omega`` gives the phase's PM flux amplitude and phase: the motor file's
``[pm_flux] scale_abc`` and ``shift_deg_abc``. Phase-to-star voltages give each phase's own values;
line-to-line voltages (no star point) give them without their zero sequence, which the plant never
sees (the star point floats): the positive and negative sequences, all that acts, are exact either
way.
"""

from __future__ import annotations

import math

import numpy as np

from linsense._check import real, reals
from linsense.errors import InputError
from linsense.model.frames import phase_fundamentals
from linsense.model.motor import PmPhases
from linsense.model.motor_schema import PHASES
from linsense.plausible import implausible

_SRC = "linsense.identify.open_circuit.pm_phases_from_emf"
#: rad, the largest gap the positions may leave in the electrical period (modulo 2 pi)
_GAP_MAX = math.radians(45.0)


def phase_values_of_line(e_line: np.ndarray) -> np.ndarray:
    """Zero-sequence-free phase values of line-to-line ones.

    ``e_A = (e_AB - e_CA)/3``, ``e_B = (e_BC - e_AB)/3``, ``e_C = (e_CA - e_BC)/3``: exact for
    phase values whose sum is zero, and otherwise those values less their zero sequence.

    Parameters
    ----------
    e_line : ndarray, shape (..., 3)
        ``e_AB, e_BC, e_CA``, V.

    Returns
    -------
    ndarray, shape (..., 3)
        ``e_A, e_B, e_C``, V.
    """
    ab, bc, ca = e_line[..., 0], e_line[..., 1], e_line[..., 2]
    return np.stack([ab - ca, bc - ab, ca - bc], axis=-1) / 3.0


def pm_phases_from_emf(theta: np.ndarray, e: np.ndarray, omega: np.ndarray | float, psi_pm: float,
                       line_to_line: bool = False, orders: int = 1) -> PmPhases:
    """Each phase's PM flux amplitude and phase from its open-circuit back-EMF.

    Least squares of ``e_k / omega = d/d theta [A_k cos(theta - 2 pi k/3 + delta_k)]`` (the
    harmonics average out over whole periods; docs/theory.md section 10); ``scale_k = A_k /
    psi_pm``, ``shift_k = delta_k``.

    Parameters
    ----------
    theta : ndarray, shape (N,)
        Electrical positions of the samples, rad (the motor's angle: ``2 pi x / pole_pitch`` from
        its d axis).
    e : ndarray, shape (N, 3)
        Open-circuit voltages, V: ``e_A, e_B, e_C`` to the star point, or ``e_AB, e_BC, e_CA``
        with ``line_to_line``.
    omega : float or ndarray, shape (N,)
        Electrical speed at the samples, rad/s (``2 pi v / pole_pitch``), nonzero.
    psi_pm : float
        The motor's PM flux linkage, Wb (``force_constant pole_pitch / (3 pi)``).
    line_to_line : bool, optional
        Whether ``e`` holds line-to-line voltages.
    orders : int, optional
        Fit an offset and the harmonics 2 .. ``orders`` beside the fundamental, so that a part of a
        period does not let them leak into it (:func:`~linsense.model.frames.phase_fundamentals`;
        1: the fundamental alone, exact over whole periods).

    Returns
    -------
    PmPhases
        The per-phase amplitudes (relative to ``psi_pm``) and phase advances (rad), held to the
        motor file's rules.

    Raises
    ------
    InputError
        Arguments of the wrong shape or not finite, a speed too low to measure (below 1e-6 of
        ``theta``'s unit per second), positions that do not span an electrical period, or a result
        outside the plausible range (:data:`linsense.plausible.KINDS`, ``flux_scale`` and
        ``flux_shift``).
    """
    th = reals(theta, _SRC, "theta", "electrical positions in rad", ndim=1)
    v = reals(e, _SRC, "e", "open-circuit voltages in V", ndim=2)
    w = np.broadcast_to(reals(omega, _SRC, "omega", "electrical speeds in rad/s"), th.shape)
    psi = real(psi_pm, _SRC, "psi_pm", 0.0, low_open=True, what="a flux linkage in Wb")
    if v.shape != (th.size, 3):
        raise InputError(_SRC, "e", f"expected shape ({th.size}, 3) (one row per position), got {v.shape}")
    if np.any(np.abs(w) < 1e-6):
        raise InputError(_SRC, "omega", "the back-EMF needs the mover moving: an electrical speed of "
                         "at least 1e-6 rad/s at every sample")
    wrapped = np.sort(np.mod(th, 2.0 * np.pi))
    gap = float(np.max(np.diff(np.concatenate([wrapped, [wrapped[0] + 2.0 * np.pi]]))))
    if gap > _GAP_MAX:
        raise InputError(_SRC, "theta", f"the positions span {math.degrees(np.ptp(th)):.4g} electrical "
                         f"degrees and leave a gap of {math.degrees(gap):.4g} deg in the period: record at "
                         f"least one electrical period (360 deg, gaps of at most {math.degrees(_GAP_MAX):g} "
                         "deg)")
    dpsi = (phase_values_of_line(v) if line_to_line else v) / w[:, None]  # Wb/rad
    amplitude, shift = phase_fundamentals(th, dpsi, derivative=True, orders=orders)
    scale = [a / psi for a in amplitude]
    for k in range(3):
        for kind, value in (("flux_scale", scale[k]), ("flux_shift", math.degrees(shift[k]))):
            msg = implausible(kind, value)
            if msg:
                raise InputError(_SRC, "e", f"phase {PHASES[k]}: {msg}; check the speed, the units, the "
                                 "wiring and the positions' origin (theta = 0 on the d axis)")
    return PmPhases(tuple(scale), tuple(shift))

"""The motor model handed to the C plant (``csrc/sim/ls_sim_plant.c``): one source of truth.

The C plant works in alpha-beta. Its inductance is the Fourier series of the three entries
``L_aa, L_bb, L_ab`` of ``L_ab(theta) = T L_abc(theta) T_inv``; because that transform is linear
and constant, each harmonic of ``L_ab`` is the transform of the same harmonic of ``L_abc``, so the
series handed to C is exactly the Python model (paper eq. 3, harmonics or a fitted table), and
``tests/test_sim_plant.py`` checks the C evaluation against ``InductanceModel.L_ab``.
"""

from __future__ import annotations

import numpy as np

from linsense._ctrl import ffi, lib
from linsense.errors import ModelError
from linsense.model.frames import abc_to_ab_matrix
from linsense.model.inductance import InductanceModel

#: Highest number of harmonic orders the C plant accepts (LS_SIM_MAX_ORDER).
MAX_ORDER = int(lib.LS_SIM_MAX_ORDER)
#: Most PM-flux harmonics the C plant accepts (LS_SIM_MAX_PM).
MAX_PM = int(lib.LS_SIM_MAX_PM)


def _entries_to_matrix(e: np.ndarray) -> np.ndarray:
    """(6, K) entry coefficients -> (K, 3, 3) symmetric matrices (order L_A, L_B, L_C, M_AB, M_BC, M_CA)."""
    K = e.shape[1]
    L = np.zeros((K, 3, 3))
    L[:, 0, 0], L[:, 1, 1], L[:, 2, 2] = e[0], e[1], e[2]
    L[:, 0, 1] = L[:, 1, 0] = e[3]
    L[:, 1, 2] = L[:, 2, 1] = e[4]
    L[:, 2, 0] = L[:, 0, 2] = e[5]
    return L


def lab_fourier(inductance: InductanceModel, tol: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Cosine and sine coefficients (H), shape (3, n_order), of ``L_aa, L_bb, L_ab`` in theta.

    Trailing orders whose coefficients are all below ``tol`` (H) are dropped, so the C plant
    evaluates only what the model has (three orders for eq. 3).

    Parameters
    ----------
    inductance : InductanceModel
        The model.
    tol : float, optional
        H.

    Returns
    -------
    cos : ndarray, shape (3, n_order)
        H.
    sin : ndarray, shape (3, n_order)
        H.

    Raises
    ------
    linsense.errors.ModelError
        More harmonic orders than the C plant takes.
    """
    out = []
    for coef in (inductance.a, inductance.b):
        Lab = abc_to_ab_matrix(_entries_to_matrix(coef))
        out.append(np.stack([Lab[:, 0, 0], Lab[:, 1, 1], Lab[:, 0, 1]]))
    cos, sin = out
    mag = np.abs(cos).max(axis=0) + np.abs(sin).max(axis=0)
    keep = np.nonzero(mag > tol)[0]
    n = int(keep[-1]) + 1 if keep.size else 1
    if n > MAX_ORDER:
        raise ModelError(
            "inductance", "", f"the model has {n} harmonic orders; the simulator takes at most {MAX_ORDER} "
            "(smooth the table with table_max_order)"
        )
    return cos[:, :n], sin[:, :n]


def fill_plant(cfg, motor, tol: float = 1e-12, lab: tuple | None = None) -> None:
    """Write the motor part of an ``ls_sim_cfg`` (cffi struct) from a :class:`Motor`.

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The configuration, written in place.
    motor : Motor
        The motor.
    tol : float, optional
        Of :func:`lab_fourier`, H.
    lab : tuple or None, optional
        :func:`lab_fourier` of the motor, when the caller has it.

    Raises
    ------
    linsense.errors.ModelError
        Too many harmonic orders or PM-flux harmonics for the C plant.
    """
    cos, sin = lab_fourier(motor.inductance, tol) if lab is None else lab
    cfg.r_s = motor.R_s
    cfg.pole_pitch = motor.pole_pitch
    cfg.psi_pm = motor.psi_pm
    cfg.n_order = cos.shape[1]
    for e in range(3):
        for k in range(cos.shape[1]):
            cfg.lab_cos[e][k] = float(cos[e, k])
            cfg.lab_sin[e][k] = float(sin[e, k])
    if len(motor.pm_harmonics) > MAX_PM:
        n = len(motor.pm_harmonics)
        raise ModelError("pm_flux", "harmonics", f"at most {MAX_PM} PM-flux harmonics, got {n}")
    cfg.n_pm = len(motor.pm_harmonics)
    for j, h in enumerate(motor.pm_harmonics):
        cfg.pm_order[j] = h.order
        cfg.pm_amp[j] = h.amplitude
        cfg.pm_phase[j] = h.phase
    # the end effect on the magnets' flux (ls_sim.h: 1 + pm_dscale[k], pm_shift[k]); a balanced
    # motor writes zeros, the plant's balanced path (bit for bit the traces before it existed)
    for k in range(3):
        cfg.pm_dscale[k] = float(motor.pm_phases.scale[k]) - 1.0
        cfg.pm_shift[k] = float(motor.pm_phases.shift[k])
    cfg.mass = motor.mass
    cfg.visc = motor.friction.viscous
    cfg.coulomb = motor.friction.coulomb


def fill_saturation(cfg, motor, sat) -> dict:
    """Switch an ``ls_sim_cfg`` (cffi) to the saturated plant of ``motor`` (or back to the linear one).

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The configuration, written in place.
    motor : Motor
        The motor.
    sat : Saturation or None
        The saturation data (None: back to the linear plant).

    Returns
    -------
    dict
        The series written (:func:`linsense.model.saturation.plant_series`; empty for None).

    Raises
    ------
    linsense.errors.ModelError
        Saturation data the C plant cannot take, naming the motor-file key.
    """
    from linsense.errors import SaturationRangeError
    from linsense.model.saturation import plant_series

    if sat is None:
        cfg.sat.on = 0
        return {}
    try:
        ser = plant_series(sat, motor.inductance, motor.psi_pm, MAX_ORDER)
    except SaturationRangeError as exc:
        raise ModelError(sat.source or motor.source, exc.key, str(exc)) from None
    cfg.sat.on = 1
    cfg.sat.n_order = ser["n_order"]
    cfg.sat.n_pow = ser["n_pow"]
    cos, sin = ser["dq_cos"], ser["dq_sin"]
    buf_c = ffi.cast("double *", ffi.addressof(cfg.sat, "dq_cos"))
    buf_s = ffi.cast("double *", ffi.addressof(cfg.sat, "dq_sin"))
    full_c = np.zeros((int(lib.LS_SIM_SAT_POW), 3, MAX_ORDER))
    full_s = np.zeros_like(full_c)
    full_c[: cos.shape[0], :, : cos.shape[2]] = cos
    full_s[: sin.shape[0], :, : sin.shape[2]] = sin
    ffi.memmove(buf_c, full_c.tobytes(), full_c.nbytes)
    ffi.memmove(buf_s, full_s.tobytes(), full_s.nbytes)
    cfg.sat.i_m = ser["i_m"]
    cfg.sat.i_sat_d = ser["i_sat_d"]
    return ser

"""A motor with its parameters off by a tolerance (docs/tuning.md, "Margins" and "The certificate").

The controller of a drive keeps the nominal model (its LUT, gain table, feed-forwards) while the
motor differs from it: every inductance by a factor, the resistance (a hot winding) and the
end-effect (eq. 3's dM0, the part of the mean mutuals M_BC and M_CA beyond M_AB).
"""

from __future__ import annotations

import dataclasses

from linsense._check import instance, real
from linsense.model.motor import Motor, as_motor


def perturbed(motor: Motor, k_inductance: float = 1.0, k_resistance: float = 1.0, k_end_effect: float = 1.0,
              label: str = "") -> Motor:
    """``motor`` with its inductances, resistance and end-effect scaled.

    Every inductance scaled by ``k_inductance``, R_s by ``k_resistance`` and the end-effect (the
    constant part of M_BC and M_CA beyond M_AB) by ``k_end_effect``; works on any inductance model
    (parametric, harmonic or tabulated: its Fourier form).

    Parameters
    ----------
    motor : Motor
        The nominal motor.
    k_inductance : float, optional
        Factor on every inductance coefficient, dimensionless.
    k_resistance : float, optional
        Factor on ``R_s``, dimensionless.
    k_end_effect : float, optional
        Factor on the end-effect ``dM0``, dimensionless.
    label : str, optional
        Appended in parentheses to the motor's name and the model's description (empty: none).

    Returns
    -------
    Motor
        A copy of ``motor`` with the perturbed values.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it; a perturbed motor outside the
        range of real motors (its constructor's checks).
    """
    src = "linsense.model.tolerance.perturbed"
    motor = as_motor(motor, src)
    k_inductance = real(k_inductance, src, "k_inductance", 0.0, low_open=True, what="a positive factor")
    k_resistance = real(k_resistance, src, "k_resistance", 0.0, what="a factor >= 0")
    k_end_effect = real(k_end_effect, src, "k_end_effect", what="a finite factor")
    instance(label, src, "label", str, "a str")
    ind = motor.inductance
    new = ind.scaled(k_inductance, k_end_effect, f"{ind.description} ({label})" if label else None)
    name = f"{motor.name} ({label})" if label else motor.name
    return dataclasses.replace(motor, name=name, R_s=motor.R_s * k_resistance, inductance=new)

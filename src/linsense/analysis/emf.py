"""The EMF observer's low-speed limit: the speed above which its position error is bounded
(docs/theory.md, "The EMF observer at speed"; the C block ``ls_emf``, ``linsense/ls_emf.h``).

The magnets' imbalance (the motor file's ``[pm_flux] scale_abc, shift_deg_abc``) is compensated in the
block from the motor file: :func:`emf_pm_compensation` gives its four configuration fields
(docs/theory.md, "The end effect on the magnets' flux").

The bound is the C library's (``ls_emf_bound``, inverted by ``ls_emf_omega_min`` through the
binding): the model's uncertainties (resistance, q inductance, the inverter's voltage error, the
current noise) against the EMF ``omega psi_pm`` at a current on the q-axis. The later design of the
hand-over band starts from it.

Example
-------
>>> from linsense.analysis.emf import emf_speed_limit
>>> lim = emf_speed_limit(motor, v_dc=72.0, f_pwm=16000.0, dead_time=0.8e-6, i_mag=2.0,
...                       f_lpf=200.0)                         # doctest: +SKIP
>>> lim.v_min                                                  # m/s  # doctest: +SKIP
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from linsense._check import real
from linsense.model.frames import phase_sequences
from linsense.model.motor import Motor, as_motor

__all__ = ["EmfPmCompensation", "emf_pm_compensation", "EmfSpeedLimit", "emf_speed_limit",
           "inverter_voltage_error", "ERR_R", "ERR_L", "DT_RESIDUAL", "I_NOISE", "EPS_MAX"]

#: relative uncertainty of the winding's resistance after the online estimate (ls_dtres's k_r)
ERR_R = 0.05
#: relative uncertainty of the q inductance (a tolerance, the fundamental's saturation)
ERR_L = 0.1
#: the share of the dead time's voltage error the modulator's compensation leaves (1: none)
DT_RESIDUAL = 1.0
#: rms current noise per sample, A (10 mA rms: the start-up's reference, a 12-bit ADC)
I_NOISE = 0.01
#: the position-error bound the EMF estimate is trusted within, rad (3 electrical degrees)
EPS_MAX = math.radians(3.0)


@dataclass(frozen=True)
class EmfPmCompensation:
    """The magnets' imbalance as the EMF block compensates it (``ls_emf_cfg``'s ``psi_pm``,
    ``pm_shift``, ``neg_re``, ``neg_im``; docs/theory.md section 10).

    The back-EMF in alpha-beta is ``j w psi_pm e^{j pm_shift} (e^{j theta} - n e^{-j theta})``.

    Attributes
    ----------
    psi_pm : float
        The positive sequence's flux linkage ``|P| psi_pm``, Wb.
    pm_shift : float
        Its phase advance ``arg P``, electrical rad (what a raw EMF angle is offset by).
    neg_re : float
        Real part of ``n = conj(N) / P``, the negative sequence relative to the positive one,
        dimensionless (``|n|`` rad is the raw EMF angle's ripple at ``2 theta``).
    neg_im : float
        Imaginary part of ``n``, dimensionless.
    harm_order : tuple of int
        The orders of the flux harmonics compensated (``ls_emf_cfg.harm_order``: the largest EMF
        harmonics ``n a``, at most ``LS_EMF_HARM_N``; 0: an empty slot).
    harm_re : tuple of float
        Their flux vectors' coefficients' real parts ``psi_pm a cos(s phi)``, Wb.
    harm_im : tuple of float
        Imaginary parts ``psi_pm a sin(s phi)``, Wb (``s`` = +1 for ``n mod 3 = 1``, -1 for 2).
    residual : float
        The angle ripple the harmonics left out make, rad (``asin`` of the sum of their ``n a``).
    """

    psi_pm: float
    pm_shift: float
    neg_re: float
    neg_im: float
    harm_order: tuple = ()
    harm_re: tuple = ()
    harm_im: tuple = ()
    residual: float = 0.0

    @property
    def neg_mag(self) -> float:
        """``|n|``: the uncompensated angle's ripple at ``2 theta``, rad (peak)."""
        return math.hypot(self.neg_re, self.neg_im)

    def cfg(self) -> dict[str, object]:
        """The ``ls_emf_cfg`` fields of the magnets (the imbalance's four, the harmonics' slots), by name.

        Returns
        -------
        dict
            ``psi_pm`` (Wb), ``pm_shift`` (rad), ``neg_re``, ``neg_im`` (dimensionless),
            ``harm_order``, ``harm_re``, ``harm_im`` (lists of ``LS_EMF_HARM_N``).
        """
        return {"psi_pm": self.psi_pm, "pm_shift": self.pm_shift, "neg_re": self.neg_re,
                "neg_im": self.neg_im, "harm_order": list(self.harm_order), "harm_re": list(self.harm_re),
                "harm_im": list(self.harm_im)}


def emf_pm_compensation(motor: Motor | str) -> EmfPmCompensation:
    """The EMF block's compensation of the motor's magnet imbalance, from its motor file.

    The sequences ``P``, ``N`` of the per-phase flux amplitude and phase
    (:func:`linsense.model.frames.phase_sequences`), and the flux harmonics with the largest EMF
    (:class:`EmfPmCompensation`); balanced without harmonics: ``psi_pm`` the motor's and the others
    0 (the block then runs as without the fields, bit for bit).

    Parameters
    ----------
    motor : Motor or str
        The motor (or a preset name or file).

    Returns
    -------
    EmfPmCompensation
        The four configuration fields.
    """
    m = as_motor(motor, "emf_pm_compensation")
    p, n = phase_sequences(np.asarray(m.pm_phases.scale), np.asarray(m.pm_phases.shift))
    harm = _harmonics(m, m.psi_pm if m.pm_phases.balanced else abs(p) * m.psi_pm)
    if m.pm_phases.balanced:
        return EmfPmCompensation(m.psi_pm, 0.0, 0.0, 0.0, *harm)
    ratio = n.conjugate() / p
    return EmfPmCompensation(abs(p) * m.psi_pm, math.atan2(p.imag, p.real), ratio.real, ratio.imag, *harm)


def _harmonics(m: Motor, psi: float) -> tuple:
    """The flux harmonics' slots (the largest ``n a`` of the orders the star winding sees), their
    coefficients ``psi a e^{j s phi}`` and the ripple of those left out (docs/theory.md, "The
    hand-over")."""
    from linsense import ctrl  # (the binding: the slots' count and limits are the C header's)

    slots, top = int(ctrl.lib.LS_EMF_HARM_N), int(ctrl.lib.LS_EMF_HARM_ORDER_MAX)
    seen = sorted((h for h in m.pm_harmonics if h.order % 3 != 0 and h.amplitude != 0.0),
                  key=lambda h: -abs(h.order * h.amplitude))
    used = [h for h in seen if h.order <= top][:slots]
    left = sum(abs(h.order * h.amplitude) for h in seen if h not in used)
    order, re, im = [0] * slots, [0.0] * slots, [0.0] * slots
    for k, h in enumerate(used):
        sg = 1.0 if h.order % 3 == 1 else -1.0
        order[k], re[k], im[k] = int(h.order), psi * h.amplitude * math.cos(sg * h.phase), \
            psi * h.amplitude * math.sin(sg * h.phase)
    return tuple(order), tuple(re), tuple(im), math.asin(min(left, 1.0))


@dataclass(frozen=True)
class EmfSpeedLimit:
    """The EMF estimate's low-speed limit for one motor and drive.

    Attributes
    ----------
    omega_min : float
        Electrical speed, rad/s, from which the bound holds (``inf``: never up to ``omega_max``).
    v_min : float
        The same in m/s.
    l_d : float
        The d inductance the block models, H: the mean over a period (the end effect's
        position-dependent part is left to the EMF's error, docs/theory.md).
    l_q : float
        The q inductance the block models, H (the mean, likewise).
    psi_pm : float
        The magnets' flux linkage, Wb.
    u_err : float
        The inverter's voltage error bound, V.
    """

    omega_min: float
    v_min: float
    l_d: float
    l_q: float
    psi_pm: float
    u_err: float


def inverter_voltage_error(v_dc: float, f_pwm: float, dead_time: float,
                           residual: float = DT_RESIDUAL) -> float:
    """The bound of the inverter's voltage error vector (V, amplitude-invariant alpha-beta).

    Each leg loses ``dead_time f_pwm v_dc`` with the sign of its current (docs/theory.md, "The EMF
    observer at speed"); the three signs make a vector of ``4/3`` of it at most, of which the
    compensation leaves ``residual``.

    Parameters
    ----------
    v_dc : float
        Bus voltage, V.
    f_pwm : float
        PWM frequency, Hz.
    dead_time : float
        Dead time, s.
    residual : float, optional
        The share left after compensation, in [0, 1].

    Returns
    -------
    float
        V.
    """
    for name, v in (("v_dc", v_dc), ("f_pwm", f_pwm), ("dead_time", dead_time), ("residual", residual)):
        real(v, "inverter_voltage_error", name, 0.0)
    return 4.0 / 3.0 * residual * dead_time * f_pwm * v_dc


def emf_speed_limit(motor: Motor | str, *, v_dc: float, f_pwm: float, dead_time: float, i_mag: float,
                    f_lpf: float, err_r: float = ERR_R, err_l: float = ERR_L,
                    dt_residual: float = DT_RESIDUAL, i_noise: float = I_NOISE, eps_max: float = EPS_MAX,
                    k_r: float = 1.0) -> EmfSpeedLimit:
    """The speed above which the EMF estimate's position error is within ``eps_max``.

    The C library's bound (``ls_emf_omega_min``) for the motor's mean inductances and magnet flux,
    sampled at ``f_pwm``, at a current ``i_mag`` on the q-axis (docs/theory.md, "The EMF observer at
    speed", the low-speed limit).

    Parameters
    ----------
    motor : Motor or str
        The motor (or a preset name or file).
    v_dc, f_pwm, dead_time : float
        Bus voltage (V), PWM and sampling frequency (Hz), dead time (s).
    i_mag : float
        The current, A (the rated one: the error grows with it).
    f_lpf : float
        The EMF's low-pass corner, Hz.
    err_r, err_l : float, optional
        Relative uncertainties of the resistance and of L_q.
    dt_residual : float, optional
        The dead time's share left by the compensation.
    i_noise : float, optional
        Current noise, A rms per sample.
    eps_max : float, optional
        The bound, rad.
    k_r : float, optional
        The resistance's scale (a warm winding).

    Returns
    -------
    EmfSpeedLimit
        The speed and what it was computed from.

    Raises
    ------
    ConfigError
        The C library refuses the block's configuration (naming the field).
    """
    from linsense import ctrl  # (the binding: its import loads the extension)

    m = as_motor(motor, "emf_speed_limit")
    for name, v in (("v_dc", v_dc), ("i_mag", i_mag), ("k_r", k_r)):
        real(v, "emf_speed_limit", name, 0.0, low_open=name == "k_r")
    theta = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    ldq = m.inductance.L_dq(theta)  # (the means: the end effect's constant part included)
    l_d, l_q = float(np.mean(ldq[:, 0, 0])), float(np.mean(ldq[:, 1, 1]))
    u_err = inverter_voltage_error(v_dc, f_pwm, dead_time, dt_residual)
    values = {"fs": f_pwm, "r_s": m.R_s, "l_d": l_d, "l_q": l_q, "f_lpf": f_lpf,
              "omega_max": float(ctrl.lib.LS_EMF_OMEGA_TS_MAX) * f_pwm, "err_r": err_r, "err_l": err_l,
              "u_err": u_err, "i_noise": i_noise} | emf_pm_compensation(m).cfg()
    w = ctrl.emf_omega_min(values, i_mag, m.psi_pm, eps_max, k_r)
    return EmfSpeedLimit(omega_min=w, v_min=w * m.pole_pitch / (2.0 * np.pi), l_d=l_d, l_q=l_q,
                         psi_pm=m.psi_pm, u_err=u_err)

"""The hand-over from the HF estimate to the EMF estimate, and the injection's fade, designed
(docs/theory.md, "The hand-over"; the C blocks ``ls_emf`` and ``ls_fuse``).

The band ``[v_lo, v_hi]`` where the observer's error moves from the HF error to the EMF error
ends where the EMF estimate's bound (:func:`linsense.analysis.emf.emf_speed_limit`, the C library's
``ls_emf_omega_min``) is within :data:`EPS_HAND` at the application's current, with the
uncertainties this drive leaves: the resistance after the online estimate, the q inductance, the
dead time's residual after the modulator's compensation, the current sensor's noise; it starts
:data:`BAND_RATIO` times lower (the HF error grows with the speed, the EMF's falls: measured on the
switching inverter, ecce2010 and small30, docs/tuning.md "The speed range"), and no lower than where
the EMF's filters, idle below ``FUSE_EMF_ON v_lo`` (the SPEED step's time budget: the C library's
``LS_FUSE_EMF_ON``), settle (:data:`SETTLE_TAUS` time constants of their low-pass) before the speed
reaches ``v_lo`` at ``a_max``: ``v_lo >= a_max t_emf / (1 - FUSE_EMF_ON)``. The injection fades
out above the band and back in below it: back in early
enough that, decelerating at ``a_max``, it is at full amplitude and the demodulator settled before
the speed reaches ``v_hi`` (``v_on``), and off :data:`HYSTERESIS` above that (``v_off``). The EMF's
low-pass is the demodulator's (the observer's bandwidth was designed against it), within the
block's limit ``LS_EMF_FLPF_FS_MAX f_pwm``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from linsense.analysis.emf import ERR_L, ERR_R, I_NOISE, emf_speed_limit, inverter_voltage_error
from linsense.model.motor import Motor

__all__ = ["HandoverDesign", "HANDOVER_KEYS", "design_handover", "emf_harmonic_ripple", "EPS_HAND",
           "EPS_HAND_DEG", "BAND_RATIO", "HYSTERESIS", "DT_RESIDUAL_DTC", "SETTLE_TAUS", "EPS_TRUST"]

#: rad, the EMF estimate's bound at the band's top (its weight is 1 from there)
EPS_HAND = math.radians(3.0)
#: deg, the same as the docs write it
EPS_HAND_DEG = math.degrees(EPS_HAND)
#: -, v_hi / v_lo
BAND_RATIO = 2.0
#: -, v_off / v_on: the injection's hysteresis
HYSTERESIS = 1.15
#: -, the share of the dead time's voltage error the modulator's compensation leaves (its current band
#: makes it partial near a current's zero)
DT_RESIDUAL_DTC = 0.25
#: -, the demodulator's settling after the injection is back, in time constants of its low-pass
SETTLE_TAUS = 5.0
#: rad, the EMF estimate's bound beyond which a band given by hand is refused: above the band its error
#: alone drives the estimate. Measured on the switching inverter (drives for 1 m/s, a move through a band
#: of top f v_emf, v_emf the design's top): the runs faulted over-speed or ran away for f <= 0.12
#: (ecce2010, small30, m60_pos20k), 0.18 (m100_edge) and 0.29 (m45_24v, m90_heavy), and ran for f >=
#: 0.31 (every motor; 3-5 deg). The bound reaches this at 0.34-0.38 v_emf on those motors: refused
#: below that (a band at 45 deg, 0.13-0.17 v_emf, let m45_24v's and m90_heavy's run away)
EPS_TRUST = math.radians(10.0)


#: the scenario keys of the design (:meth:`HandoverDesign.scenario_keys`), in its order
HANDOVER_KEYS = ("observer.emf", "observer.emf_lpf_hz", "observer.handover_v_lo", "observer.handover_v_hi",
                 "observer.inject_v_on", "observer.inject_v_off", "observer.handover_settle_s")


@dataclass(frozen=True)
class HandoverDesign:
    """The hand-over band, the injection's fade and the EMF estimate's configuration.

    Attributes
    ----------
    on : bool
        The drive runs the EMF estimate (the speed cap reaches the band).
    v_lo : float
        The band's start, m/s: the HF error alone up to it.
    v_hi : float
        The band's end, m/s: the EMF error alone from it.
    v_on : float
        The injection fades back in below it, m/s.
    v_off : float
        The injection fades out above it, m/s.
    t_settle : float
        The demodulator's settling after the injection is back, s.
    f_lpf : float
        The EMF's low-pass corner, Hz.
    err_r : float
        The resistance's relative uncertainty the band is designed for.
    err_l : float
        The q inductance's.
    u_err : float
        The inverter's voltage-error bound, V.
    i_noise : float
        The current noise, A rms.
    v_emf : float
        The speed from which the EMF bound is within :data:`EPS_HAND`, m/s (inf: never).
    v_trust : float
        The speed from which it is within :data:`EPS_TRUST`, m/s (inf: never): a band's top given by
        hand must reach it.
    limit : str
        What sets the band, in words; with the hand-over off, why it is off.
    """

    on: bool
    v_lo: float
    v_hi: float
    v_on: float
    v_off: float
    t_settle: float
    f_lpf: float
    err_r: float
    err_l: float
    u_err: float
    i_noise: float
    v_emf: float
    v_trust: float
    limit: str

    def scenario_keys(self) -> dict[str, object]:
        """The design's values at their scenario keys (``observer.*``).

        Returns
        -------
        dict
            Dotted key to value.
        """
        return dict(zip(HANDOVER_KEYS, (self.on, self.f_lpf, self.v_lo, self.v_hi, self.v_on, self.v_off,
                                        self.t_settle), strict=True))


def emf_harmonic_ripple(motor: Motor) -> float:
    """The EMF estimate's angle ripple from the magnets' flux harmonics it does not compensate, rad.

    A harmonic ``a cos(k theta + phi)`` of the flux makes an EMF harmonic ``k a`` of the fundamental
    EMF (the derivative), which the estimated frame sees at ``(k -+ 1) theta``: the angle moves by
    up to ``asin(sum k a)`` over those the block leaves out (it compensates the largest
    ``LS_EMF_HARM_N``: :func:`linsense.analysis.emf.emf_pm_compensation`; docs/theory.md, "The
    hand-over").

    Parameters
    ----------
    motor : Motor
        The motor.

    Returns
    -------
    float
        rad (0 for a sinusoidal flux; pi / 2 when the sum reaches 1).
    """
    from linsense.analysis.emf import emf_pm_compensation

    return emf_pm_compensation(motor).residual


def design_handover(motor: Motor, *, v_dc: float, f_pwm: float, dead_time: float, i_mag: float,
                    demod_lpf: float, ramp_time: float, a_max: float, v_cap: float, shape: str,
                    headroom: float = math.inf, i_noise: float = I_NOISE) -> HandoverDesign:
    """The hand-over band and the injection's fade for a drive (module docstring).

    Parameters
    ----------
    motor : Motor
        The motor.
    v_dc, f_pwm, dead_time : float
        Bus (V), PWM rate (Hz), dead time (s).
    i_mag : float
        The application's current, A (the EMF's error grows with it).
    demod_lpf : float
        The demodulator's low-pass corner, Hz.
    ramp_time : float
        The injection's ramp from 0 to its amplitude, s.
    a_max : float
        The application's acceleration, m/s^2.
    v_cap : float
        The speed-reference cap, m/s.
    shape : str
        The injection's shape (the EMF estimate runs with the pulsating and elliptical ones).
    headroom : float, optional
        The speed up to which the fundamental at the application's current fits beside the
        injection, m/s: the
        injection fades out by then where the band allows (``v_off >= HYSTERESIS v_hi``).
    i_noise : float, optional
        Current noise, A rms.

    Returns
    -------
    HandoverDesign
        The design (``on`` False where the cap stays below the band or the shape has no EMF step).
    """
    from linsense.ctrl import EMF_FLPF_FS_MAX, FUSE_EMF_ON  # (the C library's)

    f_lpf = min(demod_lpf, EMF_FLPF_FS_MAX * f_pwm)
    errors = {"v_dc": v_dc, "f_pwm": f_pwm, "dead_time": dead_time, "i_mag": i_mag, "f_lpf": f_lpf,
              "err_r": ERR_R, "err_l": ERR_L, "dt_residual": DT_RESIDUAL_DTC, "i_noise": i_noise}
    lim = emf_speed_limit(motor, eps_max=EPS_HAND, **errors)
    v_trust = emf_speed_limit(motor, eps_max=EPS_TRUST, **errors).v_min
    t_settle = SETTLE_TAUS / (2.0 * math.pi * demod_lpf)
    v_lo_emf = a_max * SETTLE_TAUS / (2.0 * math.pi * f_lpf) / (1.0 - FUSE_EMF_ON)
    v_emf = lim.v_min
    ripple = emf_harmonic_ripple(motor)
    if ripple > EPS_HAND:  # (the block's model knows only the fundamental: no speed makes it good)
        v_emf = math.inf
    v_hi = v_emf if math.isfinite(v_emf) else 1.0e3
    v_lo = v_hi / BAND_RATIO
    raised = v_lo < v_lo_emf
    if raised:  # (the EMF's filters settle between FUSE_EMF_ON v_lo and v_lo at a_max)
        v_lo = v_lo_emf
        v_hi = max(v_hi, BAND_RATIO * v_lo)
    v_on = v_hi + a_max * (ramp_time + t_settle)
    v_off = HYSTERESIS * v_on
    if v_off > headroom:  # (off before the fundamental needs the injection's voltage, where it can)
        v_off = max(headroom, v_hi * HYSTERESIS)
        v_on = max(v_hi, v_off / HYSTERESIS)
    on = shape == "pulsating" and math.isfinite(v_emf) and v_cap > v_lo
    if ripple > EPS_HAND:
        why = (f"the magnets' flux harmonics ripple the EMF estimate by {math.degrees(ripple):.2g} deg, "
               f"beyond {math.degrees(EPS_HAND):g} deg: the HF estimate carries every speed")
    elif math.isfinite(v_emf):
        why = f"the EMF estimate's bound within {math.degrees(EPS_HAND):g} deg from {v_emf:.3g} m/s"
        if raised:
            why += (f"; the band from {v_lo:.3g} m/s, where the EMF's filters, started at "
                    f"{FUSE_EMF_ON:g} v_lo, have settled at a_max {a_max:g} m/s^2")
    else:
        why = ("the EMF estimate's bound never within its limit (L_q i / psi_pm large): the HF estimate "
               "carries every speed")
    if shape != "pulsating":
        why = (f"the {shape} injection has no EMF step (the firmware's SPEED step is the pulsating "
               f"injection's): the HF estimate carries every speed")
    elif not on and math.isfinite(v_emf):  # (off for the speed cap alone)
        why = f"the speed cap {v_cap:.3g} m/s stays below the band's start {v_lo:.3g} m/s ({why})"
    u_err = inverter_voltage_error(v_dc, f_pwm, dead_time, DT_RESIDUAL_DTC)
    return HandoverDesign(on, v_lo, v_hi, v_on, v_off, t_settle, f_lpf, ERR_R, ERR_L, u_err, i_noise, v_emf,
                          v_trust, why)

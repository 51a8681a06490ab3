"""Design of the sensorless drive for a motor, a drive and an application: injection, current
loop, demodulator, observer, speed and position loops, calibration dither, speed cap and trips;
with the margins of a linearised model and the predicted cost of each parameter tolerance
(:mod:`linsense.tune.margins`).

The rules are the constants and functions of this module; docs/tuning.md states each with its
criterion and its measured effect, and the C library's defaults are generated from them for the
reference motor (:mod:`linsense.tune.defaults`). The chain, from the PWM rate down: the injection
at ``f_pwm / N`` (:func:`injection_frequency`), the current loop at ``f_inj / RATIO_INJ_CURRENT``,
the demodulator's low-pass at ``RATIO_LPF f_inj``, the PLL's bandwidth ``f_lpf / RATIO_LPF_OBS``
(with the pulsating and elliptical injections the mechanical observer at ``f_lpf / RATIO_LPF_MECH``
instead, its load estimate fed forward), the speed loop at ``f_pll / RATIO_OBS_SPEED``, the position
gain ``w_v / RATIO_SPEED_POS``; the
injection's amplitude from the dead-time voltage error and the lowest local saliency
(``DEAD_TIME_RATIO``), the limits from the application with the stated margins.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from linsense._check import brief, choice, instance
from linsense.analysis.hf import (
    end_anisotropy,
    hf_current_amplitude,
    mean_dq,
)
from linsense.compensation.lut import resistance_slope
from linsense.errors import InputError, shown
from linsense.model.motor import Motor, as_motor
from linsense.plausible import KINDS, slip
from linsense.scenario.bounds import DEAD_TIME_SHARE_MAX, F_INJ_PWM_DIV, V_DC_MIN_FRACTION
from linsense.tune.injection import (
    INJECTION_D_FRACTION,
    d_current_force_share,
    deliverable_force,
    injection_d_current,
)
from linsense.tune.margins import error_gain

#: the stated ratios (docs/tuning.md)
RATIO_PWM_INJ = 16.0  # the most PWM periods per injection period (16 samples of the HF wave)
#: the injection's frequency (docs/tuning.md, "The injection frequency"): f_pwm / N, N an integer
#: (a non-integer ratio beats with the PWM: measured, more limit cycles), the largest N <=
#: RATIO_PWM_INJ with f_pwm / N >= F_INJ_MIN (every bandwidth of the chain scales with it), N >= 4
F_INJ_MIN = 1000.0  # Hz
RATIO_INJ_CURRENT = 4.0
RATIO_LPF = 0.3
RATIO_LPF_OBS = 7.5
RATIO_OBS_SPEED = 5.0
#: the mechanical observer (the pulsating and elliptical injections; docs/tuning.md, "The observer"):
#: its triple pole at f_lpf / RATIO_LPF_MECH (measured on the seven test motors, switching
#: inverter: f_lpf / 25 leaves 1.2-1.8 deg cycles after the load step, f_lpf / 16-20 none), its load
#: estimate fed forward, the speed PI's integrator held at 0 in the sensorless modes (the estimate is
#: the integral action; the encoder modes keep the PI)
RATIO_LPF_MECH = 20.0
RATIO_SPEED_POS = 2.5
#: the mechanical observer's bandwidth at most where the q-current that the motion asks per radian of
#: estimate at it, ``m (2 pi f_obs)^2 (tau / pi) / K_f``, is MOTION_SIGNAL_MAX times the HF error
#: signal's q-current per radian, ``i_hf / gain`` (docs/tuning.md, "The observer", "A heavy mover on a
#: weak signal"): beyond, the commanded current's band near the carrier leaks into the demodulated
#: error and the observer, the speed loop and the current loop close a loop near f_inj / 2.
#: Measured (switching inverter, holds): 110-265 on the shipped motors, all hold; 1,040 (an 80 mm,
#: 3 kg, L_q / L_d 1.12 motor) trips within 30 ms, 580 (its observer at 14 Hz) holds
MOTION_SIGNAL_MAX = 300.0
#: the rule slows the observer at most this far (a signal weaker still warns: the start-up's lock gain
#: and every loop's time scale would follow it)
MOTION_SLOW_MIN = 0.1
SPEED_KI_DIV = 4.0  # speed PI: ki = m w^2 / SPEED_KI_DIV (a double real closed-loop pole)
#: the HF path's delay in injection periods (docs/tuning.md, "The HF path's delay"): while the HF
#: current passes the band-pass (group delay 2 Q / w = 0.64 periods at Q = 2) and the sampling,
#: the estimated axis turns by omega times it, and the demodulated error carries that turn as a lag
#: proportional to the speed; measured 0.73-1.18 periods over the test motors
HF_DELAY_PERIODS = 1.0
#: the injection (docs/tuning.md, "The injection amplitude"): the dead-time voltage error
#: T_d f_pwm V_dc at most DEAD_TIME_RATIO times the weakest HF error signal's voltage
#: V_inj s_min (s = (L_q - L_d)/(L_q + L_d), its lowest over the period), within the bus shares
#: below and the HF current limit; beyond DEAD_TIME_RATIO_MAX at the largest allowed amplitude no
#: design can hold everywhere (refused before simulating)
DEAD_TIME_RATIO = 1.0
DEAD_TIME_RATIO_MAX = 4.0
INJ_BUS_MIN = 1.0 / 8.0  # of V_dc
INJ_BUS_MAX = 1.0 / 6.0  # of V_dc
INJ_RAMP_TIME = 0.01  # s, the injection's ramp up and down (the start-up's quiet time covers it)
INJ_CURRENT_MAX = 0.4  # HF current, of i_max
#: the limits, with their margins over what the application needs (docs/tuning.md, "The limits")
SPEED_CAP_MARGIN = 1.25  # speed-reference cap over the application's v_max
#: a step command runs as a minimum-time move at the speed cap and a_step = v_cap w_v / STEP_ACCEL_DIV
#: (the cap reached in STEP_ACCEL_DIV speed-loop time constants; the PLL's speed lag under it,
#: 2 a / w_obs, is then 2 / (STEP_ACCEL_DIV RATIO_OBS_SPEED) = 13 % of the cap), at most
#: STEP_FORCE_SHARE of the force at i_max / m (the rest for the loops and the load); docs/tuning.md, "Steps"
STEP_ACCEL_DIV = 3.0
STEP_FORCE_SHARE = 0.5
OVERSPEED_MARGIN = 1.6  # over-speed trip over the speed cap
OBSERVER_SPEED_MARGIN = 1.25  # observer speed clamp over the over-speed trip
#: the observer's speed clamp over v_max (with the table): the three margins above
CLAMP_OVER_V_MAX = SPEED_CAP_MARGIN * OVERSPEED_MARGIN * OBSERVER_SPEED_MARGIN
CURRENT_TRIP_MARGIN = 1.3  # over-current trip over i_max plus the HF current's peak
#: the margins below which the design warns: (phase, deg; gain upward, dB), per loop. Set against
#: the switching simulation of ecce2010 at 1 kHz (docs/tuning.md, "Margins"): observers of 40 and
#: 50 Hz (32 and 21 deg, 5.6 and 3.4 dB) hold and step; 60 Hz (9.6 deg, 1.5 dB) trips
MARGIN_FLOORS = {"observer": (20.0, 3.0), "motion": (25.0, 6.0)}
MOVE_TIME_MAX = 60.0  # s, the application's move over two pole pitches (v_max, a_max)
MASS_SLIP_KG = 100.0  # a motor file's mass from which a refusal asks whether grams were typed
FORCE_MARGIN = 0.8  # the application's force (load + m a_max) at most this share of the force at i_max
RATED_LOAD_FRACTION = 0.5  # rated load, of the force at i_max, when the application does not give it
QUAD = 0.9
DITHER_CURRENT = 0.16  # of i_max
# of f_inj: low against the HF band-pass (it leaks less), above the speed loop, not a submultiple
DITHER_FREQ = 0.055
#: the friction model's slope (the Coulomb force over its linear band, plus the viscous coefficient)
#: at most this share of m / ts: the mechanical observer steps its friction forward within one PWM
#: period (ls_observer_init refuses a slope of m / ts or more; docs/tuning.md, "Friction and thrust
#: ripple"). A light mover with viscous friction (1 g, 20 N s/m at 16 kHz: 1.25 m / ts) has its
#: viscous coefficient fed forward up to the share left by the Coulomb part's
FRICTION_STEP_SHARE = 0.5
#: the observer's load clamp (observer.force_max) at most this share of the largest load estimate
#: ls_observer_init takes, force_max (2 pi / tau) ts^2 / m <= pi (a load that moves the estimate half
#: a period per step): K_f i_max on a light mover (1 g) was beyond it and the drive refused
OBSERVER_FORCE_SHARE = 0.9
RIPPLE_MAX = 0.5  # the largest thrust ripple fed forward, |c| + |s| of K_f (ls_drive_init's limit)


def _real_number(v) -> bool:
    """A real number a float holds (NaN and infinities too: :func:`design` names their key)."""
    if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real):
        return False
    try:
        float(v)
    except OverflowError:  # (10**400)
        return False
    return True


@dataclass
class DriveData:
    """The drive around the motor (SI units).

    Parameters
    ----------
    v_dc : float
        DC bus, V.
    f_pwm : float
        PWM frequency = control rate, Hz.
    dead_time : float
        Inverter dead time, s.
    i_max : float
        Current-reference limit, A.
    v_max : float
        The fastest move the drive must make (speed cap, trips, bus headroom), m/s.
    a_max : float
        The application's acceleration (force check, verification), m/s^2.
    load : float or None
        Rated load, N (None: ``RATED_LOAD_FRACTION`` of :func:`drive_force_max`).
    travel : float or None
        The stroke, m (None: unbounded).
    v_inj : float or None
        Injection amplitude, V (None: designed).
    f_inj : float or None
        Injection frequency, Hz (None: designed, :func:`injection_frequency`).
    quad : float
        Elliptical share on q, dimensionless (0: the paper's pulsating injection).
    shape : str
        Injection: ``"pulsating"`` (pulsating or elliptical), ``"rotating"`` or ``"square"`` (at
        f_pwm / 2).
    d_current : float or None
        The d-current while injecting, A (None: designed, :func:`injection_d_current`; a scenario's
        ``injection.d_current``).

    Raises
    ------
    linsense.errors.InputError
        A value of the wrong type (a number that is not a real number, None where a number is
        required, another shape), naming the field; :func:`design` checks the ranges.
    """

    v_dc: float = 72.0  # V
    f_pwm: float = 16000.0  # Hz, PWM = control rate
    dead_time: float = 0.8e-6  # s
    i_max: float = 2.5  # A, current-reference limit
    v_max: float = 0.2  # m/s, the fastest move the drive must make (speed cap, trips, bus headroom)
    a_max: float = 1.0  # m/s^2, the application's acceleration (force check, verification)
    load: float | None = None  # N, rated load (None: RATED_LOAD_FRACTION of the force at i_max)
    travel: float | None = None  # m, the stroke (None: unbounded)
    v_inj: float | None = None  # V, injection amplitude (None: designed)
    f_inj: float | None = None  # Hz, injection frequency (None: designed)
    quad: float = QUAD  # -, elliptical share on q (0: the paper's pulsating injection)
    shape: str = "pulsating"  # injection: pulsating/elliptical, rotating or square (at f_pwm / 2)
    d_current: float | None = None  # A, the d-current while injecting (None: designed)

    def __post_init__(self) -> None:
        # one validated constructor: DriveData(v_dc="72") was built and design() ended in a
        # TypeError; the ranges are design()'s (named with the option or key they came from)
        src = "linsense.tune.DriveData"
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name == "shape":
                choice(v, src, "shape", ("pulsating", "rotating", "square"), "injection")
            elif not (v is None and "None" in str(f.type)) and not _real_number(v):
                what = "None or a real number" if "None" in str(f.type) else "a real number"
                raise InputError(src, f.name, f"expected {what}, got {brief(v)} ({type(v).__name__})")


@dataclass
class Design:
    """The designed values (SI; bandwidths in Hz) and what the analysis found (docs/tuning.md).

    Attributes
    ----------
    f_inj : float
        Injection frequency, Hz.
    v_inj : float
        Injection amplitude, V.
    quad : float
        Elliptical share on q, dimensionless.
    i_hf : float
        Mean HF current amplitude, A.
    current_bw : float
        Current-loop bandwidth, Hz.
    current_kp : float
        Current PI proportional gain, V/A.
    current_ki : float
        Current PI integral gain, V/(A s).
    demod_lpf : float
        Demodulator low-pass corner, Hz.
    demod_notch : float
        The demodulator low-pass's zeros at ``2 f_inj``, Hz (0: none, when ``4 f_inj >= f_pwm``).
    demod_gain : float
        Nominal demodulator gain ``L_q / (L_q - L_d)``, dimensionless.
    observer_bw : float
        Observer bandwidth, Hz (the mechanical observer's or the PLL's, by ``observer_type``).
    speed_bw : float
        Speed-loop bandwidth, Hz.
    speed_kp : float
        Speed PI proportional gain, N s/m.
    speed_ki : float
        Speed PI integral gain, N/m.
    kp_x : float
        Position-loop gain, 1/s.
    dither_a : float
        Calibration dither amplitude, A.
    dither_hz : float
        Calibration dither frequency, Hz.
    hf_delay : float
        The HF path's delay the estimate is advanced by (pulsating, elliptical), s.
    k_e_min : float
        Lowest local error gain over the period, relative.
    k_e_max : float
        Highest local error gain over the period, relative.
    margins : dict
        Loop margins by loop and case (:func:`margins`); empty when not analysed.
    headroom_speed : float
        Speed up to which the fundamental at the application's current (its load and m a_max) fits
        beside the injection, m/s.
    dead_time_ratio : float
        ``T_d f_pwm V_dc / (V_inj s_min)``, dimensionless.
    inj_ramp_rate : float
        The injection's ramp (``V_inj / INJ_RAMP_TIME``), V/s.
    s_min : float
        Lowest ``(L_q - L_d)/(L_q + L_d)`` over the period, dimensionless.
    v_cap : float
        Speed-reference cap (controller.v_max), m/s.
    a_step : float
        A step command's acceleration (reference.step_a_max; at v_cap), m/s^2.
    omega_trip : float
        Over-speed trip (protection.omega_max), electrical rad/s.
    omega_obs : float
        Observer speed clamp (observer.omega_max), electrical rad/s.
    i_trip : float
        Over-current trip (protection.i_max), A.
    load : float
        Rated load the verification uses, N.
    observer_type : str
        ``"mech"`` (with load_ff) or ``"pll"`` (observer.type).
    load_ff : bool
        The mechanical observer's load estimate fed forward (observer.load_feedforward).
    observer_bw_pll : float
        The PLL bandwidth by the rules (observer.type "pll"), Hz.
    observer_bw_mech : float
        The mechanical observer's bandwidth (observer.type "mech"), Hz.
    force_max : float
        The force at ``i_max`` (:func:`drive_force_max`, at most :func:`observer_force_max`): the
        clamp of the load estimate (observer.force_max), N.
    force_i_max : float
        The force the drive makes at ``i_max`` in every mode (:func:`drive_force_max`), N.
    force_i_max_why : str
        How it is made (:func:`force_max_text`: ``K_f i_max``, or with the d-current's share).
    force_i_max_share : float
        The share of ``K_f i_max`` it is (:func:`force_share`, at most 1), -.
    observer_slowed : float
        The observer's and the speed loop's bandwidths over their ratio rules' (at most 1: below 1
        where :func:`motion_signal_bandwidth` limits them), -.
    friction_coulomb : float
        The motor file's Coulomb friction, N, fed forward and in the mechanical observer's model.
    friction_viscous : float
        The motor file's viscous friction, N s/m, likewise.
    friction_band : float
        The speed below which the Coulomb force is linear, m/s: ``pi/2`` times the velocity amplitude
        of the injection's q-current dither (:func:`friction_band`).
    ripple_order : int
        The order ``n`` of the force constant's ripple from the PM-flux harmonics, ``K_f (1 + c cos(n
        theta) + s sin(n theta))`` (:func:`thrust_ripple`), divided out of the current reference (0:
        none).
    ripple_cos : float
        Its ``c``, a share of K_f.
    ripple_sin : float
        Its ``s``, a share of K_f.
    limits : dict
        What limits each bandwidth (docs/tuning.md).
    tolerances : dict
        Per tolerance: predicted hold error and gain range (:func:`linsense.tune.margins.tolerance_costs`).
    warnings : list of str
        What the design could not meet.
    """

    f_inj: float
    v_inj: float
    quad: float
    i_hf: float  # A, mean HF current amplitude
    current_bw: float
    current_kp: float
    current_ki: float
    demod_lpf: float
    demod_notch: float
    demod_gain: float
    observer_bw: float
    speed_bw: float
    speed_kp: float
    speed_ki: float
    kp_x: float
    dither_a: float
    dither_hz: float
    hf_delay: float  # s, the HF path's delay the estimate is advanced by (pulsating, elliptical)
    k_e_min: float  # local error gain over the period, relative
    k_e_max: float
    margins: dict = field(default_factory=dict)
    headroom_speed: float = math.nan  # m/s, up to which the application's current fits beside the injection
    dead_time_ratio: float = math.nan  # -, T_d f_pwm V_dc / (V_inj s_min)
    inj_ramp_rate: float = math.nan  # V/s, the injection's ramp (V_inj / INJ_RAMP_TIME)
    s_min: float = math.nan  # -, lowest (L_q - L_d)/(L_q + L_d) over the period
    v_cap: float = math.nan  # m/s, speed-reference cap (controller.v_max)
    a_step: float = math.nan  # m/s^2, a step command's acceleration (reference.step_a_max; at v_cap)
    omega_trip: float = math.nan  # rad/s electrical, over-speed trip (protection.omega_max)
    omega_obs: float = math.nan  # rad/s electrical, observer speed clamp (observer.omega_max)
    i_trip: float = math.nan  # A, over-current trip (protection.i_max)
    load: float = math.nan  # N, rated load the verification uses
    observer_type: str = "pll"  # "mech" (with load_ff) or "pll" (observer.type)
    load_ff: bool = False  # the mechanical observer's load estimate fed forward (observer.load_feedforward)
    observer_bw_pll: float = math.nan  # Hz, the PLL bandwidth by the rules (observer.type "pll")
    observer_bw_mech: float = math.nan  # Hz, the mechanical observer's (observer.type = "mech")
    force_max: float = math.nan  # N, the force at i_max: the clamp of the load estimate (observer.force_max)
    force_i_max: float = math.nan  # N, the force the drive makes at i_max in every mode
    force_i_max_why: str = "K_f i_max"  # how (force_max_text)
    force_i_max_share: float = 1.0  # -, its share of K_f i_max (force_share, at most 1)
    observer_slowed: float = 1.0  # -, the observer and speed loop's bandwidth over their rule's
    friction_coulomb: float = 0.0  # N, the motor file's Coulomb friction (controller.friction_coulomb)
    friction_viscous: float = 0.0  # N s/m, its viscous friction (controller.friction_viscous)
    friction_band: float = 1.0e-3  # m/s, the Coulomb force's linear band (controller.friction_band)
    ripple_order: int = 0  # -, the force constant's ripple order fed forward (controller.ripple_order)
    ripple_cos: float = 0.0  # -, its cosine share of K_f (controller.ripple_cos)
    ripple_sin: float = 0.0  # -, its sine share (controller.ripple_sin)
    limits: dict = field(default_factory=dict)  # what limits each bandwidth (docs/tuning.md)
    tolerances: dict = field(default_factory=dict)  # per tolerance: predicted hold error, gain range
    warnings: list = field(default_factory=list)

    def as_dict(self) -> dict:
        """The design as a plain dict (``dataclasses.asdict``).

        Returns
        -------
        dict
            Field name to value.
        """
        return asdict(self)


def current_gains(bw_hz: float, L_d: float, L_q: float, R_s: float) -> tuple[float, float]:
    """PI gains of the d/q current loop for a bandwidth: pole-zero cancellation.

    Parameters
    ----------
    bw_hz : float
        Bandwidth, Hz.
    L_d, L_q : float
        Mean d and q inductances, H.
    R_s : float
        Phase resistance, ohm.

    Returns
    -------
    kp : float
        ``w (L_d + L_q) / 2``, V/A.
    ki : float
        ``w R_s``, V/(A s).
    """
    w = 2.0 * math.pi * bw_hz
    return w * 0.5 * (L_d + L_q), w * R_s


def speed_gains(bw_hz: float, mass: float) -> tuple[float, float]:
    """Speed PI gains for a bandwidth: ``kp = m w``, ``ki = m w^2 / 4``.

    A double real closed-loop pole; with the load estimate fed forward the sensorless modes hold the
    integrator at 0, the encoder modes keep it.

    Parameters
    ----------
    bw_hz : float
        Bandwidth, Hz.
    mass : float
        Moving mass, kg.

    Returns
    -------
    kp : float
        N s/m.
    ki : float
        N/m.
    """
    w = 2.0 * math.pi * bw_hz
    return mass * w, mass * w * w / SPEED_KI_DIV


def require_saliency(motor: Motor, source: str) -> tuple[float, float]:
    """The motor's mean ``L_d``, ``L_q``, refused unless ``L_q > L_d``: the one rule of every command
    that makes or runs a drive (``tune``, ``simulate``, ``calibrate``, ``lut``, ``firmware export``).

    The drive's demodulator, its error gain and its tables are for the saliency of a PM motor, ``L_q``
    above ``L_d``; a motor with reversed saliency (``L_q < L_d`` on average) was refused by ``tune``
    and ``simulate`` as "i_max leaves no injection" while ``lut`` wrote a table for it.

    Parameters
    ----------
    motor : Motor
        The motor.
    source : str
        Named in the message.

    Returns
    -------
    L_d : float
        Mean over the period, H.
    L_q : float
        Mean over the period, H.

    Raises
    ------
    linsense.errors.InputError
        No mean saliency, or reversed saliency (the values given, :func:`saliency_problem`).
    """
    problem = saliency_problem(motor)  # (the message, with what to check; DRIVE_RULES asks it too)
    if problem is not None:
        raise InputError(source, "motor", problem)
    return mean_dq(motor)


def observable_error_gain(motor: Motor, f_inj: float, quad: float, source: str) -> np.ndarray:
    """:func:`error_gain` with the nominal demodulator gain ``L_q / (L_q - L_d)``.

    Where it is not positive at every position the HF observer cannot hold, and no table
    compensates it (``tune``, ``simulate``, ``calibrate`` and ``lut`` refuse such a motor alike).

    Parameters
    ----------
    motor : Motor
        The motor.
    f_inj : float
        Injection frequency, Hz.
    quad : float
        Elliptical share on q.
    source : str
        Named in the message.

    Returns
    -------
    ndarray
        The local error gain over the period, relative.

    Raises
    ------
    linsense.errors.InputError
        No or reversed mean saliency (:func:`require_saliency`), or the gain is not positive
        everywhere.
    """
    L_d, L_q = require_saliency(motor, source)
    k_e = error_gain(motor, f_inj, quad, L_q / (L_q - L_d))
    if np.any(k_e <= 0):
        raise InputError(
            source,
            "motor",
            "the demodulated error changes sign at some positions (saliency "
            "vanishes or reverses): the HF observer cannot hold there",
        )
    return k_e


def end_effect_ratio(motor: Motor) -> float:
    """The end effect's stationary anisotropy over the saliency's rotating one.

    ``|(l_ea, l_eb)| / (|L_d - L_q| / 2)`` (alpha-beta inductance,
    :func:`linsense.analysis.hf.end_anisotropy`). A fraction ``d`` of error in the end effect tilts
    the HF ellipse's axis by up to about ``d ratio / 2`` rad, which no saliency estimator tells from a
    position shift where the tilt is across the axis (docs/tuning.md, "The end-effect tolerance").

    Parameters
    ----------
    motor : Motor
        The motor.

    Returns
    -------
    float
        Dimensionless.
    """
    l_ea, l_eb = end_anisotropy(motor)
    l_d, l_q = mean_dq(motor)
    return float(math.hypot(l_ea, l_eb) / (0.5 * abs(l_d - l_q)))


def gain_schedule(motor: Motor, f_inj: float, quad: float, n: int) -> np.ndarray:
    """The demodulator's gain table, ``1 / k_e(theta)`` at ``n`` positions (:func:`error_gain`).

    The local error gain is then 1 everywhere (docs/tuning.md, "The gain schedule").

    Parameters
    ----------
    motor : Motor
        The motor.
    f_inj : float
        Injection frequency, Hz.
    quad : float
        Elliptical share on q.
    n : int
        Table points over the period.

    Returns
    -------
    ndarray, shape (n,)
        Dimensionless.
    """
    return 1.0 / error_gain(motor, f_inj, quad, 1.0, n=n)


def gain_r_slope(motor: Motor, f_inj: float, quad: float, n: int) -> np.ndarray:
    """``d g / d k_r`` of :func:`gain_schedule`, per unit of the resistance's scale.

    ``R_s = k_r R_s0``; :func:`~linsense.compensation.lut.resistance_slope`: the drive measures
    ``k_r`` and reads ``g + (k_r - 1) dg/dk_r`` (``ls_demod_cfg.gain_r``), as its table follows it
    (``lut_r_slope``).

    Parameters
    ----------
    motor : Motor
        The motor.
    f_inj : float
        Injection frequency, Hz.
    quad : float
        Elliptical share on q.
    n : int
        Table points over the period.

    Returns
    -------
    ndarray, shape (n,)
        Per unit of ``k_r``.
    """
    return resistance_slope(motor, lambda m: gain_schedule(m, f_inj, quad, n), n)


# ------------------------------------------------------------------ the inputs, checked in order
#: Hz, the largest PWM rate: the controller library's (LS_DRIVE_FS_MAX, ls_drive.h), twice the largest
#: injection frequency of a table (linsense.limits.MAX_F_INJ)
F_PWM_MAX = 1.0e6
_DEFAULT_DRIVE = DriveData()
#: units of the drive data in messages
_UNITS = {"v_dc": "V", "f_pwm": "Hz", "dead_time": "s", "i_max": "A", "v_max": "m/s", "a_max": "m/s^2",
          "load": "N", "travel": "m", "v_inj": "V", "f_inj": "Hz", "quad": "", "shape": "", "d_current": "A"}


def limit_text(value: float, up: bool) -> str:
    """A limit for a message: 4 significant digits, rounded to the side that keeps it within the
    limit (``up`` for a lower limit), so that the value typed back as shown is accepted.

    Parameters
    ----------
    value : float
        The limit.
    up : bool
        Round up (a lower limit, "at least") or down (an upper limit, "at most").

    Returns
    -------
    str
        E.g. ``"0.5317"``, ``"33910"``, ``"1.696e-06"``, ``"7.389e+27"``.
    """
    if not (math.isfinite(value) and value != 0.0):
        return f"{value:g}"
    exp = math.floor(math.log10(abs(value)))
    step = 10.0 ** (exp - 3)
    if not (step > 0.0 and math.isfinite(value / step)):  # (a subnormal limit: shown as it is)
        return f"{value:.4g}"
    q = (math.ceil if up else math.floor)(value / step) * step
    return f"{q:.{max(4, exp + 1)}g}" if -4 <= exp < 7 else f"{q:.4g}"


def saliency_problem(motor: Motor) -> str | None:
    """What makes ``motor``'s saliency unusable for the HF observer, or None.

    No mean saliency (``L_q = L_d``), or a reversed one (``L_d > L_q`` on average: the drive's
    demodulator takes the axis of lowest inductance as d, and would settle 90 electrical degrees off
    the magnet's axis). ``tune``, ``simulate``, ``calibrate``, ``firmware export`` and ``lut`` refuse
    such a motor alike (:func:`check_drive`, :func:`require_saliency`).

    Parameters
    ----------
    motor : Motor
        The motor.

    Returns
    -------
    str or None
        The message (with the motor's mean ``L_d`` and ``L_q`` and what to check), or None.
    """
    L_d, L_q = mean_dq(motor)
    if L_q == L_d:
        return "no mean saliency (L_q = L_d): HF injection cannot see the position"
    if L_q < L_d:
        return (f"reversed saliency: the mean L_d = {L_d * 1e3:.3g} mH is above L_q = {L_q * 1e3:.3g} mH, "
                "and the HF observer would settle 90 electrical degrees off the axis of the magnet (the "
                "drive takes the axis of lowest inductance as d): check the signs of the saliency terms (in "
                "eq. 3, L2 and M2 negative give L_q > L_d) and that position 0 is the d-axis of the magnet")
    return None


class DriveInputs:
    """A design's inputs and the quantities derived from them, each computed when a rule of
    :data:`DRIVE_RULES` first asks for it.

    Parameters
    ----------
    motor : Motor
        The motor.
    d : DriveData
        The drive and application.
    """

    def __init__(self, motor: Motor, d: DriveData) -> None:
        self.motor, self.d = motor, d

    def given(self, key: str) -> bool:
        """Whether the drive data's ``key`` was given: it is not its default (``"motor"``: never).

        Parameters
        ----------
        key : str
            A :class:`DriveData` field.

        Returns
        -------
        bool
            ``True`` when the value differs from :class:`DriveData`'s default.
        """
        return key != "motor" and getattr(self.d, key) != getattr(_DEFAULT_DRIVE, key)

    def show(self, key: str) -> str:
        """The value of drive data ``key`` with its unit, for a message.

        Parameters
        ----------
        key : str
            A :class:`DriveData` field.

        Returns
        -------
        str
            E.g. ``"0.001 A"``.
        """
        v = getattr(self.d, key)
        return f"{v:g} {_UNITS[key]}".strip() if isinstance(v, float) else repr(v)

    @functools.cached_property
    def dq(self) -> tuple[float, float]:
        """Mean ``(L_d, L_q)``, H."""
        return mean_dq(self.motor)

    @functools.cached_property
    def s_min(self) -> float:
        """The lowest local saliency ratio over the period (:func:`saliency_min`)."""
        return saliency_min(self.motor)

    @property
    def f_inj(self) -> float:
        """The injection frequency, given or designed, Hz."""
        return self.d.f_inj if self.d.f_inj is not None else injection_frequency(self.d.f_pwm)

    @property
    def z(self) -> float:
        """``|R_s + j 2 pi f_inj (L_d + L_q) / 2|``, ohm."""
        return abs(complex(self.motor.R_s, 2.0 * math.pi * self.f_inj * 0.5 * sum(self.dq)))

    @property
    def dv_dt(self) -> float:
        """The dead time's voltage error ``T_d f_pwm V_dc``, V."""
        return self.d.dead_time * self.d.f_pwm * self.d.v_dc

    @property
    def v_bus_top(self) -> float:
        """The largest injection the bus allows, ``INJ_BUS_MAX V_dc``, V."""
        return self.d.v_dc * INJ_BUS_MAX

    @property
    def v_current_top(self) -> float:
        """The largest injection the current limit allows, ``INJ_CURRENT_MAX i_max |Z|``, V."""
        return INJ_CURRENT_MAX * self.d.i_max * self.z

    @property
    def v_top(self) -> float:
        """The largest injection allowed, V."""
        return min(self.v_bus_top, self.v_current_top)

    @property
    def v_need(self) -> float:
        """The smallest injection the dead time lets hold: its error at most ``DEAD_TIME_RATIO_MAX``
        times the weakest error signal ``V_inj s_min``, V."""
        return self.dv_dt / (DEAD_TIME_RATIO_MAX * self.s_min)

    @property
    def v_inj(self) -> float:
        """The injection, given or designed, V."""
        if self.d.v_inj is not None:
            return self.d.v_inj
        return min(max(self.dv_dt / (DEAD_TIME_RATIO * self.s_min), self.d.v_dc * INJ_BUS_MIN), self.v_top)

    @property
    def dead_time_ratio(self) -> float:
        """The dead time's voltage error over the weakest error signal, ``T_d f_pwm V_dc / (V_inj
        s_min)`` (inf where the signal underflows: a given injection of 5e-324 V divided by zero)."""
        signal = self.v_inj * self.s_min
        return self.dv_dt / signal if signal > 0.0 else math.inf

    @property
    def force_need(self) -> float:
        """The rated load plus ``m a_max``, N."""
        return rated_load(self.motor, self.d) + self.motor.mass * self.d.a_max

    @property
    def v_avail(self) -> float:
        """What the bus's linear range leaves beside the injection, ``V_dc / sqrt(3) - V_inj``, V."""
        return self.d.v_dc / math.sqrt(3.0) - self.v_inj

    def i_max_min(self) -> tuple[float, str]:
        """The smallest ``i_max`` the application and the injection need, A, and what sets it.

        Returns
        -------
        i_min : float
            A.
        why : str
            Each need with its current.
        """
        m, d = self.motor, self.d
        if d.load is None:  # (the rated load then is a share of the force at i_max)
            need = m.mass * d.a_max / (1.0 - RATED_LOAD_FRACTION)
        else:
            need = d.load + m.mass * d.a_max
        i_force = _current_for_force(need, m, d)
        why = [f"rated load and m a_max: {limit_text(i_force, True)} A"]
        i_inj = 0.0
        if d.v_inj is None and self.v_need <= self.v_bus_top:  # (beyond the bus share no i_max does)
            i_inj = self.v_need / (INJ_CURRENT_MAX * self.z)
            why.append(f"HF current of the injection the dead time needs: {limit_text(i_inj, True)} A")
        return max(i_force, i_inj), "; ".join(why)

    def v_dc_min(self) -> float:
        """The smallest bus that drives ``i_max`` through ``R_s`` beside the injection, V.

        The designed injection taken as its share of the bus, its current limit aside (which only
        lowers it): a bound that the design accepts.

        Returns
        -------
        float
            V.
        """
        r_i = self.motor.R_s * self.d.i_max
        if self.d.v_inj is not None:
            return math.sqrt(3.0) * (r_i + self.d.v_inj)
        share = self.d.dead_time * self.d.f_pwm / (DEAD_TIME_RATIO * self.s_min)
        share = min(max(share, INJ_BUS_MIN), INJ_BUS_MAX)
        return r_i / (1.0 / math.sqrt(3.0) - share)

    @property
    def i_need(self) -> float:
        """The q current the application needs at speed (:attr:`force_need` over the drive's force
        constant), A."""
        return self.force_need / drive_force_constant(self.motor, self.d)

    def speed_driven(self, v_avail: float) -> float:
        """The speed up to which ``v_avail`` (V) drives :attr:`i_need`, with the injection's d-current
        (:func:`fundamental_speed`), m/s.

        Parameters
        ----------
        v_avail : float
            The voltage amplitude available, V.

        Returns
        -------
        float
            m/s.
        """
        L_d, L_q = self.dq
        return fundamental_speed(self.motor, v_avail, self.i_need, L_q, i_d=injecting_d_current(self.d),
                                 L_d=L_d)

    @property
    def v_bus_speed(self) -> float:
        """The speed beyond which the bus cannot drive the current the application needs, m/s."""
        return self.speed_driven(self.d.v_dc / math.sqrt(3.0))

    @property
    def v_pwm_speed(self) -> float:
        """The speed beyond which the observer's speed clamp (the speed cap, the over-speed trip and
        their margins over ``v_max``, with the table) turns the electrical angle by more than the EMF
        estimate's period model takes per PWM period (``LS_EMF_OMEGA_TS_MAX``), m/s: the design's
        own refusal beyond it comes after the bus's (``linsense tune``), so the bus's names it."""
        from linsense.ctrl import lib

        return (float(lib.LS_EMF_OMEGA_TS_MAX) * self.d.f_pwm * self.motor.pole_pitch
                / (2.0 * math.pi * CLAMP_OVER_V_MAX))

    def _pwm_says(self, top: float) -> str:
        """The PWM's limit beside a refusal's ``top`` where it is lower ('' otherwise)."""
        pwm = self.v_pwm_speed
        if not pwm < top:
            return ""
        return (f"; and at most {limit_text(pwm, False)} m/s at {self.d.f_pwm:g} Hz PWM with the EMF "
                f"estimate on (the observer's speed clamp, {CLAMP_OVER_V_MAX:g} v_max, within the EMF "
                "estimate's largest turn of the angle per period)")

    @functools.cached_property
    def k_e(self) -> np.ndarray:
        """The local error gain over the period with the nominal demodulator gain (:func:`error_gain`)."""
        L_d, L_q = self.dq
        return error_gain(self.motor, self.f_inj, self.d.quad, L_q / (L_q - L_d))


@dataclass(frozen=True)
class Rule:
    """One check of a design's inputs (:data:`DRIVE_RULES`).

    Attributes
    ----------
    stage : int
        1: an input against its own range; 2: a pair of inputs (or an input and the motor);
        3: a quantity derived from them.
    keys : tuple of str or callable
        The inputs it reads, in the order one is named: the first the user gave, else the first
        (``keys(x)`` of the :class:`DriveInputs` where the order depends on them).
    holds : callable
        ``holds(x) -> bool``.
    says : callable
        ``says(x, key) -> str``: what is wrong, with the value of ``key`` and its limit.
    """

    stage: int
    keys: tuple[str, ...] | Callable[[DriveInputs], tuple[str, ...]]
    holds: Callable[[DriveInputs], bool]
    says: Callable[[DriveInputs, str], str]


def _own_range(key: str, ok: Callable[[float], bool], what: str) -> Rule:
    """A stage-1 rule: drive data ``key`` (None: not given, accepted) within its own range."""
    return Rule(1, (key,), lambda x: getattr(x.d, key) is None or ok(getattr(x.d, key)),
                lambda x, k: f"{what}, got {shown(getattr(x.d, k))}")


def _positive(v: float) -> bool:
    return math.isfinite(v) and v > 0.0


def _dead_time_share_says(x: DriveInputs, key: str) -> str:
    d = x.d
    share = f"{d.dead_time * d.f_pwm * 100:.3g} % of the PWM period"
    rule = f"the dead time must be below {DEAD_TIME_SHARE_MAX * 100:g} % of the PWM period"
    if key == "f_pwm":
        top = limit_text(DEAD_TIME_SHARE_MAX / d.dead_time, False)
        return (f"{x.show('f_pwm')} makes the dead time ({x.show('dead_time')}) {share}; {rule}: below {top} "
                "Hz with this dead time")
    top = limit_text(DEAD_TIME_SHARE_MAX / d.f_pwm, False)
    return (f"{x.show('dead_time')} is {share} ({1.0 / d.f_pwm:.3g} s at f_pwm = {d.f_pwm:g} Hz); {rule}: "
            f"below {top} s")


def _f_inj_says(x: DriveInputs, key: str) -> str:
    d = x.d
    if key == "f_inj":
        return (f"{x.show('f_inj')} must be at most {limit_text(d.f_pwm / F_INJ_PWM_DIV, False)} Hz "
                f"(f_pwm / {F_INJ_PWM_DIV:g})")
    return (f"{x.show('f_pwm')} leaves the injection at most f_pwm / {F_INJ_PWM_DIV:g} = "
            f"{d.f_pwm / F_INJ_PWM_DIV:.3g} Hz, below its "
            f"lowest {F_INJ_MIN / 8.0:g} Hz (the bandwidths of the loops follow it): at least "
            f"{limit_text(F_INJ_MIN / 2.0, True)} Hz")


def _v_inj_says(x: DriveInputs, key: str) -> str:
    from linsense.ctrl import V_INJ_SHARE_MAX as share  # (the C library's limit)

    v_uv = x.d.v_dc * V_DC_MIN_FRACTION  # (the under-voltage limit)
    return (f"{x.show('v_inj')} leaves no voltage for the fundamental on a {x.d.v_dc:g} V bus (amplitude * "
            f"sqrt(3) must be below {share:g} of the {v_uv:.3g} V under-voltage limit, {share * v_uv:.3g} "
            f"V): below {limit_text(share * v_uv / math.sqrt(3.0), False)} V")


def _share_slope(m: Motor, d: DriveData) -> float:
    """How fast the d-current's share of the force constant falls with ``i_max``, 1/A: ``c`` in
    ``share = 1 - c i_max`` for the designed d-current (a share of ``i_max``), 0 for a given one or
    where the share does not fall."""
    if d.d_current is not None:
        return 0.0
    return max(0.0, 1.0 - force_share(m, dataclasses.replace(d, i_max=1.0)))


def _current_for_force(force: float, m: Motor, d: DriveData) -> float:
    """The smallest ``i_max`` at which :func:`drive_force_max` reaches ``force``, A: ``F / K_f`` over
    a given d-current's share; with the designed one the share falls with ``i_max``, so ``K_f i (1 -
    c i)`` peaks at ``K_f / (4 c)`` (inf beyond it)."""
    x = force / m.force_constant
    c = _share_slope(m, d)
    if c == 0.0 or not math.isfinite(x):  # (a share that does not fall with i_max: 1, or a given one's)
        return x / min(1.0, force_share(m, d))
    disc = 1.0 - 4.0 * c * x
    return 2.0 * x / (1.0 + math.sqrt(disc)) if disc >= 0.0 else math.inf


def _d_current_holds(x: DriveInputs) -> bool:
    from linsense.ctrl import KF_SHARE_MIN  # (the C library's limit: ls_drive_init)
    return force_share(x.motor, x.d) >= KF_SHARE_MIN


def _d_current_says(x: DriveInputs, key: str) -> str:
    from linsense.ctrl import KF_SHARE_MIN
    m, d = x.motor, x.d
    L_d, L_q = x.dq
    given = d.d_current is not None
    i_d = injecting_d_current(d)
    how = "" if given else f"{INJECTION_D_FRACTION:g} i_max = "
    what = (f"the {d.shape} injection's d-current {how}{i_d:.3g} A leaves {force_share(m, d):.3g} of the "
            f"force constant (L_d {L_d * 1e3:.3g} mH, L_q {L_q * 1e3:.3g} mH, psi_pm "
            f"{m.psi_pm * 1e3:.3g} mWb: the reluctance force), below the {KF_SHARE_MIN:g} the drive accepts")
    # (the share 1 + (L_d - L_q) i_d / psi_pm falls to KF_SHARE_MIN at this d-current)
    i_d_top = (1.0 - KF_SHARE_MIN) * m.psi_pm / abs(L_q - L_d)
    if given:
        return f"{x.show('d_current')}: {what}: |d_current| at most {limit_text(i_d_top, False)} A"
    i_top = limit_text(i_d_top / INJECTION_D_FRACTION, False)
    if key == "shape":
        return f"{x.show('shape')}: {what}: use the pulsating injection, or i_max at most {i_top} A"
    return f"{x.show('i_max')}: {what}: at most {i_top} A, or the pulsating injection"


def _force_says(x: DriveInputs, key: str) -> str:
    m, d = x.motor, x.d
    f_max, ma, load = drive_force_max(m, d), m.mass * d.a_max, rated_load(m, d)
    kfi = force_max_text(m, d)
    share = f" = {RATED_LOAD_FRACTION:g} of the force at i_max," if d.load is None else ""
    slip = " (did you type g? the motor file's mass is in kg)" if m.mass >= MASS_SLIP_KG else ""
    need = (f"the {x.force_need:.3g} N the application needs (rated load {load:.3g} N{share} + m a_max "
            f"{ma:.3g} N, the motor's mass {m.mass:g} kg{slip})")
    c = _share_slope(m, d)
    # (the designed d-current's share falls with i_max: the force peaks at K_f / (4 c), at 1 / (2 c))
    peak = "" if c == 0.0 else (
        f"; with the {d.shape} injection's d-current {INJECTION_D_FRACTION:g} i_max the force at i_max "
        f"peaks at {m.force_constant / (4.0 * c):.4g} N (i_max {1.0 / (2.0 * c):.4g} A)")
    if key == "i_max":
        i_min, why = x.i_max_min()
        if not math.isfinite(i_min):
            return (f"{x.show('i_max')}: {kfi} = {f_max:.3g} N is below {need}, and no i_max makes it{peak}: "
                    "use the pulsating injection, or lower the load or a_max")
        return (f"{x.show('i_max')}: {kfi} = {f_max:.3g} N is below {need}: i_max must be at least "
                f"{limit_text(i_min, True)} A ({why})")
    more = "raise i_max" if c == 0.0 or 2.0 * c * d.i_max < 1.0 else "use the pulsating injection"
    if key == "load":
        return (f"{x.show('load')}: {need} is beyond {kfi} = {f_max:.3g} N: at most "
                f"{limit_text(f_max - ma, False)} N at this a_max, or {more}")
    return (f"{x.show('a_max')}: {need} is beyond {kfi} = {f_max:.3g} N: at most "
            f"{limit_text((f_max - load) / m.mass, False)} m/s^2 with this load and i_max")


def _bus_drives_i_max(x: DriveInputs) -> bool:
    return x.motor.R_s * x.d.i_max < x.d.v_dc / math.sqrt(3.0)


def _bus_says(x: DriveInputs, key: str) -> str:
    """R_s i_max against the bus (stage 2) or against what the injection leaves of it (stage 3)."""
    d, r_i, v_lin = x.d, x.motor.R_s * x.d.i_max, x.d.v_dc / math.sqrt(3.0)
    if key == "i_max":
        top = limit_text(max(x.v_avail, 0.0) / x.motor.R_s, False)
        return (f"{x.show('i_max')}: R_s i_max = {r_i:.3g} V is beyond the {x.v_avail:.3g} V the "
                f"{d.v_dc:g} V bus leaves beside the injection ({x.v_inj:.3g} V; V_dc / sqrt(3) - V_inj): "
                f"at most {top} A")
    if key == "v_inj":
        return (f"{x.show('v_inj')}: after it there is {x.v_avail:.3g} V left of the {d.v_dc:g} V bus "
                f"(V_dc / sqrt(3) - V_inj), below R_s i_max = {r_i:.3g} V: below "
                f"{limit_text(v_lin - r_i, False)} V")
    left = (f"after the injection ({x.v_inj:.3g} V) there is {x.v_avail:.3g} V left" if _bus_drives_i_max(x)
            else f"its linear range V_dc / sqrt(3) is {v_lin:.3g} V")
    return (f"{x.show('v_dc')}: {left}, below R_s i_max = {r_i:.3g} V: at least "
            f"{limit_text(x.v_dc_min(), True)} V")


def _injection_keys(x: DriveInputs) -> tuple[str, ...]:
    if x.v_bus_top < x.v_need:  # (no i_max makes the share of the bus hold: the share of the dead time)
        return ("dead_time", "f_pwm")
    return ("i_max", "f_inj", "v_dc", "dead_time", "f_pwm")


def _injection_holds(x: DriveInputs) -> bool:
    return x.d.v_inj is not None or (x.v_top > 0.0 and x.v_need <= x.v_top)


def _injection_says(x: DriveInputs, key: str) -> str:
    d, k = x.d, DEAD_TIME_RATIO_MAX * x.s_min  # (the injection needed is dv_dt / k)
    bus = x.v_bus_top <= x.v_current_top
    top = f"the largest injection allowed is {x.v_top:.3g} V (" + (
        f"{INJ_BUS_MAX:.3g} V_dc)" if bus else f"{INJ_CURRENT_MAX:g} i_max |Z(f_inj)|, |Z| = {x.z:.3g} ohm)")
    need = (f"the dead-time voltage error T_d f_pwm V_dc = {x.dv_dt:.3g} V needs an injection of at least "
            f"{x.v_need:.3g} V (the error at most {DEAD_TIME_RATIO_MAX:g} x the weakest HF error signal "
            f"V_inj s_min, s_min = {x.s_min:.3g})")
    i_inj = limit_text(x.v_need / (INJ_CURRENT_MAX * x.z), True)
    if key == "i_max":
        i_min, why = x.i_max_min()
        return f"{x.show('i_max')}: {need}; {top}: i_max must be at least {limit_text(i_min, True)} A ({why})"
    if key == "f_inj":
        z_min = x.v_need / (INJ_CURRENT_MAX * d.i_max)
        r_s = x.motor.R_s  # (|R_s + j w L| = z_min; products: a square of 1e155 overflowed)
        f_min = math.sqrt(max(z_min - r_s, 0.0) * (z_min + r_s)) / (2.0 * math.pi * 0.5 * sum(x.dq))
        return (f"{x.show('f_inj')}: {need}; {top}: at least {limit_text(f_min, True)} Hz, or i_max at least "
                f"{i_inj} A")
    if key == "v_dc":
        top_v = limit_text(k * x.v_top / (d.dead_time * d.f_pwm), False)
        return (f"{x.show('v_dc')}: {need}; {top}: at most {top_v} V with this i_max, or i_max at least "
                f"{i_inj} A")
    share = f"{d.dead_time * d.f_pwm * 100:.3g} % of the PWM period"
    small = "the saliency is too small for this dead time"
    if key == "f_pwm":
        more = (f"at most {limit_text(k * x.v_top / (d.dead_time * d.v_dc), False)} Hz with this dead time"
                if bus else f"lower it, or raise i_max to at least {i_inj} A")
        return f"{x.show('f_pwm')} makes the dead time {share}: {need}; {top}: {small}: {more}"
    more = "" if bus else f", or raise i_max to at least {i_inj} A"
    top_t = limit_text(k * x.v_top / (d.f_pwm * d.v_dc), False)
    return (f"{x.show('dead_time')} is {share}: {need}; {top}: {small}: at most {top_t} s at f_pwm = "
            f"{d.f_pwm:g} Hz{more}")


def _cap_says(x: DriveInputs, key: str) -> str:
    """The speed cap beyond linear motors' speeds; the bus's own limit beside it where it is lower
    (else a user at the cap's limit met the bus's refusal next)."""
    top = KINDS["speed"].high / SPEED_CAP_MARGIN
    try:
        bus = x.v_bus_speed
    except (ArithmeticError, ValueError):  # (absurd inputs, refused by their own rules next)
        bus = math.inf
    more = f", what the {x.d.v_dc:g} V bus allows at the application's current" if bus < top else ""
    return (f"{x.show('v_max')}: its speed cap, {SPEED_CAP_MARGIN:g} v_max = "
            f"{SPEED_CAP_MARGIN * x.d.v_max:.4g} m/s, is beyond the speeds of {KINDS['speed'].of} "
            f"({KINDS['speed'].high:g} m/s): at most {limit_text(min(top, bus), False)} m/s{more}"
            f"{x._pwm_says(min(top, bus))}")


def _speed_says(x: DriveInputs, key: str) -> str:
    m, d = x.motor, x.d
    i_q, i_d = x.i_need, injecting_d_current(d)
    share = f", {RATED_LOAD_FRACTION:g} of the force at i_max where none is given" if d.load is None else ""
    with_d = f", with the {d.shape} injection's d-current {i_d:.3g} A" if i_d else ""
    why = (f"where the back-EMF with R_s i, and omega L_q i, at the current the application needs at speed "
           f"({i_q:.3g} A: the rated load {rated_load(m, d):.3g} N{share}, and m a_max "
           f"{m.mass * d.a_max:.3g} N{with_d}) take the whole linear range V_dc / sqrt(3), injection aside")
    if key == "v_dc":
        v_min = math.sqrt(3.0) * _fundamental_voltage(m, d.v_max, i_q, x.dq[1], i_d, x.dq[0])
        return (f"{x.show('v_dc')} allows {x.v_bus_speed:.3g} m/s, below v_max = {d.v_max:g} m/s ({why}): at "
                f"least {limit_text(v_min, True)} V")
    return (f"{x.show('v_max')} is beyond what the {d.v_dc:g} V bus allows, {x.v_bus_speed:.3g} m/s ({why}): "
            f"at most {limit_text(x.v_bus_speed, False)} m/s, or raise v_dc{x._pwm_says(x.v_bus_speed)}")


def _injection_text(dz: Design, d: DriveData) -> str:
    """The design print's injection rule: the dead time's error against the signal, and where it is
    over the target, that the injection is at the largest it may be."""
    over = dz.dead_time_ratio > DEAD_TIME_RATIO * (1.0 + 1e-9) and d.v_inj is None
    why = (f": over the target, the injection at its largest allowed, {INJ_BUS_MAX:.3g} V_dc or "
           f"{INJ_CURRENT_MAX:g} i_max of HF current; refused beyond {DEAD_TIME_RATIO_MAX:g}" if over else "")
    return (f"dead-time error {dz.dead_time_ratio:.2g} x the weakest error signal (target "
            f"{DEAD_TIME_RATIO:g}; bus share {dz.v_inj / d.v_dc:.3g} V_dc{why})")


def _move_keys(x: DriveInputs) -> tuple[str, ...]:
    slow = 2.0 * x.motor.pole_pitch / x.d.v_max >= x.d.v_max / x.d.a_max
    return ("v_max", "a_max") if slow else ("a_max", "v_max")


def _move_holds(x: DriveInputs) -> bool:
    return 2.0 * x.motor.pole_pitch / x.d.v_max + x.d.v_max / x.d.a_max <= MOVE_TIME_MAX


def _move_says(x: DriveInputs, key: str) -> str:
    d, two, t = x.d, 2.0 * x.motor.pole_pitch, MOVE_TIME_MAX
    limit = ""
    if key == "a_max" and two / d.v_max < t:
        limit = f": at least {limit_text(d.v_max / (t - two / d.v_max), True)} m/s^2 at this v_max"
    elif key == "v_max" and t * d.a_max * t * d.a_max > 4.0 * two * d.a_max:
        # (2 tau / v + v / a = T: v^2 - T a v + 2 tau a = 0)
        root = math.sqrt(t * d.a_max * t * d.a_max - 4.0 * two * d.a_max)
        slow = two / d.v_max >= d.v_max / d.a_max
        v = (t * d.a_max + (-root if slow else root)) / 2.0
        limit = f": {'at least' if slow else 'at most'} {limit_text(v, slow)} m/s at this a_max"
    return (f"{x.show(key)}: a move over two pole pitches at v_max = {d.v_max:g} m/s, a_max = {d.a_max:g} "
            f"m/s^2 lasts {two / d.v_max + d.v_max / d.a_max:.3g} s, beyond {t:g} s{limit}")


def _error_gain_says(x: DriveInputs, key: str) -> str:
    return ("the demodulated error changes sign at some positions (saliency vanishes or reverses) with "
            f"the injection at {x.f_inj:g} Hz, quad = {x.d.quad:g}: the HF observer cannot hold there")


def _travel_says(x: DriveInputs, key: str) -> str:
    return (f"{x.d.travel * 1e3:g} mm: the stroke must cover at least one pole pitch "
            f"({x.motor.pole_pitch * 1e3:g} mm: the drive holds anywhere in the period)")


def _v_inj_fits(x: DriveInputs) -> bool:
    from linsense.ctrl import injection_fits  # (the C library's rule: ls_drive_inject_fits)

    return x.d.v_inj is None or injection_fits(x.d.v_inj, x.d.v_dc * V_DC_MIN_FRACTION)


#: the design's checks of its inputs, in the order they run (docs/tuning.md): (1) each input against
#: its own range, (2) pairs of inputs (and an input against the motor), (3) the quantities derived
#: from them; so a message always names an input the user can change: the first of its rule's keys
#: the user gave (a value that is not the default), with that input's limit
DRIVE_RULES: tuple[Rule, ...] = (
    *(_own_range(k, _positive, "must be a positive number") for k in ("v_dc", "f_pwm", "i_max", "v_max",
                                                                      "a_max")),
    Rule(1, ("f_pwm",), lambda x: x.d.f_pwm <= F_PWM_MAX,
         lambda x, k: f"{x.show('f_pwm')} is beyond the largest rate of the controller library: at most "
                      f"{F_PWM_MAX:g} Hz"),
    _own_range("dead_time", lambda v: math.isfinite(v) and v >= 0.0, "must be a number of seconds >= 0"),
    Rule(1, ("shape",), lambda x: x.d.shape in ("pulsating", "rotating", "square"),
         lambda x, k: f"must be pulsating, rotating or square, got {x.d.shape!r}"),
    _own_range("quad", lambda v: 0.0 <= v < 1.0, "must be in [0, 1)"),
    _own_range("load", _positive, "the rated load must be a force > 0 N (the certificate's loads are "
               "fractions of it)"),
    _own_range("travel", _positive, "must be a stroke > 0 m"),
    Rule(1, ("travel",), lambda x: x.d.travel is None or x.d.travel <= KINDS["stroke"].high,
         lambda x, k: f"{x.d.travel * 1e3:g} mm is beyond the strokes of linear-motor axes: at most "
                      f"{KINDS['stroke'].high * 1e3:g} mm"),
    Rule(1, ("v_max",), lambda x: not x.d.v_max * SPEED_CAP_MARGIN > KINDS["speed"].high, _cap_says),
    _own_range("v_inj", _positive, "must be positive"),
    _own_range("f_inj", lambda v: math.isfinite(v) and v >= F_INJ_MIN / 8.0,
               f"must be at least {F_INJ_MIN / 8.0:g} Hz (the bandwidths of the loops follow it)"),
    Rule(1, ("motor",), lambda x: saliency_problem(x.motor) is None, lambda x, k: saliency_problem(x.motor)),
    # (2) pairs
    Rule(2, ("dead_time", "f_pwm"), lambda x: x.d.dead_time * x.d.f_pwm < DEAD_TIME_SHARE_MAX,
         _dead_time_share_says),
    Rule(2, ("quad",), lambda x: x.d.shape == "pulsating" or x.d.quad == 0.0 or not x.given("quad"),
         lambda x, k: f"{x.d.quad:g}: only with the pulsating injection (the {x.d.shape} injection has no "
                      "q-axis share): leave it out"),
    Rule(2, ("f_inj",), lambda x: x.d.shape != "square" or x.d.f_inj is None,
         lambda x, k: f"{x.show('f_inj')}: the square wave runs at f_pwm / 2 = {x.d.f_pwm / 2.0:g} Hz: leave "
                      "it out"),
    Rule(2, ("f_inj", "f_pwm"), lambda x: F_INJ_MIN / 8.0 <= x.f_inj <= x.d.f_pwm / F_INJ_PWM_DIV,
         _f_inj_says),
    Rule(2, ("travel",), lambda x: x.d.travel is None or x.d.travel >= x.motor.pole_pitch, _travel_says),
    Rule(2, ("v_inj",), _v_inj_fits, _v_inj_says),
    Rule(2, ("i_max", "load", "a_max"), lambda x: x.force_need <= drive_force_max(x.motor, x.d),
         _force_says),
    Rule(2, ("d_current", "i_max", "shape"), _d_current_holds, _d_current_says),
    Rule(2, ("i_max", "v_dc"), _bus_drives_i_max, _bus_says),
    # (3) derived quantities
    Rule(3, _injection_keys, _injection_holds, _injection_says),
    Rule(3, ("i_max", "v_dc", "v_inj"), lambda x: x.v_avail > x.motor.R_s * x.d.i_max, _bus_says),
    Rule(3, ("v_max", "v_dc"), lambda x: x.d.v_max <= x.v_bus_speed, _speed_says),
    Rule(3, _move_keys, _move_holds, _move_says),
    Rule(3, ("motor",), lambda x: bool(np.all(x.k_e > 0.0)), _error_gain_says),
)


def check_drive(motor: Motor, d: DriveData, source: str = "<tune>") -> DriveInputs:
    """Check a design's inputs against :data:`DRIVE_RULES`, in order.

    Parameters
    ----------
    motor : Motor
        The motor.
    d : DriveData
        The drive and application.
    source : str, optional
        Named in the message.

    Returns
    -------
    DriveInputs
        The inputs with what the rules derived from them.

    Raises
    ------
    linsense.errors.InputError
        The first rule broken, naming ``source``, the input (the first of the rule's keys the user
        gave, else its first), its value and its limit.
    """
    x = DriveInputs(motor, d)
    for i, rule in enumerate(DRIVE_RULES):
        if not rule.holds(x):
            keys = rule.keys(x) if callable(rule.keys) else rule.keys
            key = next((k for k in keys if x.given(k)), keys[0])
            hint = _slip(x, key, DRIVE_RULES[:i + 1])
            raise InputError(source, key, rule.says(x, key) + (f"; {hint}" if hint else ""))
    return x


#: the kind of quantity of each drive input (:data:`linsense.plausible.KINDS`), for the slip of unit
#: a refusal suggests; ``travel`` is typed in mm (``--travel``), as its messages show it
_KIND = {"v_dc": ("voltage", None), "f_pwm": ("pwm_frequency", None), "dead_time": ("dead_time", None),
         "i_max": ("current", None), "v_max": ("speed", None), "travel": ("stroke", "mm"),
         "v_inj": ("voltage", None), "f_inj": ("injection_frequency", None), "quad": ("share", None)}


def _slip(x: DriveInputs, key: str, rules: tuple[Rule, ...]) -> str:
    """The slip of unit of drive input ``key`` under which ``rules`` (those up to the one it broke)
    hold: ``"did you type us? (0.8 us is 8e-07 s)"``, or ``""``."""
    if key not in _KIND or not isinstance(getattr(x.d, key), float | int):
        return ""
    kind, unit = _KIND[key]
    to_si = KINDS[kind].sizes()[unit] if unit else 1.0
    if KINDS[kind].holds(getattr(x.d, key)):  # (a plausible value, SI in d: its unit is not the doubt;
        return ""                                      # "16 mV" for a 16 V injection misled)

    def ok(v: float) -> bool:
        y = DriveInputs(x.motor, dataclasses.replace(x.d, **{key: v * to_si}))
        return all(r.holds(y) for r in rules)

    return slip(kind, getattr(x.d, key) / to_si, unit, ok=ok)


def design(
    motor: Motor, drive: DriveData | None = None, source: str = "<tune>", analyse: bool = True
) -> Design:
    """Design the drive for ``motor`` (docs/tuning.md).

    Parameters
    ----------
    motor : Motor
        The motor.
    drive : DriveData or None, optional
        The drive around it (None: the defaults, the paper's drive).
    source : str, optional
        Named in messages.
    analyse : bool, optional
        Also compute the margins of the linearised model (python-control) and the tolerances.

    Returns
    -------
    Design
        The designed values; ``warnings`` lists what could not be met.

    Raises
    ------
    linsense.errors.InputError
        The first of :data:`DRIVE_RULES` the motor and drive break (:func:`check_drive`), naming
        ``source``, the input at fault, its value and its limit.
        An argument of the wrong type (``motor`` not a motor, ``drive`` not a :class:`DriveData`),
        naming it.
    """
    src = "linsense.tune.design"
    motor = as_motor(motor, src)
    if drive is not None:
        instance(drive, src, "drive", DriveData, "None or a DriveData")
    instance(source, src, "source", str, "a str (named in messages)")
    instance(analyse, src, "analyse", bool, "True or False")
    d = drive or DriveData()
    x = check_drive(motor, d, source)  # (every refusal: DRIVE_RULES, in order)
    warnings: list[str] = []
    i_hf, headroom = _injection_and_bus(motor, d, x, warnings)
    dz = _loops(motor, d, x, i_hf, headroom, warnings)
    _limits(dz, motor, d, warnings)
    _friction_ripple(dz, motor, d, x.dq[1], warnings)
    if analyse:
        _analyse(dz, motor, d, warnings)
    return dz


def _injection_and_bus(
    motor: Motor, d: DriveData, x: DriveInputs, warnings: list[str]
) -> tuple[float, float]:
    """The HF current of the injection and the speed up to which the bus leaves room beside it for the
    application's current; the dead time's, HF current's, bus's and error gain's warnings appended to
    ``warnings``."""
    f_inj, v_inj = x.f_inj, x.v_inj
    if d.v_inj is not None and x.dead_time_ratio > DEAD_TIME_RATIO_MAX:
        warnings.append(f"the given injection leaves the dead time's voltage error "
                        f"{x.dead_time_ratio:.3g} times the weakest HF error signal (the design "
                        f"refuses above {DEAD_TIME_RATIO_MAX:g}): expect the holds to fail")
    i_hf = float(
        np.mean(hf_current_amplitude(motor, np.linspace(0, 2 * np.pi, 90, endpoint=False), v_inj, f_inj))
    )
    if i_hf > d.i_max:
        warnings.append(f"the HF current ({i_hf:.2f} A) exceeds i_max ({d.i_max:g} A): lower v_inj")
    # the fundamental beside the injection, at the current the application needs at speed (its load
    # and m a_max; a step's i_max may saturate the current loop for a moment, as on any bus)
    headroom = x.speed_driven(x.v_avail)
    if headroom < d.v_max:
        warnings.append(
            f"the bus leaves room for the fundamental up to {headroom:.3g} m/s at the application's "
            f"{x.i_need:.3g} A, below v_max = {d.v_max:g} m/s"
        )
    if x.k_e.min() < 0.3:
        warnings.append(
            f"the error gain drops to {x.k_e.min():.2f} of nominal at some positions "
            "(low saliency): consider observer.gain_schedule = true"
        )
    return i_hf, headroom


def _loops(
    motor: Motor, d: DriveData, x: DriveInputs, i_hf: float, headroom: float, warnings: list[str]
) -> Design:
    """The loops' design: the current loop, demodulator, observer, speed and position loops, the
    dither and the ramp, from the injection ``x`` (:func:`check_drive`)."""
    L_d, L_q = x.dq
    f_inj, s_min, v_inj = x.f_inj, x.s_min, x.v_inj
    f_i = f_inj / RATIO_INJ_CURRENT
    kp_i, ki_i = current_gains(f_i, L_d, L_q, motor.R_s)
    f_lpf = RATIO_LPF * f_inj
    f_pll = f_lpf / RATIO_LPF_OBS
    f_v = f_pll / RATIO_OBS_SPEED
    gain = L_q / (L_q - L_d)
    f_mech = f_lpf / RATIO_LPF_MECH
    mech = d.shape == "pulsating"  # (the rotating and square injections: the PLL, not yet verified)
    slow = min(1.0, motion_signal_bandwidth(motor, i_hf, gain) / f_mech) if mech else 1.0
    if slow < MOTION_SLOW_MIN:
        warnings.append(f"the HF error signal i_hf / gain = {i_hf / abs(gain):.3g} A/rad is too weak for "
                        f"this mover: the observer would be slowed to {slow:.2g} of f_lpf / "
                        f"{RATIO_LPF_MECH:g} (design rule: {MOTION_SIGNAL_MAX:g} x the signal; "
                        f"docs/tuning.md, \"The observer\"), "
                        f"kept at {MOTION_SLOW_MIN:g}: more injection voltage (--v-inj) or saliency")
        slow = MOTION_SLOW_MIN
    f_mech, f_v = slow * f_mech, slow * f_v  # (the speed loop keeps its ratio to the observer)
    f_obs = f_mech if mech else f_pll
    kp_v, ki_v = speed_gains(f_v, motor.mass)  # (the PI's integral: the encoder modes' with load_ff)
    kp_x = 2.0 * math.pi * f_v / RATIO_SPEED_POS
    k_e = x.k_e
    dz = Design(
        f_inj=f_inj, v_inj=v_inj, quad=d.quad, i_hf=i_hf,
        current_bw=f_i, current_kp=kp_i, current_ki=ki_i,
        demod_lpf=f_lpf,
        demod_notch=2.0 * f_inj if 4.0 * f_inj < d.f_pwm else 0.0,  # (below fs / 2 only)
        demod_gain=gain,
        observer_bw=f_obs,
        observer_type="mech" if mech else "pll",
        load_ff=mech,
        observer_bw_pll=f_pll, observer_bw_mech=f_mech,
        speed_bw=f_v, speed_kp=kp_v, speed_ki=ki_v, kp_x=kp_x,
        dither_a=DITHER_CURRENT * d.i_max,
        dither_hz=DITHER_FREQ * f_inj,
        hf_delay=HF_DELAY_PERIODS / f_inj if d.shape == "pulsating" else 0.0,
        k_e_min=float(k_e.min()), k_e_max=float(k_e.max()),
        headroom_speed=headroom,
        warnings=warnings,
        dead_time_ratio=x.dead_time_ratio,
        inj_ramp_rate=v_inj / INJ_RAMP_TIME,
        s_min=s_min,
        observer_slowed=slow,
    )
    return dz


def motion_signal_bandwidth(motor: Motor, i_hf: float, gain: float) -> float:
    """The largest mechanical observer's bandwidth for the motor's mover and HF error signal
    (:data:`MOTION_SIGNAL_MAX`; docs/tuning.md, "A heavy mover on a weak signal").

    Parameters
    ----------
    motor : Motor
        The motor (its mass, pole pitch and force constant).
    i_hf : float
        The HF current's amplitude, A.
    gain : float
        The demodulator's gain ``L_q / (L_q - L_d)``: the HF error signal is ``i_hf / gain`` per rad.

    Returns
    -------
    float
        Hz: where ``m (2 pi f)^2 (tau / pi) / K_f = MOTION_SIGNAL_MAX i_hf / gain`` (inf without a
        signal's gain or a mass).
    """
    per_rad = motor.mass * motor.pole_pitch / (math.pi * motor.force_constant)  # A per rad at 1 rad/s^2
    if not (per_rad > 0.0 and math.isfinite(gain) and gain != 0.0):
        return math.inf
    return math.sqrt(MOTION_SIGNAL_MAX * i_hf / (abs(gain) * per_rad)) / (2.0 * math.pi)


def _analyse(dz: Design, motor: Motor, d: DriveData, warnings: list[str]) -> None:
    """Fill ``dz.tolerances`` and ``dz.margins`` (the linearised model) and append to ``warnings``
    the margins below their floors and the tolerances the drive does not hold."""
    from linsense.tune.margins import TOLERANCE_ERR_DEG, TOLERANCES, tolerance_costs

    # (the model of the tolerances is the pulsating/elliptical injection's; the other shapes have
    # their own tables: not predicted, the certificate measures them)
    dz.tolerances = tolerance_costs(motor, dz.f_inj, dz.quad) if d.shape == "pulsating" else {}
    k_lo = min([t["k_lo"] for t in dz.tolerances.values()] + [1.0])
    k_hi = max([t["k_hi"] for t in dz.tolerances.values()] + [1.0])
    dz.margins = margins(dz, motor, d, k_lo, k_hi)
    for name, m in dz.margins.items():
        if "unscheduled" in name:
            continue  # informative: the design schedules the gain
        pm_min, gm_min = MARGIN_FLOORS["observer" if name.startswith("observer") else "motion"]
        pm, gm = m["pm_deg"], m["gm_up_db"]
        if pm is None or pm < pm_min or (gm is not None and gm < gm_min):
            warnings.append(f"{name}: phase margin {pm} deg, gain margin {gm} dB (below the floor "
                            f"{pm_min:g} deg / {gm_min:g} dB)")
    for name, t in dz.tolerances.items():
        if not t["error_deg"] <= TOLERANCE_ERR_DEG:
            held = (f"holds {t['error_deg']:.3g} deg off target" if math.isfinite(t["error_deg"])
                    else "has no hold near the target at some positions")
            if name.startswith("dM0"):  # (docs/tuning.md, "The end-effect tolerance")
                k_e = TOLERANCES[name][2]
                per10 = t["error_deg"] / (abs(k_e - 1.0) * 10.0)
                warnings.append(
                    f"the motor file's table costs {per10:.2g} deg per 10 % of error in the end effect (a "
                    f"motor off by {name} {held}; model, bound {TOLERANCE_ERR_DEG:g} deg; the end effect is "
                    f"{end_effect_ratio(motor):.2f} of the saliency): measure the table on the machine "
                    f"(linsense calibrate, then --table), as the certificate does")
                continue
            warnings.append(f"a motor off by {name} {held} with this drive's nominal LUT (model; bound "
                            f"{TOLERANCE_ERR_DEG:g} deg): identify or calibrate the motor")


def friction_steps(motor: Motor, f_pwm: float) -> float:
    """The viscous coefficient the controller feeds forward, N s/m.

    The motor's, up to the share of :data:`FRICTION_STEP_SHARE` ``m f_pwm`` the mechanical observer
    steps through (half of it when there is Coulomb friction too: the other half is its linear
    band's, :func:`friction_band`).

    Parameters
    ----------
    motor : Motor
        The motor.
    f_pwm : float
        The drive's rate, Hz.

    Returns
    -------
    float
        N s/m.
    """
    budget = FRICTION_STEP_SHARE * motor.mass * f_pwm
    return min(float(motor.friction.viscous), 0.5 * budget if motor.friction.coulomb > 0.0 else budget)


def observer_force_max(motor: Motor, f_pwm: float) -> float:
    """The largest load clamp of the mechanical observer the design sets, N.

    :data:`OBSERVER_FORCE_SHARE` of ``pi m / ((2 pi / tau) ts^2)``, the load estimate that moves the
    observer's position estimate half a period per PWM period (ls_observer_init's bound).

    Parameters
    ----------
    motor : Motor
        The motor.
    f_pwm : float
        The drive's rate, Hz.

    Returns
    -------
    float
        N.
    """
    return OBSERVER_FORCE_SHARE * 0.5 * motor.mass * f_pwm**2 * motor.pole_pitch


def friction_band(motor: Motor, d: DriveData, v_inj: float, f_inj: float, quad: float, L_q: float) -> float:
    """The speed below which the dither-averaged Coulomb friction is linear, m/s.

    The injection's q current ``i_q = kappa V_inj / |R_s + j w L_q|`` (``kappa`` 1 for the rotating and
    square shapes) shakes the mover at ``v_d = K_f i_q / (m w)``; averaged over it the relay
    ``F_c sign(v)`` becomes ``F_c (2/pi) asin(v / v_d)``, whose slope at 0 the linear band
    ``pi/2 v_d`` keeps. Without a dither the band is the narrowest the mechanical observer steps
    through (its friction's slope, with the viscous coefficient fed forward
    (:func:`friction_steps`), ``ts / m`` at most :data:`FRICTION_STEP_SHARE`).

    Parameters
    ----------
    motor : Motor
        The motor.
    d : DriveData
        The drive.
    v_inj, f_inj, quad : float
        The injection (V, Hz, elliptical share).
    L_q : float
        The mean q inductance, H.

    Returns
    -------
    float
        m/s.
    """
    w = 2.0 * math.pi * f_inj
    kappa = quad if d.shape == "pulsating" else 1.0
    i_q = kappa * v_inj / abs(complex(motor.R_s, w * L_q))
    kf = motor.force_constant * force_share(motor, d)  # (the d-current's reluctance force counted)
    v_d = kf * i_q / (motor.mass * w)
    slope = FRICTION_STEP_SHARE * motor.mass * d.f_pwm - friction_steps(motor, d.f_pwm)
    floor = motor.friction.coulomb / slope
    return max(0.5 * math.pi * v_d, floor)


def thrust_ripple(motor: Motor) -> dict[int, tuple[float, float]]:
    """The force constant's ripple from the PM-flux harmonics, by order: ``{n: (c, s)}``.

    A harmonic ``a cos(k theta + phi)`` of the flux (k = 6j -+ 1; triplen orders make no force) gives
    the q current's force ``K_f i_q (1 -+ k a cos((k +- 1) theta + phi))`` (the simulator's plant,
    ``ls_sim_pm_flux``); the 5th and 7th add up at order 6.

    Parameters
    ----------
    motor : Motor
        The motor.

    Returns
    -------
    dict
        Order -> (cosine share, sine share) of ``K_f``.
    """
    out: dict[int, tuple[float, float]] = {}
    for h in motor.pm_harmonics:
        k = int(h.order)
        if k % 3 == 0 or k < 2:
            continue
        n, sg = (k - 1, 1.0) if k % 3 == 1 else (k + 1, -1.0)
        c, s = out.get(n, (0.0, 0.0))
        out[n] = (c + sg * k * h.amplitude * math.cos(h.phase), s - sg * k * h.amplitude * math.sin(h.phase))
    return out


def _friction_ripple(dz: Design, motor: Motor, d: DriveData, L_q: float, warnings: list) -> None:
    """The friction and thrust ripple the controller feeds forward (docs/tuning.md, "Friction and
    thrust ripple"). Fills ``dz`` in place."""
    f = motor.friction
    dz.friction_coulomb = float(f.coulomb)
    dz.friction_viscous = friction_steps(motor, d.f_pwm)
    if dz.friction_viscous < f.viscous:  # (a light mover)
        warnings.append(
            f"the viscous friction {f.viscous:.3g} N s/m is fed forward as {dz.friction_viscous:.3g} N s/m: "
            f"the mechanical observer steps a friction slope up to {FRICTION_STEP_SHARE:g} m f_pwm "
            f"({FRICTION_STEP_SHARE * motor.mass * d.f_pwm:.3g} N s/m for {motor.mass:g} kg at "
            f"{d.f_pwm:g} Hz; ls_observer_init)")
    if f.coulomb > 0.0:
        dz.friction_band = friction_band(motor, d, dz.v_inj, dz.f_inj, dz.quad, L_q)
    ripple = thrust_ripple(motor)
    if ripple:
        n = max(ripple, key=lambda k: math.hypot(*ripple[k]))
        c, s = ripple[n]
        if abs(c) + abs(s) > RIPPLE_MAX:
            warnings.append(f"the PM-flux harmonics' thrust ripple of order {n} ({math.hypot(c, s):.3g} of "
                            f"K_f) is beyond what the drive divides out ({RIPPLE_MAX:g}): not fed forward")
        else:
            dz.ripple_order, dz.ripple_cos, dz.ripple_sin = n, c, s
        rest = [k for k in ripple if k != dz.ripple_order and math.hypot(*ripple[k]) > 0.0]
        if rest:
            warnings.append("the thrust ripple of order " + ", ".join(str(k) for k in sorted(rest))
                            + " is not fed forward (the drive divides out one order)")


def injection_frequency(f_pwm: float) -> float:
    """``f_pwm / N``: the injection frequency for a PWM frequency.

    The largest integer ``N <= RATIO_PWM_INJ`` (and ``>= 4``) that keeps the injection at
    ``F_INJ_MIN`` or above (ecce2010's 16 kHz: 1 kHz; 10 kHz: 1 kHz; 8 kHz: 1 kHz; 12 kHz: 1 kHz;
    20 kHz: 1.25 kHz).

    Parameters
    ----------
    f_pwm : float
        PWM frequency, Hz.

    Returns
    -------
    float
        Hz.
    """
    n = int(min(RATIO_PWM_INJ, max(4.0, math.floor(f_pwm / F_INJ_MIN))))
    return f_pwm / n


def saliency_min(motor: Motor, n: int = 360) -> float:
    """The lowest local saliency ratio ``(L_q - L_d)/(L_q + L_d)`` over the period.

    The weakest HF error signal, relative (docs/tuning.md, "The injection amplitude").

    Parameters
    ----------
    motor : Motor
        The motor.
    n : int, optional
        Positions over the period.

    Returns
    -------
    float
        Dimensionless.
    """
    from linsense.analysis.hf import dq_components

    L_d, L_q, _ = dq_components(motor, np.linspace(0.0, 2.0 * np.pi, n, endpoint=False))
    return float(np.min((L_q - L_d) / (L_q + L_d)))


def uncompensated_speed_factor(motor: Motor) -> float:
    """The largest ratio of the estimate's speed to the mover's without a compensation table.

    ``max(1 + de*/dtheta)`` (2.93 for ecce2010). The drive's trips and clamps act on the estimate,
    so a drive run without its table needs them this much wider.

    Parameters
    ----------
    motor : Motor
        The motor.

    Returns
    -------
    float
        At least 1.
    """
    from linsense.analysis.hf import loop_gain_factor

    th = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    return float(max(1.0, np.max(loop_gain_factor(motor, th))))


def rated_load(motor: Motor, d: DriveData) -> float:
    """The rated load: the application's, else :data:`RATED_LOAD_FRACTION` of the force at
    ``i_max`` (:func:`drive_force_max`).

    Parameters
    ----------
    motor : Motor
        The motor.
    d : DriveData
        The drive and application.

    Returns
    -------
    float
        N.
    """
    return d.load if d.load is not None else RATED_LOAD_FRACTION * drive_force_max(motor, d)


def injecting_d_current(d: DriveData) -> float:
    """The d-current while the drive injects: ``d.d_current`` given, else the design's
    (:func:`~linsense.tune.injection.injection_d_current` of ``i_max`` and the shape).

    Parameters
    ----------
    d : DriveData
        The drive.

    Returns
    -------
    float
        A.
    """
    return d.d_current if d.d_current is not None else injection_d_current(d.i_max, d.shape)


def force_share(motor: Motor, d: DriveData) -> float:
    """The force constant's share with the injection's d-current (docs/tuning.md, "The force at
    i_max"): 1 with the pulsating injection, below 1 with the rotating vector and the square wave on
    a motor whose ``L_q`` exceeds ``L_d``.

    Parameters
    ----------
    motor : Motor
        The motor (its mean inductances and magnets' flux, as the controller's model).
    d : DriveData
        The drive (:func:`injecting_d_current`).

    Returns
    -------
    float
        ``1 + (L_d - L_q) i_d / psi_pm``
        (:func:`~linsense.tune.injection.d_current_force_share`), -.
    """
    L_d, L_q = mean_dq(motor)
    return d_current_force_share(L_d, L_q, motor.psi_pm, injecting_d_current(d))


def drive_force_constant(motor: Motor, d: DriveData) -> float:
    """The force per ampere of q-current in every mode: ``K_f``, times :func:`force_share` where
    that is below 1 (the firmware's force constant while it injects; the modes without the
    injection have ``K_f``).

    Parameters
    ----------
    motor : Motor
        The motor (its ``K_f``, mean inductances and magnets' flux).
    d : DriveData
        The drive (its shape, ``i_max`` and d-current: :func:`injecting_d_current`).

    Returns
    -------
    float
        N/A.
    """
    return deliverable_force(motor.force_constant, 1.0, force_share(motor, d))


def drive_force_max(motor: Motor, d: DriveData) -> float:
    """The force the drive makes at ``i_max`` in every mode, :func:`drive_force_constant` ``i_max``.

    Parameters
    ----------
    motor, d : Motor, DriveData
        As :func:`drive_force_constant`.

    Returns
    -------
    float
        N.
    """
    return deliverable_force(motor.force_constant, d.i_max, force_share(motor, d))


def force_max_text(motor: Motor, d: DriveData, i_max_key: str = "i_max") -> str:
    """How a message names :func:`drive_force_max`: ``K_f i_max``, with the d-current's share when
    it counts.

    Parameters
    ----------
    motor, d : Motor, DriveData
        The motor and the drive whose force it names.
    i_max_key : str
        How the current limit is named (a scenario's message: ``"controller.i_max"``).

    Returns
    -------
    str
        ``"K_f i_max"``, or with the share: ``"K_f i_max x 0.778 (the share ...)"``.
    """
    share = force_share(motor, d)
    if share >= 1.0:
        return f"K_f {i_max_key}"
    what = ("" if d.d_current is not None else f"{INJECTION_D_FRACTION:g} {i_max_key} = ") + \
        f"{injecting_d_current(d):.3g} A"
    return (f"K_f {i_max_key} x {share:.3g} (the share of the force constant that the {d.shape} "
            f"injection's d-current {what} leaves with L_q > L_d)")


def bus_speed(motor: Motor, v_dc: float, i_q: float, i_d: float = 0.0) -> float:
    """The speed beyond which the bus cannot drive ``i_q`` (and ``i_d``): where the steady-state
    voltage (:func:`fundamental_speed`) reaches the linear range ``V_dc / sqrt(3)`` (no voltage left
    for an injection).

    Parameters
    ----------
    motor : Motor
        The motor.
    v_dc : float
        Bus voltage, V.
    i_q : float
        The q current, A.
    i_d : float, optional
        The d current, A (a d-current the drive keeps: the rotating vector's, the square wave's).

    Returns
    -------
    float
        m/s (0 where ``R_s |i|`` alone takes the range).
    """
    L_d, L_q = mean_dq(motor)
    return fundamental_speed(motor, v_dc / math.sqrt(3.0), i_q, L_q, i_d=i_d, L_d=L_d)


def _fundamental_voltage(motor: Motor, v: float, i_q: float, L_q: float, i_d: float = 0.0,
                         L_d: float = 0.0) -> float:
    """The steady-state voltage amplitude (V) that drives ``i_d``, ``i_q`` at the speed ``v`` (m/s):
    :func:`fundamental_speed`'s ``|(v_d, v_q)|``, its inverse."""
    w = 2.0 * math.pi * v / motor.pole_pitch
    return math.hypot(motor.R_s * i_d - w * L_q * i_q, motor.R_s * i_q + w * (L_d * i_d + motor.psi_pm))


def fundamental_speed(motor: Motor, v_avail: float, i_q: float, L_q: float, i_d: float = 0.0,
                      L_d: float = 0.0) -> float:
    """The speed at which the steady-state voltage of the currents reaches ``v_avail``: up to it the
    voltage drives them (the bus's linear range, or what the injection leaves of it).

    The voltage in the rotor frame (docs/theory.md, the machine's equations, at constant current):
    ``v_d = R_s i_d - w L_q i_q`` and ``v_q = R_s i_q + w (L_d i_d + psi_pm)``. The back-EMF and
    ``R_s i_q`` lie on the same axis and add; ``w L_q i_q`` is normal to them. The speed solves
    ``v_d^2 + v_q^2 = v_avail^2``, a quadratic in ``w``.

    Parameters
    ----------
    motor : Motor
        The motor.
    v_avail : float
        The voltage amplitude available, V.
    i_q : float
        The q current, A (> 0 the motoring bound, the callers' |i_q|; < 0 regenerating, a higher speed).
    L_q : float
        The mean q inductance, H.
    i_d : float, optional
        The d current, A.
    L_d : float, optional
        The mean d inductance, H (used with ``i_d``).

    Returns
    -------
    float
        m/s (0 where ``R_s |i|`` alone takes ``v_avail``; inf where no speed brings the voltage to it).
    """
    w_per_v = 2.0 * math.pi / motor.pole_pitch  # electrical rad/s per m/s
    # (scaled by the largest voltage: no square overflows with a_max = 1e300, whose current is huge)
    k = max(abs(v_avail), motor.R_s * math.hypot(i_d, i_q), 1e-30)
    a, c = motor.R_s * i_d / k, motor.R_s * i_q / k  # v_d, v_q at standstill
    b, e = -L_q * i_q / k, (L_d * i_d + motor.psi_pm) / k  # their change per rad/s
    q2, q1, q0 = b * b + e * e, a * b + c * e, a * a + c * c - (v_avail / k) ** 2
    if q0 >= 0.0:
        return 0.0
    if q2 <= 0.0:
        return math.inf
    return (-q1 + math.sqrt(q1 * q1 - q2 * q0)) / q2 / w_per_v


def _limits(dz: Design, motor: Motor, d: DriveData, warnings: list) -> None:
    """The speed cap, the trips and the observer's clamp with their margins over the application
    (docs/tuning.md, "The limits"); the rated load. Fills ``dz`` in place."""
    w_per_v = 2.0 * math.pi / motor.pole_pitch  # electrical rad/s per m/s
    f_max, kfi = drive_force_max(motor, d), force_max_text(motor, d)
    dz.force_i_max, dz.force_i_max_why = f_max, kfi
    dz.force_i_max_share = min(1.0, force_share(motor, d))
    dz.load = rated_load(motor, d)
    dz.force_max = min(f_max, observer_force_max(motor, d.f_pwm))
    if dz.force_max < f_max:  # (a light mover)
        warnings.append(
            f"the observer's load clamp is {dz.force_max:.3g} N, below {kfi} = {f_max:.3g} N: a larger "
            f"load estimate would move the estimate of this {motor.mass:g} kg mover more than "
            f"{OBSERVER_FORCE_SHARE / 2:g} period per PWM period (ls_observer_init)")
    need = dz.load + motor.mass * d.a_max  # (within the force at i_max: DRIVE_RULES)
    if need > FORCE_MARGIN * f_max:
        warnings.append(
            f"the application needs {need:.3g} N (load {dz.load:.3g} N + m a_max "
            f"{motor.mass * d.a_max:.3g} N), over {FORCE_MARGIN:g} of {kfi} = {f_max:.3g} N: "
            "raise i_max or lower a_max / the load")
    dz.v_cap = SPEED_CAP_MARGIN * d.v_max
    dz.a_step = min(dz.v_cap * 2.0 * math.pi * dz.speed_bw / STEP_ACCEL_DIV,
                    STEP_FORCE_SHARE * f_max / motor.mass)
    dz.omega_trip = OVERSPEED_MARGIN * dz.v_cap * w_per_v
    dz.omega_obs = OBSERVER_SPEED_MARGIN * dz.omega_trip
    th = np.linspace(0.0, 2.0 * np.pi, 90, endpoint=False)
    i_hf_peak = float(np.max(hf_current_amplitude(motor, th, dz.v_inj, dz.f_inj))) * math.hypot(1.0, dz.quad)
    dz.i_trip = CURRENT_TRIP_MARGIN * (d.i_max + i_hf_peak)
    if dz.v_cap > dz.headroom_speed:
        warnings.append(f"the speed cap {dz.v_cap:.3g} m/s ({SPEED_CAP_MARGIN:g} v_max) is beyond the "
                        f"{dz.headroom_speed:.3g} m/s up to which the bus drives the application's current "
                        "beside the injection")
    dz.limits = {
        "injection": _injection_text(dz, d),
        "observer": (f"the demodulator's low-pass ({dz.demod_lpf:.4g} Hz) / "
                     f"{RATIO_LPF_MECH if dz.observer_type == 'mech' else RATIO_LPF_OBS:g}"
                     if dz.observer_slowed >= 1.0 else
                     f"the heavy mover on a weak HF signal: the q-current the motion asks per rad at "
                     f"the observer's bandwidth, m w^2 (tau / pi) / K_f, at most {MOTION_SIGNAL_MAX:g} "
                     f"times the HF error signal's i_hf / gain = {dz.i_hf / abs(dz.demod_gain):.3g} A/rad "
                     f"(x {dz.observer_slowed:.3g} of the low-pass / {RATIO_LPF_MECH:g})"),
        "speed loop": f"the low-pass / {RATIO_LPF_OBS * RATIO_OBS_SPEED:g}" + (
            "" if dz.observer_slowed >= 1.0 else f", x {dz.observer_slowed:.3g} with the observer"),
        "position loop": f"the speed loop's w / {RATIO_SPEED_POS:g}",
        "steps": (f"a move at the speed cap and {dz.a_step:.3g} m/s^2: "
                  + (f"the speed loop's w v_cap / {STEP_ACCEL_DIV:g}"
                     if dz.a_step < STEP_FORCE_SHARE * f_max / motor.mass else
                     f"{STEP_FORCE_SHARE:g} {kfi} / m")),
    }


def startup_lock_gain(observer_type: str, f_obs: float, f_lpf: float) -> float:
    """The start-up's gain on the demodulated error while the HF observer locks at zero current.

    ``startup.lock_gain``: without a load estimate the mechanical observer's gains (3 w, 3 w^2) act
    as a PLL's; times ``2 w_pll / (3 w)`` its k1 is the PLL's at ``f_lpf / RATIO_LPF_OBS`` (k2 then
    0.75 of it: damping 1.15), so it slews onto the axis as the PLL does (measured, 200 starts on
    ecce2010 without load or friction: 0.096 mm of motion while detecting, 0.099 with the PLL;
    0.121 without the gain, 0.111 with k2 matched instead); 1 with the PLL.

    Parameters
    ----------
    observer_type : str
        ``"mech"`` or ``"pll"``.
    f_obs : float
        The observer's bandwidth, Hz.
    f_lpf : float
        The demodulator's low-pass corner, Hz.

    Returns
    -------
    float
        Dimensionless.
    """
    if observer_type != "mech":
        return 1.0
    return 2.0 * (f_lpf / RATIO_LPF_OBS) / (3.0 * f_obs)


def _observer_gains(f_bw: float, mech: bool = False) -> tuple[float, ...]:
    """k1, k2 of the PLL with both poles at -2 pi f, or k1, k2, k3 of the mechanical observer with its
    three: the C library's rule (ls_observer_gains), as the drive computes them."""
    from linsense.ctrl import observer_gains

    return observer_gains(f_bw, mech)


def loops(*, mass: float, kp_x: float, speed_kp: float, speed_ki: float, observer_k: tuple[float, ...],
          current_bw: float, demod_lpf: float, f_inj: float, f_pwm: float, k_e: float, g: float = 1.0,
          load_ff: bool = False):
    """The observer loop and the motion loop (python-control transfer functions; docs/tuning.md).

    The observer loop ``k_e H_lpf(s) e^{-s T_d} (k1 s + k2)/s^2``: the demodulator's low-pass, the HF
    band-pass's envelope delay ``Q/(pi f_inj)`` (Q = 2) and 1.5 sampling periods (Pade, 2nd order),
    with the local error gain ``k_e`` (1: the gain schedule's nominal) and the PLL's gains
    ``observer_k = (k1, k2)``. The motion loop broken at
    the force reference, ``g C_v(s) (kp_x T(s) + S_v(s)) P(s) C_i(s)``: mass, current loop, speed
    PI and the observer's transfers from the true position to its position and speed estimates;
    ``g`` scales what the observer reports (``1 + de*/dtheta`` of an uncompensated observer,
    ../shared/brief.md section 4 in the notes; 1 with the LUT).

    The mechanical observer (``observer_k = (k1, k2, k3)``; docs/tuning.md, "The observer"): the
    observer loop ``k_e H_lpf e^{-s T_d} G_o``, ``G_o = k1/s + k2/s^2 + k3/s^3``; its model takes the
    force reference u (the estimate of the load aside), so its error sees only what the model
    misses, the current loop: ``E = eps/u = k_e H (C_i - 1) / (m s^2 (1 + k_e H G_o))``, and the
    motion loop broken at u is ``C_v (kp_x x_est + v_est)/u + load_ff k3 m E / s`` with
    ``x_est/u = 1/(m s^2) + G_o E`` and ``v_est/u = 1/(m s) + (k2/s + k3/s^2) E``.

    Parameters
    ----------
    mass : float
        Moving mass, kg.
    kp_x : float
        Position gain, 1/s.
    speed_kp : float
        Speed PI proportional gain, N s/m.
    speed_ki : float
        Speed PI integral gain, N/m.
    observer_k : tuple of float
        ``(k1, k2)`` of the PLL (1/s, 1/s^2) or ``(k1, k2, k3)`` of the mechanical observer.
    current_bw : float
        Current-loop bandwidth, Hz.
    demod_lpf : float
        Demodulator low-pass corner, Hz.
    f_inj : float
        Injection frequency, Hz.
    f_pwm : float
        PWM frequency, Hz.
    k_e : float
        Local error gain, relative.
    g : float, optional
        Factor on what the observer reports.
    load_ff : bool, optional
        The mechanical observer's load estimate fed forward.

    Returns
    -------
    observer_loop : control.TransferFunction
        The observer loop.
    motion_loop : control.TransferFunction
        The motion loop broken at the force reference.
    """
    import control as ct

    s = ct.tf("s")
    w_l = 2.0 * math.pi * demod_lpf
    h_lpf = w_l**2 / (s**2 + math.sqrt(2.0) * w_l * s + w_l**2)
    t_d = 2.0 / (math.pi * f_inj) + 1.5 / f_pwm
    num, den = ct.pade(t_d, 2)
    kh = k_e * h_lpf * ct.tf(num, den)
    w_i = 2.0 * math.pi * current_bw
    if len(observer_k) == 3:
        return _mech_loops(kh, observer_k, w_i, mass=mass, kp_x=kp_x, speed_kp=speed_kp, speed_ki=speed_ki,
                           g=g, load_ff=load_ff)
    k1, k2 = observer_k
    g_o = (k1 * s + k2) / s**2
    t_pos = ct.minreal(kh * g_o / (1 + kh * g_o), verbose=False)
    s_v = ct.minreal((k2 / s) * kh / (1 + kh * g_o), verbose=False)
    c_v = speed_kp + speed_ki / s
    l_mot = ct.minreal(g * c_v * (kp_x * t_pos + s_v) / (mass * s**2) * w_i / (s + w_i), verbose=False)
    return kh * g_o, l_mot


def _mech_loops(kh, observer_k: tuple[float, ...], w_i: float, *, mass: float, kp_x: float, speed_kp: float,
                speed_ki: float, g: float, load_ff: bool):
    """:func:`loops` of the mechanical observer ``observer_k = (k1, k2, k3)``: ``kh`` the error
    path (gain, low-pass, delay), ``w_i`` the current loop's bandwidth, rad/s."""
    import control as ct

    s = ct.tf("s")
    k1, k2, k3 = observer_k
    g_o = k1 / s + k2 / s**2 + k3 / s**3
    c_i = w_i / (s + w_i)
    e_u = ct.minreal(kh * (c_i - 1) / (mass * s**2 * (1 + kh * g_o)), verbose=False)
    x_u = 1 / (mass * s**2) + g_o * e_u
    v_u = 1 / (mass * s) + (k2 / s + k3 / s**2) * e_u
    c_v = speed_kp + speed_ki / s if speed_ki else speed_kp
    l_mot = g * c_v * (kp_x * x_u + v_u)
    if load_ff:
        l_mot = l_mot + k3 * mass / s * e_u
    return kh * g_o, ct.minreal(l_mot, verbose=False)


def margins(dz: Design, motor: Motor, drive: DriveData, k_lo: float = 1.0, k_hi: float = 1.0) -> dict:
    """Gain and phase margins of the observer loop and of the motion loop (:func:`loops`), with the
    demodulator's gain schedule that makes the local error gain 1 everywhere for the nominal motor
    (the design's), at the lowest and highest local gain the tolerances leave (``k_lo``, ``k_hi``:
    :func:`linsense.tune.margins.tolerance_costs`), and without the schedule at its lowest and
    highest (informative).

    Parameters
    ----------
    dz : Design
        The design.
    motor : Motor
        The motor.
    drive : DriveData
        The drive.
    k_lo, k_hi : float, optional
        Lowest and highest local error gain the tolerances leave.

    Returns
    -------
    dict
        ``"observer loop (<case>, k_e = <k>)"`` and ``"motion loop (...)"`` to
        :func:`loop_margins`' dict.
    """
    out = {}
    cases = (
        ("tolerances, lowest", k_lo),
        ("scheduled", 1.0),
        ("tolerances, highest", k_hi),
        ("unscheduled min", dz.k_e_min),
        ("unscheduled max", dz.k_e_max),
    )
    for label, k in cases:
        # (with the load estimate fed forward the sensorless step holds the PI's integrator at 0)
        ki = 0.0 if dz.load_ff else dz.speed_ki
        l_obs, l_mot = loops(mass=motor.mass, kp_x=dz.kp_x, speed_kp=dz.speed_kp, speed_ki=ki,
                             observer_k=_observer_gains(dz.observer_bw, dz.observer_type == "mech"),
                             current_bw=dz.current_bw, demod_lpf=dz.demod_lpf,
                             f_inj=dz.f_inj, f_pwm=drive.f_pwm, k_e=k, load_ff=dz.load_ff)
        out[f"observer loop ({label}, k_e = {k:.2f})"] = loop_margins(l_obs)
        out[f"motion loop ({label}, k_e = {k:.2f})"] = loop_margins(l_mot)
    return out


def loop_margins(loop, f_lo: float = 0.01, f_hi: float = 5000.0) -> dict:
    """Phase margin at the (highest) gain crossover, and the gain margins above it (upward: how much
    more gain makes it unstable) and below it (downward, for conditionally stable loops such as a
    double integrator under a PI: how much less gain does), from the frequency response.

    Parameters
    ----------
    loop : callable
        The loop transfer function, evaluated at ``1j w`` (rad/s).
    f_lo, f_hi : float, optional
        Frequency range of the response, Hz.

    Returns
    -------
    dict
        ``pm_deg``, ``gm_up_db``, ``gm_down_db``, ``crossover_hz`` (None where there is none).
    """
    w = 2.0 * np.pi * np.logspace(np.log10(f_lo), np.log10(f_hi), 6000)
    resp = loop(1j * w)
    mag = np.abs(resp)
    ph = np.unwrap(np.angle(resp))
    above = np.flatnonzero((mag[:-1] >= 1.0) & (mag[1:] < 1.0))
    if above.size == 0:
        return {"pm_deg": None, "gm_up_db": None, "gm_down_db": None, "crossover_hz": None}
    kc = above[-1]
    pm = (math.degrees(ph[kc]) + 180.0) % 360.0
    pm = pm - 360.0 if pm > 180.0 else pm
    # phase crossings of -180 (mod 360)
    x = (np.degrees(ph) + 180.0) / 360.0
    cross = np.flatnonzero(np.floor(x[:-1]) != np.floor(x[1:]))
    up = [20 * math.log10(1.0 / mag[i]) for i in cross if i > kc]
    down = [20 * math.log10(mag[i]) for i in cross if i < kc and mag[i] > 1.0]
    return {
        "pm_deg": round(pm, 1),
        "gm_up_db": round(min(up), 2) if up else None,
        "gm_down_db": round(min(down), 2) if down else None,
        "crossover_hz": round(float(w[kc]) / (2 * math.pi), 2),
    }

"""Design of the start-up pulses (``LS_MODE_STARTUP``, ``ls_startup_cfg``) from
the motor's saturation data.

The polarity signal of a d-axis pulse pair is the difference of the current changes that the same
volt-seconds drive along and against the magnets' flux. With the saturation model of the
simulator (:mod:`linsense.model.saturation`: incremental ``L_d(i_d) = L_d0 k(i_d)``,
``k = f(i_d + i_m) / f(i_m)``, ``f(u) = 1 / (1 + (u / a)^2)``, ``a`` from the small-pulse polarity
``(L_d(-I) - L_d(+I)) / L_d / I``, e.g. ``linsense fea --polarity``), the pulse is integrated,
``L_d0 k(i) di/dt = V - R_s i``, for ``+V`` and ``-V``:

* amplitude: 90 % of the bus's linear range ``V_dc / sqrt(3)`` (the fastest rise: the shortest
  pulse, the least force time);
* length: the shortest whole number of PWM periods whose current reaches ``1.1 i_max`` (the
  signal grows with the square of the current, the force impulse with the current);
* pairs: the current-sensor noise (rms per phase, plus the ADC's quantisation) gives the standard
  deviation of the decision, ``2 sigma / sqrt(pairs)`` (each pulse is measured as the change of
  one sample to another); the pairs make the expected signal where it is smallest (at the largest
  ``L_d`` over the period) ``Z_SIGMA`` of them, and ``i_min`` is ``I_MIN_SIGMA`` of them: a start
  fails (undecided, outputs off) with a probability of 3e-5 (3.5 sigma), decides wrong below 1e-9,
  and a motor without the signal is refused in 99 % of starts instead of decided at random;
* rests: ``4 L/R`` of zero voltage (the current decays; each pulse is measured from its own start);
* the force: an axis error ``e`` and the end-effect's cross-coupling ``L_dq / L_q`` turn part of the
  pulse into q-current, whose force alternates with the pulses' signs and nearly cancels; the
  reluctance force ``(3/4) (2 pi / tau) dL_d/dtheta i_d^2`` has one sign: the predicted motion is
  their drift over the pulses.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from linsense.analysis.hf import dq_components
from linsense.errors import InputError
from linsense.model.motor import Motor
from linsense.model.saturation import d_factor, i_sat_d_of
from linsense.scenario.keys import checked

Z_SIGMA = 6.0  # expected signal (at the largest L_d) over its standard deviation
I_MIN_SIGMA = 2.5  # i_min in standard deviations
PULSE_CURRENT = 1.1  # of i_max
PULSE_BUS = 0.9  # of V_dc / sqrt(3)
REST_TAU = 4.0  # rests in L_d / R_s
PAIRS_MAX = 64
LOCK_OBS = 2.8  # t_lock = LOCK_OBS / f_obs (2.8 / 40 Hz = 70 ms: the lock settled in the simulator)
ERR_LOCK = 0.2  # rad
LOCK_ACCURACY = math.radians(2.0)  # rad, axis error assumed during the pulses
MOTION_BAR_MM = 0.1  # mm, the motion while detecting that the design warns beyond


@dataclass
class StartupDesign:
    """The designed ``ls_startup_cfg`` (SI) and what the model predicts (docs/firmware.md).

    Attributes
    ----------
    polarity : float
        The saturation data used, 1/A.
    v_pulse : float
        Pulse amplitude, V.
    t_pulse : float
        Pulse length, s.
    t_rest : float
        Zero voltage before each pulse, s.
    pairs : int
        (+, -) pulse pairs.
    i_min : float
        Smallest ``|i_diff|`` accepted as a decision, A.
    t_lock : float
        HF lock before the pulses, s.
    err_lock : float
        The lock is accepted within it, rad.
    t_quiet : float
        Injection ramp-down before the pulses, s.
    t_settle : float
        HF relock after the pulses, s.
    i_peak : float
        Current at the end of a +V pulse, A.
    signal : float
        Expected ``|di_+| - |di_-|``, A.
    sigma : float
        Standard deviation of the decision (i_diff), A.
    detect_s : float
        The whole sequence (shortest lock), s.
    motion_mm : float
        Predicted drift over the pulses, mm.
    warnings : list of str
        What the design could not meet.
    """

    polarity: float  # 1/A, the saturation data used
    v_pulse: float  # V
    t_pulse: float  # s
    t_rest: float  # s
    pairs: int
    i_min: float  # A
    t_lock: float  # s
    err_lock: float  # rad
    t_quiet: float  # s
    t_settle: float  # s
    i_peak: float  # A, current at the end of a +V pulse
    signal: float  # A, expected |di_+| - |di_-|
    sigma: float  # A, standard deviation of the decision (i_diff)
    detect_s: float  # s, the whole sequence (shortest lock)
    motion_mm: float  # mm, predicted drift over the pulses
    warnings: list = field(default_factory=list)

    def as_dict(self) -> dict:
        """The design as a plain dict (``dataclasses.asdict``).

        Returns
        -------
        dict
            Field name to value.
        """
        return asdict(self)

    def scenario_keys(self, digits: int | None = 6) -> dict:
        """The scenario's ``[startup]`` section.

        Parameters
        ----------
        digits : int or None, optional
            Significant digits of the reals (None: unrounded).

        Returns
        -------
        dict
            Key to value (``err_lock_deg`` in degrees).
        """
        r = (lambda v: v) if digits is None else (lambda v: float(f"{v:.{digits}g}"))  # noqa: E731
        return dict(checked({"t_lock": r(self.t_lock), "err_lock_deg": r(math.degrees(self.err_lock)),
                             "t_quiet": r(self.t_quiet), "v_pulse": r(self.v_pulse),
                             "t_pulse": r(self.t_pulse), "t_rest": r(self.t_rest), "pairs": int(self.pairs),
                             "i_min": r(self.i_min), "t_settle": r(self.t_settle)}, "startup"))

    def lines(self) -> list[str]:
        """The report's lines on the start-up.

        Returns
        -------
        list of str
            One line: pulses, pairs, signal against noise, lock, detection time and drift.
        """
        return [
            f"  start-up       pulses {self.v_pulse:.3g} V x {self.t_pulse * 1e3:.3g} ms "
            f"({self.i_peak:.2f} A), {self.pairs} pairs, rests {self.t_rest * 1e3:.3g} ms; signal "
            f"{self.signal * 1e3:.3g} mA against {self.sigma * 1e3:.3g} mA rms (polarity "
            f"{self.polarity * 100:.3g} %/A), i_min {self.i_min * 1e3:.3g} mA; lock "
            f"{self.t_lock * 1e3:.3g} ms, detection {self.detect_s * 1e3:.0f} ms, drift from the pulses "
            f"~{self.motion_mm:.3g} mm",
        ]


def pulse_currents(L_d0: float, R_s: float, i_m: float, a: float, v: float, t: float,
                   n_sub: int = 400) -> tuple[float, float]:
    """Current change of a ``+v`` and a ``-v`` pulse from zero current (RK2 on the saturated d-axis).

    Parameters
    ----------
    L_d0 : float
        Unsaturated d inductance, H.
    R_s : float
        Phase resistance, ohm.
    i_m : float
        Magnet current, A.
    a : float
        d saturation current (:func:`linsense.model.saturation.i_sat_d_of`), A.
    v : float
        Pulse amplitude, V.
    t : float
        Pulse length, s.
    n_sub : int, optional
        Integration steps.

    Returns
    -------
    di_plus : float
        A.
    di_minus : float
        A (negative).
    """
    def di(x: float, vs: float) -> float:
        return (vs - R_s * x) / (L_d0 * float(d_factor(x, i_m, a)))

    out = []
    for vs in (v, -v):
        i, h = 0.0, t / n_sub
        for _ in range(n_sub):
            i += h * di(i + 0.5 * h * di(i, vs), vs)
        out.append(i)
    return out[0], out[1]


def design_startup(motor: Motor, *, v_dc: float, f_pwm: float, i_max: float, observer_bw: float,
                   v_inj: float, polarity: float | None = None, current_noise: float = 0.01,
                   adc_bits: int = 12, adc_range: float = 10.0, ramp_rate: float | None = None,
                   i_trip: float | None = None, source: str = "<tune>") -> StartupDesign | None:
    """The start-up for ``motor``, or None without saturation data.

    None when ``polarity`` is None and the motor file has no ``[saturation] polarity``.

    Parameters
    ----------
    motor : Motor
        The motor.
    v_dc : float
        DC bus, V.
    f_pwm : float
        PWM frequency, Hz.
    i_max : float
        Current-reference limit, A.
    observer_bw : float
        Observer bandwidth, Hz.
    v_inj : float
        Injection amplitude, V.
    polarity : float or None, optional
        Polarity signal, 1/A (None: the motor's saturation data).
    current_noise : float, optional
        Current-sensor noise, A rms.
    adc_bits : int, optional
        ADC resolution, bits (0: none).
    adc_range : float, optional
        ADC range, +- A.
    ramp_rate : float or None, optional
        The injection's ramp, V/s (None: the C library's default).
    i_trip : float or None, optional
        The over-current protection's limit, A (None: the C library's default).
    source : str, optional
        Named in messages.

    Returns
    -------
    StartupDesign or None
        The design.

    Raises
    ------
    linsense.errors.InputError
        A polarity or noise out of range.
    """
    from linsense.ctrl import drive_default_cfg

    c_def = drive_default_cfg()
    ramp_rate = float(c_def.inject.ramp_rate) if ramp_rate is None else ramp_rate
    i_trip = float(c_def.prot.i_max) if i_trip is None else i_trip
    polarity = _polarity(motor, polarity, current_noise, source)
    if polarity is None:
        return None
    warnings: list[str] = []
    th = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    L_d, L_q, L_dq = dq_components(motor, th)
    L_d0 = float(np.mean(L_d))
    i_m, a = _saturation_currents(motor, polarity, L_d0, source)
    ts, v = 1.0 / f_pwm, PULSE_BUS * v_dc / math.sqrt(3.0)  # (v: the pulses' voltage)
    n, dp = _pulse_steps(L_d0, motor.R_s, i_m, a, v, ts, PULSE_CURRENT * i_max, warnings)
    # the signal where it is smallest: at the largest L_d over the period (the least current)
    sp, sm = pulse_currents(float(np.max(L_d)), motor.R_s, i_m, a, v, n * ts)
    signal = sp + sm  # (sm < 0)
    pairs, sigma = _pulse_pairs(signal, current_noise, adc_bits, adc_range, warnings)
    i_min = I_MIN_SIGMA * sigma
    n_rest = max(3, math.ceil(REST_TAU * L_d0 / motor.R_s / ts))
    t_pulse, t_rest = n * ts, n_rest * ts
    if dp >= 0.9 * i_trip:
        warnings.append(f"the pulses reach {dp:.2f} A, within 10 % of the over-current trip at "
                        f"{i_trip:.2f} A")
    t_lock, t_quiet, t_settle, t_pulses = _detect_times(v_inj / ramp_rate, observer_bw, pairs, t_pulse,
                                                        t_rest)
    motion = _pulse_motion(motor, th, (L_d, L_q, L_dq), dp, 2 * pairs, (t_pulse, t_rest, t_pulses), warnings)
    return StartupDesign(polarity=polarity, v_pulse=v, t_pulse=t_pulse, t_rest=t_rest, pairs=int(pairs),
                         i_min=i_min, t_lock=t_lock, err_lock=ERR_LOCK, t_quiet=t_quiet, t_settle=t_settle,
                         i_peak=dp, signal=signal, sigma=sigma,
                         detect_s=t_lock + t_quiet + t_pulses + t_settle, motion_mm=motion * 1e3,
                         warnings=warnings)


def _polarity(motor: Motor, polarity: float | None, current_noise: float, source: str) -> float | None:
    """The polarity signal, 1/A: ``polarity``, else the motor's saturation data, else None;
    refused out of range, as a negative current noise is."""
    if polarity is None and motor.saturation is not None and motor.saturation.polarity > 0:
        polarity = motor.saturation.polarity
    if polarity is None:
        return None
    if not (math.isfinite(polarity) and polarity > 0):
        raise InputError(source, "polarity", f"must be a positive number (1/A), got {polarity!r}")
    if not (math.isfinite(current_noise) and current_noise >= 0):
        raise InputError(source, "current_noise", f"must be >= 0 A, got {current_noise!r}")
    return polarity


def _saturation_currents(motor: Motor, polarity: float, L_d0: float, source: str) -> tuple[float, float]:
    """The magnet's equivalent d current and the saturation current (:func:`i_sat_d_of`) the
    polarity signal says, A; a polarity no saturation explains refused."""
    sat = motor.saturation
    i_m = sat.magnet_current if sat is not None and sat.magnet_current is not None else motor.psi_pm / L_d0
    try:
        a = i_sat_d_of(polarity, i_m)
    except ValueError as exc:
        raise InputError(source, "polarity", str(exc)) from None
    return i_m, a


def _detect_times(t_ramp: float, observer_bw: float, pairs: float, t_pulse: float,
                  t_rest: float) -> tuple[float, float, float, float]:
    """The detection's phases, s: the observer's lock, the quiet wait, the settling after the
    injection's ramp ``t_ramp``, and the pulse pairs'."""
    t_lock = LOCK_OBS / observer_bw
    t_quiet = t_ramp + 2e-3
    t_settle = t_ramp + 20e-3
    t_pulses = (2 * pairs + 1) * (t_pulse + t_rest)
    return t_lock, t_quiet, t_settle, t_pulses


def _pulse_steps(L_d0: float, R_s: float, i_m: float, a: float, v: float, ts: float, i_target: float,
                 warnings: list[str]) -> tuple[int, float]:
    """The PWM periods of one pulse (the fewest that reach ``i_target``, at most 400) and the
    positive pulse's peak current, A; a warning if the bus is too low to reach it."""
    n = 2
    while True:
        dp, dm = pulse_currents(L_d0, R_s, i_m, a, v, n * ts)
        if dp >= i_target or n >= 400:
            break
        n += 1
    if dp < i_target:
        warnings.append(f"the pulses reach {dp:.2f} A only (target {i_target:.2f} A): the bus is too low")
    return n, dp


def _pulse_pairs(signal: float, current_noise: float, adc_bits: int, adc_range: float,
                 warnings: list[str]) -> tuple[float, float]:
    """The pulse pairs that decide the polarity against the noise (at most ``PAIRS_MAX``, with a
    warning) and the noise of their mean difference, A rms."""
    lsb = 2.0 * adc_range / 2**adc_bits if adc_bits > 0 else 0.0
    sigma_1 = math.hypot(current_noise, lsb / math.sqrt(12.0))  # (hypot: 1e300 A of noise overflowed)
    q = Z_SIGMA * 2.0 * sigma_1 / signal if signal > 0 else 0.0
    r2 = q * q  # (a product: q**2 raised OverflowError beyond 1e154)
    pairs = (max(1, math.ceil(r2)) if math.isfinite(r2) else math.inf) if signal > 0 else PAIRS_MAX
    if pairs > PAIRS_MAX:
        warnings.append(f"the saturation signal ({signal * 1e3:.3g} mA) needs {pairs:g} pulse pairs against "
                        f"{sigma_1 * 1e3:.3g} mA of noise: limited to {PAIRS_MAX}, the decision is less sure")
        pairs = PAIRS_MAX
    return pairs, 2.0 * sigma_1 / math.sqrt(pairs)


def _pulse_motion(motor: Motor, th: np.ndarray, dq: tuple, dp: float, pulses: int, times: tuple,
                  warnings: list[str]) -> float:
    """How far a free, frictionless mover may move while detecting, m: the one-signed reluctance
    force's drift over the pulses and one pulse's q-force impulse; a warning above
    ``MOTION_BAR_MM``. ``dq``: (L_d, L_q, L_dq) over ``th``; ``times``: (pulse, rest, all
    pulses), s."""
    L_d, L_q, L_dq = dq
    t_pulse, t_rest, t_pulses = times
    L_d0 = float(np.mean(L_d))
    kx = 2.0 * math.pi / motor.pole_pitch
    dld = float(np.max(np.abs(np.gradient(L_d, th))))
    t_eff = t_pulse / 3.0 + 0.5 * L_d0 / motor.R_s  # s, i^2 over a pulse and its decay, in peak units
    f_rel = 0.75 * kx * dld * dp**2
    v_rel = pulses * f_rel * t_eff / motor.mass
    cross = float(np.max(np.abs(L_dq / L_q))) + math.sin(LOCK_ACCURACY)
    j_q = motor.force_constant * dp * cross * (t_pulse / 2.0 + L_d0 / motor.R_s)
    motion = 0.5 * v_rel * t_pulses + j_q / motor.mass * (t_pulse + t_rest)
    if motion * 1e3 > MOTION_BAR_MM:
        warnings.append(f"a free, frictionless mover may move {motion * 1e3:.3f} mm while detecting (more "
                        f"than {MOTION_BAR_MM:g} mm): the pulses' reluctance force drifts it; guide friction "
                        f"or a brake holds it (docs/firmware.md)")
    return motion

"""The drive's design composed once: the gains and limits (:func:`~linsense.tune.design.design`),
the start-up (:func:`~linsense.tune.startup.design_startup`), the widening of the trips on the
estimate of a drive run without its table, and a measured table; and the one mapping of its values
onto scenario keys (:meth:`DriveDesign.scenario_keys`).

``linsense tune``, the firmware exporter, the simulator's build (a scenario's unset gains) and the
verification certificate all call :func:`design_drive`; the scenario ``tune`` writes, the C header
and the simulator's designed scenario all read :meth:`DriveDesign.scenario_keys`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

from linsense.analysis.hf import mean_dq
from linsense.model.motor import Motor
from linsense.scenario.bounds import V_DC_MAX_FRACTION, V_DC_MIN_FRACTION
from linsense.scenario.keys import checked
from linsense.tune.design import (
    INJ_RAMP_TIME,
    Design,
    DriveData,
    DriveInputs,
    design,
    uncompensated_speed_factor,
)
from linsense.tune.handover import HandoverDesign, design_handover
from linsense.tune.startup import StartupDesign, design_startup

#: the keys whose values are the inputs as given (the drive data, the application, the motor
#: file's friction): a scenario holds them as they are; the rest are computed (written to 6 digits)
GIVEN_KEYS = frozenset({
    "inverter.v_dc", "inverter.f_pwm", "inverter.dead_time", "controller.i_max", "reference.v_max",
    "reference.a_max", "controller.friction_coulomb", "controller.friction_viscous", "controller.rated_load",
})


@dataclass
class DriveDesign:
    """A drive designed for a motor (:func:`design_drive`).

    Attributes
    ----------
    motor : Motor or None
        The motor (the file's; None: a design given without it, whose keys have no
        ``controller.model``).
    drive : DriveData
        The drive and its application (``v_max``, ``a_max``, ``load``, ``travel``).
    design : Design
        The gains, limits and margins.
    startup : StartupDesign or None
        The start-up pulses (None: no saturation data, or not asked for).
    uncompensated : bool
        The drive runs without its compensation table: the trips and the clamp on the estimate are
        widened by :attr:`k_est`.
    k_est : float
        ``uncompensated_speed_factor`` for a drive without its table, else 1.
    table : MeasuredTable or None
        A measured compensation table in place of the motor file's
        (:func:`linsense.compensation.measured.read_measured_table`).
    table_fit : tuple of str
        What the table's end-effect fit says: its line and a doubt ("" for none); empty without a
        table.
    handover : HandoverDesign or None
        The hand-over band and the injection's fade (:func:`~linsense.tune.handover.design_handover`;
        None: a design given without its motor).
    """

    motor: Motor | None
    drive: DriveData
    design: Design
    startup: StartupDesign | None = None
    uncompensated: bool = False
    k_est: float = 1.0
    table: object = None
    table_fit: tuple = field(default_factory=tuple)
    handover: HandoverDesign | None = None

    @functools.cached_property
    def model(self) -> Motor:
        """The motor the controller believes: the file's, with the end effect a measured table says.

        Returns
        -------
        Motor
            :func:`linsense.compensation.measured.end_effect_fit` of the table, else the motor.
        """
        if self.table is None:
            return self.motor
        from linsense.compensation.measured import end_effect_fit

        return end_effect_fit(self.motor, self.table.values, self.drive.shape, *self.table_injection())[0]

    def table_injection(self) -> tuple[float, float]:
        """The frequency and kappa a table of this drive is for.

        Returns
        -------
        f_inj : float
            The injection's frequency (the square wave's ``f_pwm / 2``), Hz.
        quad : float
            Its kappa (the pulsating/elliptical injection's; 0 for the others).
        """
        d, dz = self.drive, self.design
        f_inj = d.f_pwm / 2.0 if d.shape == "square" else dz.f_inj
        return f_inj, dz.quad if d.shape == "pulsating" else 0.0

    def observer_bw(self, observer_type: str) -> float:
        """The observer's designed bandwidth for an observer type.

        Parameters
        ----------
        observer_type : str
            ``"mech"`` or ``"pll"``.

        Returns
        -------
        float
            Hz.
        """
        dz = self.design
        return dz.observer_bw_mech if observer_type == "mech" else dz.observer_bw_pll

    def scenario_keys(self, *, uncompensated: bool | None = None) -> dict[str, object]:
        """The design's values at their scenario keys: the one mapping.

        Unrounded, in the keys' units (``startup.err_lock_deg`` in degrees). Every value the design
        sets: the drive data, the injection, the observer, the loops' bandwidths and gains, the
        limits and trips, the calibration's dither, the friction and thrust ripple fed forward, the
        controller's model of the motor (:attr:`model`) and the start-up. Who writes a scenario
        takes the keys it writes from here (:data:`GIVEN_KEYS` as given, the rest to 6 digits).

        Parameters
        ----------
        uncompensated : bool or None, optional
            Whether the drive runs without its table (the trips and clamp on the estimate widened
            by :attr:`k_est`); None: :attr:`uncompensated` (a C header's drive runs its table).

        Returns
        -------
        dict
            Dotted key to value.
        """
        dz, d = self.design, self.drive
        k = self.k_est if (self.uncompensated if uncompensated is None else uncompensated) else 1.0
        keys: dict[str, object] = {
            "inverter.v_dc": d.v_dc, "inverter.f_pwm": d.f_pwm, "inverter.dead_time": d.dead_time,
            "controller.i_max": d.i_max, "controller.model.demod_gain": dz.demod_gain,
            "injection.shape": d.shape, "injection.amplitude": dz.v_inj, "injection.frequency": dz.f_inj,
            "injection.quadrature": dz.quad, "injection.ramp_rate": dz.inj_ramp_rate,
            "observer.type": dz.observer_type, "observer.bandwidth_hz": dz.observer_bw,
            "observer.load_feedforward": dz.load_ff, "observer.demod_lpf_hz": dz.demod_lpf,
            "observer.demod_notch": True, "observer.gain_schedule": True, "observer.force_max": dz.force_max,
            "observer.omega_max": dz.omega_obs * k, "observer.hf_delay_s": dz.hf_delay,
            "observer.dead_time_model": "forward",
            "controller.current_bandwidth_hz": dz.current_bw, "controller.speed_bandwidth_hz": dz.speed_bw,
            "controller.current_kp": dz.current_kp, "controller.current_ki": dz.current_ki,
            "controller.speed_kp": dz.speed_kp, "controller.speed_ki": dz.speed_ki,
            "controller.kp_x": dz.kp_x,
            "controller.v_max": dz.v_cap, "controller.step_a_max": dz.a_step,
            "reference.v_max": d.v_max, "reference.a_max": d.a_max,
            "protection.omega_max": dz.omega_trip * k, "protection.i_max": dz.i_trip,
            "protection.v_dc_min": d.v_dc * V_DC_MIN_FRACTION,
            "protection.v_dc_max": d.v_dc * V_DC_MAX_FRACTION,
            "calibration.dither_a": dz.dither_a, "calibration.dither_hz": dz.dither_hz,
            "controller.friction_coulomb": dz.friction_coulomb,
            "controller.friction_viscous": dz.friction_viscous,
            "controller.friction_band": dz.friction_band, "controller.ripple_order": dz.ripple_order,
            "controller.ripple_cos": dz.ripple_cos, "controller.ripple_sin": dz.ripple_sin,
        }
        if d.load is not None:  # (the application's rated load: the scenario's design takes it too)
            keys["controller.rated_load"] = d.load
        if self.motor is not None:  # (the controller believes the motor: its own parameters)
            m = self.model
            L_d, L_q = mean_dq(m)
            keys.update({"motor.pole_pitch": m.pole_pitch,
                         "controller.model.force_constant": m.force_constant, "controller.model.mass": m.mass,
                         "controller.model.L_d": L_d, "controller.model.L_q": L_q,
                         "controller.model.R_s": m.R_s, "controller.model.psi_pm": m.psi_pm})
        if self.startup is not None:
            keys.update({f"startup.{k}": v for k, v in self.startup.scenario_keys(digits=None).items()})
        if self.handover is not None:
            keys.update(self.handover.scenario_keys())
        return dict(checked(keys))

    @property
    def warnings(self) -> list[str]:
        """What the design and the start-up's could not meet, and the table's doubt.

        Returns
        -------
        list of str
            The warnings, the design's first.
        """
        out = list(self.design.warnings) + (list(self.startup.warnings) if self.startup is not None else [])
        h = self.handover
        if h is not None and h.on:  # (the injection fades out at speed: its room matters up to v_off)
            out = [w for w in out if not w.startswith(("the bus leaves room for the fundamental",
                                                        "the speed cap "))]
            if h.v_off > self.design.headroom_speed:
                out.append(f"the injection fades out at {h.v_off:.3g} m/s, above the "
                           f"{self.design.headroom_speed:.3g} m/s up to which the bus leaves the fundamental "
                           "room beside it at the application's current: the current loop saturates "
                           "between them")
        if self.table is not None:  # (the file's table's cost is moot: the drive runs the measured one)
            out = [w for w in out if not w.startswith("the motor file's table costs")]
            out += [f"{self.table.source}: {self.table_fit[1]}"] if self.table_fit[1] else []
        return out


def design_drive(motor: Motor, drive: DriveData | None = None, *, source: str = "<tune>",
                 analyse: bool = True, startup: bool = True, polarity: float | None = None,
                 current_noise: float = 0.01, uncompensated: bool = False, table: str | None = None,
                 table_via: tuple[str, str, str] | None = None, points: int = 256) -> DriveDesign:
    """Design the drive for ``motor``: the only place the design is composed (docs/tuning.md).

    The gains and limits (:func:`~linsense.tune.design.design`), then the start-up
    (:func:`~linsense.tune.startup.design_startup`, locking at the PLL's bandwidth), the widening of
    the trips on the estimate for a drive without its table
    (:func:`~linsense.tune.design.uncompensated_speed_factor`) and a measured table, read at the
    designed injection.

    Parameters
    ----------
    motor : Motor
        The motor.
    drive : DriveData or None, optional
        The drive and its application (``v_max``, ``a_max``, ``load``, ``travel``: DriveData holds
        them); None: the defaults, the paper's drive.
    source : str, optional
        Named in messages (the motor or scenario given).
    analyse : bool, optional
        Also the margins of the linearised model and the tolerances.
    startup : bool, optional
        Design the start-up (None without saturation data).
    polarity : float or None, optional
        The start-up's saturation data, 1/A (None: the motor file's).
    current_noise : float, optional
        Current-sensor noise for the start-up's pulse pairs, A rms.
    uncompensated : bool, optional
        The drive runs without its compensation table.
    table : str or None, optional
        A measured compensation table's file in place of the motor file's table.
    table_via : tuple of str or None, optional
        Where ``table`` was named (``(scenario, key, value)``), for its refusal.
    points : int, optional
        Table points.

    Returns
    -------
    DriveDesign
        The design.

    Raises
    ------
    linsense.errors.InputError
        The design's refusal, a start-up's polarity or noise out of range, or a table refused.
    """
    d = drive if drive is not None else DriveData()
    dz = design(motor, d, source, analyse=analyse)
    su = None
    if startup:  # (the start-up locks as the PLL would: startup.lock_gain, design.startup_lock_gain)
        su = design_startup(motor, v_dc=d.v_dc, f_pwm=d.f_pwm, i_max=d.i_max, observer_bw=dz.observer_bw_pll,
                            v_inj=dz.v_inj, polarity=polarity, current_noise=current_noise,
                            ramp_rate=dz.inj_ramp_rate, source=source)
    k_est = uncompensated_speed_factor(motor) if uncompensated else 1.0
    hand = design_handover(motor, v_dc=d.v_dc, f_pwm=d.f_pwm, dead_time=d.dead_time,
                           i_mag=DriveInputs(motor, d).i_need,
                           demod_lpf=dz.demod_lpf, ramp_time=INJ_RAMP_TIME, a_max=d.a_max, v_cap=dz.v_cap,
                           shape=d.shape, headroom=dz.headroom_speed)
    out = DriveDesign(motor, d, dz, su, uncompensated, k_est, handover=hand)
    if table is not None:
        from linsense.compensation.measured import fit_report, read_measured_table

        f_table, q_table = out.table_injection()
        out.table = read_measured_table(table, motor=motor, injection=d.shape, f_inj=f_table, quad=q_table,
                                        points=points, via=table_via)
        out.table_fit = fit_report(motor, out.table.raw, d.shape, f_table, q_table, points)
    return out

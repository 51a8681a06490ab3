"""The controller's tables of a scenario: the compensation table (and its slope in the resistance)
and the demodulator's gain table, from the motor model with the resistance the controller believes
(or, with ``observer.lut_model = "measured"``, the compensation table of a stamped measured file),
as cached ``ls_lut`` objects (the drive only reads them, through const pointers)."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from linsense.compensation.lut import build_lut, lut_r_slope
from linsense.compensation.measured import end_effect_fit, fit_report, read_measured_table
from linsense.ctrl import make_lut
from linsense.model.motor import Motor
from linsense.scenario.load import Scenario
from linsense.scenario.rules import compensation_of
from linsense.sim.cache import memo, motor_key
from linsense.tune.cfgmap import Values
from linsense.tune.design import gain_r_slope, gain_schedule
from linsense.tune.injection import injection_tables, rotating_r_slopes


@dataclasses.dataclass
class Tables:
    """The ``ls_lut`` objects of one drive (None: not used).

    Attributes
    ----------
    comp : linsense.ctrl.Lut or None
        The compensation table.
    gain_table : linsense.ctrl.Lut or None
        The demodulator's gain schedule.
    comp_r : linsense.ctrl.Lut or None
        The compensation table's slope in the resistance's scale.
    gain_r : linsense.ctrl.Lut or None
        The gain schedule's slope in the resistance's scale.
    """

    comp: object = None
    gain_table: object = None
    comp_r: object = None
    gain_r: object = None


def drive_tables(sc: Scenario, model_motor: Motor, R_s: float, v: Values,
                 stamp_motor: Motor | None = None) -> Tables:
    """The tables of a designed scenario.

    For ``sensorless_lut``, and for the HF observer beside the encoder in sensored mode; the
    resistance-aware slopes when the drive measures the resistance (``ls_dtres_adapt`` with the
    forward residual model).

    With ``observer.lut_model = "measured"`` the compensation table is the measured one of
    ``observer.lut_file`` (:func:`measured_comp`: its stamp checked against this drive, resampled to
    ``lut_points``). Its slope in the resistance (``comp_r``) and the gain tables are the model's of
    the motor whose end effect fits the measured table, which the build makes the controller's model
    (:func:`measured_model`): the table was measured at the winding's
    temperature of the calibration, and the drive measures the resistance online
    (``ls_dtres_adapt``) and moves the measured table by the model's slope times the measured
    change; the gain schedule follows the saliency, which the end effect changes at the weak
    positions (with the file's gain schedule a motor whose end effect is 25 % off its file held in a
    0.64 deg p-p cycle at one position of 48 on small30; with the fitted one, 0.009 deg).

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    model_motor : Motor
        The motor the controller believes in.
    R_s : float
        The resistance the controller believes, ohm.
    v : Values
        Its drive values (:func:`linsense.sim.drive_cfg.drive_values`).
    stamp_motor : Motor or None, optional
        The motor a measured table's stamp must name: the controller's motor as loaded, before the
        end-effect fit (default ``model_motor``).

    Returns
    -------
    Tables
        The tables.
    """
    obs = sc.spec.observer
    stamp_motor = model_motor if stamp_motor is None else stamp_motor

    def lut_motor() -> Motor:
        return dataclasses.replace(model_motor, R_s=R_s)

    key = (motor_key(model_motor), R_s, obs.lut_points)
    r_slopes = (obs.resistance_adapt and v.field("hf_dtres") and v.field("dtres.forward")
                and v.field("dtres.adapt"))
    if v["injection.shape"] != "pulsating":
        return _shape_tables(sc, lut_motor, key, v, r_slopes, stamp_motor)
    t = Tables()
    inj = sc.spec.injection
    if compensation_of(sc.spec.control.mode, obs.compensation) == "lut":
        f_lut = inj.frequency if obs.lut_model in ("resistive", "measured") else None
        quad = inj.quadrature if f_lut else 0.0
        if obs.lut_model == "measured":
            t.comp = measured_comp(sc, stamp_motor, f_lut, quad)
        else:
            t.comp = memo(("lut",) + key + (f_lut, quad),
                          lambda: make_lut(build_lut(lut_motor(), obs.lut_points, f_inj=f_lut, quad=quad)))
        if f_lut and r_slopes:
            # the table's slope in R_s, for the resistance the drive measures (ls_dtres_adapt)
            t.comp_r = memo(("lut_r",) + key + (f_lut, quad),
                            lambda: make_lut(lut_r_slope(lut_motor(), obs.lut_points, f_lut, quad)))
    if obs.gain_schedule:
        # the demodulator gain that makes the error's local slope 1 everywhere (the saliency and,
        # with the elliptical injection and R_s, its phase set it; docs/tuning.md)
        g = (inj.frequency, inj.quadrature, obs.lut_points)
        t.gain_table = memo(("gain_table",) + key[:2] + g,
                            lambda: make_lut(gain_schedule(lut_motor(), *g)))
        if t.comp_r is not None:  # (it follows the measured resistance as the table does)
            t.gain_r = memo(("gain_r",) + key[:2] + g, lambda: make_lut(gain_r_slope(lut_motor(), *g)))
    return t


def lut_file_path(sc: Scenario) -> Path:
    """The file of ``observer.lut_file``, a relative path taken against the scenario file's folder.

    Parameters
    ----------
    sc : Scenario
        The scenario (``observer.lut_file`` given).

    Returns
    -------
    Path
        The file.
    """
    p = Path(sc.spec.observer.lut_file)
    return p if p.is_absolute() else sc.base_dir / p


def measured_comp(sc: Scenario, model_motor: Motor, f_inj: float, quad: float):
    """The measured compensation table of ``observer.lut_file`` as an ``ls_lut``.

    Read with :func:`linsense.compensation.measured.read_measured_table` for this drive: the motor
    the controller believes in, as loaded (its data's digest; a ``controller.model.R_s`` does not
    change it), the scenario's injection shape, the frequency the drive injects at and kappa;
    resampled to ``observer.lut_points``. Cached by the file's path, modification time and size and
    these (an edited file is read again).

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    model_motor : Motor
        The motor the controller believes in.
    f_inj : float
        The injection frequency the drive runs, Hz (the square wave: ``f_pwm / 2``).
    quad : float
        Kappa.

    Returns
    -------
    linsense.ctrl.Lut
        The table.

    Raises
    ------
    linsense.errors.InputError
        Naming the scenario and ``observer.lut_file``, then the reader's refusal (the table file and
        its key or row).
    """
    key = ("measured_comp",) + _measured_key(sc, model_motor, f_inj, quad)
    return memo(key, lambda: make_lut(measured_values(sc, model_motor, f_inj, quad)))


def _measured_key(sc: Scenario, model_motor: Motor, f_inj: float, quad: float) -> tuple:
    """The cache key of a measured table: the file (path, modification time, size) and the drive."""
    path = lut_file_path(sc)
    try:
        st = os.stat(path)
        where = (os.fspath(path), st.st_mtime_ns, st.st_size)
    except OSError:
        where = (os.fspath(path), None, None)  # (the reader refuses it; a refusal is not cached)
    return where + (motor_key(model_motor), sc.spec.injection.shape, f_inj, quad, sc.spec.observer.lut_points)


def measured_values(sc: Scenario, model_motor: Motor, f_inj: float, quad: float) -> np.ndarray:
    """The measured table of ``observer.lut_file``, rad at ``observer.lut_points`` points (cached;
    :func:`measured_comp`).

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    model_motor : Motor
        The motor the controller believes in, as loaded.
    f_inj : float
        The injection frequency the drive runs, Hz.
    quad : float
        Kappa.

    Returns
    -------
    ndarray
        rad.

    Raises
    ------
    linsense.errors.InputError
        As :func:`measured_comp`.
    """
    return _measured_table(sc, model_motor, f_inj, quad).values


def _measured_table(sc: Scenario, model_motor: Motor, f_inj: float, quad: float):
    """The scenario's measured table as read for this drive (cached; :func:`measured_values`)."""
    key = ("measured",) + _measured_key(sc, model_motor, f_inj, quad)
    return memo(key, lambda: read_measured_table(
        lut_file_path(sc), motor=model_motor, injection=sc.spec.injection.shape, f_inj=f_inj, quad=quad,
        points=sc.spec.observer.lut_points, via=lut_file_via(sc)))


def lut_file_via(sc: Scenario) -> tuple[str, str, str]:
    """Where a scenario names its measured table, for the reader's messages
    (:func:`linsense.compensation.measured.read_measured_table`'s ``via``).

    Parameters
    ----------
    sc : Scenario
        The scenario (``observer.lut_file`` given).

    Returns
    -------
    tuple of str
        ``(scenario, "observer.lut_file", value as written)``.
    """
    return sc.source, "observer.lut_file", str(sc.spec.observer.lut_file)


def measured_model(sc: Scenario, model_motor: Motor) -> Motor:
    """The controller's motor with the end effect its measured table says.

    A measured table departs from the motor file's table mostly by the end effect, which the rest
    of the drive's model needs too: the gain schedule and the table's slope in the resistance (the
    saliency at the weak positions), the dead-time residual's model (the stationary anisotropy,
    :func:`linsense.analysis.hf.end_anisotropy`). Fitted once per table
    (:func:`linsense.compensation.measured.end_effect_fit`); ``model_motor`` itself without a
    measured table. On small30 driven on a plant whose end effect is 25 % above its file, with the
    measured table and the file's model one hold of 48 ends in a 0.82 deg p-p cycle; with the
    fitted model 0.009 deg.

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    model_motor : Motor
        The motor the controller believes in, as loaded (the table's stamp names it).

    Returns
    -------
    Motor
        The fitted motor.

    Raises
    ------
    linsense.errors.InputError
        As :func:`measured_comp`.
    """
    fit = _fit_args(sc, model_motor)
    if fit is None:
        return model_motor
    fitted = end_effect_fit(*fit)[0]  # (kept by its inputs)
    R_s = sc.spec.controller.model.R_s
    return fitted if R_s is None else dataclasses.replace(fitted, R_s=model_motor.R_s)


def _fit_args(sc: Scenario, model_motor: Motor) -> tuple | None:
    """The arguments of :func:`~linsense.compensation.measured.end_effect_fit` for a scenario's
    measured table (the motor with the resistance the drive believes, the table, the injection), or
    None when the drive runs no measured table."""
    obs = sc.spec.observer
    if obs.lut_model != "measured" or compensation_of(sc.spec.control.mode, obs.compensation) != "lut":
        return None
    inj = sc.spec.injection
    shape = inj.shape
    f_run = sc.spec.inverter.f_pwm / 2.0 if shape == "square" else inj.frequency
    quad = inj.quadrature if shape == "pulsating" else 0.0
    values = measured_values(sc, model_motor, f_run, quad)
    R_s = sc.spec.controller.model.R_s
    lut_motor = model_motor if R_s is None else dataclasses.replace(model_motor, R_s=R_s)
    return lut_motor, values, shape, f_run, quad


def measured_warnings(sc: Scenario, model_motor: Motor) -> list[str]:
    """What the end-effect fit of a scenario's measured table doubts, as ``linsense tune --table``
    says it (:func:`linsense.compensation.measured.fit_report`): a table that does not look like the
    motor's (edited, or another motor's with this one's stamp), named by the scenario and its key.

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    model_motor : Motor
        The motor the controller believes in, as loaded.

    Returns
    -------
    list of str
        One warning, or none (no measured table, or one the fit explains and the drive's table
        length reads closely enough).
    """
    fit = _fit_args(sc, model_motor)
    if fit is None:
        return []
    lut_motor, _, shape, f_run, quad = fit
    raw = _measured_table(sc, model_motor, f_run, quad).raw  # (judged at its own points)
    doubt = fit_report(lut_motor, raw, shape, f_run, quad, sc.spec.observer.lut_points)[1]
    where, key, value = lut_file_via(sc)
    return [f"{where}: {key}: {value!r}: {doubt}"] if doubt else []


def _shape_tables(sc: Scenario, lut_motor, key: tuple, v: Values, r_slopes: bool,
                  model_motor: Motor) -> Tables:
    """The rotating or square wave's tables (each shape's table and gain computed once for both)."""
    obs, ctl, inj = sc.spec.observer, sc.spec.control, sc.spec.injection
    shape, f_inj, fs = inj.shape, v.field("inject.freq"), sc.spec.inverter.f_pwm
    model_key, R_s, points = key

    def shape_tables(f: float | None):
        return memo(("shape_tables", shape, model_key, R_s, points, f),
                    lambda: injection_tables(lut_motor(), shape, points, f))

    t = Tables()
    rot_r = None
    if compensation_of(ctl.mode, obs.compensation) == "lut":
        f_lut = f_inj if obs.lut_model in ("resistive", "measured") else None
        if obs.lut_model == "measured":  # (f_inj: the frequency the drive runs, f_pwm / 2 for the square
            # wave, as the calibration stamps it)
            t.comp = measured_comp(sc, model_motor, f_inj, inj.quadrature)
        else:
            t.comp = memo(("lut", shape, model_key, R_s, points, f_lut),
                          lambda: make_lut(shape_tables(f_lut)[0]))
        if shape == "rotating" and f_lut and r_slopes:
            rot_r = memo(("rot_r", model_key, R_s, points, f_inj, fs, ctl.delay_comp, inj.amplitude),
                         lambda: tuple(make_lut(x) for x in rotating_r_slopes(
                             lut_motor(), points, f_inj, fs, ctl.delay_comp, inj.amplitude)))
            t.comp_r = rot_r[0]
    if obs.gain_schedule:
        t.gain_table = memo(("gain_table", shape, model_key, R_s, f_inj, points),
                            lambda: make_lut(shape_tables(f_inj)[1]))
        if rot_r is not None:
            t.gain_r = rot_r[1]
    return t

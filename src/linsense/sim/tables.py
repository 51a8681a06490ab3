"""The controller's tables of a scenario: the compensation table (and its slope in the resistance)
and the demodulator's gain table, from the motor model with the resistance the controller believes
(or, with ``observer.lut_model = "measured"``, the compensation table of a stamped measured file),
as cached ``ls_lut`` objects (the drive only reads them, through const pointers)."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from linsense.compensation.lut import build_lut, lut_r_slope
from linsense.compensation.measured import read_measured_table
from linsense.ctrl import make_lut
from linsense.errors import InputError
from linsense.model.motor import Motor
from linsense.sim.cache import memo, motor_key
from linsense.sim.scenario import Scenario, compensation_of
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


def drive_tables(sc: Scenario, model_motor: Motor, R_s: float, v: Values) -> Tables:
    """The tables of a designed scenario.

    For ``sensorless_lut``, and for the HF observer beside the encoder in sensored mode; the
    resistance-aware slopes when the drive measures the resistance (``ls_dtres_adapt`` with the
    forward residual model).

    With ``observer.lut_model = "measured"`` the compensation table is the measured one of
    ``observer.lut_file`` (:func:`measured_comp`: its stamp checked against this drive, resampled to
    ``lut_points``). Its slope in the resistance (``comp_r``) and the gain tables stay the model's,
    as with ``"resistive"``: the table was measured at the winding's temperature of the calibration,
    and the drive measures the resistance online (``ls_dtres_adapt``) and moves the measured table
    by the model's slope times the measured change, as it moves the model's; the gain schedule
    follows the saliency, which the measurement does not give.

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

    Returns
    -------
    Tables
        The tables.
    """
    obs = sc.spec.observer

    def lut_motor() -> Motor:
        return dataclasses.replace(model_motor, R_s=R_s)

    key = (motor_key(model_motor), R_s, obs.lut_points)
    r_slopes = (obs.resistance_adapt and v.field("hf_dtres") and v.field("dtres.forward")
                and v.field("dtres.adapt"))
    if v["injection.shape"] != "pulsating":
        return _shape_tables(sc, lut_motor, key, v, r_slopes, model_motor)
    t = Tables()
    inj = sc.spec.injection
    if compensation_of(sc.spec.control.mode, obs.compensation) == "lut":
        f_lut = inj.frequency if obs.lut_model in ("resistive", "measured") else None
        quad = inj.quadrature if f_lut else 0.0
        if obs.lut_model == "measured":
            t.comp = measured_comp(sc, model_motor, f_lut, quad)
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
    obs = sc.spec.observer
    path = lut_file_path(sc)
    shape, points = sc.spec.injection.shape, obs.lut_points
    try:
        st = os.stat(path)
        where = (os.fspath(path), st.st_mtime_ns, st.st_size)
    except OSError:
        where = (os.fspath(path), None, None)  # (the reader refuses it; a refusal is not cached)
    key = ("measured",) + where + (motor_key(model_motor), shape, f_inj, quad, points)
    try:
        return memo(key, lambda: make_lut(read_measured_table(
            path, motor=model_motor, injection=shape, f_inj=f_inj, quad=quad, points=points).values))
    except InputError as exc:
        raise InputError(sc.source, "observer.lut_file", f"{obs.lut_file!r}: {exc}") from None


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
        if obs.lut_model == "measured":
            # (the frequency the drive runs: the square wave's f_pwm / 2, as the calibration stamps it)
            f_run = fs / 2.0 if shape == "square" else inj.frequency
            t.comp = measured_comp(sc, model_motor, f_run, inj.quadrature)
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

"""What ``linsense tune`` writes: a complete scenario (TOML) and a firmware configuration (C99)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import tomli_w

from linsense.analysis.hf import end_anisotropy
from linsense.compensation.lut import (
    build_lut,
    c_comment_text,
    c_identifier,
    c_name_problem,
    c_symbol,
    lut_r_slope,
)
from linsense.compensation.stamp import data_digest, stamp_comment, stamp_macros
from linsense.errors import InputError
from linsense.io import working_folder
from linsense.model.motor import Motor, names_a_path
from linsense.tune.cfgmap import Values, header_rows
from linsense.tune.design import (
    V_DC_MAX_FRACTION,
    V_DC_MIN_FRACTION,
    Design,
    DriveData,
    gain_r_slope,
    gain_schedule,
    mean_dq,
)


def end_stops(pole_pitch: float, travel: float) -> dict:
    """The ``[travel]`` section for a stroke from 0.

    The end stops lie a twentieth of the pole pitch beyond each end (a run that reaches them ends
    with the travel fault).

    Parameters
    ----------
    pole_pitch : float
        Pole pitch, m.
    travel : float
        Stroke, m.

    Returns
    -------
    dict
        ``min_mm``, ``max_mm`` (mm).
    """
    return {"min_mm": _r(-0.05 * pole_pitch * 1e3), "max_mm": _r((travel + 0.05 * pole_pitch) * 1e3)}


def scenario_dict(dz: Design, drive: DriveData, motor_ref: str, base: dict | None = None,
                  startup=None, k_est: float = 1.0, pole_pitch: float | None = None,
                  table: str | None = None) -> dict:
    """A complete scenario with the design's drive data and gains written out.

    ``base`` (a scenario's given keys, or a 2 s hold) with the design written over it;
    ``startup`` fills ``[startup]`` when the scenario's mode is "startup".

    Parameters
    ----------
    dz : Design
        The design.
    drive : DriveData
        The drive.
    motor_ref : str
        The scenario's ``motor`` value (preset or path).
    base : dict or None, optional
        The scenario's given keys (None: a 2 s hold).
    startup : StartupDesign or None, optional
        The start-up design (:class:`linsense.tune.startup.StartupDesign`).
    k_est : float, optional
        The trips and clamp on the estimate widened by it (a drive without its table:
        ``uncompensated_speed_factor``).
    pole_pitch : float or None, optional
        Pole pitch, m, for the ``[travel]`` end stops when the drive has a travel.
    table : str or None, optional
        A measured table's file (``linsense calibrate``'s ``lut_measured.json``): the drive's
        compensation table (``observer.lut_model = "measured"``, ``observer.lut_file``); None: the
        table from the motor file.

    Returns
    -------
    dict
        The scenario, as nested dicts of its TOML.
    """
    sc = {k: (dict(v) if isinstance(v, dict) else v) for k, v in (base or {}).items()}
    sc["motor"] = motor_ref
    sc.setdefault("scenario", {"name": "tuned", "duration": 2.0})
    sc.setdefault("reference", {"type": "hold"})
    sc.setdefault("inverter", {}).update(
        {"v_dc": drive.v_dc, "f_pwm": drive.f_pwm, "dead_time": drive.dead_time}
    )
    inj = sc.setdefault("injection", {})
    inj.update({"amplitude": _r(dz.v_inj), "ramp_rate": _r(dz.inj_ramp_rate)})
    if drive.shape != "pulsating":
        inj["shape"] = drive.shape
    shape = inj.get("shape", "pulsating")
    if shape == "pulsating":  # (kappa is the pulsating/elliptical injection's own)
        inj["quadrature"] = _r(dz.quad)
    else:
        inj.pop("quadrature", None)
    if shape == "square":  # (at f_pwm / 2, not a design choice)
        inj.pop("frequency", None)
    else:
        inj["frequency"] = _r(dz.f_inj)
    sc.setdefault("observer", {}).update(
        {
            "type": dz.observer_type,
            "bandwidth_hz": _r(dz.observer_bw),
            "demod_lpf_hz": _r(dz.demod_lpf),
            "gain_schedule": True,
            "omega_max": _r(dz.omega_obs * k_est),
            "hf_delay_s": _r(dz.hf_delay),
        }
    )
    for k in ("k1", "k2", "k3"):
        sc["observer"].pop(k, None)
    if table is not None:
        sc["observer"].update({"lut_model": "measured", "lut_file": table})
    if dz.observer_type == "mech":  # (the clamp of its load estimate; the PLL has none)
        sc["observer"]["force_max"] = _r(dz.force_max)
    else:
        sc["observer"].pop("force_max", None)
    con = sc.setdefault("controller", {})
    for k in ("speed_kp", "speed_ki", "current_kp", "current_ki"):
        con.pop(k, None)
    con.update(
        {
            "current_bandwidth_hz": _r(dz.current_bw),
            "speed_bandwidth_hz": _r(dz.speed_bw),
            "i_max": drive.i_max,
            "v_max": _r(dz.v_cap),
            "step_a_max": _r(dz.a_step),
        }
    )
    if con.get("position_type", "p") == "p":
        con["kp_x"] = _r(dz.kp_x)
    # the motor file's friction and thrust ripple, fed forward (only where it has them: the keys'
    # defaults are none)
    for k in ("friction_coulomb", "friction_viscous", "friction_band", "ripple_order", "ripple_cos",
              "ripple_sin"):
        con.pop(k, None)
    if dz.friction_coulomb > 0.0 or dz.friction_viscous > 0.0:
        con.update({"friction_coulomb": dz.friction_coulomb, "friction_viscous": dz.friction_viscous,
                    "friction_band": _r(dz.friction_band)})
    if dz.ripple_order:
        con.update({"ripple_order": dz.ripple_order, "ripple_cos": _r(dz.ripple_cos),
                    "ripple_sin": _r(dz.ripple_sin)})
    sc.setdefault("calibration", {}).update({"dither_a": _r(dz.dither_a), "dither_hz": _r(dz.dither_hz)})
    # limits the scenario gives are kept (they are not gains); otherwise they follow the bus
    prot = sc.setdefault("protection", {})
    prot.setdefault("v_dc_min", _r(drive.v_dc * V_DC_MIN_FRACTION))
    prot.setdefault("v_dc_max", _r(drive.v_dc * V_DC_MAX_FRACTION))
    prot.update({"omega_max": _r(dz.omega_trip * k_est), "i_max": _r(dz.i_trip)})
    # the application's speed and acceleration, which the limits above are designed from: written
    # whatever the reference, so that the scenario holds the drive it was designed for (a re-tune or
    # calibrate over it reads them back: without them it designed for the default 0.2 m/s)
    sc["reference"] = {**sc["reference"], "v_max": drive.v_max, "a_max": drive.a_max}
    if drive.travel is not None and "travel" not in sc and pole_pitch is not None:
        sc["travel"] = end_stops(pole_pitch, drive.travel)
    if startup is not None and sc.get("control", {}).get("mode") == "startup":
        sc.setdefault("startup", {}).update(startup.scenario_keys())
    return sc


def scenario_toml(
    dz: Design,
    drive: DriveData,
    motor_spec: str,
    out: Path,
    base: dict | None = None,
    base_dir: Path | None = None,
    startup=None,
    k_est: float = 1.0,
    pole_pitch: float | None = None,
    table: str | None = None,
) -> str:
    """The scenario as TOML.

    A motor-file or table path (relative to ``base_dir``, default the working folder, as the command
    line gives it) is made relative to the output file's folder, and so is an absolute
    ``controller.model.motor`` of ``base``.

    Parameters
    ----------
    dz : Design
        The design.
    drive : DriveData
        The drive.
    motor_spec : str
        The motor as given (preset name or path).
    out : Path
        The output file.
    base : dict or None, optional
        The scenario's given keys.
    base_dir : Path or None, optional
        The folder a relative motor path is relative to.
    startup : StartupDesign or None, optional
        The start-up design.
    k_est : float, optional
        Widening of the trips and clamp on the estimate.
    pole_pitch : float or None, optional
        Pole pitch, m.
    table : str or None, optional
        A measured table's file (:func:`scenario_dict`).

    Returns
    -------
    str
        The TOML text, with a comment line summarising the design.
    """

    def relative(path: str) -> str:
        p = Path(path)
        if not p.is_absolute():
            p = (base_dir or working_folder()) / p
        return os.path.relpath(p.resolve(), Path(out).resolve().parent)

    ref = relative(motor_spec) if names_a_path(motor_spec) else motor_spec
    table = None if table is None else relative(table)
    sc = scenario_dict(dz, drive, ref, base, startup, k_est, pole_pitch, table)
    model = sc.get("controller", {}).get("model", {})
    if names_a_path(model.get("motor", "")):  # (every path in the scenario relative to its own folder)
        sc["controller"] = {**sc["controller"], "model": {**model, "motor": relative(model["motor"])}}
    head = (
        f"# Designed by `linsense tune` for motor {ref!r} (docs/tuning.md): {dz.v_inj:.3g} V / "
        f"{dz.f_inj:g} Hz injection, current loop {dz.current_bw:.3g} Hz, observer {dz.observer_bw:.3g} Hz, "
        f"speed loop {dz.speed_bw:.3g} Hz, position {dz.kp_x:.3g} 1/s.\n"
    )
    return head + tomli_w.dumps(sc)


def check_c_header(drive: DriveData) -> None:
    """Refuse a drive that :func:`c_header` cannot configure (before anything is designed or run).

    Parameters
    ----------
    drive : DriveData
        The drive.

    Raises
    ------
    linsense.errors.InputError
        For an injection other than the pulsating/elliptical one.
    """
    if drive.shape != "pulsating":
        from linsense.errors import InputError

        raise InputError("--format", "c", f"the C header configures the pulsating/elliptical injection; "
                         f"for the {drive.shape} injection write a scenario (--format toml)")


def design_digest(motor: Motor, drive: DriveData, points: int = 256, table=None) -> str:
    """The SHA-256 of a drive's data: the motor, the drive data, the table length and a measured
    table's values (:mod:`linsense.compensation.stamp`); the stamp of ``ls_cfg_<name>.h`` and the
    key by which a verification is matched to a header.

    Parameters
    ----------
    motor : Motor
        The motor.
    drive : DriveData
        The drive.
    points : int, optional
        Table points.
    table : MeasuredTable or None, optional
        A measured compensation table.

    Returns
    -------
    str
        64 hexadecimal digits.
    """
    if table is None:
        return data_digest(motor=motor, drive=drive, points=points)
    return data_digest(motor=motor, drive=drive, points=points, table=np.asarray(table.values))


def _r(v: float) -> float:
    return float(f"{v:.6g}")


def design_values(dz: Design, drive: DriveData, motor: Motor, startup=None) -> Values:
    """The design as the scenario keys of the mapping (:mod:`linsense.tune.cfgmap`), unrounded.

    What ``tune --format c`` writes. The pulsating/elliptical injection, the forward dead-time
    model, the motor's own parameters (the controller believes the motor); the start-up design's SI
    values.

    Parameters
    ----------
    dz : Design
        The design.
    drive : DriveData
        The drive.
    motor : Motor
        The motor.
    startup : StartupDesign or None, optional
        The start-up design.

    Returns
    -------
    Values
        The keys, derived values and fields.
    """
    L_d, L_q = mean_dq(motor)
    keys = {
        "inverter.f_pwm": drive.f_pwm, "inverter.dead_time": drive.dead_time,
        "motor.pole_pitch": motor.pole_pitch,
        "controller.i_max": drive.i_max, "controller.model.force_constant": motor.force_constant,
        "controller.model.mass": motor.mass, "controller.model.L_d": L_d, "controller.model.L_q": L_q,
        "controller.model.R_s": motor.R_s, "controller.model.psi_pm": motor.psi_pm,
        "controller.model.demod_gain": dz.demod_gain,
        "injection.shape": "pulsating", "injection.amplitude": dz.v_inj, "injection.frequency": dz.f_inj,
        "injection.quadrature": dz.quad, "injection.ramp_rate": dz.inj_ramp_rate,
        "observer.type": dz.observer_type, "observer.bandwidth_hz": dz.observer_bw,
        "observer.load_feedforward": dz.load_ff, "observer.demod_lpf_hz": dz.demod_lpf,
        "observer.demod_notch": True, "observer.force_max": dz.force_max, "observer.omega_max": dz.omega_obs,
        "observer.hf_delay_s": dz.hf_delay, "observer.dead_time_model": "forward",
        "controller.current_kp": dz.current_kp, "controller.current_ki": dz.current_ki,
        "controller.speed_kp": dz.speed_kp, "controller.speed_ki": dz.speed_ki, "controller.kp_x": dz.kp_x,
        "controller.v_max": dz.v_cap, "controller.step_a_max": dz.a_step,
        "reference.v_max": drive.v_max, "reference.a_max": drive.a_max,
        "protection.omega_max": dz.omega_trip, "protection.i_max": dz.i_trip,
        "protection.v_dc_min": drive.v_dc * V_DC_MIN_FRACTION,
        "protection.v_dc_max": drive.v_dc * V_DC_MAX_FRACTION,
        "calibration.dither_a": dz.dither_a, "calibration.dither_hz": dz.dither_hz,
        "controller.friction_coulomb": dz.friction_coulomb,
        "controller.friction_viscous": dz.friction_viscous,
        "controller.friction_band": dz.friction_band, "controller.ripple_order": dz.ripple_order,
        "controller.ripple_cos": dz.ripple_cos, "controller.ripple_sin": dz.ripple_sin,
    }
    derived = {"model.end_anisotropy": lambda v: end_anisotropy(motor)}
    fields = {}
    if startup is not None:
        keys.update({f"startup.{k}": getattr(startup, k) for k in
                     ("t_lock", "t_quiet", "v_pulse", "t_pulse", "t_rest", "pairs", "i_min", "t_settle")})
        fields["startup.err_lock"] = startup.err_lock  # (the design's, in rad)
    return Values(keys.__getitem__, derived, fields)


#: the prefix of a drive configuration's C names (``ls_cfg_<name>``) and the characters its longest
#: name adds after them (``LS_CFG_<NAME>_DATA_SHA256``)
CFG_PREFIX = "ls_cfg_"
CFG_SUFFIX_CHARS = len("_DATA_SHA256")


def c_config_name(name: str | None, motor_name: str, source: str = "name") -> str:
    """The ``<name>`` of ``ls_cfg_<name>.h`` and its symbols.

    A name given is used as given or refused (:func:`linsense.compensation.lut.c_symbol`: it was
    made lower-case and ``'my drive!'`` became ``my_drive`` without a word); without one, the
    motor's name made a C identifier.

    Parameters
    ----------
    name : str or None
        The name given (``--name``).
    motor_name : str
        The motor's name, for the default.
    source : str, optional
        The option or argument the name came from, for the message.

    Returns
    -------
    str
        The name.

    Raises
    ------
    linsense.errors.InputError
        A name C cannot take, naming the rule (for the default: give a name).
    """
    if name is not None:
        return c_symbol(name, source, CFG_PREFIX, CFG_SUFFIX_CHARS)
    sym = c_identifier(motor_name)
    why = c_name_problem(CFG_PREFIX + sym, CFG_SUFFIX_CHARS)
    if why is not None:
        raise InputError(source, "", f"the C name made from the motor's name {motor_name!r}, "
                                     f"{CFG_PREFIX + sym!r}, {why}: give a name")
    return sym


def c_header(dz: Design, drive: DriveData, motor: Motor, name: str | None = None, points: int = 256,
             startup=None, table=None, unverified: str = "", verified_by: str = "") -> str:
    """``ls_cfg_<name>.h``: the drive's configuration for the C library.

    The compensation and gain tables, their slopes in the resistance's scale, and
    ``ls_cfg_<name>(cfg, comp, gain, comp_r, gain_r)``, which fills an ``ls_drive_cfg`` from
    ``ls_drive_default_cfg`` with the design (the library holds no motor's numbers) and sets
    ``cfg->lib_version`` to this linsense's version, which ``ls_drive_init`` compares with the
    library's (another is refused: ``LS_ERR_VERSION``). Stamped with that version and the SHA-256
    of the motor and drive data (:mod:`linsense.compensation.stamp`; ``LS_CFG_<NAME>_LIB_VERSION``,
    ``LS_CFG_<NAME>_DATA_SHA256``).

    Parameters
    ----------
    dz : Design
        The design.
    drive : DriveData
        The drive.
    motor : Motor
        The motor.
    name : str or None, optional
        The name in the symbols (default the motor's).
    points : int, optional
        Table points.
    startup : StartupDesign or None, optional
        The start-up design.
    table : MeasuredTable or None, optional
        A measured compensation table at ``points`` points
        (:func:`linsense.compensation.measured.read_measured_table`) in place of the motor file's;
        its values are in the data's digest.
    unverified : str, optional
        Why the drive is written without a passed certificate (``--unverified``): said in the
        header's comment; "" for a verified drive.
    verified_by : str, optional
        The certificate the drive passed (said in the header's comment).

    Returns
    -------
    str
        The header's text.

    Raises
    ------
    linsense.errors.InputError
        For an injection other than the pulsating/elliptical one.
    """
    check_c_header(drive)
    sym = c_config_name(name, motor.name)
    fn = f"ls_cfg_{sym}"
    lut = build_lut(motor, points, f_inj=dz.f_inj, quad=dz.quad).values if table is None else table.values
    stamped = motor  # (the stamp's and the digest's motor: the file's)
    if table is not None:  # (the rest of the drive's model takes the end effect the table says, as the
        # simulator's does: linsense.sim.tables.measured_model)
        from linsense.compensation.measured import end_effect_fit

        motor = end_effect_fit(motor, table.values, "pulsating", dz.f_inj, dz.quad)[0]
    lut_r = lut_r_slope(motor, points, dz.f_inj, dz.quad)
    gain = gain_schedule(motor, dz.f_inj, dz.quad, points)
    gain_r = gain_r_slope(motor, dz.f_inj, dz.quad, points)

    def f(v: float) -> str:
        return f"LS_R({v:.9e})"

    def array(vals: np.ndarray) -> str:
        rows = [", ".join(f"{v:.9e}f" for v in vals[i : i + 4]) for i in range(0, len(vals), 4)]
        return ",\n    ".join(rows)

    v = design_values(dz, drive, motor, startup)
    rows = header_rows(startup is not None)
    body = "\n".join(f"    cfg->{r.field} = {f(v.field(r.field))};" for r in rows if r.kind != "count")
    bw = v["observer.bandwidth_hz"]
    body += "".join(f"\n    cfg->{r.field} = {int(v.field(r.field))}u;" for r in rows if r.kind == "count")
    guard = f"LS_CFG_{sym.upper()}_H"
    prefix = f"LS_CFG_{sym.upper()}"
    shown = c_comment_text(stamped.name)
    digest = design_digest(stamped, drive, points, table)
    comp_what = ("with R_s" if table is None else
                 f"measured ({c_comment_text(Path(table.source).name)}, {table.stamp.points} points"
                 f"{', resampled' if table.resampled else ''})")
    import textwrap

    if unverified:
        said = textwrap.wrap("NOT VERIFIED: written with --unverified; " + c_comment_text(unverified), 96)
    else:
        said = textwrap.wrap("Verified: " + c_comment_text(verified_by), 96) if verified_by else []
    status = "".join(f" * {ln}\n" for ln in said) + (" *\n" if said else "")
    return f"""/* Drive configuration for motor {shown}, designed by `linsense tune` (docs/tuning.md).
{status}
 * Drive: {drive.v_dc:g} V bus, {drive.f_pwm:g} Hz PWM, {drive.dead_time * 1e6:g} us dead time,
 * i_max {drive.i_max:g} A.
 * Injection {dz.v_inj:.4g} V / {dz.f_inj:g} Hz (kappa {dz.quad:g}), current loop {dz.current_bw:.4g} Hz,
 * demodulator {dz.demod_lpf:.4g} Hz (zeros at {dz.demod_notch:g} Hz), observer {dz.observer_bw:.4g} Hz,
 * speed loop {dz.speed_bw:.4g} Hz, position {dz.kp_x:.4g} 1/s.
 *
 *   ls_lut comp, gain, comp_r, gain_r;
 *   ls_lut_cfg cc = {{{fn}_comp, {sym.upper()}_LEN}}, gc = {{{fn}_gain, {sym.upper()}_LEN}};
 *   ls_lut_cfg rc = {{{fn}_comp_r, {sym.upper()}_LEN}}, hc = {{{fn}_gain_r, {sym.upper()}_LEN}};
 *   ls_lut_init(&comp, &cc); ls_lut_init(&gain, &gc); ls_lut_init(&comp_r, &rc); ls_lut_init(&gain_r, &hc);
 *   {fn}(&cfg, &comp, &gain, &comp_r, &gain_r);      then ls_drive_init(&drive, &cfg)
 *
 * ls_drive_init refuses it (LS_ERR_VERSION) with a library of another version than linsense's below:
{stamp_comment(digest)} */
#ifndef {guard}
#define {guard}

#include "linsense/ls_drive.h"

#define {sym.upper()}_LEN {points}u
{stamp_macros(prefix, digest)}
/* Psi_LUT (rad) over one electrical period for this injection, {comp_what} */
static const float {fn}_comp[{points}] = {{
    {array(lut)}
}};

/* dPsi_LUT/dk_r (rad per unit of the resistance's scale): the table follows the resistance the
 * drive measures (ls_dtres_adapt, ls_demod_cfg.comp_r) */
static const float {fn}_comp_r[{points}] = {{
    {array(lut_r)}
}};

/* demodulator gain (-) that makes the local error gain 1 everywhere */
static const float {fn}_gain[{points}] = {{
    {array(gain)}
}};

/* dg/dk_r (-): the gain follows the measured resistance too */
static const float {fn}_gain_r[{points}] = {{
    {array(gain_r)}
}};

/* ls_drive_default_cfg, then the design; comp, gain, comp_r and gain_r: ls_lut objects over the
 * tables above (comp_r, gain_r NULL: the tables do not follow the measured resistance) */
static inline void {fn}(ls_drive_cfg *cfg, const ls_lut *comp, const ls_lut *gain, const ls_lut *comp_r,
                        const ls_lut *gain_r)
{{
    ls_drive_default_cfg(cfg);
    cfg->lib_version = {prefix}_LIB_VERSION; /* made for this version of the library */
{body}
    cfg->obs.type = {v.field("obs.type")};
    cfg->load_ff = {"true" if v.field("load_ff") else "false"}; /* the observer's load estimate fed forward */
    ls_observer_gains(&cfg->obs, {f(bw)}); /* the library's rule for the bandwidth (Hz) */
    cfg->demod.comp = comp;
    cfg->demod.gain_table = gain;
    cfg->demod.comp_r = comp_r;
    cfg->demod.gain_r = gain_r;
}}

#endif /* {guard} */
"""

"""What ``linsense tune`` writes: a complete scenario (TOML) and a firmware configuration (C99)."""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np
import tomli_w

from linsense._check import instance
from linsense.analysis.emf import emf_pm_compensation
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
from linsense.scenario.sections import InjectionSection
from linsense.tune.cfgmap import Values, header_rows
from linsense.tune.design import (
    DriveData,
    gain_r_slope,
    gain_schedule,
)
from linsense.tune.drive_design import GIVEN_KEYS, DriveDesign
from linsense.tune.handover import HANDOVER_KEYS


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


#: where the writers below are (named in a refusal)
_SRC = "linsense.tune.export"


def _drive_design(made, fn: str) -> DriveDesign:
    """``made`` if a :class:`~linsense.tune.drive_design.DriveDesign`, else InputError naming ``fn``.

    The writers take the drive's design as :func:`~linsense.tune.drive_design.design_drive` composed
    it, and nothing else: a :class:`~linsense.tune.design.Design` with its drive, start-up and
    table given beside it was a second way to put a design together.
    """
    return instance(made, f"{_SRC}.{fn}", "made", DriveDesign,
                    "a DriveDesign: call linsense.tune.design_drive(motor, drive, ...) and pass its result")


#: the keys that are counts (written as integers)
COUNT_KEYS = frozenset({"controller.ripple_order", "startup.pairs"})


def written(keys: dict, key: str):
    """A design's value as a scenario holds it: a given input as given, a computed real to 6 digits.

    Parameters
    ----------
    keys : dict
        :meth:`DriveDesign.scenario_keys`.
    key : str
        The dotted key.

    Returns
    -------
    object
        The value.
    """
    v = keys[key]
    if key in GIVEN_KEYS or key in COUNT_KEYS or isinstance(v, (bool, str)):
        return v
    return _r(v)


def scenario_dict(made: DriveDesign, *, motor_ref: str = "", base: dict | None = None,
                  table: str | None = None) -> dict:
    """A complete scenario with the design's drive data and gains written out.

    ``base`` (a scenario's given keys, or a 2 s hold) with the design's keys
    (:meth:`~linsense.tune.drive_design.DriveDesign.scenario_keys`) written over it; the start-up
    fills ``[startup]`` when the scenario's mode is "startup"; ``inverter.fidelity`` is "switching"
    (the model the certificate judges, with the dead time) unless the scenario gives one.

    Parameters
    ----------
    made : DriveDesign
        The drive's design (:func:`~linsense.tune.drive_design.design_drive`: its drive, start-up,
        widening of the trips on the estimate, and its motor's pole pitch for the ``[travel]`` end
        stops when the drive has a travel).
    motor_ref : str, optional
        The scenario's ``motor`` value (preset or path).
    base : dict or None, optional
        The scenario's given keys (None: a 2 s hold).
    table : str or None, optional
        A measured table's file (``linsense calibrate``'s ``lut_measured.json``): the drive's
        compensation table (``observer.lut_model = "measured"``, ``observer.lut_file``); None: the
        table from the motor file.

    Returns
    -------
    dict
        The scenario, as nested dicts of its TOML.

    Raises
    ------
    linsense.errors.InputError
        For a ``made`` other than a DriveDesign (a plain Design: call ``design_drive``).
    """
    dd = _drive_design(made, "scenario_dict")
    pole_pitch = None if dd.motor is None else dd.motor.pole_pitch
    keys = dd.scenario_keys()
    put = functools.partial(_put, keys)
    sc = {k: (dict(v) if isinstance(v, dict) else v) for k, v in (base or {}).items()}
    sc["motor"] = motor_ref
    sc.setdefault("scenario", {"name": "tuned", "duration": 2.0})
    sc.setdefault("reference", {"type": "hold"})
    put(sc.setdefault("inverter", {}), "inverter.v_dc", "inverter.f_pwm", "inverter.dead_time")
    # the inverter model the certificate judged the drive on (with its dead time), so that simulating
    # the file shows the drive that was verified; a fidelity the scenario gives is kept
    sc["inverter"].setdefault("fidelity", "switching")
    _put_injection(sc.setdefault("injection", {}), keys)
    _put_observer(sc.setdefault("observer", {}), keys, table)
    _put_controller(sc.setdefault("controller", {}), keys)
    put(sc.setdefault("calibration", {}), "calibration.dither_a", "calibration.dither_hz")
    # limits the scenario gives are kept (they are not gains); otherwise they follow the bus
    prot = sc.setdefault("protection", {})
    for k in ("protection.v_dc_min", "protection.v_dc_max"):
        prot.setdefault(k.rsplit(".", 1)[1], written(keys, k))
    put(prot, "protection.omega_max", "protection.i_max")
    # the application's speed and acceleration, which the limits above are designed from: written
    # whatever the reference, so that the scenario holds the drive it was designed for (a re-tune or
    # calibrate over it reads them back: without them it designed for the default 0.2 m/s)
    sc["reference"] = put(dict(sc["reference"]), "reference.v_max", "reference.a_max")
    if dd.drive.travel is not None and "travel" not in sc and pole_pitch is not None:
        sc["travel"] = end_stops(pole_pitch, dd.drive.travel)
    if dd.startup is not None and sc.get("control", {}).get("mode") == "startup":
        put(sc.setdefault("startup", {}), *(k for k in keys if k.startswith("startup.")))
    return sc


def _put(keys: dict, section: dict, *names: str) -> dict:
    """``section`` with the design's values of the scenario keys ``names`` written into it."""
    section.update({n.rsplit(".", 1)[1]: written(keys, n) for n in names})
    return section


def _put_injection(inj: dict, keys: dict) -> None:
    """The design's ``[injection]``: amplitude and ramp, shape, and the shape's own keys."""
    _put(keys, inj, "injection.amplitude", "injection.ramp_rate")
    if keys["injection.shape"] != "pulsating":
        _put(keys, inj, "injection.shape")
    shape = inj.get("shape", "pulsating")
    if shape == "pulsating":  # (kappa is the pulsating/elliptical injection's own)
        _put(keys, inj, "injection.quadrature")
    else:
        inj.pop("quadrature", None)
    if shape == "square":  # (at f_pwm / 2, not a design choice)
        inj.pop("frequency", None)
    else:
        _put(keys, inj, "injection.frequency")


def _put_observer(obs: dict, keys: dict, table: str | None) -> None:
    """The design's ``[observer]``, its gains left to the bandwidth, a measured ``table`` if any."""
    _put(keys, obs, "observer.type", "observer.bandwidth_hz", "observer.demod_lpf_hz",
         "observer.gain_schedule", "observer.omega_max", "observer.hf_delay_s")
    for k in ("k1", "k2", "k3"):
        obs.pop(k, None)
    if table is not None:
        obs.update({"lut_model": "measured", "lut_file": table})
    if keys["observer.type"] == "mech":  # (the clamp of its load estimate; the PLL has none)
        _put(keys, obs, "observer.force_max")
    else:
        obs.pop("force_max", None)
    # the EMF estimate and its hand-over where the design runs it (else the keys' default: off; a
    # scenario's own emf = false kept)
    off = obs.get("emf") is False
    for k in HANDOVER_KEYS:
        obs.pop(k.split(".", 1)[1], None)
    if off:
        obs["emf"] = False
    elif keys.get("observer.emf"):
        _put(keys, obs, *HANDOVER_KEYS)


def _put_controller(con: dict, keys: dict) -> None:
    """The design's ``[controller]``: loop bandwidths, limits, position gain, and the motor
    file's friction and thrust ripple fed forward."""
    for k in ("speed_kp", "speed_ki", "current_kp", "current_ki"):
        con.pop(k, None)
    _put(keys, con, "controller.current_bandwidth_hz", "controller.speed_bandwidth_hz", "controller.i_max",
         "controller.v_max", "controller.step_a_max")
    if con.get("position_type", "p") == "p":
        _put(keys, con, "controller.kp_x")
    if "controller.rated_load" in keys:  # (the application's, given: the scenario's design takes it)
        _put(keys, con, "controller.rated_load")
    # the motor file's friction and thrust ripple, fed forward (only where it has them: the keys'
    # defaults are none)
    for k in ("friction_coulomb", "friction_viscous", "friction_band", "ripple_order", "ripple_cos",
              "ripple_sin"):
        con.pop(k, None)
    if keys["controller.friction_coulomb"] > 0.0 or keys["controller.friction_viscous"] > 0.0:
        _put(keys, con, "controller.friction_coulomb", "controller.friction_viscous",
             "controller.friction_band")
    if keys["controller.ripple_order"]:
        _put(keys, con, "controller.ripple_order", "controller.ripple_cos", "controller.ripple_sin")


def scenario_toml(made: DriveDesign, motor_spec: str, out: Path, base: dict | None = None,
                  base_dir: Path | None = None, table: str | None = None) -> str:
    """The scenario as TOML.

    A motor-file or table path (relative to ``base_dir``, default the working folder, as the command
    line gives it) is made relative to the output file's folder, and so is an absolute
    ``controller.model.motor`` of ``base``.

    Parameters
    ----------
    made : DriveDesign
        The drive's design (:func:`~linsense.tune.drive_design.design_drive`).
    motor_spec : str
        The motor as given (preset name or path).
    out : Path
        The output file.
    base : dict or None, optional
        The scenario's given keys.
    base_dir : Path or None, optional
        The folder a relative motor path is relative to.
    table : str or None, optional
        A measured table's file (:func:`scenario_dict`).

    Returns
    -------
    str
        The TOML text, with a comment line summarising the design.

    Raises
    ------
    linsense.errors.InputError
        For a ``made`` other than a DriveDesign (a plain Design: call ``design_drive``).
    """

    def relative(path: str) -> str:
        p = Path(path)
        if not p.is_absolute():
            p = (base_dir or working_folder()) / p
        return os.path.relpath(p.resolve(), Path(out).resolve().parent)

    ref = relative(motor_spec) if names_a_path(motor_spec) else motor_spec
    table = None if table is None else relative(table)
    dd = _drive_design(made, "scenario_toml")
    sc = scenario_dict(dd, motor_ref=ref, base=base, table=table)
    dz = dd.design
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


def design_values(dd: DriveDesign) -> Values:
    """The drive's design as the scenario keys of the mapping (:mod:`linsense.tune.cfgmap`), unrounded.

    What ``tune --format c`` writes: :meth:`~linsense.tune.drive_design.DriveDesign.scenario_keys`
    of the drive running its table (the controller believes the motor, with the end effect of a
    measured table); the start-up's lock error in radians as designed.

    Parameters
    ----------
    dd : DriveDesign
        The drive's design.

    Returns
    -------
    Values
        The keys, derived values and fields.
    """
    keys = dd.scenario_keys(uncompensated=False)
    derived = {"model.end_anisotropy": lambda v: end_anisotropy(dd.model),
               "model.emf_pm": lambda v: emf_pm_compensation(dd.model).cfg()}
    # (the keys the design leaves to the schema's defaults that a field reads: the force limits the
    # injection's d-current, designed, and the square wave's measures)
    inj = InjectionSection.model_fields
    for key in ("d_current", "dead_time_measures"):
        if f"injection.{key}" not in keys:
            derived[f"injection.{key}"] = inj[key].default
    fields = {} if dd.startup is None else {"startup.err_lock": dd.startup.err_lock}  # (rad: no round trip)
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


def c_header(made: DriveDesign, *, name: str | None = None, points: int = 256, unverified: str = "",
             verified_by: str = "") -> str:
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
    made : DriveDesign
        The drive's design (:func:`~linsense.tune.drive_design.design_drive`: its keys,
        :func:`design_values`; its motor, start-up and measured table, whose values are in the
        data's digest).
    name : str or None, optional
        The name in the symbols (default the motor's).
    points : int, optional
        Table points (a measured table's: as ``design_drive`` read it).
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
        For a ``made`` other than a DriveDesign (a plain Design: call ``design_drive``), a design
        without its motor, or an injection other than the pulsating/elliptical one.
    """
    dd = _drive_design(made, "c_header")
    if dd.motor is None:
        raise InputError(f"{_SRC}.c_header", "made", "the design has no motor (the header holds the "
                                                      "motor's tables): call design_drive with the motor")
    check_c_header(dd.drive)
    sym = c_config_name(name, dd.motor.name)  # (the stamp's and the digest's motor: the file's)
    digest = design_digest(dd.motor, dd.drive, points, dd.table)
    return (_c_head_comment(dd, sym, digest, _c_status(unverified, verified_by))
            + _c_tables_code(dd, sym, points, digest) + _c_function_code(dd, sym))


def _c_real(v: float) -> str:
    """A real constant of the C header, in the library's real type."""
    return f"LS_R({v:.9e})"


def _c_array(vals: np.ndarray) -> str:
    """The body of a C float array, four values a row."""
    rows = [", ".join(f"{v:.9e}f" for v in vals[i : i + 4]) for i in range(0, len(vals), 4)]
    return ",\n    ".join(rows)


def _c_status(unverified: str, verified_by: str) -> str:
    """The header comment's lines saying whether the drive passed its certificate."""
    import textwrap

    if unverified:
        said = textwrap.wrap("NOT VERIFIED: written with --unverified; " + c_comment_text(unverified), 96)
    else:
        said = textwrap.wrap("Verified: " + c_comment_text(verified_by), 96) if verified_by else []
    return "".join(f" * {ln}\n" for ln in said) + (" *\n" if said else "")


def _c_head_comment(dd: DriveDesign, sym: str, digest: str, status: str) -> str:
    """The header's opening comment: the drive, the design, how to use it, and the stamp."""
    dz, drive = dd.design, dd.drive
    fn, shown = f"ls_cfg_{sym}", c_comment_text(dd.motor.name)
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
"""


def _c_tables_code(dd: DriveDesign, sym: str, points: int, digest: str) -> str:
    """The header's guard, stamp macros and four tables: compensation, gain and their slopes in
    the resistance's scale."""
    dz, table = dd.design, dd.table
    fn, guard, prefix = f"ls_cfg_{sym}", f"LS_CFG_{sym.upper()}_H", f"LS_CFG_{sym.upper()}"
    lut = build_lut(dd.motor, points, f_inj=dz.f_inj, quad=dz.quad).values if table is None else table.values
    # (the rest of the drive's model takes the end effect a measured table says, as the simulator's
    # does: linsense.sim.drive_tables.measured_model)
    motor = dd.model
    lut_r = lut_r_slope(motor, points, dz.f_inj, dz.quad)
    gain = gain_schedule(motor, dz.f_inj, dz.quad, points)
    gain_r = gain_r_slope(motor, dz.f_inj, dz.quad, points)
    comp_what = ("with R_s" if table is None else
                 f"measured ({c_comment_text(Path(table.source).name)}, {table.stamp.points} points"
                 f"{', resampled' if table.resampled else ''})")
    return f"""#ifndef {guard}
#define {guard}

#include "linsense/ls_drive.h"

#define {sym.upper()}_LEN {points}u
{stamp_macros(prefix, digest)}
/* Psi_LUT (rad) over one electrical period for this injection, {comp_what} */
static const float {fn}_comp[{points}] = {{
    {_c_array(lut)}
}};

/* dPsi_LUT/dk_r (rad per unit of the resistance's scale): the table follows the resistance the
 * drive measures (ls_dtres_adapt, ls_demod_cfg.comp_r) */
static const float {fn}_comp_r[{points}] = {{
    {_c_array(lut_r)}
}};

/* demodulator gain (-) that makes the local error gain 1 everywhere */
static const float {fn}_gain[{points}] = {{
    {_c_array(gain)}
}};

/* dg/dk_r (-): the gain follows the measured resistance too */
static const float {fn}_gain_r[{points}] = {{
    {_c_array(gain_r)}
}};
"""


def _c_function_code(dd: DriveDesign, sym: str) -> str:
    """The header's ``ls_cfg_<sym>`` function, which fills an ``ls_drive_cfg`` with the design."""
    fn, guard, prefix = f"ls_cfg_{sym}", f"LS_CFG_{sym.upper()}_H", f"LS_CFG_{sym.upper()}"
    v = design_values(dd)
    rows = header_rows(dd.startup is not None)
    body = "\n".join(f"    cfg->{r.field} = {_c_real(v.field(r.field))};" for r in rows if r.kind != "count")
    body += "".join(f"\n    cfg->{r.field} = {int(v.field(r.field))}u;" for r in rows if r.kind == "count")
    bw = _c_real(v["observer.bandwidth_hz"])
    return f"""
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
    cfg->emf_on = {"true" if v.field("emf_on") else "false"}; /* the EMF estimate, the hand-over at speed */
    ls_observer_gains(&cfg->obs, {bw}); /* the library's rule for the bandwidth (Hz) */
    cfg->demod.comp = comp;
    cfg->demod.gain_table = gain;
    cfg->demod.comp_r = comp_r;
    cfg->demod.gain_r = gain_r;
}}

#endif /* {guard} */
"""

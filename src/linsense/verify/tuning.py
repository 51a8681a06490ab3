"""``tune``: a drive designed for a motor, written as a scenario or a C header, and verified.

What ``linsense tune`` does apart from reading its options and writing its files: the design
(:func:`linsense.tune.design_drive`), the scenario the simulator reads back, the certificate's runs
and the text of the scenario or of the C header, returned in a :class:`TuneResult`. It lives with
the certificate, above the simulator, because it runs the simulator; the design alone is
:mod:`linsense.tune`, below it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from linsense.errors import InputError, as_given
from linsense.io import Say, quiet, working_folder
from linsense.model.motor import Motor, load_motor, names_a_path
from linsense.scenario.load import Scenario, scenario_from_dict
from linsense.sim.build import build, compensation_of, drive_data, resolve_motor
from linsense.sim.cache import motor_key
from linsense.sim.drive_tables import lut_file_path, lut_file_via
from linsense.tune.design import (
    CURRENT_TRIP_MARGIN,
    OVERSPEED_MARGIN,
    RATIO_INJ_CURRENT,
    RATIO_LPF,
    SPEED_CAP_MARGIN,
    DriveData,
    limit_text,
)
from linsense.tune.drive_design import DriveDesign, design_drive
from linsense.tune.export import (
    c_config_name,
    c_header,
    check_c_header,
    design_digest,
    scenario_dict,
    scenario_toml,
)
from linsense.tune.handover import BAND_RATIO
from linsense.verify.certificate import (
    VERIFIED_BY,
    Certificate,
    certificate_base,
    failed_summary,
    motor_ref,
    prepare,
)

__all__ = ["FORMATS", "TuneResult", "design_lines", "handover_line", "motor_pitch", "scenario_table", "tune"]

#: what :func:`tune` writes: a complete scenario, or an ``ls_drive_cfg`` set-up header
FORMATS = ("toml", "c")


@dataclass
class TuneResult:
    """What :func:`tune` designed, wrote and verified.

    Attributes
    ----------
    made : DriveDesign
        The design (gains, start-up, table).
    motor : Motor
        The motor designed for.
    drive : DriveData
        The drive data the design used.
    fmt : str
        ``toml`` or ``c``.
    text : str or None
        The scenario TOML or the C header; None for a header refused (:attr:`refused`).
    scenario : dict
        The tuned scenario as a dict (what the TOML says).
    certificate : Certificate or None
        The verification (None when not run).
    digest : str
        The SHA-256 of the drive's data (the certificate's ``data_sha256``).
    unverified : str
        Why a C header written is not verified ("" when it is, and for a scenario).
    refused : str
        Why a C header was not made ("" when it was).
    warnings : list of str
        The design's warnings.
    files : list of Path
        The files written (:func:`~linsense.verify.tune_output.tune_to`; :func:`tune` writes none).
    """

    made: DriveDesign
    motor: Motor
    drive: DriveData
    fmt: str
    text: str | None
    scenario: dict
    certificate: Certificate | None = None
    digest: str = ""
    unverified: str = ""
    refused: str = ""
    warnings: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    @property
    def passed(self) -> bool | None:
        """Whether the certificate passed (None when it was not run)."""
        return None if self.certificate is None else bool(self.certificate.passed)

    def summary(self) -> dict:
        """The design in a JSON-ready dict (``linsense tune --json``).

        Returns
        -------
        dict
            The motor, the design, the start-up keys, the warnings (and the reason a header is
            unverified).
        """
        su = self.made.startup
        return {"motor": self.motor.name, "design": self.made.design.as_dict(),
                "startup": None if su is None else su.scenario_keys(),
                "warnings": list(self.warnings),
                **({"unverified": self.unverified} if self.unverified else {})}

    def certificate_doc(self, output: str = "-") -> dict:
        """The certificate's JSON (``<out>.verification.json``).

        Parameters
        ----------
        output : str, optional
            The output it certifies (its file name is recorded), ``-`` for standard output.

        Returns
        -------
        dict
            The certificate, the output, the motor, the drive data, the data's digest and the design.
        """
        if self.certificate is None:
            raise ValueError("no certificate: tune(..., verify=False)")
        doc = self.certificate.as_dict()
        doc.update(output=Path(output).name if output != "-" else "-", motor=self.motor.name,
                   drive={k: v for k, v in vars(self.drive).items()}, data_sha256=self.digest,
                   design={k: v for k, v in self.made.design.as_dict().items()
                           if k not in ("margins", "warnings")})
        return doc


def scenario_table(sc: Scenario) -> tuple[str, tuple[str, str, str]] | None:
    """The measured table a scenario's drive runs (``observer.lut_model = "measured"``), or None (the
    model's table).

    Parameters
    ----------
    sc : linsense.scenario.load.Scenario
        The scenario.

    Returns
    -------
    tuple or None
        The table's file as an absolute path, and where the scenario names it (the reader's ``via``:
        a refusal of the table names the scenario and ``observer.lut_file``, as ``simulate`` does).
    """
    if sc.spec.observer.lut_model != "measured":
        return None
    return str(lut_file_path(sc).resolve()), lut_file_via(sc)


def _motor_checked(motor: str, dd: DriveData, scenario: Scenario | None, fmt: str, name: str | None,
                   detail: Callable) -> Motor:
    """The motor loaded; the header's drive data and name, and the scenario's believed motor,
    checked before anything is designed or run (the C name never rewritten)."""
    if fmt == "c":
        check_c_header(dd)
    m = load_motor(motor)
    detail(f"motor {motor!r}: {m.source}")
    if scenario is not None:
        _same_believed_motor(scenario, m, motor)
    if fmt == "c":
        c_config_name(name, m.name, "--name")
    return m


def _designed(m: Motor, dd: DriveData, motor: str, base: dict | None, src: str, given: dict,
              say: Callable) -> tuple[DriveDesign, dict]:
    """The design (:func:`~linsense.tune.design_drive` with ``given``) and its scenario as a dict,
    read back as ``simulate`` reads it: tune never writes a scenario the simulator refuses."""
    # a drive run without its table (sensorless_nolut) gets its trips on the estimate wider
    mode = (base or {}).get("control", {}).get("mode", "sensorless_lut")
    no_table = compensation_of(mode, (base or {}).get("observer", {}).get("compensation")) == "none"
    made = design_drive(m, dd, source=src, uncompensated=no_table, **given)
    if (base or {}).get("observer", {}).get("emf") is False and made.handover is not None:
        # (the scenario's choice, kept: its band is not designed, the HF estimate carries every speed)
        made.handover = dataclasses.replace(made.handover, on=False, limit="observer.emf = false in the "
                                            "scenario: the HF estimate carries every speed")
    if made.table is not None:
        if made.table.note:
            say(f"  table          {made.table.note}")
        say(f"  table          {made.table_fit[0]}")
    table = given["table"]
    sc_dict = scenario_dict(made, motor_ref=motor, base=base,
                            table=None if table is None else str(Path(table).resolve()))
    _check_clamp(sc_dict, m, dd, src)
    build(scenario_from_dict(sc_dict, src, working_folder()))
    return made, sc_dict


def _check_clamp(sc: dict, m: Motor, dd: DriveData, src: str) -> None:
    """Refuse, naming ``v_max``, a design whose observer clamp (``observer.omega_max``: the speed cap,
    the over-speed trip and the clamp's margins over ``v_max``, wider without the table) the EMF
    estimate's period model cannot take (``LS_EMF_OMEGA_TS_MAX f_pwm``; the C library refused it
    naming ``observer.omega_max`` and ``emf.omega_max``, keys the user never gave)."""
    from linsense.ctrl import lib

    obs = sc.get("observer", {})
    w, f_pwm = float(obs.get("omega_max", 0.0)), float(sc["inverter"]["f_pwm"])
    per = float(lib.LS_EMF_OMEGA_TS_MAX)
    if not obs.get("emf") or w <= per * f_pwm:
        return
    ratio = w / (2.0 * math.pi * dd.v_max / m.pole_pitch)  # (the clamp over v_max, electrical)
    raise InputError(src, "v_max", f"{dd.v_max:g} m/s is beyond what {f_pwm:g} Hz PWM allows on a "
                     f"{m.pole_pitch * 1e3:g} mm pole pitch: the observer's speed clamp, {ratio:.3g} v_max "
                     f"(the speed cap, the over-speed trip and their margins), may turn the electrical angle "
                     f"by at most {per:g} rad per PWM period with the EMF estimate on: at most "
                     f"{limit_text(dd.v_max * per * f_pwm / w, False)} m/s, or a PWM rate of at least "
                     f"{limit_text(w / per, True)} Hz")


def _scenario_base(scenario: Scenario, base: dict, table: str | None,
                   say: Callable) -> tuple[str | None, tuple[str, str, str] | None]:
    """The scenario's keys kept (``base``, edited in place) and the table the drive runs: ``table``,
    else the scenario's measured table (its path and where the scenario names it)."""
    base.pop("motor", None)
    model = base.get("controller", {}).get("model", {})
    if names_a_path(model.get("motor", "")):  # (absolute here, relative to the output when written)
        model["motor"] = str((scenario.base_dir / model["motor"]).resolve())
    # the scenario's measured table is the drive's (``table`` over it): designed, verified and
    # written with it, its path made relative to the output again
    own_table = scenario_table(scenario)
    for key in ("lut_model", "lut_file"):
        base.get("observer", {}).pop(key, None)
    if table is None and own_table is not None:
        say(f"  table          the scenario's measured table {own_table[0]}")
        return own_table
    return table, None


def _header(res: TuneResult, cert_run: Callable[[], Certificate] | None, name: str | None, unverified: bool,
            say: Callable, ready: Callable | None) -> TuneResult:
    """The C header of ``res``, made once the certificate passed (or ``unverified``, saying why)."""
    res.certificate = None if cert_run is None else _certify(cert_run, say)
    cert = res.certificate
    reason = "not verified (--no-verify)" if cert is None else "" if cert.passed else failed_summary(cert)
    if reason and not unverified:
        res.refused = reason
        return res
    res.unverified = reason
    by = "" if reason else VERIFIED_BY[cert.quick]
    res.text = c_header(res.made, name=name, unverified=reason, verified_by=by)
    if ready is not None:
        ready(res)
    return res


def _drive_of(scenario: Scenario | None, drive: dict | None) -> DriveData:
    """The scenario's drive data (or the defaults) with ``drive``'s values over it."""
    dd = DriveData() if scenario is None else drive_data(scenario)
    names = [f.name for f in dataclasses.fields(DriveData)]
    for key, val in (drive or {}).items():
        if key not in names:
            raise InputError("drive", key, f"{val!r}: not a drive datum (one of {', '.join(names)})")
        setattr(dd, key, val)
    tr = None if scenario is None else scenario.spec.travel
    if dd.travel is not None and tr is not None and tr.bounded:
        stroke = (tr.max_mm - tr.min_mm) * 1e-3
        if abs(dd.travel - stroke) > 1e-9 * max(stroke, 1.0):
            # (the certificate's moves and end stops follow --travel, the scenario written keeps its own)
            raise InputError(scenario.source, "travel",
                             f"{dd.travel * 1e3:g} mm beside the scenario's [travel], {tr.min_mm:g} to "
                             f"{tr.max_mm:g} mm ({stroke * 1e3:g} mm of stroke): the certificate would judge "
                             "moves the written scenario's end stops do not hold; give the scenario's "
                             "stroke, or leave --travel out")
    return dd


def _other_motor(sc: Scenario | None, motor: Motor) -> str:
    """What tune says when the scenario was written for another motor than ``motor`` ('' when it was
    not): its drive data and keys, chosen for that motor, are designed here for this one (tune
    --motor k62 --scenario of k48 designed the 24 V motor on the 100 V, 4 A, 40 N drive without a
    word; the scenario it writes names --motor)."""
    if sc is None:
        return ""
    theirs = resolve_motor(sc, check=False)
    if motor_key(theirs) == motor_key(motor):
        return ""
    return (f"the scenario {sc.source} was written for the motor {theirs.name!r}: its drive data and keys "
            f"(bus, PWM, dead time, i_max, rated load, speed) are designed here for {motor.name!r} (--motor)")


def _same_believed_motor(sc: Scenario, motor: Motor, motor_spec: str) -> None:
    """Refuse a scenario whose drive believes in another motor (``controller.model.motor``) than the
    one tune designs it for: tune designs and certifies the drive believing in ``motor`` (the
    certificate's runs pin the model to it), so the scenario it wrote would run another drive than
    the one certified."""
    spec = sc.spec.controller.model.motor
    if spec is None:
        return
    believed = resolve_motor(sc, spec, "controller.model.motor", check=False)
    if motor_key(believed) != motor_key(motor):
        raise InputError(sc.source, "controller.model.motor",
                         f"{spec!r} ({believed.name}): the scenario's drive believes in another motor than "
                         f"the one tune designs and certifies it for, {motor_spec!r} ({motor.name}): remove "
                         f"the key, or give --motor {spec}")


def tune(motor: str, *, scenario: Scenario | None = None, source: str | None = None,
         drive: dict | None = None, fmt: str = "toml", name: str | None = None, polarity: float | None = None,
         current_noise: float = 0.01, table: str | None = None, quick: bool = False, verify: bool = True,
         unverified: bool = False, out: str | Path = "-", say: Say = quiet, warn: Say = quiet,
         detail: Say = quiet, ready: Callable[[TuneResult], object] | None = None,
         refusal: Callable[[InputError], InputError] = as_given, table_route: str = "calibrate",
         ) -> TuneResult:
    """Design the drive for a motor, make its scenario or C header, and verify it in the simulator.

    Nothing is written (:func:`~linsense.verify.tune_output.tune_to` writes the text and the
    certificate). Every refusal comes before the certificate runs.

    Parameters
    ----------
    motor : str
        The motor: a file, a preset or a packaged example's name.
    scenario, source : Scenario or None, str or None, optional
        A scenario whose drive data, measured table and other keys are kept; its name as the user
        gave it (default its file).
    drive : dict or None, optional
        Drive data over the scenario's (:class:`~linsense.tune.design.DriveData`'s names, SI units).
    fmt, name : str, str or None, optional
        ``toml`` (a complete scenario) or ``c`` (an ``ls_drive_cfg`` header); the C header's name
        suffix (default the motor's name).
    polarity, current_noise : float or None, float, optional
        Saturation data for the start-up pulses, 1/A (default the motor file's); current-sensor
        noise, A rms per phase.
    table : str or None, optional
        A measured compensation table (``lut_measured.json``) in place of the motor's (default the
        scenario's measured table, if any).
    quick, verify, unverified, table_route : bool, bool, bool, str, optional
        The quick certificate (the nominal plant only); run the certificate; ``c``: make the header
        even if it fails or is not run, saying why in it; how it measures the tables of the motors
        off by their end effect (``"calibrate"``: the encoder; ``"commission"``: without a sensor).
    out : str or pathlib.Path, optional
        Where the scenario will be written (its relative paths are made relative to it).
    say, warn, detail : callable, optional
        Called with each line of the report, each warning and each detail (the motor file read).
    ready, refusal : callable, optional
        Called with the result once its text is made (a scenario before the certificate runs, a
        header after it); maps a refusal of the drive data to the input the user typed.

    Returns
    -------
    TuneResult
        The design, the text, the certificate.

    Raises
    ------
    InputError
        Drive data, a table or a scenario the design, the header or the simulator refuses.
    """
    if fmt not in FORMATS:
        raise InputError("format", "", f"{fmt!r}: one of {', '.join(FORMATS)}")
    base, base_dir, src, table_via = None, None, motor, None
    if scenario is not None:
        base, base_dir, src = scenario.given(), scenario.base_dir, source or scenario.source
        table, table_via = _scenario_base(scenario, base, table, say)
    dd = _drive_of(scenario, drive)
    m = _motor_checked(motor, dd, scenario, fmt, name, detail)
    table_abs = None if table is None else str(Path(table).resolve())
    given = {"polarity": polarity, "current_noise": current_noise, "table": table, "table_via": table_via}
    try:
        made, sc_dict = _designed(m, dd, motor, base, src, given, say)
    except InputError as exc:  # (the drive data refused: named at the input the user typed)
        raise refusal(exc) from None
    # (the certificate's runs are built before anything is made: a refusal leaves no file)
    cert_run = prepare(m, motor_ref(motor), certificate_base(sc_dict), str(base_dir or working_folder()),
                       v_max=dd.v_max, a_max=dd.a_max, load=made.design.load, travel=dd.travel, quick=quick,
                       table_route=table_route) if verify else None
    mode = (base or {}).get("control", {}).get("mode", "sensorless_lut")
    _report(made, m, dd, say, warn, mode if verify else "", other := _other_motor(scenario, m))
    res = TuneResult(made, m, dd, fmt, None, sc_dict, digest=design_digest(m, dd, 256, made.table),
                     warnings=list(made.warnings) + ([other] if other else []))
    if fmt == "c":  # (the header waits for the verdict: made only for a drive that passed)
        return _header(res, cert_run, name, unverified, say, ready)
    res.text = scenario_toml(made, motor, Path(out), base, working_folder(), table=table_abs)
    (ready or quiet)(res)
    res.certificate = None if cert_run is None else _certify(cert_run, say)
    return res


def _report(made: DriveDesign, m: Motor, dd: DriveData, say: Callable, warn: Callable, mode: str,
            other: str = "") -> None:
    """Say the design, its start-up and its warnings, ``other`` the scenario's other motor's
    (:func:`_other_motor`; and that the certificate judges the sensorless drive, not the scenario's
    control ``mode``, when it runs)."""
    for line in design_lines(made.design, m.name, dd, made.handover):
        say(line)
    if made.startup is not None:
        for line in made.startup.lines():
            say(line)
    else:
        say("  start-up       not designed: no saturation data (--polarity, or [saturation] polarity "
            "in the motor file)")
    for w in [*made.warnings, *([other] if other else [])]:
        warn(w)
    if mode not in ("", "sensorless_lut"):
        say(f"  (the certificate judges the designed sensorless drive with its table, not control.mode = "
            f"{mode!r} of the scenario)")


def _certify(cert_run: Callable[[], Certificate], say: Callable) -> Certificate:
    """Run the prepared certificate and say it."""
    cert = cert_run()
    for line in cert.lines():
        say(line)
    return cert


def motor_pitch(dd: DriveData, dz) -> float:
    """m/s per electrical rad/s of the design (from its speed cap and trip).

    Parameters
    ----------
    dd : DriveData
        The drive data.
    dz : Design
        The design.

    Returns
    -------
    float
        m/s per rad/s (NaN without a trip).
    """
    return dz.v_cap * OVERSPEED_MARGIN / dz.omega_trip if dz.omega_trip else float("nan")


def handover_line(hand, dz) -> str:
    """The hand-over's line of the design (what sets the band, the fade and the speed cap).

    Parameters
    ----------
    hand : HandoverDesign
        The hand-over (:func:`linsense.tune.handover.design_handover`).
    dz : Design
        The design (its speed cap and the bus's room beside the injection).

    Returns
    -------
    str
        The line.
    """
    if not hand.on:
        return f"  hand-over      off: {hand.limit}"
    return (f"  hand-over      the HF estimate alone up to {hand.v_lo:.3g} m/s, the EMF estimate alone from "
            f"{hand.v_hi:.3g} m/s ({hand.limit}; v_lo = v_hi / {BAND_RATIO:g}), its low-pass "
            f"{hand.f_lpf:.4g} Hz; the injection fades out above {hand.v_off:.3g} m/s and back in below "
            f"{hand.v_on:.3g} m/s (settled {hand.t_settle * 1e3:.2g} ms before v_hi at a_max), leaving the "
            f"fundamental the whole bus (the speed cap {dz.v_cap:.3g} m/s)")


def design_lines(dz, motor_name: str, dd, hand=None) -> list[str]:
    """The design as a person reads it.

    Parameters
    ----------
    dz : Design
        The design.
    motor_name : str
        The motor's name.
    dd : DriveData
        The drive data.
    hand : HandoverDesign or None, optional
        The hand-over (:attr:`linsense.tune.drive_design.DriveDesign.handover`); None: no line.

    Returns
    -------
    list of str
        The report's lines.
    """
    lines = [
        f"design for {motor_name}: {dd.v_dc:g} V bus, {dd.f_pwm:g} Hz PWM, "
        f"{dd.dead_time * 1e6:g} us dead time, "
        f"i_max {dd.i_max:g} A",
        (f"  injection      {dz.v_inj:.4g} V at {dz.f_inj:g} Hz on d, kappa {dz.quad:g} on q: HF current "
         f"{dz.i_hf:.3g} A; fundamental fits up to {dz.headroom_speed:.3g} m/s at the application's current"
         if dd.shape == "pulsating" else
         f"  injection      {dd.shape}, {dz.v_inj:.4g} V"
         f"{' at f_pwm / 2' if dd.shape == 'square' else f' at {dz.f_inj:g} Hz'} (the loops below are "
         f"designed as for {dz.f_inj:g} Hz); fundamental fits up to {dz.headroom_speed:.3g} m/s"),
        f"  current loop   {dz.current_bw:.4g} Hz (f_inj / {RATIO_INJ_CURRENT:g}): "
        f"kp {dz.current_kp:.4g} V/A, "
        f"ki {dz.current_ki:.4g} V/(A s)",
        f"  demodulator    low-pass {dz.demod_lpf:.4g} Hz ({RATIO_LPF:g} f_inj), "
        f"zeros at {dz.demod_notch:g} Hz; gain "
        f"{dz.demod_gain:.4g}, scheduled (local error gain {dz.k_e_min:.2f}..{dz.k_e_max:.2f} unscheduled)",
        f"  observer       {dz.observer_bw:.4g} Hz "
        + ("mechanical, its load estimate fed forward" if dz.load_ff else dz.observer_type.upper())
        + f" (limited by {dz.limits.get('observer', '')})"
        + (f"; the HF path's delay {dz.hf_delay * 1e3:.3g} ms compensated (1 / f_inj)"
           if dz.hf_delay > 0 else ""),
        *([handover_line(hand, dz)] if hand is not None else []),
        f"  speed loop     {dz.speed_bw:.4g} Hz ({dz.limits.get('speed loop', '')}): "
        f"kp {dz.speed_kp:.4g} N s/m, "
        f"ki {dz.speed_ki:.4g} N/m"
        + (" (the encoder modes'; 0 sensorless: the load estimate)" if dz.load_ff else ""),
        f"  position loop  kp_x {dz.kp_x:.4g} 1/s ({dz.limits.get('position loop', '')})",
        f"  steps          {dz.limits.get('steps', '')}",
        f"  limits         speed cap {dz.v_cap:.3g} m/s ({SPEED_CAP_MARGIN:g} v_max), over-speed trip "
        f"{dz.omega_trip:.4g} rad/s ({dz.omega_trip * motor_pitch(dd, dz) :.3g} m/s), observer clamp "
        f"{dz.omega_obs:.4g} rad/s, over-current trip {dz.i_trip:.3g} A ({CURRENT_TRIP_MARGIN:g} x (i_max "
        f"+ HF "
        f"peak)); rated load {dz.load:.3g} N"
        + ("" if dz.force_i_max_share >= 1.0 else
           f"; the force at i_max {dz.force_i_max:.3g} N, {dz.force_i_max_why}"),
        f"  injection rule {dz.limits.get('injection', '')}",
        f"  calibration    dither {dz.dither_a:.3g} A at {dz.dither_hz:.4g} Hz",
        "  margins (linearised model: phase margin, gain margin up / down (none: no gain limits it), "
        "crossover):",
    ]
    def gm(v) -> str:  # (None: no phase crossing, no gain limits the loop that way)
        return "none" if v is None else f"{v} dB"

    for k, m in dz.margins.items():
        lines.append(f"    {k:48s} {m['pm_deg']} deg, {gm(m['gm_up_db'])} / {gm(m['gm_down_db'])}, "
                     f"{m['crossover_hz']} Hz")
    if dz.tolerances:
        lines.append("  tolerances (model: worst hold error with the nominal LUT; scheduled error gain):")
        for k, t in dz.tolerances.items():
            lines.append(f"    {k:48s} {t['error_deg']:.3g} deg, k_e {t['k_lo']:.2f}..{t['k_hi']:.2f}")
    return lines

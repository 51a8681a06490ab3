"""``linsense tune``: the drive designed for a motor, its report and its verification certificate."""

from __future__ import annotations

import os
from pathlib import Path

import click

from linsense.cli import _common as c
from linsense.cli.runs import (
    application_options,
    apply_drive_data,
    drive_options,
    drive_refusal,
    scenario_arg,
    scenario_table,
)
from linsense.errors import InputError
from linsense.io import NAME_MAX, working_folder
from linsense.version import docs


@click.command(short_help="Design the drive for a motor and verify it.",
               epilog=c.see("tuning"))
@click.option("--motor", "motor_spec", required=True, help=c.MOTOR_HELP)
@click.option("--scenario", "scenario_path", default=None,
              help="scenario (a file or a packaged example's name) whose drive data (bus, PWM, dead "
                   "time, i_max, injection) and other keys are kept")
@drive_options
@click.option("--quad", type=float, default=None, callback=c.quad,
              help="elliptical share kappa on q (0: pulsating; default 0.9)")
@click.option("--format", "fmt", type=click.Choice(["toml", "c"]), default="toml", show_default=True,
              help="toml: a complete scenario; c: an ls_drive_cfg set-up header for the firmware")
@click.option("--polarity", type=float, default=None, callback=c.finite(0.0, True),
              help="saturation data for the start-up pulses, 1/A: (L_d(-I) - L_d(+I)) / L_d per A of d "
                   "pulse (polarity.csv of linsense fea --polarity: rel / I); default: the motor file's "
                   "[saturation] polarity, else no start-up design")
@click.option("--current-noise", type=float, default=0.01, show_default=True, callback=c.finite(0.0, False),
              help="current-sensor noise, A rms per phase (a 12-bit ADC over +-10 A on top), for the "
                   "pulse pairs")
@click.option("--name", default=None, help="C name suffix (default: the motor name)")
@application_options
@click.option("--injection", "shape", type=click.Choice(["pulsating", "rotating", "square"]), default=None,
              help="the injection: pulsating/elliptical (default; kappa --quad), rotating vector, or "
                   f"square wave at f_pwm / 2 with its dead-time measures ({docs('firmware')})")
@click.option("--table", "table_path", default=None, type=click.Path(dir_okay=False), callback=c.not_empty,
              help="a measured compensation table (lut_measured.json of linsense calibrate) in place of "
                   "the motor file's: checked against the motor and the injection, resampled if its "
                   "grid differs")
@click.option("--quick", is_flag=True, help="verify the nominal plant only (holds at 8 positions, the steps, "
              "moves at +-rated load)")
@click.option("--no-verify", is_flag=True, help="do not run the verification (not with --format c: a C "
              "header is written only for a verified drive, or with --unverified)")
@click.option("--unverified", is_flag=True, help="--format c: write the header even if the certificate "
              "fails, with the reason in its comment and in the JSON")
@c.out_option("tune", "motor", folder=False, ext=".toml or .h", dash=True)
@c.json_option
def tune(motor_spec: str, scenario_path: str | None, quad, fmt: str, polarity: float | None,
         current_noise: float, name: str | None, v_max, a_max, load, travel, shape, table_path,
         quick: bool, no_verify: bool, unverified: bool, out: str | None, as_json: bool, **drive) -> None:
    """Design the drive for a motor: injection, current loop, demodulator, observer, speed and
    position loops, limits and trips; print the design and its margins; write a
    scenario or a C header; then verify it in the simulator (switching inverter with dead time) and
    write verification.json and verification.png beside the output (exit 1 if a check fails). A C
    header is written only for a drive that passes (--unverified: anyway, saying why in it)."""
    from linsense.io import write_atomic
    from linsense.model.motor import names_a_path
    from linsense.sim.build import compensation_of, drive_data
    from linsense.tune.design import DriveData
    from linsense.tune.drive_design import design_drive
    from linsense.tune.export import c_header, check_c_header, design_digest, scenario_dict, scenario_toml

    if as_json and out == "-":
        raise click.UsageError("--json and --out - both write to standard output: give --out a file")
    if fmt == "c" and no_verify and not unverified:
        raise click.UsageError("--format c writes a header only for a verified drive: drop --no-verify "
                               "(or give --unverified to write it unverified)")
    if unverified and fmt != "c":
        raise click.UsageError("--unverified is for --format c (a scenario is written whatever the "
                               "certificate says)")
    if name is not None and fmt != "c":  # (not ignored with a scenario)
        raise click.UsageError("--name names the C header's symbols: only with --format c")
    if as_json or out == "-":
        c.data_on_stdout()  # (stdout carries the file itself, or the JSON summary)
    out = c.default_out(out, motor_spec, "tune", ".h" if fmt == "c" else ".toml")
    json_path, png_path = _certificate_paths(out)  # (their names checked before the work)
    _own_certificate(out)
    say = c.say
    base, base_dir, src, table_via, sc = None, None, motor_spec, None, None
    dd = DriveData()
    if scenario_path is not None:
        sc = scenario_arg(scenario_path, "--scenario")
        base, base_dir, src = sc.given(), sc.base_dir, scenario_path
        base.pop("motor", None)
        model = base.get("controller", {}).get("model", {})
        if names_a_path(model.get("motor", "")):  # (absolute here, relative to the output when written)
            model["motor"] = str((sc.base_dir / model["motor"]).resolve())
        dd = drive_data(sc)
        # the scenario's measured table is the drive's (--table over it): designed, verified and
        # written with it, its path made relative to the output again
        own_table = scenario_table(sc)
        for key in ("lut_model", "lut_file"):
            base.get("observer", {}).pop(key, None)
        if table_path is None and own_table is not None:
            table_path, table_via = own_table
            say(f"  table          the scenario's measured table {table_path}")
    typed = apply_drive_data(dd, drive, quad, v_max, a_max, load, travel, shape)
    if fmt == "c":
        check_c_header(dd)
    motor = c.load(motor_spec)
    if sc is not None:
        _same_believed_motor(sc, motor, motor_spec)
    if fmt == "c":  # (the C name checked, never rewritten, before anything is designed or run)
        from linsense.tune.export import c_config_name

        c_config_name(name, motor.name, "--name")
    # a drive run without its table (sensorless_nolut) gets its trips on the estimate wider
    mode = (base or {}).get("control", {}).get("mode", "sensorless_lut")
    no_table = compensation_of(mode, (base or {}).get("observer", {}).get("compensation")) == "none"
    try:
        made = design_drive(motor, dd, source=src, polarity=polarity, current_noise=current_noise,
                            uncompensated=no_table, table=table_path, table_via=table_via)
    except InputError as exc:  # (with a scenario: the option typed, or the scenario's key)
        raise exc if sc is None else drive_refusal(exc, typed, sc, src) from None
    dz, su, table = made.design, made.startup, made.table
    if table is not None:
        if table.note:
            say(f"  table          {table.note}")
        say(f"  table          {made.table_fit[0]}")
    table_abs = None if table_path is None else str(Path(table_path).resolve())
    sc_dict = scenario_dict(made, motor_ref=motor_spec, base=base, table=table_abs)
    _read_back(sc_dict, src, typed, sc)
    cert_run = None
    if not no_verify:  # (its runs are built before anything is written: a refusal leaves no file)
        from linsense.verify.certificate import certificate_base, motor_ref, prepare

        cert_run = prepare(motor, motor_ref(motor_spec), certificate_base(sc_dict),
                           str(base_dir or working_folder()), v_max=dd.v_max, a_max=dd.a_max, load=dz.load,
                           travel=dd.travel, quick=quick)
    for line in design_lines(dz, motor.name, dd):
        say(line)
    if su is not None:
        for line in su.lines():
            say(line)
    else:
        say("  start-up       not designed: no saturation data (--polarity, or [saturation] polarity "
            "in the motor file)")
    warnings = made.warnings
    for w in warnings:
        c.warn(w)
    if mode != "sensorless_lut" and not no_verify:
        say(f"  (the certificate judges the designed sensorless drive with its table, not control.mode = "
            f"{mode!r} of the scenario)")
    files: list = []
    cert = None
    digest = design_digest(motor, dd, 256, table)
    reason = ""
    if fmt == "c":  # (the header waits for the verdict: written only for a drive that passed)
        from linsense.verify.certificate import VERIFIED_BY, failed_summary

        if cert_run is not None:  # (its files written with the header only: a refusal leaves the
            # earlier output set, header and certificate, as it was)
            cert = _run_certificate(cert_run)
        reason = "not verified (--no-verify)" if cert is None else "" if cert.passed else failed_summary(cert)
        if reason and not unverified:
            c.elapsed()
            if as_json:
                verification = {k: v for k, v in cert.as_dict().items() if k != "runs"}
                c.emit_json("tune", files, False, verification=verification, refused=reason)
            c.warn(f"{out} not written: {reason} (--unverified writes it anyway)")
            raise click.exceptions.Exit(1)
        by = "" if reason else VERIFIED_BY[cert.quick]
        text = c_header(made, name=name, unverified=reason, verified_by=by)
        if cert is not None:
            _write_certificate(cert, motor, dd, dz, quick, json_path, png_path, files, digest, out)
    else:
        text = scenario_toml(made, dd, motor_spec, Path(out), base, working_folder(), table=table_abs)
    files.insert(0, write_atomic(out, text))
    if out != "-":
        say(str(files[0]))
    summary = {"motor": motor.name, "design": dz.as_dict(),
               "startup": None if su is None else su.scenario_keys(),
               "warnings": list(warnings), **({"unverified": reason} if reason else {})}
    if cert_run is None:
        for p in (json_path, png_path):  # (a certificate of an earlier design would be stale)
            p.unlink(missing_ok=True)
        c.elapsed()
        if as_json:
            c.emit_json("tune", files, None, verification=None, **summary)
        return
    if cert is None:
        cert = _run_certificate(cert_run)
        _write_certificate(cert, motor, dd, dz, quick, json_path, png_path, files, digest, out)
    c.elapsed()
    if as_json:
        verification = {k: v for k, v in cert.as_dict().items() if k != "runs"}
        c.emit_json("tune", files, bool(cert.passed), verification=verification, **summary)
    if not cert.passed:
        raise click.exceptions.Exit(1)


def _same_believed_motor(sc, motor, motor_spec: str) -> None:
    """Refuse a scenario whose drive believes in another motor (``controller.model.motor``) than the
    one tune designs it for: tune designs and certifies the drive believing in ``--motor`` (the
    certificate's runs pin the model to it), so the scenario it wrote would run another drive than
    the one certified."""
    from linsense.sim.build import resolve_motor
    from linsense.sim.cache import motor_key

    spec = sc.spec.controller.model.motor
    if spec is None:
        return
    believed = resolve_motor(sc, spec, "controller.model.motor", check=False)
    if motor_key(believed) != motor_key(motor):
        raise InputError(sc.source, "controller.model.motor",
                         f"{spec!r} ({believed.name}): the scenario's drive believes in another motor than "
                         f"the one tune designs and certifies it for, {motor_spec!r} ({motor.name}): remove "
                         f"the key, or give --motor {spec}")


def _read_back(sc_dict: dict, src: str, typed: set, sc) -> None:
    """Read the scenario tune writes back as ``linsense simulate`` reads it (its checks and build),
    before anything is designed further, run or written: tune never writes a scenario the simulator
    refuses (the scenario's own keys kept over a changed drive, such as a protection's bus range
    tuned for another bus). A refusal names the input as :func:`drive_refusal` does."""
    from linsense.sim.build import build
    from linsense.sim.scenario import scenario_from_dict

    try:
        build(scenario_from_dict(sc_dict, src, working_folder()))
    except InputError as exc:
        raise exc if sc is None else drive_refusal(exc, typed, sc, src) from None


def _certificate_paths(out: str) -> tuple[Path, Path]:
    """``<out stem>.verification.json`` and ``.png`` beside the output file (in the working folder
    for ``-`` or a device such as /dev/null)."""
    p = Path(out)
    if out == "-" or (p.exists() and not p.is_file()):
        folder, stem = working_folder(), "tune"
    else:
        folder, stem = p.resolve().parent, p.stem
        name = f"{stem}.verification.json"
        if len(os.fsencode(name)) > NAME_MAX:  # (its write failed after the work, the scenario written)
            from linsense.errors import InputError

            raise InputError("--out", "", f"{out!r}: the certificate written beside it, the name's stem and "
                             f"'.verification.json', would be a file name of {len(os.fsencode(name))} bytes, "
                             f"beyond the {NAME_MAX} bytes of a file name: give a shorter --out")
    return folder / f"{stem}.verification.json", folder / f"{stem}.verification.png"


def _own_certificate(out: str) -> None:
    """Refuse an output whose certificate files (``<stem>.verification.json``, ``.png``) are another
    output's: ``tune --format c --out a.h`` then ``tune --no-verify --out a.toml`` deleted the
    header's certificate, and a verified ``--out a.toml`` replaced it, without a word. A certificate
    names the output it certifies (its ``output``); one of another output is left alone (exit 2,
    before anything runs). One without the key (an earlier linsense's) is this output's."""
    import json

    json_path, _ = _certificate_paths(out)
    try:
        owner = json.loads(json_path.read_text(encoding="utf-8")).get("output")
    except (OSError, ValueError, AttributeError):  # (none, or not a certificate: nothing to keep)
        return
    mine = Path(out).name if out != "-" else "-"
    if isinstance(owner, str) and owner != mine:
        raise InputError(str(json_path), "output", f"{owner!r}: this is the certificate of {owner}, which "
                         f"--out {out} would replace (or delete, with --no-verify): give --out another name "
                         f"than {owner}'s stem")


def _run_certificate(cert_run):
    """Run the prepared certificate and print it."""
    cert = cert_run()
    for line in cert.lines():
        c.say(line)
    return cert


def _write_certificate(cert, motor, dd, dz, quick: bool, json_path: Path, png_path: Path, files: list,
                       digest: str = "", output: str = "-") -> None:
    """Write the certificate's JSON and figure (appended to ``files``); the JSON names the ``output``
    it certifies (:func:`_own_certificate`)."""
    import json

    from linsense.io import write_atomic
    from linsense.report.figures import save_png
    from linsense.report.verify_figures import certificate_figure

    doc = cert.as_dict()
    doc.update(output=Path(output).name if output != "-" else "-", motor=motor.name,
               drive={k: v for k, v in vars(dd).items()}, data_sha256=digest,
               design={k: v for k, v in dz.as_dict().items() if k not in ("margins", "warnings")})
    files.append(write_atomic(json_path, json.dumps(doc, indent=1, sort_keys=True) + "\n"))
    c.say(str(files[-1]))
    fig = certificate_figure(cert.rows, f"{motor.name}: {cert.verdict()}", quick=quick,
                             calibrations=cert.extra.get("calibrations"))
    files.append(save_png(fig, png_path, 100))
    c.say(str(files[-1]))


def motor_pitch(dd, dz) -> float:
    """m/s per electrical rad/s of the design (from its speed cap and trip)."""
    from linsense.tune.design import OVERSPEED_MARGIN

    return dz.v_cap * OVERSPEED_MARGIN / dz.omega_trip if dz.omega_trip else float("nan")


def design_lines(dz, motor_name: str, dd) -> list[str]:
    """The design as a person reads it."""
    from linsense.tune.design import (  # noqa: F401 (the printed ratios)
        CURRENT_TRIP_MARGIN,
        RATIO_INJ_CURRENT,
        RATIO_LPF,
        SPEED_CAP_MARGIN,
    )
    lines = [
        f"design for {motor_name}: {dd.v_dc:g} V bus, {dd.f_pwm:g} Hz PWM, "
        f"{dd.dead_time * 1e6:g} us dead time, "
        f"i_max {dd.i_max:g} A",
        (f"  injection      {dz.v_inj:.4g} V at {dz.f_inj:g} Hz on d, kappa {dz.quad:g} on q: HF current "
         f"{dz.i_hf:.3g} A; fundamental fits up to {dz.headroom_speed:.3g} m/s at i_max"
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
        f"peak)); rated load {dz.load:.3g} N",
        f"  injection rule {dz.limits.get('injection', '')}",
        f"  calibration    dither {dz.dither_a:.3g} A at {dz.dither_hz:.4g} Hz",
        "  margins (linearised model: phase margin, gain margin up / down, crossover):",
    ]
    for k, m in dz.margins.items():
        lines.append(f"    {k:48s} {m['pm_deg']} deg, {m['gm_up_db']} dB / {m['gm_down_db']} dB, "
                     f"{m['crossover_hz']} Hz")
    if dz.tolerances:
        lines.append("  tolerances (model: worst hold error with the nominal LUT; scheduled error gain):")
        for k, t in dz.tolerances.items():
            lines.append(f"    {k:48s} {t['error_deg']:.3g} deg, k_e {t['k_lo']:.2f}..{t['k_hi']:.2f}")
    return lines



COMMANDS = [tune]

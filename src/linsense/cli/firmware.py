"""``linsense firmware``: the C controller library as a firmware project takes it (``export``)."""

from __future__ import annotations

import click

from linsense.cli import _common as c
from linsense.cli.runs import (
    application_options,
    apply_drive_data,
    drive_options,
    drive_refusal,
    scenario_arg,
)
from linsense.errors import InputError
from linsense.io import working_folder


@click.group(short_help="The firmware: export a project that builds with CMake.",
             epilog=c.see("firmware"))
def firmware() -> None:
    """The C controller library as a firmware project takes it."""


@firmware.command(short_help="Write a self-contained firmware project for a motor.",
                  epilog=c.see("firmware"))
@click.argument("folder", type=click.Path(file_okay=False), callback=c.folder_out)
@click.option("--motor", "motor_spec", required=True, help=c.MOTOR_HELP)
@click.option("--scenario", "scenario_path", default=None,
              help="scenario (a file or a packaged example's name) whose drive data (bus, PWM, dead "
                   "time, i_max, injection) the design takes, as linsense tune does")
@drive_options
@application_options
@click.option("--quad", type=float, default=None, callback=c.quad,
              help="elliptical share kappa on q (0: pulsating; default 0.9)")
@click.option("--name", default=None, help="C name suffix of ls_cfg_<name>.h (default: the motor name)")
@click.option("--table", "table_path", default=None, type=click.Path(dir_okay=False), callback=c.not_empty,
              help="a measured compensation table (lut_measured.json of linsense calibrate) in place of "
                   "the motor file's")
@click.option("--unverified", is_flag=True,
              help="write the project even if the quick certificate fails (the reason in the header's "
                   "comment and the JSON)")
@c.json_option
def export(folder: str, motor_spec: str, scenario_path: str | None, name: str | None, table_path: str | None,
           unverified: bool, as_json: bool, quad, v_max, a_max, load, travel, **drive) -> None:
    """Write FOLDER: the C library's sources and headers with its CMake package, the drive's
    configuration designed for the motor, its drive and application (ls_cfg_<name>.h, as linsense
    tune --format c writes it with the same options), an example main.c with a synthetic motor, a
    CMakeLists.txt and the Cortex-M4F toolchain file.
    `cmake -S FOLDER -B b && cmake --build b` builds it on the host, with
    -DCMAKE_TOOLCHAIN_FILE=FOLDER/cmake/arm-none-eabi-m4f.cmake for the Cortex-M4F; nothing in it
    refers to a file outside FOLDER. FOLDER must be missing, empty or an earlier output of linsense
    (files it did not write, such as a build folder, are kept). The drive is verified first (the
    quick certificate of linsense tune --quick, switching inverter with dead time): a drive that
    fails is not written (exit 1, naming the failed checks) unless --unverified."""
    from linsense.firmware.project import firmware_files, write_firmware
    from linsense.tune.design import DriveData
    from linsense.verify.certificate import VERIFIED_BY, failed_summary

    if as_json:
        c.data_on_stdout()
    dd, src, table_via, sc = DriveData(), motor_spec, None, None
    if scenario_path is not None:
        from linsense.sim.build import drive_data
        from linsense.verify.tuning import scenario_table

        sc = scenario_arg(scenario_path, "--scenario")
        dd = drive_data(sc)
        src = scenario_path
        own_table = scenario_table(sc)
        if table_path is None and own_table is not None:  # (the scenario's measured table is the
            # drive's; --table over it)
            table_path, table_via = own_table
    typed = apply_drive_data(dd, drive, quad, v_max, a_max, load, travel)
    motor = c.load(motor_spec)
    from linsense.tune.export import c_config_name

    c_config_name(name, motor.name, "--name")  # (checked before anything is designed, never rewritten)
    try:
        made = firmware_files(motor, dd, src, name, table=table_path, table_via=table_via)
    except InputError as exc:  # (with a scenario: the option typed, or the scenario's key)
        raise exc if sc is None else drive_refusal(exc, typed, sc, src) from None
    for line in made.lines:
        c.say(line)
    for w in made.warnings:
        c.warn(w)
    cert = _quick_certificate(motor_spec, motor, dd, made, table_path)
    lines = cert.lines()
    if cert.passed:  # (the export's own check: the quick certificate; tune --format c runs the full one)
        lines[-1] = ("quick certificate passed: written (linsense tune --format c runs the full "
                     "certificate of the same drive)")
    for line in lines:
        c.say(line)
    reason = "" if cert.passed else failed_summary(cert)
    if reason and not unverified:
        c.elapsed()
        if as_json:
            c.emit_json("firmware export", [], False, motor=made.motor, name=made.name, digest=made.digest,
                        certificate="quick", refused=reason)
        c.warn(f"{folder} not written: {reason} (--unverified writes it anyway)")
        raise click.exceptions.Exit(1)
    made = made.certified(reason, "" if reason else VERIFIED_BY[True])
    files = write_firmware(folder, made)
    c.files_report(files)
    c.elapsed()
    if as_json:
        c.emit_json("firmware export", files, not reason, motor=made.motor, name=made.name,
                    digest=made.digest, certificate="quick", **({"unverified": reason} if reason else {}))


def _quick_certificate(motor_spec: str, motor, dd, made, table_path: str | None):
    """The quick certificate of the exported drive (the design ``made`` holds, with its table)."""
    from pathlib import Path

    from linsense.tune.export import scenario_dict
    from linsense.verify.certificate import certificate_base, motor_ref, prepare

    spec = motor_ref(motor_spec)
    table = None if table_path is None else str(Path(table_path).resolve())
    base = certificate_base(scenario_dict(made.drive_design, motor_ref=spec, table=table))
    return prepare(motor, spec, base, str(working_folder()), v_max=dd.v_max, a_max=dd.a_max,
                   load=made.design.load, travel=dd.travel, quick=True)()


COMMANDS = [firmware]

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
    from linsense.firmware.verified_export import export_firmware
    from linsense.tune.design import DriveData

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
    def refusal(exc):  # (with a scenario: the option typed, or the scenario's key)
        return exc if sc is None else drive_refusal(exc, typed, sc, src)

    res = export_firmware(folder, c.load(motor_spec), dd, motor_spec=motor_spec, source=src, name=name,
                          table=table_path, table_via=table_via, unverified=unverified, say=c.say,
                          warn=c.warn, refusal=refusal)
    made, reason = res.export, res.reason
    if res.written:
        c.files_report(res.files)
    c.elapsed()
    if as_json:
        outcome = ({"refused": reason} if not res.written else {"unverified": reason} if reason else {})
        c.emit_json("firmware export", res.files, res.written and not reason, motor=made.motor,
                    name=made.name, digest=made.digest, certificate="quick", **outcome)
    if not res.written:
        c.warn(f"{folder} not written: {reason} (--unverified writes it anyway)")
        raise click.exceptions.Exit(1)


COMMANDS = [firmware]

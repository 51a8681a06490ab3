"""``linsense firmware``: the C controller library as a firmware project takes it (``export``)."""

from __future__ import annotations

import click

from linsense.cli import _common as c


@click.group(short_help="The firmware: export a project that builds with CMake.",
             epilog=c.see("firmware"))
def firmware() -> None:
    """The C controller library as a firmware project takes it."""


@firmware.command(short_help="Write a self-contained firmware project for a motor.",
                  epilog=c.see("firmware"))
@click.argument("folder", type=click.Path(file_okay=False))
@click.option("--motor", "motor_spec", required=True, help=c.MOTOR_HELP)
@click.option("--scenario", "scenario_path", default=None,
              help="scenario (a file or a packaged example's name) whose drive data (bus, PWM, dead "
                   "time, i_max, injection) the design takes, as linsense tune does")
@click.option("--name", default=None, help="C name suffix of ls_cfg_<name>.h (default: the motor name)")
@c.json_option
def export(folder: str, motor_spec: str, scenario_path: str | None, name: str | None, as_json: bool) -> None:
    """Write FOLDER: the C library's sources and headers with its CMake package, the drive's
    configuration designed for the motor (ls_cfg_<name>.h, as linsense tune --format c writes it),
    an example main.c with a synthetic motor, a CMakeLists.txt and the Cortex-M4F toolchain file.
    `cmake -S FOLDER -B b && cmake --build b` builds it on the host, with
    -DCMAKE_TOOLCHAIN_FILE=FOLDER/cmake/arm-none-eabi-m4f.cmake for the Cortex-M4F; nothing in it
    refers to a file outside FOLDER. FOLDER must be missing, empty or an earlier output of linsense
    (files it did not write, such as a build folder, are kept)."""
    from linsense.firmware.export import firmware_files, write_firmware
    from linsense.tune.design import DriveData

    if as_json:
        c.data_on_stdout()
    dd, src = DriveData(), motor_spec
    if scenario_path is not None:
        from linsense.sim.build import drive_data
        from linsense.sim.scenario import load_scenario

        dd = drive_data(load_scenario(c.example("scenarios", scenario_path, "--scenario")))
        src = scenario_path
    motor = c.load(motor_spec)
    made = firmware_files(motor, dd, src, name)
    files = write_firmware(folder, made)
    c.files_report(files)
    for line in made.lines:
        c.say(line)
    c.elapsed()
    if as_json:
        c.emit_json("firmware export", files, True, motor=made.motor, name=made.name, digest=made.digest)


COMMANDS = [firmware]

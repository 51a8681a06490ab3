"""The model's commands: ``model``, ``lut``, ``plot``, ``bench-emulate``, ``identify``, and
``examples`` (copy the packaged examples out)."""

from __future__ import annotations

import math

import click

from linsense.cli import _common as c
from linsense.errors import InputError
from linsense.limits import MAX_POSITIONS
from linsense.version import docs


@click.command(short_help="Tabulate the HF inductance model (CSV).",
               epilog=c.see("cli"))
@click.option("--motor", "motor_spec", required=True, help=c.MOTOR_HELP)
@click.option("--points", default=360, show_default=True, callback=c.points, help="positions over one period")
@c.out_option("model", "motor", folder=False, ext=".csv", dash=True)
def model(motor_spec: str, points: int, out: str | None) -> None:
    """Tabulate the HF inductance model, Psi_LUT and the uncompensated observer (CSV, SI units)."""
    from linsense.analysis.model_table import model_table, table_to_csv
    from linsense.io import write_atomic

    motor = c.load(motor_spec)
    out = c.default_out(out, motor_spec, "model", ".csv")
    write_atomic(out, table_to_csv(model_table(motor, points)))
    c.elapsed()


@click.command(short_help="Export the compensation LUT (CSV, JSON or C).",
               epilog=c.see("theory"))
@click.option("--motor", "motor_spec", required=True, help=c.MOTOR_HELP)
@click.option("--points", default=360, show_default=True, callback=c.points, help="table length")
@click.option("--format", "fmt", type=click.Choice(["csv", "json", "c"]), default="csv", show_default=True)
@click.option("--symbol", default=None, help="C array name (default ls_lut_<motor name>)")
@click.option("--f-inj", "f_inj", type=float, default=None,
              help="injection frequency in Hz: include the winding resistance (exact zero of the "
                   "demodulated error; default: the paper's eq. 12, which neglects it)")
@click.option("--quad", type=float, default=None, callback=c.quad,
              help="the injection's q-axis share kappa (elliptical injection, 0 = the paper's pulsating "
                   "one; default: the firmware's, ls_drive_default_cfg, with --f-inj, else 0: eq. 12; "
                   "without --f-inj R_s is neglected)")
@click.option("--injection", type=click.Choice(["pulsating", "rotating", "square"]), default="pulsating",
              show_default=True, help="rotating: the table of the rotating-vector estimate; square: of the "
                                      f"square wave at --f-inj, e.g. f_pwm/2 ({docs('theory')})")
@c.out_option("lut", "motor", folder=False, ext=".csv, .json or .h", dash=True)
def lut(motor_spec: str, points: int, fmt: str, symbol: str | None, f_inj: float | None, quad: float | None,
        injection: str, out: str | None) -> None:
    """Export the compensation LUT Psi_LUT(theta) = atan(-L_dq/L_q) as CSV, JSON or a C header."""
    from linsense.compensation.lut import build_lut, export, table_frequency
    from linsense.ctrl import drive_default_cfg
    from linsense.io import write_atomic
    from linsense.tune.design import observable_error_gain

    if f_inj is not None:  # (refused as the table refuses it, at the option)
        table_frequency(f_inj, "--f-inj", "")
    if symbol is not None:  # (checked, never rewritten: 'my lut!' was my_lut, int was int_t)
        if fmt != "c":
            raise InputError("--symbol", "", f"names the C header's array: only with --format c (not {fmt})")
        from linsense.compensation.lut import LUT_SUFFIX_CHARS, c_symbol

        c_symbol(symbol, "--symbol", longest_suffix=LUT_SUFFIX_CHARS)
    if quad is not None and injection != "pulsating":
        raise InputError("--quad", "", f"only with --injection pulsating (the {injection} injection has no "
                         "q-axis share)")
    firmware = drive_default_cfg()  # (the firmware's injection: its kappa and frequency; the cfg is
    # kept whole: a member of a freed cffi struct reads garbage)
    f_fw, q_fw = float(firmware.inject.freq), round(float(firmware.inject.quad), 6)
    note, quad = _eq12_note(quad is None and f_inj is None and injection == "pulsating" and fmt == "c", f_fw,
                            q_fw), quad if quad is not None else q_fw if f_inj is not None else 0.0
    motor = c.load(motor_spec)
    # (a motor the HF observer cannot hold is refused as tune and simulate refuse it)
    observable_error_gain(motor, f_inj or f_fw, quad, motor_spec)
    if fmt == "c" and symbol is None:
        from linsense.compensation.lut import default_lut_symbol

        default_lut_symbol(motor.name, motor.source, "motor.name")
    if note:  # (after the refusals: one line where it is refused)
        c.warn(note)
    out = c.default_out(out, motor_spec, "lut", {"csv": ".csv", "json": ".json", "c": ".h"}[fmt])
    write_atomic(out, export(build_lut(motor, points, f_inj, quad=quad, injection=injection), fmt, symbol))
    c.elapsed()


def _eq12_note(eq12: bool, f_fw: float, q_fw: float) -> str:
    """What ``lut --format c`` says of the default table, eq. 12 (``eq12``): the paper's pulsating
    injection's, not the firmware's default elliptical one (kappa ``q_fw`` at ``f_fw`` Hz), whose table kappa
    moves by 3-4 times (ecce2010: -3.4..3.6 deg against -16.5..6.9 at kappa 0.9 and 1 kHz; the
    docs had called eq. 12's header "the firmware's table")."""
    if not eq12:
        return ""
    return (f"eq. 12's table is the paper's pulsating injection's (kappa 0, R_s neglected); the firmware's "
            f"default injection is elliptical (kappa {q_fw:g} at {f_fw:g} Hz), whose table is --f-inj "
            f"{f_fw:g} (linsense tune writes the drive's own)")


@click.command(short_help="Draw the paper's model figures (PNG).",
               epilog=c.see("theory"))
@click.option("--motor", "motor_spec", required=True, help=c.MOTOR_HELP)
@click.option("--points", default=56, show_default=True, callback=c.points, help="LUT points drawn")
@c.out_option("plot", "motor", folder=True)
@c.json_option
def plot(motor_spec: str, points: int, out: str | None, as_json: bool) -> None:
    """Draw the paper's Figs. 5, 6, 8a, 8b, the LUT and the uncompensated-observer analysis (PNG)."""
    from linsense.compensation.lut import build_lut
    from linsense.io import output_set
    from linsense.report.figures import write_model_figures

    if as_json:
        c.data_on_stdout()
    motor = c.load(motor_spec)
    out = c.default_out(out, motor_spec, "plot")
    with output_set(out, "plot") as s:
        write_model_figures(motor, build_lut(motor, points), s.root)
    c.files_report(s.files)
    c.elapsed()
    if as_json:
        c.emit_json("plot", s.files, True, motor=motor.name)


@click.command("bench-emulate", short_help="Emulate a bench measurement on a motor (CSV).",
               epilog=c.see("identify"))
@click.option("--motor", "motor_spec", required=True, help=c.MOTOR_HELP)
@click.option("--positions", default=56, show_default=True, type=click.IntRange(8, MAX_POSITIONS),
              help="equally spaced positions over one pole pitch")
@click.option("--noise", default=0.0, show_default=True, type=float, callback=c.plausible("relative_noise"),
              help="relative complex Gaussian noise on every phasor (0.01 = 1 %)")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(min=0), help="random seed")
@click.option("--freq", "freq_hz", default=1000.0, show_default=True, type=float,
              callback=c.finite(0.0, True), help="excitation frequency, Hz")
@click.option("--current", default=1.0, show_default=True, type=float, callback=c.finite(0.0, True),
              help="nominal current amplitude, A peak (each row: random phase, 0.8..1.2 times this)")
@click.option("--amplitude-only", is_flag=True, help="write magnitudes only (I, VA, VB, VC), as the paper")
@click.option("--open-circuit", is_flag=True,
              help="write an open-circuit back-EMF record instead (mover pushed at --speed, winding open)")
@click.option("--speed", default=0.5, show_default=True, type=float, callback=c.finite(-math.inf, True),
              help="with --open-circuit: the mover's speed, m/s")
@click.option("--periods", default=2.0, show_default=True, type=float, callback=c.finite(0.0, True),
              help="with --open-circuit: electrical periods travelled")
@click.option("--rate", default=10e3, show_default=True, type=float, callback=c.finite(0.0, True),
              help="with --open-circuit: sampling rate, Hz")
@click.option("--line-to-line", is_flag=True,
              help="with --open-circuit: record VAB, VBC, VCA (no star point)")
@c.out_option("bench-emulate", "motor", folder=False, ext=".csv", dash=True)
@click.pass_context
def bench_emulate(ctx: click.Context, motor_spec: str, positions: int, noise: float, seed: int,
                  freq_hz: float, current: float, amplitude_only: bool, open_circuit: bool, speed: float,
                  periods: float, rate: float, line_to_line: bool, out: str | None) -> None:
    """Emulate the bench test (each phase fed in turn at N positions) on a motor model (CSV), or
    with --open-circuit its back-EMF record (the magnets' flux per phase)."""
    from linsense.identify.bench import bench_to_csv, emulate_bench
    from linsense.identify.emf_record import emf_to_csv, emulate_emf
    from linsense.io import write_atomic

    _one_test(ctx, open_circuit)
    motor = c.load(motor_spec)
    if open_circuit:
        text = emf_to_csv(emulate_emf(motor, speed, periods, rate, noise, seed, line_to_line))
    else:
        text = bench_to_csv(emulate_bench(motor, positions, noise, seed, freq_hz, current, amplitude_only))
    write_atomic(c.default_out(out, motor_spec, "bench-emulate", ".csv"), text)
    c.elapsed()


#: bench-emulate's options of each test (the others are refused with it)
_HF_OPTIONS = {"positions": "--positions", "freq_hz": "--freq", "current": "--current",
               "amplitude_only": "--amplitude-only"}
_OC_OPTIONS = {"speed": "--speed", "periods": "--periods", "rate": "--rate", "line_to_line": "--line-to-line"}


def _one_test(ctx: click.Context, open_circuit: bool) -> None:
    """Refuse an option of the other test than the one emulated (it would be ignored)."""
    wrong = _HF_OPTIONS if open_circuit else _OC_OPTIONS
    for param, option in wrong.items():
        if ctx.get_parameter_source(param) == click.core.ParameterSource.COMMANDLINE:
            test, alt = (("the HF bench test", "") if open_circuit
                         else ("--open-circuit", ", or add --open-circuit"))
            raise click.UsageError(f"{option} is for {test}: drop it{alt}")


@click.command(short_help="Identify the HF inductance model from a bench file.",
               epilog=c.see("identify"))
@click.argument("bench", type=click.Path(dir_okay=False))
@c.out_option("identify", "bench file", folder=True)
@click.option("--harmonics", default=1, show_default=True, type=click.IntRange(1, 20),
              help="K: fit the even orders 2, 4, ..., 2K (1 = the five parameters of eq. 3)")
@click.option("--motor", "motor_spec", default=None,
              help="motor giving pole pitch, force constant, mass (and R_s for amplitude-only data)")
@click.option("--pole-pitch", "pole_pitch_mm", type=float, callback=c.plausible("pole_pitch", "mm"),
              default=None,
              help="one electrical period, mm (overrides --motor)")
@click.option("--force-constant", type=float, callback=c.plausible("force_constant"), default=None,
              help="N/A per peak phase current (overrides --motor)")
@click.option("--mass", type=float, callback=c.plausible("mass"), default=None, help="kg (overrides --motor)")
@click.option("--resistance", type=float, callback=c.plausible("resistance"), default=None,
              help="phase resistance, ohm, for amplitude-only data (0 neglects it as the paper does)")
@click.option("--name", default=None, help="motor name in motor.toml (default: the bench file name)")
@click.option("--points", default=360, show_default=True, callback=c.points, help="length of lut_fit.csv")
@click.option("--emf", "emf", default=None, type=click.Path(dir_okay=False),
              help="open-circuit back-EMF record (CSV): the magnets' flux per phase, [pm_flux] scale_abc, "
                   "shift_deg_abc")
@c.json_option
def identify(bench: str, out: str | None, harmonics: int, motor_spec: str | None, pole_pitch_mm: float | None,
             force_constant: float | None, mass: float | None, resistance: float | None, name: str | None,
             points: int, emf: str | None, as_json: bool) -> None:
    """Identify the HF inductance model from a bench file (a file or a packaged example's name):
    motor.toml, tables, LUTs, fit.json and figures."""
    from linsense.identify.identification import fit_report, render_outputs, summary_lines
    from linsense.identify.identification import identify as run_identify
    from linsense.io import output_set
    from linsense.report.identify_figures import identify_figure_files

    if as_json:
        c.data_on_stdout()
    bench = c.example("bench", bench, "BENCH")
    emf = c.example("bench", emf, "--emf") if emf is not None else None
    out = c.default_out(out, bench, "identify")
    base = c.load(motor_spec) if motor_spec is not None else None
    ident = run_identify(
        bench, base=base, harmonics=harmonics,
        pole_pitch=None if pole_pitch_mm is None else pole_pitch_mm * 1e-3,
        force_constant=force_constant, mass=mass, resistance=resistance, name=name, points=points, emf=emf,
    )
    files = {**render_outputs(ident), **identify_figure_files(ident)}
    with output_set(out, "identify") as s:
        for rel, content in files.items():
            s.write(rel, content)
    c.files_report(s.files)
    for line in summary_lines(ident):
        c.say(line)
    for w in ident.warnings:
        c.warn(w)
    c.elapsed()
    if as_json:
        c.emit_json("identify", s.files, True, fit=fit_report(ident), warnings=list(ident.warnings))


@click.command(short_help="Copy the packaged examples into a folder.",
               epilog=c.see("cli"))
@click.argument("folder", type=click.Path(file_okay=False), required=False, callback=c.folder_out)
@click.option("--force", is_flag=True, help="overwrite files that exist (else: refused, nothing copied)")
@click.option("--list", "list_only", is_flag=True, help="only list the examples' names by kind, copy nothing")
@c.json_option
def examples(folder: str | None, force: bool, list_only: bool, as_json: bool) -> None:
    """Copy every packaged example (motors, scenarios, sweeps, FEA geometries, a bench file, the
    firmware example) into FOLDER, keeping their sub-folders; they refer to each other by relative
    paths, so the copies work as they are. Each is also usable by name: --motor small30,
    `linsense simulate step3_lut`."""
    from linsense import examples as ex
    from linsense.model.motor import preset_names

    if as_json:
        c.data_on_stdout()
    named = {kind: ex.names(kind) for kind in ex.KINDS if ex.KINDS[kind] is not None}
    named["motors"] = [*preset_names(), *named["motors"]]
    if list_only:
        for kind, names in named.items():
            c.say(f"{kind:10s} {', '.join(names)}")
        if as_json:
            c.emit_json("examples", [], True, names=named)
        return
    if folder is None:
        raise click.UsageError("give the FOLDER to copy the examples into (or --list)")
    written = ex.copy_to(folder, force=force)
    c.files_report(written)
    c.say(f"{len(written)} example files copied into {folder}")
    if as_json:
        c.emit_json("examples", written, True, names=named)


COMMANDS = [model, lut, plot, bench_emulate, identify, examples]

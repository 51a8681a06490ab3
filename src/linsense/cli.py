"""The ``linsense`` command.

Bad input (a :class:`~linsense.errors.LinsenseError` or a usage error) ends with exit code 2 and a
single line on stderr naming the file, key and value; no traceback, and no output file: every
output is checked before anything is written, and written atomically.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import click
import numpy as np

from linsense.errors import InputError, LinsenseError
from linsense.limits import MAX_POINTS, MAX_POSITIONS
from linsense.version import __version__

MOTOR_HELP = "preset name (e.g. ecce2010) or path to a motor .toml file"


def _points(ctx, param, value: int) -> int:
    if value < 4:
        raise click.BadParameter(f"must be >= 4, got {value}")
    if value > MAX_POINTS:
        raise click.BadParameter(f"{value:,} is beyond the limit of {MAX_POINTS:,} (docs/limits.md)")
    return value


def _load(spec: str):
    from linsense.model.motor import load_motor

    return load_motor(spec)


def _version(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    """``--version``: the package's version and the C library's (``LS_VERSION_*``, ls_types.h)."""
    if not value or ctx.resilient_parsing:
        return
    from linsense.ctrl import ffi, lib

    c_version = f"{lib.LS_VERSION_MAJOR}.{lib.LS_VERSION_MINOR}.{lib.LS_VERSION_PATCH}"
    real = "float" if ffi.sizeof("LS_REAL") == 4 else "double"
    click.echo(f"linsense {__version__} (C library {c_version}, LS_REAL {real})")
    ctx.exit()


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=_version,
              help="Show the version of linsense and of its C library, and exit.")
def cli() -> None:
    """End-effect-aware HF-injection sensorless control of linear PM motors."""


def _show(v: float | None, unit: str, fmt: str = ".2f") -> str:
    """A metric for a person: 'n/a' where it is not defined."""
    return "n/a" if v is None else f"{v:{fmt}} {unit}"


def _quad(ctx, param, value):
    """Click callback: the injection's q-axis share kappa, in [0, 1), or None."""
    if value is not None and not (np.isfinite(value) and 0.0 <= value < 1.0):
        raise click.BadParameter(f"must be in [0, 1), got {value!r}")
    return value


@cli.command()
@click.option("--motor", "motor_spec", required=True, help=MOTOR_HELP)
@click.option("--points", default=360, show_default=True, callback=_points, help="positions over one period")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="output CSV file")
def model(motor_spec: str, points: int, out: str) -> None:
    """Tabulate the HF inductance model, Psi_LUT and the uncompensated observer (CSV, SI units)."""
    from linsense.analysis.tables import model_table, table_to_csv
    from linsense.io import write_atomic

    motor = _load(motor_spec)
    write_atomic(out, table_to_csv(model_table(motor, points)))


@cli.command()
@click.option("--motor", "motor_spec", required=True, help=MOTOR_HELP)
@click.option("--points", default=360, show_default=True, callback=_points, help="table length")
@click.option("--format", "fmt", type=click.Choice(["csv", "json", "c"]), default="csv", show_default=True)
@click.option("--symbol", default=None, help="C array name (default ls_lut_<motor name>)")
@click.option("--f-inj", "f_inj", type=float, default=None,
              help="injection frequency in Hz: include the winding resistance (exact zero of the "
                   "demodulated error; default: the paper's eq. 12, which neglects it)")
@click.option("--quad", type=float, default=None, callback=_quad,
              help="with --f-inj: the injection's q-axis share kappa (elliptical injection, 0 = the "
                   "paper's pulsating one; default: the firmware's, ls_drive_default_cfg)")
@click.option("--injection", type=click.Choice(["pulsating", "rotating", "square"]), default="pulsating",
              show_default=True, help="rotating: the table of the rotating-vector estimate; square: of the "
                                      "square wave at --f-inj, e.g. f_pwm/2 (docs/theory.md)")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="output file")
def lut(motor_spec: str, points: int, fmt: str, symbol: str | None, f_inj: float | None, quad: float | None,
        injection: str, out: str) -> None:
    """Export the compensation LUT Psi_LUT(theta) = atan(-L_dq/L_q) as CSV, JSON or a C header."""
    from linsense.compensation.lut import build_lut, export
    from linsense.ctrl import drive_default_cfg
    from linsense.io import write_atomic
    from linsense.limits import MAX_F_INJ, MIN_F_INJ
    from linsense.tune.design import observable_error_gain

    if f_inj is not None and not (f_inj > 0 and np.isfinite(f_inj)):
        raise InputError("--f-inj", "", f"must be a positive frequency in Hz, got {f_inj!r}")
    if f_inj is not None and f_inj < MIN_F_INJ:
        raise InputError("--f-inj", "", f"{f_inj:g} Hz is below the lower limit of {MIN_F_INJ:g} Hz (an HF "
                         "injection: below it the resistance is all of the HF impedance; docs/limits.md)")
    if f_inj is not None and f_inj > MAX_F_INJ:
        raise InputError("--f-inj", "", f"{f_inj:g} Hz is beyond the limit of {MAX_F_INJ:g} Hz (half of a "
                         "1 MHz PWM; docs/limits.md)")
    if quad is not None and f_inj is None:
        raise InputError("--quad", "", "only with --f-inj (eq. 12 neglects R_s, where kappa changes nothing)")
    if quad is not None and injection != "pulsating":
        raise InputError("--quad", "", f"only with --injection pulsating (the {injection} injection has no "
                         "q-axis share)")
    firmware = drive_default_cfg()  # (the firmware's injection: its kappa and frequency; the cfg is
    # kept whole: a member of a freed cffi struct reads garbage)
    if quad is None:
        quad = round(float(firmware.inject.quad), 6) if f_inj is not None else 0.0
    motor = _load(motor_spec)
    # (a motor the HF observer cannot hold is refused as tune and simulate refuse it: issue 23)
    observable_error_gain(motor, f_inj or float(firmware.inject.freq), quad if f_inj else 0.0, motor_spec)
    write_atomic(out, export(build_lut(motor, points, f_inj, quad=quad, injection=injection), fmt, symbol))


@cli.command()
@click.option("--motor", "motor_spec", required=True, help=MOTOR_HELP)
@click.option("--points", default=56, show_default=True, callback=_points, help="LUT points drawn")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="output folder")
def plot(motor_spec: str, points: int, out: str) -> None:
    """Draw paper Figs. 5, 6, 8a, 8b, the LUT and the uncompensated-observer analysis (PNG)."""
    from linsense.compensation.lut import build_lut
    from linsense.io import output_set
    from linsense.report.figures import write_model_figures

    motor = _load(motor_spec)
    with output_set(out, "plot") as s:
        write_model_figures(motor, build_lut(motor, points), s.root)
    for f in s.files:
        click.echo(str(f))


@cli.command()
@click.option("--motor", "motor_spec", default="ecce2010", show_default=True, help=MOTOR_HELP)
@click.option("--out", default="out", show_default=True, type=click.Path(file_okay=False))
@click.option("--quick", is_flag=True,
              help="fewer calibration points, hold positions and map cells (about 15 s)")
@click.option("--model-only", is_flag=True, help="only the model's tables, LUT files and figures (no runs)")
def reproduce(motor_spec: str, out: str, quick: bool, model_only: bool) -> None:
    """The paper's Section V, claim by claim (make demo): model tables and LUT files, Figs. 5-13
    with the closed-loop runs on the switching inverter with dead time, metrics.json and a
    self-contained report.html in OUT (docs/reproduce.md)."""
    from linsense.reproduce.pipeline import reproduce as run

    _load(motor_spec)  # (a bad motor: one line and exit code 2 before anything runs)
    files, lines = run(out, motor_spec, quick=quick, progress=sys.stderr.isatty(), model_only=model_only)
    for f in files:
        click.echo(str(f))
    for line in lines:
        click.echo(line)


def _finite(minimum: float, strict: bool):
    """Click callback: a finite number ``> minimum`` (``>=`` unless ``strict``), or None."""

    def check(ctx, param, value):
        if value is None:
            return value
        ok = np.isfinite(value) and (value > minimum if strict else value >= minimum)
        if not ok:
            op = ">" if strict else ">="
            raise click.BadParameter(f"must be a finite number {op} {minimum:g}, got {value!r}")
        return value

    return check


@cli.command("bench-emulate")
@click.option("--motor", "motor_spec", required=True, help=MOTOR_HELP)
@click.option("--positions", default=56, show_default=True, type=click.IntRange(8, MAX_POSITIONS),
              help="equally spaced positions over one pole pitch")
@click.option("--noise", default=0.0, show_default=True, type=float, callback=_finite(0.0, False),
              help="relative complex Gaussian noise on every phasor (0.01 = 1 %)")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(min=0), help="random seed")
@click.option("--freq", "freq_hz", default=1000.0, show_default=True, type=float, callback=_finite(0.0, True),
              help="excitation frequency, Hz")
@click.option("--current", default=1.0, show_default=True, type=float, callback=_finite(0.0, True),
              help="nominal current amplitude, A peak (each row: random phase, 0.8..1.2 times this)")
@click.option("--amplitude-only", is_flag=True, help="write magnitudes only (I, VA, VB, VC), as the paper")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="output bench CSV file")
def bench_emulate(motor_spec: str, positions: int, noise: float, seed: int, freq_hz: float, current: float,
                  amplitude_only: bool, out: str) -> None:
    """Emulate the bench test (each phase fed in turn at N positions) on a motor model (CSV)."""
    from linsense.identify.bench import bench_to_csv, emulate_bench
    from linsense.io import write_atomic

    motor = _load(motor_spec)
    data = emulate_bench(motor, positions, noise, seed, freq_hz, current, amplitude_only)
    write_atomic(out, bench_to_csv(data))


@cli.command()
@click.argument("bench", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False), help="output folder")
@click.option("--harmonics", default=1, show_default=True, type=click.IntRange(1, 20),
              help="K: fit the even orders 2, 4, ..., 2K (1 = the five parameters of eq. 3)")
@click.option("--motor", "motor_spec", default=None,
              help="motor giving pole pitch, force constant, mass (and R_s for amplitude-only data)")
@click.option("--pole-pitch", "pole_pitch_mm", type=float, callback=_finite(0.0, True), default=None,
              help="one electrical period, mm (overrides --motor)")
@click.option("--force-constant", type=float, callback=_finite(0.0, True), default=None,
              help="N/A per peak phase current (overrides --motor)")
@click.option("--mass", type=float, callback=_finite(0.0, True), default=None, help="kg (overrides --motor)")
@click.option("--resistance", type=float, callback=_finite(0.0, False), default=None,
              help="phase resistance, ohm, for amplitude-only data (0 neglects it as the paper does)")
@click.option("--name", default=None, help="motor name in motor.toml (default: the bench file name)")
@click.option("--points", default=360, show_default=True, callback=_points, help="length of lut_fit.csv")
def identify(bench: str, out: str, harmonics: int, motor_spec: str | None, pole_pitch_mm: float | None,
             force_constant: float | None, mass: float | None, resistance: float | None, name: str | None,
             points: int) -> None:
    """Identify the HF inductance model from a bench file: motor.toml, tables, LUTs, fit.json, figures."""
    from linsense.identify.pipeline import identify as run_identify
    from linsense.identify.pipeline import render_outputs, summary_lines
    from linsense.io import output_set
    from linsense.report.identify_figures import identify_figure_files

    base = _load(motor_spec) if motor_spec is not None else None
    ident = run_identify(
        bench, base=base, harmonics=harmonics,
        pole_pitch=None if pole_pitch_mm is None else pole_pitch_mm * 1e-3,
        force_constant=force_constant, mass=mass, resistance=resistance, name=name, points=points,
    )
    files = {**render_outputs(ident), **identify_figure_files(ident)}
    with output_set(out, "identify") as s:
        for rel, content in files.items():
            s.write(rel, content)
    for f in s.files:
        click.echo(str(f))
    for line in summary_lines(ident):
        click.echo(line)
    for w in ident.warnings:
        click.echo(f"linsense: warning: {w}", err=True)


@cli.command()
@click.argument("scenario", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False), help="output folder")
@click.option("--fidelity", type=click.Choice(["average", "switching"]), default=None,
              help="override the scenario's inverter fidelity")
@click.option("--trace", "trace_fmt", type=click.Choice(["parquet", "csv", "none"]), default=None,
              help="trace file format (written chunk by chunk while the run goes)  [default: parquet; csv "
                   "without the parquet extra]")
@click.option("--decimate", type=click.IntRange(1, 1_000_000), default=None,
              help="record one sample every N PWM periods (1 .. 1e6; overrides the scenario's "
                   "record.decimate)")
@click.option("--mat", is_flag=True, help="also write the trace as MATLAB trace.mat (held in memory: at most "
                                          "1,000,000 samples)")
@click.option("--plot/--no-plot", default=False, show_default=True, help="draw sim.png")
@click.option("--check", is_flag=True, help="exit with code 1 when the run is not stable (for CI)")
def simulate(scenario: str, out: str, fidelity: str | None, trace_fmt: str, decimate: int | None, mat: bool,
             plot: bool, check: bool) -> None:
    """Run a closed-loop drive simulation: metrics.json, timing.json, trace.parquet (or .csv; and
    trace.mat), sim.png with --plot.

    Exit codes: 0 done (with --check: and stable), 1 with --check: not stable, 2 bad input (the
    scenario, or a configuration that trips the drive at t = 0)."""
    from linsense.io import output_set, split_timing
    from linsense.sim.build import build, check_trace_file
    from linsense.sim.scenario import load_scenario
    from linsense.sim.stream import simulate_streamed
    from linsense.sim.trace import MAT_MAX_SAMPLES, TraceWriter, have_parquet, trace_columns, write_mat

    if trace_fmt is None:  # (the core install has no pyarrow: its default trace is the CSV one)
        trace_fmt = "parquet" if have_parquet() else "csv"
        if trace_fmt == "csv":
            click.echo("linsense: note: trace.csv, not trace.parquet: the Parquet trace needs pyarrow "
                       "(pip install 'linsense[parquet]')", err=True)
    sc = load_scenario(scenario)
    if fidelity is not None:
        sc = sc.replace(inverter={"fidelity": fidelity})
    if decimate is not None:
        sc = sc.replace(record={"decimate": decimate})
    b = build(sc, trace_in_memory=False)  # streamed: the trace is never whole in memory
    if trace_fmt != "none":
        check_trace_file(b)
    n_rec = -(-b.n_steps // int(b.cfg.decimate))
    if mat and n_rec > MAT_MAX_SAMPLES:
        need = -(-b.n_steps // MAT_MAX_SAMPLES)
        raise InputError("--mat", "", f"trace.mat is written from the whole trace held in memory: {n_rec:,} "
                                      f"samples is beyond the limit of {MAT_MAX_SAMPLES:,} (docs/limits.md); "
                                      f"record fewer (--decimate {need}) or use the Parquet trace")
    mat_parts: list[dict] = []

    def run(f=None):
        writer = TraceWriter(f, trace_fmt) if f is not None else None

        def on_chunk(arrays):
            if writer is not None:
                writer.write(arrays)
            if mat:
                mat_parts.append({k: np.array(v, dtype=float) for k, v in trace_columns(arrays).items()})

        try:
            sr = simulate_streamed(b, on_chunk=on_chunk if writer is not None or mat else None, plot=plot)
        except BaseException:
            if writer is not None:
                writer.abort()
            raise
        if writer is not None:
            writer.close()
        return sr

    with output_set(out, "simulate") as s:
        if trace_fmt == "none":
            sr = run()
        else:
            done = []
            s.write_with(f"trace.{trace_fmt}", lambda f: done.append(run(f)))
            sr = done[0]
        metrics, timing = split_timing(sr.metrics)
        s.write("metrics.json", json.dumps(metrics, indent=1) + "\n")
        s.write("timing.json", json.dumps(timing, indent=1) + "\n")
        if mat:
            cols = {k: np.concatenate([p[k] for p in mat_parts]) for k in mat_parts[0]}
            mat_parts.clear()
            write_mat(cols, s.path("trace.mat"), metrics=sr.metrics)
        if plot:
            from linsense.report.figures import save_png
            from linsense.report.sim_figures import DPI, sim_figure

            save_png(sim_figure(sr.plot), s.path("sim.png"), DPI)
    for f in s.files:
        click.echo(str(f))
    m = sr.metrics

    click.echo(
        f"{m['scenario']}: "
        f"{'stable' if m['stable'] else 'not stable: ' + str(m['unstable_reason'])} (fault {m['fault']}); "
        f"max |err| {_show(m['max_abs_err_deg'], 'deg')} "
        f"(transient {_show(m['transient_max_err_deg'], 'deg')}, "
        f"steady {_show(m['steady_max_err_deg'], 'deg')}, bias {_show(m['bias_deg'], 'deg')}); "
        f"final x {m['final_position_mm']} mm, limit cycle {_show(m['limit_cycle_deg'], 'deg', '.3g')} "
        f"({m['limit_cycle_mm']} mm), overshoot {_show(m['overshoot_deg'], 'deg', '.3g')} "
        f"({m['overshoot_mm']} mm); "
        f"{m['sim_s']} s simulated in {m['wall_s']} s "
        f"({m['realtime_factor']}x real time)"
    )
    if check and not m["stable"]:
        click.echo(f"linsense: not stable: {m['unstable_reason']}", err=True)
        raise click.exceptions.Exit(1)


def _drive_options(f):
    """The drive data as options (``--v-dc --f-pwm --dead-time --i-max --v-inj --f-inj``, SI units;
    :class:`~linsense.tune.design.DriveData`'s names): a command gets them as keyword arguments,
    None where not given."""
    dflt = " (default: the scenario's, else the design's drive data)"
    opts = [
        click.option("--v-dc", type=float, default=None, callback=_finite(0.0, True),
                     help="bus voltage, V" + dflt),
        click.option("--f-pwm", type=float, default=None, callback=_finite(0.0, True),
                     help="PWM rate, Hz" + dflt),
        click.option("--dead-time", type=float, default=None, callback=_finite(0.0, False),
                     help="the inverter's dead time, s" + dflt),
        click.option("--i-max", type=float, default=None, callback=_finite(0.0, True),
                     help="current limit, A" + dflt),
        click.option("--v-inj", type=float, default=None, callback=_finite(0.0, True),
                     help="injection amplitude, V (default: the scenario's, else designed)"),
        click.option("--f-inj", type=float, default=None, callback=_finite(0.0, True),
                     help="injection frequency, Hz (default: the scenario's, else designed)"),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


@cli.command()
@click.option("--motor", "motor_spec", default=None,
              help=MOTOR_HELP + "; with --scenario it must be the scenario's motor")
@click.option("--scenario", "scenario_path", type=click.Path(dir_okay=False), default=None,
              help="the drive to calibrate: the scenario's motor, bus, PWM, dead time, injection (shape, "
                   "amplitude, frequency, kappa), gains and [calibration] keys; the options below over it")
@click.option("--positions", default=56, show_default=True, type=click.IntRange(4, 4096),
              help="points over one electrical period")
@click.option("--load", default=0.0, show_default=True, type=float, callback=_finite(-math.inf, False),
              help="constant load force, N (opposing positive motion when > 0)")
@click.option("--fidelity", type=click.Choice(["switching", "average"]), default="switching",
              show_default=True, help="inverter model, with the drive's dead time (a scenario's fidelity is "
                                      "not used)")
@click.option("--quad", default=None, type=float, callback=_quad,
              help="the injection's q-axis share kappa (default: the scenario's, else the design's; 0: the "
                   "paper's pulsating injection)")
@_drive_options
@click.option("--saturated", is_flag=True, default=False,
              help="on the saturated plant (the motor file's [saturation], docs/simulator.md)")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="output folder")
def calibrate(motor_spec: str | None, scenario_path: str | None, positions: int, load: float, fidelity: str,
              quad: float | None, saturated: bool, out: str, **drive) -> None:
    """Run the firmware's LUT calibration in the simulator (paper Fig. 9) on the drive that will use
    the table: a scenario's (--scenario), or the design for the motor (linsense tune's, with the
    drive data given): lut_measured.csv, metrics.json, calibration.png. Exit code 1 if it does not
    complete."""
    from linsense.io import output_set, split_timing
    from linsense.report.figures import fig_calibration, save_png
    from linsense.sim.calibrate import calibrate as run_calibration
    from linsense.sim.calibrate import lut_csv
    from linsense.sim.scenario import load_scenario

    if motor_spec is None and scenario_path is None:
        raise click.UsageError("give --motor or --scenario (the drive to calibrate)")
    sc = load_scenario(scenario_path) if scenario_path is not None else None
    motor = _load(motor_spec) if motor_spec is not None else None
    extra = {"saturation": {"enabled": True}} if saturated else {}
    cal = run_calibration(motor_spec if sc is not None else motor, positions, load, fidelity, quad=quad,
                          source=motor_spec or "<calibrate>", scenario=sc, drive=drive, **extra)
    metrics, timing = split_timing(cal.metrics)
    with output_set(out, "calibrate") as s:
        s.write("lut_measured.csv", lut_csv(cal))
        s.write("metrics.json", json.dumps(metrics, indent=1) + "\n")
        s.write("timing.json", json.dumps(timing, indent=1) + "\n")
        save_png(fig_calibration(cal, cal.motor), s.path("calibration.png"))
    for f in s.files:
        click.echo(str(f))
    m = cal.metrics
    click.echo(f"{m['motor']}: {m['points_done']}/{m['points']} points, load {m['load_n']:g} N, "
               f"{m['fidelity']}, {m['v_dc']:g} V, {m['f_pwm_hz']:g} Hz PWM, {m['dead_time_s'] * 1e6:g} us; "
               f"{m['injection_shape']} injection {m['v_inj']:.3g} V at {m['f_inj_hz']:g} Hz, kappa "
               f"{m['injection_quad']:g}: "
               f"max |measured - model with R_s| {_show(m['max_diff_deg'], 'deg', '.3g')}, against eq. 12 "
               f"{_show(m['max_diff_eq12_deg'], 'deg', '.3g')}; {m['sim_s']} s simulated in {m['wall_s']} s")
    if not cal.completed:
        click.echo(f"linsense: calibration did not complete ({m['points_done']} of {m['points']} points, "
                   f"fault {m['fault']})", err=True)
        raise click.exceptions.Exit(1)


@cli.command()
@click.option("--motor", "motor_spec", required=True, help=MOTOR_HELP)
@click.option("--scenario", "scenario_path", type=click.Path(dir_okay=False), default=None,
              help="scenario whose drive data (bus, PWM, dead time, i_max, injection) and other keys "
                   "are kept")
@_drive_options
@click.option("--quad", type=float, default=None, callback=_quad,
              help="elliptical share kappa on q (0: pulsating; default 0.9)")
@click.option("--format", "fmt", type=click.Choice(["toml", "c"]), default="toml", show_default=True,
              help="toml: a complete scenario; c: an ls_drive_cfg set-up header for the firmware")
@click.option("--polarity", type=float, default=None, callback=_finite(0.0, True),
              help="saturation data for the start-up pulses, 1/A: (L_d(-I) - L_d(+I)) / L_d per A of d "
                   "pulse (polarity.csv of linsense fea --polarity: rel / I); default: the motor file's "
                   "[saturation] polarity, else no start-up design")
@click.option("--current-noise", type=float, default=0.01, show_default=True, callback=_finite(0.0, False),
              help="current-sensor noise, A rms per phase (a 12-bit ADC over +-10 A on top), for the "
                   "pulse pairs")
@click.option("--name", default=None, help="C name suffix (default: the motor name)")
@click.option("--v-max", type=float, default=None, callback=_finite(0.0, True),
              help="the application's top speed, m/s (default 0.2): speed cap, trips, verification")
@click.option("--a-max", type=float, default=None, callback=_finite(0.0, True),
              help="the application's acceleration, m/s^2 (default 1)")
@click.option("--load", type=float, default=None, callback=_finite(0.0, False),
              help="the rated load force, N (default half of K_f i_max): verification's loads")
@click.option("--travel", type=float, default=None, callback=_finite(0.0, True),
              help="the stroke, mm (default: unbounded)")
@click.option("--injection", "shape", type=click.Choice(["pulsating", "rotating", "square"]), default=None,
              help="the injection: pulsating/elliptical (default; kappa --quad), rotating vector, or "
                   "square wave at f_pwm / 2 with its dead-time measures (docs/firmware.md)")
@click.option("--quick", is_flag=True, help="verify at 8 positions on the nominal plant only")
@click.option("--no-verify", is_flag=True, help="do not run the verification")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="output file")
def tune(motor_spec: str, scenario_path: str | None, quad, fmt: str, polarity: float | None,
         current_noise: float, name: str | None, v_max, a_max, load, travel, shape, quick: bool,
         no_verify: bool, out: str, **drive) -> None:
    """Design the drive for a motor: injection, current loop, demodulator, observer, speed and
    position loops, limits and trips (docs/tuning.md); print the design and its margins; write a
    scenario or a C header; then verify it in the simulator (switching inverter with dead time) and
    write verification.json and verification.png beside the output (exit 1 if a check fails)."""
    import functools

    from linsense.io import write_atomic
    from linsense.sim.build import compensation_of, drive_data
    from linsense.sim.scenario import load_scenario
    from linsense.tune.design import DriveData, design, uncompensated_speed_factor
    from linsense.tune.export import c_header, scenario_dict, scenario_toml

    say = functools.partial(click.echo, err=out == "-")  # (stdout carries the file itself then)
    base, base_dir, src = None, None, motor_spec
    dd = DriveData()
    if scenario_path is not None:
        sc = load_scenario(scenario_path)
        base, base_dir, src = sc.given(), sc.base_dir, scenario_path
        base.pop("motor", None)
        dd = drive_data(sc)
    given = {**drive, "quad": quad, "v_max": v_max, "a_max": a_max, "load": load,
             "travel": None if travel is None else travel * 1e-3, "shape": shape}
    for key, val in given.items():  # (the drive data options: _drive_options, DriveData's names)
        if val is not None:
            setattr(dd, key, val)
    motor = _load(motor_spec)
    dz = design(motor, dd, src)
    from linsense.tune.startup import design_startup
    # (the start-up locks as the PLL would: startup.lock_gain, linsense.tune.design.startup_lock_gain)
    su = design_startup(motor, v_dc=dd.v_dc, f_pwm=dd.f_pwm, i_max=dd.i_max, observer_bw=dz.observer_bw_pll,
                        v_inj=dz.v_inj, polarity=polarity, current_noise=current_noise,
                        ramp_rate=dz.inj_ramp_rate, source=src)
    # a drive run without its table (sensorless_nolut) gets its trips on the estimate wider
    mode = (base or {}).get("control", {}).get("mode", "sensorless_lut")
    no_table = compensation_of(mode, (base or {}).get("observer", {}).get("compensation")) == "none"
    k_est = uncompensated_speed_factor(motor) if no_table else 1.0
    sc_dict = scenario_dict(dz, dd, motor_spec, base, startup=su, k_est=k_est, pole_pitch=motor.pole_pitch)
    cert_run = None
    if not no_verify:  # (its runs are built before anything is written: a refusal leaves no file)
        from linsense.verify.certificate import motor_ref, prepare

        cert_run = prepare(motor, motor_ref(motor_spec), _certificate_base(sc_dict),
                           str(base_dir or Path.cwd()), v_max=dd.v_max, a_max=dd.a_max, load=dz.load,
                           travel=dd.travel, quick=quick)
    if fmt == "c":
        text = c_header(dz, dd, motor, name, startup=su)
    else:
        text = scenario_toml(dz, dd, motor_spec, Path(out), base, Path.cwd(), startup=su, k_est=k_est,
                             pole_pitch=motor.pole_pitch)
    say(str(write_atomic(out, text)))
    for line in design_lines(dz, motor.name, dd):
        say(line)
    if su is not None:
        for line in su.lines():
            say(line)
    else:
        say("  start-up       not designed: no saturation data (--polarity, or [saturation] polarity "
            "in the motor file)")
    for w in dz.warnings + (su.warnings if su is not None else []):
        click.echo(f"linsense: warning: {w}", err=True)
    if mode != "sensorless_lut" and not no_verify:
        say(f"  (the certificate judges the designed sensorless drive with its table, not control.mode = "
            f"{mode!r} of the scenario)")
    json_path, png_path = _certificate_paths(out)
    if cert_run is None:
        for p in (json_path, png_path):  # (a certificate of an earlier design would be stale)
            p.unlink(missing_ok=True)
        return
    _verify_tuned(cert_run, motor, dd, dz, quick, json_path, png_path, say)


def _certificate_base(sc: dict) -> dict:
    """The tuned scenario the certificate varies: the designed sensorless drive (its mode, start-up
    and the scenario's own reference and travel are the certificate's, per run)."""
    base = {k: (dict(v) if isinstance(v, dict) else v) for k, v in sc.items()}
    for k in ("control", "startup", "reference", "travel", "initial", "load"):
        base.pop(k, None)
    return base


def _certificate_paths(out: str) -> tuple[Path, Path]:
    """``<out stem>.verification.json`` and ``.png`` beside the output file (in the working folder
    for ``-`` or a device such as /dev/null)."""
    p = Path(out)
    if out == "-" or (p.exists() and not p.is_file()):
        folder, stem = Path.cwd(), "tune"
    else:
        folder, stem = p.resolve().parent, p.stem
    return folder / f"{stem}.verification.json", folder / f"{stem}.verification.png"


def _verify_tuned(cert_run, motor, dd, dz, quick: bool, json_path: Path, png_path: Path, say) -> None:
    """Run the prepared certificate, print it, write its JSON and figure; exit 1 when a check
    fails (a quick run never claims the full certificate)."""
    import io
    import json

    from linsense.io import write_atomic
    from linsense.report.verify_figures import certificate_figure

    cert = cert_run()
    for line in cert.lines():
        say(line)
    doc = cert.as_dict()
    doc.update(motor=motor.name, drive={k: v for k, v in vars(dd).items()},
               design={k: v for k, v in dz.as_dict().items() if k not in ("margins", "warnings")})
    say(str(write_atomic(json_path, json.dumps(doc, indent=1, sort_keys=True) + "\n")))
    fig = certificate_figure(cert.rows, f"{motor.name}: {cert.verdict()}", quick=quick)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    say(str(write_atomic(png_path, buf.getvalue())))
    if not cert.passed:
        raise click.exceptions.Exit(1)


@cli.command("fea")
@click.argument("geometry")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="output folder")
@click.option("--positions", type=click.IntRange(12, 720), default=56, show_default=True,
              help="rod positions over one electrical period (12 .. 720)")
@click.option("--mesh", "level", type=click.Choice(["coarse", "default", "fine"]), default="default",
              show_default=True, help="mesh level")
@click.option("--lut-points", default=360, show_default=True, callback=_points, help="length of lut.csv")
@click.option("--load-current", default="0", show_default=True,
              help="q-axis current (A) setting the state of a saturating iron (needs a B-H curve); a "
                   "comma list (0,1,2) sweeps the loads: per-load tables and LUTs, lut_vs_load.png")
@click.option("--workers", type=click.IntRange(1, 64), default=1, show_default=True,
              help="processes for the Newton solves of a saturating iron")
@click.option("--polarity", default=None,
              help="d-axis pulse amplitudes (A, comma list: 0.5,1,2): the saturation signal for magnet "
                   "polarity detection, L_d(-I) - L_d(+I), in polarity.csv and fea.json")
@click.option("--polarity-positions", type=click.IntRange(3, 720), default=4, show_default=True,
              help="rod positions over one electrical period for --polarity")
def fea(geometry: str, out: str, positions: int, level: str, lut_points: int, load_current: str,
        workers: int, polarity: str | None, polarity_positions: int) -> None:
    """Axisymmetric FEA of a tubular motor (GEOMETRY: .toml file or preset): inductances.csv, motor.toml,
    lut.csv, geometry.json, fea.json and figures."""
    from linsense.report.fea import run_fea

    files, lines, warnings = run_fea(geometry, out, positions, level, lut_points,
                                     progress=sys.stderr.isatty(), load_current=load_current, workers=workers,
                                     polarity=polarity, polarity_positions=polarity_positions)
    for f in files:
        click.echo(str(f))
    for line in lines:
        click.echo(line)
    for w in warnings:
        click.echo(f"linsense: warning: {w}", err=True)


@cli.command("sweep")
@click.argument("sweep_file", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False),
              help="output folder (the same folder again resumes a killed sweep)")
@click.option("--workers", type=click.IntRange(1, 1024), default=None,
              help="workers of the local cluster (default: one per core)")
@click.option("--scheduler", default=None, help="address of a running dask scheduler (tcp://host:8786)")
@click.option("--processes", is_flag=True, help="local workers as processes instead of threads")
@click.option("--no-progress", is_flag=True, help="no progress bar")
@click.option("--restart", is_flag=True,
              help="discard the rows already in --out (a sweep whose inputs changed) and start over")
def sweep_cmd(sweep_file: str, out: str, workers: int | None, scheduler: str | None, processes: bool,
              no_progress: bool, restart: bool) -> None:
    """Run a sweep: a base scenario with keys varied, on dask.distributed (docs/sweeps.md)."""
    from linsense.io import write_atomic, write_atomic_with
    from linsense.report.sweep_figures import FIGURES
    from linsense.sweep import load_sweep, sweep
    from linsense.sweep.studies import summary_line

    sw = load_sweep(sweep_file)
    df = sweep(sw, out, workers=workers, scheduler=scheduler, processes=processes,
               progress=not no_progress and sys.stderr.isatty(), restart=restart)
    out_dir = Path(out)
    axes = [a.key for a in sw.spec.axis]
    relative = {a.key: a.relative for a in sw.spec.axis}
    click.echo(str(write_atomic_with(out_dir / "results.parquet", lambda f: df.to_parquet(f, index=False))))
    study = sw.spec.sweep.study
    line = summary_line(study, df, axes)
    click.echo(str(write_atomic(out_dir / "summary.txt", f"{sw.name}: {line}\n")))
    if study:
        fig = FIGURES[study](df, axes, relative)
        png = out_dir / f"{study}.png"
        click.echo(str(write_atomic_with(png, lambda f: fig.savefig(f, format="png", dpi=110,
                                                                    metadata={"Software": None}))))
    click.echo(f"{sw.name}: {line}")


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


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI, mapping every expected failure to exit code 2 and one line."""
    np.seterr(all="ignore")
    try:
        # in this mode click returns the code of a click.exceptions.Exit instead of exiting
        rc = cli.main(args=argv, prog_name="linsense", standalone_mode=False)
        if isinstance(rc, int) and rc != 0:
            sys.exit(rc)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.Abort as exc:
        if isinstance(exc.__cause__, KeyboardInterrupt):  # (click turns Ctrl-C into Abort)
            click.echo("linsense: interrupted", err=True)
            sys.exit(130)
        click.echo("linsense: aborted", err=True)
        sys.exit(1)
    except KeyboardInterrupt:  # Ctrl-C: the run stops within a second, its outputs not written
        click.echo("linsense: interrupted", err=True)
        sys.exit(130)
    except click.UsageError as exc:
        ctx = f"{exc.ctx.command_path}: " if exc.ctx else ""
        click.echo(f"linsense: error: {ctx}{exc.format_message()}".replace("\n", " "), err=True)
        sys.exit(2)
    except (LinsenseError, InputError) as exc:
        click.echo(f"linsense: error: {exc}".replace("\n", " "), err=True)
        sys.exit(2)
    except (OSError, ValueError) as exc:
        click.echo(f"linsense: error: {exc}".replace("\n", " "), err=True)
        sys.exit(2)
    sys.exit(0)


if __name__ == "__main__":  # pragma: no cover
    main()

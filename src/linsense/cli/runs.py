"""The commands that run the simulator or a solver: ``simulate``, ``calibrate``, ``reproduce``,
``fea`` and ``sweep``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from linsense.cli import _common as c
from linsense.errors import InputError
from linsense.io import working_folder
from linsense.version import docs


def scenario_arg(spec: str, option: str = "SCENARIO"):
    """The scenario a command argument names: ``-`` reads it from standard input (relative paths
    in it from the working folder), else a file or a packaged example's name; the one path of every
    command that takes a scenario (``simulate``, ``calibrate``, ``tune`` and ``firmware export``
    ``--scenario``), so that ``linsense tune --out - | linsense tune --scenario -`` reads as
    ``simulate -`` does."""
    from linsense.scenario.load import load_scenario, scenario_from_dict

    if spec == "-":
        from linsense.io import decode_text, parse_toml

        text = decode_text(c.read_stdin(), "<stdin>", "scenario")
        return scenario_from_dict(parse_toml(text, "<stdin>"), "<stdin>", working_folder())
    return load_scenario(c.example("scenarios", spec, option))


@click.command(short_help="Run a closed-loop drive simulation.",
               epilog=c.see("simulator"))
@click.argument("scenario")
@c.out_option("simulate", "scenario", folder=True)
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
@click.option("--pil", is_flag=True,
              help="processor in the loop: the drive on a Cortex-M4F under QEMU, the plant on the host "
                   "(a source tree with make tools run): metrics.json of that run, pil.json comparing it "
                   "with the host build's")
@c.json_option
def simulate(scenario: str, out: str | None, fidelity: str | None, trace_fmt: str | None,
             decimate: int | None, mat: bool, plot: bool, check: bool, pil: bool, as_json: bool) -> None:
    """Run a closed-loop drive simulation of SCENARIO (a file, a packaged example's name such as
    step3_lut, or - for standard input): metrics.json, timing.json, trace.parquet (or .csv; and
    trace.mat), sim.png with --plot. With --pil the drive runs on the Cortex-M4F under QEMU.

    Exit codes: 0 done (with --check: and stable, and with --pil the firmware's run identical to the
    host build's), 1 with --check: not so, 2 bad input (the scenario, or a configuration that trips
    the drive at t = 0)."""
    if pil:
        others = {"--fidelity": fidelity, "--trace": trace_fmt, "--decimate": decimate, "--mat": mat,
                  "--plot": plot}
        return _simulate_pil(scenario, out, [k for k, v in others.items() if v], check, as_json)
    from linsense.sim.to_folder import default_trace_format, simulate_to

    if as_json:
        c.data_on_stdout()
    if trace_fmt is None:  # (the core install has no pyarrow: its default trace is the CSV one)
        trace_fmt = default_trace_format()
        if trace_fmt == "csv":
            c.warn("trace.csv, not trace.parquet: the Parquet trace needs pyarrow "
                   "(pip install -e '.[parquet]' in linsense's source tree)")
    sc = scenario_arg(scenario)
    out = c.default_out(out, sc.name if scenario == "-" else scenario, "simulate")
    figure = None
    if plot:
        from linsense.report.sim_figures import write_sim_figure as figure
    done = simulate_to(out, sc, trace=trace_fmt, decimate=decimate, fidelity=fidelity, mat=mat, plot=figure,
                       warn=c.warn)
    metrics, timing = done.metrics, done.timing
    c.files_report(done.files)
    m = done.run.metrics
    _say_metrics(m)
    c.detail("timing: " + ", ".join(f"{k} {v}" for k, v in timing.items()))
    c.elapsed()
    if as_json:
        c.emit_json("simulate", done.files, bool(m["stable"]), metrics=metrics, timing=timing)
    if check and not m["stable"]:
        click.echo(f"linsense: not stable: {m['unstable_reason']}", err=True)
        raise click.exceptions.Exit(1)


def _say_metrics(m: dict) -> None:
    """The run's one-line report."""
    show = c.show
    # (after a fault the run's end is where it stopped, not a settled hold: no limit cycle to show)
    end = (f"final x {m['final_position_mm']} mm (where the fault stopped it); " if m["fault"] != "none" else
           f"final x {m['final_position_mm']} mm, limit cycle {show(m['limit_cycle_deg'], 'deg', '.3g')} "
           f"({m['limit_cycle_mm']} mm), overshoot {show(m['overshoot_deg'], 'deg', '.3g')} "
           f"({m['overshoot_mm']} mm); ")
    c.say(
        f"{m['scenario']}: "
        f"{'stable' if m['stable'] else 'not stable: ' + str(m['unstable_reason'])} (fault {m['fault']}); "
        f"max |err| {show(m['max_abs_err_deg'], 'deg')} "
        f"(transient {show(m['transient_max_err_deg'], 'deg')}, "
        f"steady {show(m['steady_max_err_deg'], 'deg')}, bias {show(m['bias_deg'], 'deg')}); "
        f"{end}{m['sim_s']} s simulated in {m['wall_s']} s "
        f"({m['realtime_factor']}x real time)"
    )


def _simulate_pil(scenario: str, out: str | None, others: list[str], check: bool, as_json: bool) -> None:
    """``simulate --pil``: the closed loop with the firmware under QEMU (:mod:`linsense.firmware.pil`);
    metrics.json of that run, timing.json, pil.json (both runs' metrics and how they differ)."""
    from linsense.firmware.pil import closed_loop_to

    if scenario == "-":
        raise InputError("--pil", "", "runs a scenario file or a packaged example's name, not standard input")
    if others:
        raise InputError("--pil", "", f"runs the scenario as its file sets it: not with {', '.join(others)}")
    if as_json:
        c.data_on_stdout()
    path = c.example("scenarios", scenario, "SCENARIO")
    scenario_arg(path)  # (bad input refused before anything is built)
    done = closed_loop_to(c.default_out(out, scenario, "simulate"), path)
    metrics, timing, rec = done.metrics, done.timing, done.record
    c.files_report(done.files)
    _say_metrics({**metrics, "wall_s": timing.get("wall_s"),
                  "realtime_factor": timing.get("realtime_factor")})
    same = ("every output of every step identical to the host build's" if rec["identical_steps"]
            else "not identical to the host build's; metrics differ by " + (", ".join(
                f"{k} {v:.3g}" for k, v in sorted(rec["metric_differences"].items())) or "nothing"))
    c.say(f"{metrics['scenario']}: the drive on the Cortex-M4F under QEMU ({rec['steps']} steps, "
          f"{timing['wall_s']:.1f} s wall, libm {rec['libm']}): {same}")
    c.elapsed()
    if as_json:
        c.emit_json("simulate", done.files, done.ok, metrics=metrics, timing=timing, pil=rec)
    if check and not done.ok:
        why = "not stable: " + str(metrics["unstable_reason"]) if not metrics["stable"] else \
            "the firmware's run differs from the host build's"
        click.echo(f"linsense: {why}", err=True)
        raise click.exceptions.Exit(1)


def drive_options(f):
    """The drive data as options (``--v-dc --f-pwm --dead-time --i-max --v-inj --f-inj``, SI units;
    :class:`~linsense.tune.design.DriveData`'s names): a command gets them as keyword arguments,
    None where not given."""
    dflt = " (default: the scenario's, else the design's drive data)"
    opts = [
        click.option("--v-dc", type=float, default=None, callback=c.finite(0.0, True),
                     help="bus voltage, V" + dflt),
        click.option("--f-pwm", type=float, default=None, callback=c.finite(0.0, True),
                     help="PWM rate, Hz" + dflt),
        click.option("--dead-time", type=float, default=None, callback=c.finite(0.0, False),
                     help="the inverter's dead time, s" + dflt),
        click.option("--i-max", type=float, default=None, callback=c.finite(0.0, True),
                     help="current limit, A" + dflt),
        click.option("--v-inj", type=float, default=None, callback=c.finite(0.0, True),
                     help="injection amplitude, V (default: the scenario's, else designed)"),
        click.option("--f-inj", type=float, default=None, callback=c.finite(0.0, True),
                     help="injection frequency, Hz (default: the scenario's, else designed)"),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def application_options(f):
    """The application's data as options (``--v-max --a-max --load --travel``; the design's speed cap,
    trips and verification follow them): a command gets them as keyword arguments, None where not
    given (``travel`` in mm, as typed)."""
    opts = [
        click.option("--v-max", type=float, default=None, callback=c.finite(0.0, True),
                     help="the application's top speed, m/s (default 0.2): speed cap, trips, verification"),
        click.option("--a-max", type=float, default=None, callback=c.finite(0.0, True),
                     help="the application's acceleration, m/s^2 (default 1)"),
        click.option("--load", type=float, default=None, callback=c.finite(0.0, True),
                     help="the rated load force, N (default half the force at i_max: K_f i_max, less the "
                          "share the rotating or square injection's d-current takes): verification's loads"),
        click.option("--travel", type=float, default=None, callback=c.finite(0.0, True),
                     help="the stroke, mm (default: unbounded)"),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def apply_drive_data(dd, drive: dict, quad=None, v_max=None, a_max=None, load=None, travel=None,
                     shape=None):
    """Set the options given (not None) on a :class:`~linsense.tune.design.DriveData`.

    Parameters
    ----------
    dd : DriveData
        The drive data to update.
    drive : dict
        The :func:`drive_options` by name.
    quad, v_max, a_max, load, shape : optional
        Kappa, m/s, m/s^2, N, the injection's shape.
    travel : float or None, optional
        The stroke, mm.

    Returns
    -------
    set of str
        The names of the drive data given as options (:func:`drive_refusal`).
    """
    given = {**drive, "quad": quad, "v_max": v_max, "a_max": a_max, "load": load,
             "travel": None if travel is None else travel * 1e-3, "shape": shape}
    for key, val in given.items():
        if val is not None:
            setattr(dd, key, val)
    return {key for key, val in given.items() if val is not None}


#: drive data (DriveData's names) -> the option that gives it
DRIVE_OPTIONS = {"v_dc": "--v-dc", "f_pwm": "--f-pwm", "dead_time": "--dead-time", "i_max": "--i-max",
                 "v_inj": "--v-inj", "f_inj": "--f-inj", "quad": "--quad", "v_max": "--v-max",
                 "a_max": "--a-max", "load": "--load", "travel": "--travel", "shape": "--injection"}


def drive_refusal(exc: InputError, typed: set[str], sc, source: str) -> InputError:
    """A refusal of drive data (named by its DriveData name, as the design does, or by its scenario
    key) said where the input came from, when a command took its drive data from a scenario and
    options over it: the option typed (``--v-inj: 40 V ...``), else the scenario's key (``s.toml:
    injection.amplitude: 12 V ...``), never the scenario for a value typed, nor a key the file does
    not have.

    Parameters
    ----------
    exc : InputError
        The refusal, naming the scenario and a DriveData name or scenario key.
    typed : set of str
        The drive data given as options (:func:`apply_drive_data`).
    sc : linsense.scenario.load.Scenario
        The scenario the rest came from.
    source : str
        The name the design was given for it (the scenario as typed).

    Returns
    -------
    InputError
        The refusal at the input's origin (``exc`` itself for another key).
    """
    from linsense.sim.build import DESIGN_KEYS

    name = next((k for k, v in DESIGN_KEYS.items() if v == exc.key), exc.key)
    if exc.source not in (source, sc.source) or name not in DRIVE_OPTIONS:
        return exc
    if name in typed:
        return InputError(DRIVE_OPTIONS[name], "", exc.message)
    return InputError(sc.source, DESIGN_KEYS.get(name, name), exc.message)


@click.command(short_help="Run the firmware's LUT calibration in the simulator.",
               epilog=c.see("simulator"))
@click.option("--motor", "motor_spec", default=None,
              help=c.MOTOR_HELP + "; with --scenario it must be the scenario's motor")
@click.option("--scenario", "scenario_path", default=None,
              help="the drive to calibrate (a file or a packaged example's name): the scenario's motor, "
                   "bus, PWM, dead time, injection (shape, amplitude, frequency, kappa), gains and "
                   "[calibration] keys; the options below over it")
@click.option("--positions", default=56, show_default=True, type=click.IntRange(4, 4096),
              help="points over one electrical period")
@click.option("--load", default=0.0, show_default=True, type=float, callback=c.finite(-math.inf, False),
              help="constant load force, N (opposing positive motion when > 0)")
@click.option("--fidelity", type=click.Choice(["switching", "average"]), default="switching",
              show_default=True, help="inverter model, with the drive's dead time (a scenario's fidelity is "
                                      "not used)")
@click.option("--quad", default=None, type=float, callback=c.quad,
              help="the injection's q-axis share kappa (default: the scenario's, else the design's; 0: the "
                   "paper's pulsating injection)")
@drive_options
@click.option("--saturated", is_flag=True, default=False,
              help=f"on the saturated plant (the motor file's [saturation], {docs('simulator')})")
@c.out_option("calibrate", "scenario's or motor", folder=True)
@c.json_option
def calibrate(motor_spec: str | None, scenario_path: str | None, positions: int, load: float, fidelity: str,
              quad: float | None, saturated: bool, out: str | None, as_json: bool, **drive) -> None:
    """Run the firmware's LUT calibration in the simulator (paper Fig. 9) on the drive that will use
    the table: a scenario's (--scenario), or the design for the motor (linsense tune's, with the
    drive data given): lut_measured.csv, lut_measured.json (stamped with the drive it is valid for,
    for a scenario's observer.lut_model = "measured"; when the calibration completed), metrics.json,
    calibration.png. Exit code 1 if it does not complete."""
    from linsense.report.figures import fig_calibration, save_png
    from linsense.studies.calibration_folder import calibrate_to

    if as_json:
        c.data_on_stdout()
    if motor_spec is None and scenario_path is None:
        raise click.UsageError("give --motor or --scenario (the drive to calibrate)")
    sc = scenario_arg(scenario_path, "--scenario") if scenario_path is not None else None
    motor = c.load(motor_spec) if motor_spec is not None else None
    out = c.default_out(out, scenario_path or motor_spec, "calibrate")
    done = calibrate_to(out, motor_spec if sc is not None else motor, positions=positions, load=load,
                        fidelity=fidelity, quad=quad, source=motor_spec or "<calibrate>", scenario=sc,
                        drive=drive, saturated=saturated,
                        figure=lambda cal, path: save_png(fig_calibration(cal, cal.motor), path))
    for w in done.warnings:
        c.warn(w)
    cal, metrics, timing = done.calibration, done.metrics, done.timing
    c.files_report(done.files)
    m = cal.metrics
    show = c.show
    shape = _injection_name(m)
    c.say(f"{m['motor']}: {m['points_done']}/{m['points']} points, load {m['load_n']:g} N, "
          f"{m['fidelity']}, {m['v_dc']:g} V, {m['f_pwm_hz']:g} Hz PWM, {m['dead_time_s'] * 1e6:g} us; "
          f"{shape} injection {m['v_inj']:.3g} V at {m['f_inj_hz']:g} Hz, kappa "
          f"{m['injection_quad']:g}: "
          f"max |measured - model with R_s| {show(m['max_diff_deg'], 'deg', '.3g')}, against eq. 12 "
          f"{show(m['max_diff_eq12_deg'], 'deg', '.3g')}; {m['sim_s']} s simulated in {m['wall_s']} s")
    c.elapsed()
    if as_json:
        c.emit_json("calibrate", done.files, done.completed, metrics=metrics, timing=timing)
    if not cal.completed:
        click.echo(f"linsense: calibration did not complete ({m['points_done']} of {m['points']} points, "
                   f"fault {m['fault']})", err=True)
        raise click.exceptions.Exit(1)


@click.command(short_help="Learn the end-effect table without a sensor.",
               epilog=c.see("tuning"))
@click.option("--motor", "motor_spec", default=None,
              help=c.MOTOR_HELP + "; with --scenario it must be the scenario's motor")
@click.option("--scenario", "scenario_path", default=None,
              help="the drive to commission (a file or a packaged example's name): its motor, bus, PWM, dead "
                   "time, injection and gains; its [travel] bounds the stroke")
@click.option("--speed", default=None, type=float, callback=c.finite(0.0, True),
              help="commissioning speed, m/s (default: 1.3 times the hand-over band's top of the drive "
                   "designed for the first of 2, 1.5, 1, 0.7 m/s the bus allows; its cruise must be above "
                   "the band of the drive designed for the speed itself)")
@click.option("--stroke", "stroke_mm", default=None, type=float, callback=c.finite(0.0, True),
              help="the back-and-forth stroke, mm (default: the scenario's travel, else what the speed needs "
                   "and three pole pitches)")
@click.option("--load", default=0.0, show_default=True, type=float, callback=c.finite(-math.inf, False),
              help="constant load force, N (opposing positive motion when > 0)")
@click.option("--positions", default=None, type=click.IntRange(4, 4096),
              help="table points over one electrical period (default: 56, more where the motor's table needs "
                   "them to be read within 0.5 deg)")
@click.option("--fidelity", type=click.Choice(["switching", "average"]), default="switching",
              show_default=True, help="inverter model, with the drive's dead time")
@click.option("--route", type=click.Choice(["pulsating", "direct"]), default="pulsating", show_default=True,
              help="pulsating: an elliptical drive learns with the pulsating injection and gets the model's "
                   "table of the end effect that fits; direct: the drive's own injection learns its table")
@drive_options
@c.out_option("commission", "scenario's or motor", folder=True)
@c.json_option
def commission(motor_spec: str | None, scenario_path: str | None, speed: float | None,
               stroke_mm: float | None, load: float, positions: int | None, fidelity: str, route: str,
               out: str | None, as_json: bool, **drive) -> None:
    """Learn the end-effect table without a sensor (docs/tuning.md, "Commissioning without a sensor"):
    the mover runs back and forth at a speed where the EMF estimate is trusted, the HF demodulator
    beside it, and the drive (LS_MODE_COMMISSION) learns the table from the HF error against the EMF
    position, both directions averaged; calibrate's outputs (lut_measured.csv, lut_measured.json for
    linsense tune --table and observer.lut_model = "measured", metrics.json). Refused (exit code 2)
    before the run: too little travel, a load the drive cannot hold at speed, no saliency, no EMF
    estimate in the design. Exit code 1 if it does not complete (and where the estimate was lost), or
    if its table is more than 0.3 deg off the simulated plant's own."""
    from linsense.report.figures import fig_commission, save_png
    from linsense.studies.commission import LOST_DEG, commission_to

    if as_json:
        c.data_on_stdout()
    if motor_spec is None and scenario_path is None:
        raise click.UsageError("give --motor or --scenario (the drive to commission)")
    sc = scenario_arg(scenario_path, "--scenario") if scenario_path is not None else None
    motor = c.load(motor_spec) if motor_spec is not None else None
    if sc is not None and motor is not None:  # (--motor then names the scenario's motor: checked)
        from linsense.compensation.stamp import data_digest
        from linsense.sim.build import resolve_motor

        theirs = resolve_motor(sc)
        if data_digest(motor=motor) != data_digest(motor=theirs):
            raise InputError(motor_spec, "--motor", f"{motor.name!r} is not the motor of the scenario "
                             f"{scenario_path} ({theirs.name!r}): give one of them, or the scenario's own")
        motor = None
    out = c.default_out(out, scenario_path or motor_spec, "commission")
    done = commission_to(out, motor, scenario=sc, speed=speed, stroke_mm=stroke_mm, load=load,
                         points=positions, fidelity=fidelity, route=route, drive=drive,
                         source=motor_spec or "<commission>",
                         figure=lambda cal, path: save_png(fig_commission(cal, cal.motor), path))
    m = done.calibration.metrics
    c.files_report(done.files)
    show = c.show
    run = (f"{m['points_done']}/{m['points']} points both ways at {m['speed_m_s']:.3g} m/s "
           f"(band top {m['v_hi_m_s']:.3g} m/s) over {m['stroke_mm']:.0f} mm, {m['fidelity']}, "
           f"{m['dead_time_s'] * 1e6:g} us, route {m['route']}")
    if done.completed:
        c.say(f"{m['motor']}: {run}: max |table - plant's| {show(m['max_diff_deg'], 'deg', '.3g')} (the "
              f"motor file's table: {show(m['start_diff_deg'], 'deg', '.3g')}), end-effect scale "
              f"{m['end_effect_k']:.3f}; {m['sim_s']} s simulated")
    else:  # (the table as the run left it is not a commissioned one: no figures of it here)
        c.say(f"{m['motor']}: NOT commissioned, {run}; fault {m['fault']} after {m['sim_s']} s simulated")
    c.elapsed()
    if as_json:
        c.emit_json("commission", done.files, done.completed, metrics=done.metrics, timing=done.timing)
    if not done.completed:
        lost = ("" if m.get("lost_at_s") is None else
                f"; the estimate was lost at {m['lost_at_s']:.3g} s, the mover at "
                f"{m['lost_speed_m_s']:.3g} m/s (its error beyond {LOST_DEG:g} deg): the HF estimate, which "
                f"carries the drive below the hand-over band and through the reversals "
                f"({_injection_name(m)} injection, the commissioning's d-current), did not hold it")
        click.echo(f"linsense: commissioning did not complete ({m['points_done']} of {m['points']} points, "
                   f"fault {m['fault']}){lost}", err=True)
        raise click.exceptions.Exit(1)
    if m["max_diff_deg"] > m["table_bound_deg"]:
        click.echo(f"linsense: the table learned is {m['max_diff_deg']:.3g} deg off the simulated plant's "
                   f"(a commissioning is held to {m['table_bound_deg']:g} deg): not a commissioned table"
                   + (" (the direct route learns with the drive's own injection, whose HF error at the "
                      "cruise it then carries: the pulsating route does not)"
                      if m["route"] == "direct" else ""),
                   err=True)
        raise click.exceptions.Exit(1)


def _injection_name(m: dict) -> str:
    """A run's injection as a person names it (``injection_shape``, ``injection_quad`` of its metrics):
    the library's pulsating shape with a q-axis share is the elliptical injection."""
    shape = m["injection_shape"]
    return "elliptical" if shape == "pulsating" and m["injection_quad"] else shape


def failed_claims(metrics: dict) -> list[str]:
    """The claims of a reproduction's ``metrics.json`` that do not hold (the paper's and those
    beyond it), as ``claim: paper ..., ours ...`` lines; [] for a model-only run."""
    out = []
    for key in ("claims", "claims_beyond"):
        for cl in metrics.get(key, ()):
            if not cl["holds"]:
                out.append(f"{cl['claim']}: paper {cl['paper']}, ours {cl['ours']}")
    return out


@click.command(short_help="Reproduce the paper's Section V, claim by claim.",
               epilog=c.see("reproduce"))
@click.option("--motor", "motor_spec", default="ecce2010", show_default=True, help=c.MOTOR_HELP)
@click.option("--out", default="out", show_default=True, type=click.Path(file_okay=False),
              callback=c.folder_out, help="output folder")
@click.option("--quick", is_flag=True,
              help="fewer calibration points, hold positions and map cells (about 15 s)")
@click.option("--model-only", is_flag=True, help="only the model's tables, LUT files and figures (no runs)")
@click.option("--check", is_flag=True, help="exit with code 1 when a claim does not hold (for CI)")
@c.json_option
def reproduce(motor_spec: str, out: str, quick: bool, model_only: bool, check: bool, as_json: bool) -> None:
    """Reproduce the paper's Section V, claim by claim (make demo): model tables and LUT files,
    Figs. 5-13 with the closed-loop runs on the switching inverter with dead time, metrics.json and
    a self-contained report.html in OUT."""
    from linsense.reproduce.pipeline import reproduce as run

    if as_json:
        c.data_on_stdout()
    c.load(motor_spec)  # (a bad motor: one line and exit code 2 before anything runs)
    files, lines = run(out, motor_spec, quick=quick, progress=c.progress(), model_only=model_only)
    c.files_report(files)
    for line in lines:
        c.say(line)
    metrics = {} if model_only else json.loads((Path(out) / "metrics.json").read_text(encoding="utf-8"))
    failed = failed_claims(metrics)
    c.elapsed()
    if as_json:
        keep = ("claim", "paper", "ours", "holds")
        c.emit_json("reproduce", files, not failed, motor=motor_spec, quick=quick, model_only=model_only,
                    claims=[{k: cl[k] for k in keep} for cl in metrics.get("claims", [])],
                    claims_beyond=[{k: cl[k] for k in keep} for cl in metrics.get("claims_beyond", [])])
    if check and failed:
        click.echo(f"linsense: {len(failed)} claim(s) do not hold: " + "; ".join(failed), err=True)
        raise click.exceptions.Exit(1)


@click.command("fea", short_help="Axisymmetric FEA of a tubular motor.",
               epilog=c.see("fea"))
@click.argument("geometry")
@c.out_option("fea", "geometry", folder=True)
@click.option("--positions", type=click.IntRange(12, 720), default=56, show_default=True,
              help="rod positions over one electrical period (12 .. 720)")
@click.option("--mesh", "level", type=click.Choice(["coarse", "default", "fine"]), default="default",
              show_default=True, help="mesh level")
@click.option("--lut-points", default=360, show_default=True, callback=c.points, help="length of lut.csv")
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
@c.json_option
def fea(geometry: str, out: str | None, positions: int, level: str, lut_points: int, load_current: str,
        workers: int, polarity: str | None, polarity_positions: int, as_json: bool) -> None:
    """Axisymmetric FEA of a tubular motor (GEOMETRY: a .toml file, a preset such as tubular56 or a
    packaged example's name such as tubular56_bh): inductances.csv, motor.toml, lut.csv,
    geometry.json, fea.json and figures."""
    from linsense.fea.geometry import preset_names
    from linsense.report.fea import run_fea

    if as_json:
        c.data_on_stdout()
    geometry = c.example("fea", geometry, "GEOMETRY", tuple(preset_names()))
    out = c.default_out(out, geometry, "fea")
    files, lines, warnings = run_fea(geometry, out, positions, level, lut_points,
                                     progress=c.progress(), load_current=load_current, workers=workers,
                                     polarity=polarity, polarity_positions=polarity_positions)
    c.files_report(files)
    for line in lines:
        c.say(line)
    for w in warnings:
        c.warn(w)
    c.elapsed()
    if as_json:
        fea_json = Path(out) / "fea.json"
        doc = json.loads(fea_json.read_text(encoding="utf-8")) if fea_json.is_file() else None
        c.emit_json("fea", files, True, fea=doc, warnings=list(warnings))


@click.command("sweep", short_help="Run a sweep of scenarios (threads or dask).",
               epilog=c.see("sweeps"))
@click.argument("sweep_file")
@click.option("--out", default=None, type=click.Path(file_okay=False), callback=c.folder_out,
              help="output folder, the same folder again resumes a killed sweep (default: NAME-sweep/ in "
                   "the working folder, NAME the sweep file's)")
@click.option("--workers", type=click.IntRange(1, 1024), default=None,
              help="local worker threads (or processes) (default: one per core)")
@click.option("--scheduler", default=None, help="address of a running dask scheduler (tcp://host:8786)")
@click.option("--processes", is_flag=True, help="local workers as processes instead of threads")
@click.option("--no-progress", is_flag=True, help="no progress bar")
@click.option("--restart", is_flag=True,
              help="discard the rows already in --out (a sweep whose inputs changed) and start over")
@click.option("--check", is_flag=True, help="exit with code 1 when a point is not stable or refused (for CI)")
@c.json_option
def sweep_cmd(sweep_file: str, out: str | None, workers: int | None, scheduler: str | None, processes: bool,
              no_progress: bool, restart: bool, check: bool, as_json: bool) -> None:
    """Run a sweep (SWEEP_FILE: a file or a packaged example's name such as injection): a base
    scenario with keys varied, on local worker threads or a dask.distributed cluster."""
    from linsense.sweep import load_sweep
    from linsense.sweep.sweep_folder import sweep_to

    if as_json:
        c.data_on_stdout()
    sw = load_sweep(c.example("sweeps", sweep_file, "SWEEP_FILE"))
    out = c.default_out(out, sweep_file, "sweep")
    figure = None
    if sw.spec.sweep.study:  # (matplotlib: only for a study's figure)
        from linsense.report.sweep_figures import write_sweep_figure as figure
    done = sweep_to(out, sw, workers=workers, scheduler=scheduler, processes=processes,
                    progress=not no_progress and c.progress(), restart=restart, figure=figure)
    c.files_report(done.files)
    c.say(f"{done.name}: {done.summary}")
    failed, n = done.failed_runs, len(done.rows)
    c.elapsed()
    if as_json:
        c.emit_json("sweep", done.files, not failed, name=done.name, study=done.study, axes=done.axes, runs=n,
                    stable=done.stable, not_stable=done.not_stable, refused=done.refused, failed_runs=failed,
                    summary=done.summary)
    if check and failed:
        click.echo(f"linsense: {len(failed)} of {n} sweep points not stable or refused (runs "
                   f"{', '.join(map(str, failed[:20]))}{', ...' if len(failed) > 20 else ''})", err=True)
        raise click.exceptions.Exit(1)


COMMANDS = [simulate, calibrate, commission, reproduce, fea, sweep_cmd]

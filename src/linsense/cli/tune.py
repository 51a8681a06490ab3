"""``linsense tune``: the drive designed for a motor, its report and its verification certificate."""

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
from linsense.version import docs


def _check_options(as_json: bool, out: str | None, fmt: str, no_verify: bool, unverified: bool, quick: bool,
                   table_route: str, name: str | None) -> None:
    """Refuse the options that contradict each other or would do nothing (one line, exit code 2)."""
    if as_json and out == "-":
        raise click.UsageError("--json and --out - both write to standard output: give --out a file")
    if fmt == "c" and no_verify and not unverified:
        raise click.UsageError("--format c writes a header only for a verified drive: drop --no-verify "
                               "(or give --unverified to write it unverified)")
    if no_verify and (quick or table_route is not None):  # (not ignored: they shape the certificate)
        raise click.UsageError(f"{'--quick' if quick else '--table-route'} shapes the certificate, which "
                               "--no-verify does not run: drop one of them")
    if unverified and fmt != "c":
        raise click.UsageError("--unverified is for --format c (a scenario is written whatever the "
                               "certificate says)")
    if name is not None and fmt != "c":  # (not ignored with a scenario)
        raise click.UsageError("--name names the C header's symbols: only with --format c")
    ext = {"c": ".toml", "toml": ".h"}[fmt]  # (the other format's extension: the file would mislead)
    if out not in (None, "-") and out.lower().endswith(ext):
        what, own = ("a C header", ".h") if fmt == "c" else ("a scenario", ".toml")
        raise click.UsageError(f"--out {out}: --format {fmt} writes {what}, not a {ext} file: name it {own}")


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
@click.option("--table-route", type=click.Choice(["calibrate", "commission"]), default=None,
              help="how the certificate measures the table of a motor off by its end effect: the "
              "firmware's calibration (an encoder; the default) or the sensorless commissioning "
              "(linsense commission)")
@c.out_option("tune", "motor", folder=False, ext=".toml or .h", dash=True)
@c.json_option
def tune(motor_spec: str, scenario_path: str | None, quad, fmt: str, polarity: float | None,
         current_noise: float, name: str | None, v_max, a_max, load, travel, shape, table_path,
         quick: bool, no_verify: bool, unverified: bool, table_route: str, out: str | None, as_json: bool,
         **drive) -> None:
    """Design the drive for a motor: injection, current loop, demodulator, observer, speed and
    position loops, limits and trips; print the design and its margins; write a
    scenario or a C header; then verify it in the simulator (switching inverter with dead time) and
    write verification.json and verification.png beside the output (exit 1 if a check fails). A C
    header is written only for a drive that passes (--unverified: anyway, saying why in it)."""
    from linsense.report.verify_figures import write_certificate_figure
    from linsense.verify.tune_output import tune_to

    _check_options(as_json, out, fmt, no_verify, unverified, quick, table_route, name)
    if as_json or out == "-":
        c.data_on_stdout()  # (stdout carries the file itself, or the JSON summary)
    out = c.default_out(out, motor_spec, "tune", ".h" if fmt == "c" else ".toml")
    sc = None if scenario_path is None else scenario_arg(scenario_path, "--scenario")
    given = _Given()
    typed = apply_drive_data(given, drive, quad, v_max, a_max, load, travel, shape)
    res = tune_to(out, motor_spec, figure=write_certificate_figure, say=c.say, scenario=sc,
                  source=scenario_path, drive=vars(given), fmt=fmt, name=name, polarity=polarity,
                  current_noise=current_noise, table=table_path, quick=quick, verify=not no_verify,
                  unverified=unverified, warn=c.warn, detail=c.detail, table_route=table_route or "calibrate",
                  refusal=lambda exc: _refusal(exc, typed, sc, scenario_path))
    cert = res.certificate
    verification = None if cert is None else {k: v for k, v in cert.as_dict().items() if k != "runs"}
    c.elapsed()
    if as_json:
        c.emit_json("tune", res.files, not res.refused and res.passed, verification=verification,
                    **({"refused": res.refused} if res.refused else res.summary()))
    if res.refused:
        c.warn(f"{out} not written: {res.refused} (--unverified writes it anyway)")
    if res.refused or (cert is not None and not cert.passed):
        raise click.exceptions.Exit(1)


def _refusal(exc: InputError, typed: set[str], sc, source: str | None) -> InputError:
    """A refusal of drive data at the option typed or the scenario's key (:func:`drive_refusal`)."""
    return exc if sc is None else drive_refusal(exc, typed, sc, source)


class _Given:
    """The drive data typed as options (:func:`apply_drive_data` sets them here)."""


COMMANDS = [tune]

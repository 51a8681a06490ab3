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
    from linsense.verify.tuning import tune as run_tune

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
    sc = None if scenario_path is None else scenario_arg(scenario_path, "--scenario")
    given = _Given()
    typed = apply_drive_data(given, drive, quad, v_max, a_max, load, travel, shape)
    files: list = []

    def write(res) -> None:  # (a header after its certificate's files, a scenario before its runs)
        if res.certificate is not None:
            _write_certificate(res, quick, json_path, png_path, files, out)
        files.insert(0, write_atomic(out, res.text))
        if out != "-":
            c.say(str(files[0]))

    res = run_tune(motor_spec, scenario=sc, source=scenario_path, drive=vars(given), fmt=fmt, name=name,
                   polarity=polarity, current_noise=current_noise, table=table_path, quick=quick,
                   verify=not no_verify, unverified=unverified, out=out, say=c.say, warn=c.warn,
                   detail=c.detail, ready=write, refusal=lambda exc: _refusal(exc, typed, sc, scenario_path))
    cert = res.certificate
    verification = None if cert is None else {k: v for k, v in cert.as_dict().items() if k != "runs"}
    if res.refused:
        c.elapsed()
        if as_json:
            c.emit_json("tune", files, False, verification=verification, refused=res.refused)
        c.warn(f"{out} not written: {res.refused} (--unverified writes it anyway)")
        raise click.exceptions.Exit(1)
    if cert is None:
        for p in (json_path, png_path):  # (a certificate of an earlier design would be stale)
            p.unlink(missing_ok=True)
    elif fmt == "toml":
        _write_certificate(res, quick, json_path, png_path, files, out)
    c.elapsed()
    if as_json:
        c.emit_json("tune", files, res.passed, verification=verification, **res.summary())
    if cert is not None and not cert.passed:
        raise click.exceptions.Exit(1)


def _refusal(exc: InputError, typed: set[str], sc, source: str | None) -> InputError:
    """A refusal of drive data at the option typed or the scenario's key (:func:`drive_refusal`)."""
    return exc if sc is None else drive_refusal(exc, typed, sc, source)


class _Given:
    """The drive data typed as options (:func:`apply_drive_data` sets them here)."""


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


def _write_certificate(res, quick: bool, json_path: Path, png_path: Path, files: list,
                       output: str = "-") -> None:
    """Write the certificate's JSON and figure (appended to ``files``); the JSON names the ``output``
    it certifies (:func:`_own_certificate`)."""
    import json

    from linsense.io import write_atomic
    from linsense.report.figures import save_png
    from linsense.report.verify_figures import certificate_figure

    cert = res.certificate
    text = json.dumps(res.certificate_doc(output), indent=1, sort_keys=True) + "\n"
    files.append(write_atomic(json_path, text))
    c.say(str(files[-1]))
    fig = certificate_figure(cert.rows, f"{res.motor.name}: {cert.verdict()}", quick=quick,
                             calibrations=cert.extra.get("calibrations"))
    files.append(save_png(fig, png_path, 100))
    c.say(str(files[-1]))



COMMANDS = [tune]

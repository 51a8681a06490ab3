"""One command's output fed into another: a motor file, a
bench file, a LUT, a measured table or a tuned scenario handed on, edited in between or paired with
another motor's file. Each case was a wrong answer without a word, or a refusal that did not say
which file of the chain is wrong.

The rules behind them:

* **an input is named where it came from**: a value a command took from a scenario is named by
  the scenario and its key (``observer.lut_file``, ``injection.amplitude``), a value typed as an
  option by the option (``--v-inj``), whichever command reads it (``simulate``, ``tune``,
  ``firmware export``);
* **an output is what the next command reads, read back before it is written**: the scenario
  ``tune`` writes is read as ``simulate`` reads it (never one the simulator refuses), keeps the
  application it was designed for (``reference.v_max``, ``a_max``: a re-tune over it designs the
  same drive), believes in the motor it was designed and certified for (a ``controller.model.motor``
  of another motor is refused), and its paths are relative to where it is written; a certificate
  names the output it certifies (another output's is not replaced); every command reads a scenario
  argument through one path (``-`` is standard input for ``tune`` and ``firmware export`` too);
* **a file is checked against the other files it is paired with**: the derived columns of a
  ``linsense model`` table against its inductances, a bench file against the pole pitch it is read
  with, a measured table against the motor (its end-effect fit at its own points, and its
  resolution where the drive reads it, said by every command that reads or writes it).
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import tomllib
from importlib import resources
from pathlib import Path

import pytest

import linsense
from linsense.compensation.lut import build_lut
from linsense.compensation.measured import measured_table_json, table_stamp
from linsense.model.motor import load_motor

#: the scenario `linsense tune --motor small30` writes (its certificate passes)
TUNED = """motor = "small30"

[scenario]
name = "tuned"
duration = 0.2

[reference]
type = "hold"

[inverter]
v_dc = 72.0
f_pwm = 16000.0
dead_time = 8e-07

[injection]
amplitude = 12.0
ramp_rate = 1200.0
quadrature = 0.9
frequency = 1000.0

[observer]
type = "mech"
bandwidth_hz = 15.0
demod_lpf_hz = 300.0
gain_schedule = true
omega_max = 104.72
hf_delay_s = 0.001
force_max = 25.0

[controller]
current_bandwidth_hz = 250.0
speed_bandwidth_hz = 8.0
i_max = 2.5
v_max = 0.25
step_a_max = 4.18879
kp_x = 20.1062

[calibration]
dither_a = 0.4
dither_hz = 55.0

[protection]
v_dc_min = 40.0
v_dc_max = 90.0
omega_max = 83.7758
i_max = 5.13278
"""

def small30_text(dM0: str = "-0.25e-3") -> str:
    return f"""[motor]
name = "small30"
R_s = 2.0
pole_pitch = 0.030
force_constant = 10.0
mass = 0.8

[inductance]
L0 = 1.5e-3
L2 = -0.17e-3
M0 = -0.5e-3
M2 = -0.17e-3
dM0 = {dM0}
"""


def measured(scale: float = 1.0, shift: int = 0) -> str:
    """A measured table of small30's drive (the model's resistive table, as a calibration measures
    it to 0.1 deg), scaled or shifted to make it another motor's."""
    m = load_motor("small30")
    v = build_lut(m, 56, f_inj=1000.0, quad=0.9).values * scale
    v = list(v[shift:]) + list(v[:shift])
    return measured_table_json(v, table_stamp(m, "pulsating", 1000.0, 0.9, 56))


def with_table(path: str) -> str:
    return TUNED.replace("force_max = 25.0", f'force_max = 25.0\nlut_model = "measured"\nlut_file = "{path}"')


@pytest.fixture
def files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)

    def write(**texts: str):
        for name, text in texts.items():
            (tmp_path / name).write_text(text)
        return tmp_path

    return write


# ---------------------------------------------------------------- a value named where it came from
def test_a_scenario_s_table_of_another_motor_is_named_by_the_scenario_in_tune(files, run_cli):
    """``tune --motor ecce2010 --scenario s.toml``: the scenario's measured table (small30's) was refused
    naming only the table's absolute path, not the scenario key that brought it."""
    files(**{"s.toml": with_table("t.json"), "t.json": measured()})
    line = run_cli("tune", "--motor", "ecce2010", "--scenario", "s.toml", "--no-verify", "--out",
                   "o.toml").refused("s.toml: observer.lut_file: 't.json':", "stamp.motor_sha256", "small30")
    assert "ecce2010" in line


def test_a_scenario_s_table_of_another_motor_is_named_by_the_scenario_in_firmware_export(files, run_cli):
    files(**{"s.toml": with_table("t.json"), "t.json": measured()})
    run_cli("firmware", "export", "fw", "--motor", "ecce2010", "--scenario", "s.toml").refused(
        "s.toml: observer.lut_file: 't.json':", "stamp.motor_sha256")


def test_an_option_s_value_is_not_blamed_on_the_scenario(files, run_cli):
    """``tune --scenario s.toml --v-inj 40``: the 40 V typed as an option was blamed on s.toml."""
    files(**{"s.toml": TUNED})
    line = run_cli("tune", "--motor", "small30", "--scenario", "s.toml", "--v-inj", "40", "--no-verify",
                   "--out", "o.toml").refused("--v-inj", "40 V")
    assert "s.toml" not in line, line


def test_a_scenario_s_value_is_named_by_its_key(files, run_cli):
    """``tune --scenario tuned.toml --v-dc 36``: the tuned scenario's 12 V injection (designed for its
    72 V bus) was named ``v_inj``, a key the file does not have."""
    files(**{"s.toml": TUNED})
    for cmd in (("tune", "--motor", "small30", "--no-verify", "--out", "o.toml"),
                ("firmware", "export", "fw", "--motor", "small30")):
        line = run_cli(*cmd, "--scenario", "s.toml", "--v-dc", "36").refused(
            "s.toml: injection.amplitude: 12 V", "36 V bus")
        assert ": v_inj:" not in line, line


def test_a_relative_motor_path_says_where_it_was_looked_for(files, run_cli):
    """A tuned scenario moved away from its motor file: the message did not say the path is taken
    relative to the scenario's folder."""
    (files() / "sub").mkdir()
    files(**{"sub/s.toml": TUNED.replace('motor = "small30"', 'motor = "../m/small30.toml"')})
    run_cli("simulate", "sub/s.toml", "--out", "o", "--trace", "none").refused(
        "sub/s.toml: motor:", "'../m/small30.toml'", "relative to the scenario's folder")


# ---------------------------------------------------------------- what an output holds
def test_tune_refuses_a_scenario_whose_drive_believes_in_another_motor(files, run_cli):
    """``tune --motor small30 --scenario s.toml`` with ``controller.model.motor`` another motor: tune
    certified the drive believing in small30 (the certificate pins the model) and wrote the scenario
    believing in the other one, exit 0."""
    files(**{"s.toml": TUNED + '\n[controller.model]\nmotor = "other.toml"\n',
             "other.toml": small30_text("-0.40e-3")})
    run_cli("tune", "--motor", "small30", "--scenario", "s.toml", "--no-verify", "--out", "o.toml").refused(
        "s.toml: controller.model.motor", "'other.toml'", "small30")
    # the same motor's data under another file name is that motor; written elsewhere, its path is
    # made relative to the output (it was copied as written, and named a file that is not there)
    files(**{"other.toml": small30_text()})
    (files() / "out").mkdir()
    assert run_cli("tune", "--motor", "small30", "--scenario", "s.toml", "--no-verify",
                   "--out", "out/o.toml").code == 0
    assert 'motor = "../other.toml"' in (files() / "out" / "o.toml").read_text()
    assert run_cli("simulate", "out/o.toml", "--out", "sim", "--trace", "none").code == 0


def test_tune_never_writes_a_scenario_the_simulator_refuses(files, run_cli):
    """``tune --scenario tuned.toml --v-dc 100``: the scenario's protection bus range (tuned for 72 V,
    kept as the scenario's own limits) trips a 100 V drive at t = 0; ``--no-verify`` wrote it, exit 0,
    and the certificate blamed "the certificate's hold run"."""
    files(**{"s.toml": TUNED})
    for more in (("--no-verify",), ("--quick",)):
        line = run_cli("tune", "--motor", "small30", "--scenario", "s.toml", "--v-dc", "100", *more,
                       "--out", "o.toml").refused("--v-dc", "[40, 90] V", "protection.v_dc_max", "got 100")
        assert "certificate" not in line, line
    assert not (files() / "o.toml").exists()


def test_a_re_tune_over_the_tuned_scenario_designs_the_same_drive(files, run_cli):
    """``tune --v-max 0.3`` then ``tune --scenario`` over its output: the application's speed was not in
    the scenario, so the re-tune designed for the default 0.2 m/s (speed cap 0.375 -> 0.25 m/s, the
    over-speed trip lowered) without a word."""
    files()
    assert run_cli("tune", "--motor", "small30", "--v-max", "0.3", "--a-max", "2", "--no-verify",
                   "--out", "a.toml").code == 0
    assert run_cli("tune", "--motor", "small30", "--scenario", "a.toml", "--no-verify",
                   "--out", "b.toml").code == 0
    a, b = (tomllib.loads(open(f).read()) for f in ("a.toml", "b.toml"))
    assert a == b


# ---------------------------------------------------------------- a file against its pair
def test_an_edited_derived_column_of_a_model_table_is_refused(files, run_cli):
    """``linsense model`` output used as a motor's inductance table, its ``psi_lut_deg`` and ``L_dq``
    columns doubled: read past, the motor unchanged, without a word."""
    root = files(**{"m.toml": small30_text().split("L0 =")[0] + 'table = "t.csv"\n'})
    assert run_cli("model", "--motor", "small30", "--points", "72", "--out", "t.csv").code == 0
    rows = list(csv.reader(open(root / "t.csv")))
    assert run_cli("lut", "--motor", "m.toml", "--points", "8", "--out", "l.csv").code == 0  # (as written)
    col = rows[0].index("L_dq")
    rows[3][col] = repr(2.0 * float(rows[3][col]))
    with open(root / "t.csv", "w", newline="") as f:
        csv.writer(f).writerows(rows)
    run_cli("lut", "--motor", "m.toml", "--points", "8", "--out", "l.csv").refused(
        "t.csv", "row 4, column L_dq", "L_A .. M_CA")


@pytest.mark.parametrize("motor", ["ecce2010", "ex/m45.toml"])
def test_a_bench_file_of_another_pole_pitch_is_refused(files, run_cli, motor):
    """A bench file of a 60 mm motor identified with ``--motor ecce2010`` (56 mm): a fitted motor file,
    exit 0 (residual 6.5 times the right pitch's); read with 45 mm, refused blaming the fitted
    model's saliency."""
    m60 = resources.files("linsense.examples") / "motors" / "class"
    root = files(**{"m60.toml": (m60 / "m60_pos20k.toml").read_text()})
    (root / "ex").mkdir()
    (root / "ex" / "m45.toml").write_text((m60 / "m45_24v.toml").read_text())
    assert run_cli("bench-emulate", "--motor", "m60.toml", "--positions", "56", "--noise", "0.01", "--seed",
                   "1", "--out", "b.csv").code == 0
    line = run_cli("identify", "b.csv", "--motor", motor, "--out", "id").refused(
        "b.csv: column position_mm", "read with the pole pitch", f"({'--motor ' if '/' in motor else ''}",
        "with a pole pitch of 60.0")
    assert "saliency" not in line, line


def test_an_implausible_measured_table_is_said_by_simulate(files, run_cli):
    """A measured table whose values were turned over (another motor's, or edited): ``tune`` warned
    that it does not look like the motor's, ``simulate`` ran it without a word."""
    files(**{"s.toml": with_table("t.json"), "t.json": measured(scale=-1.0)})
    r = run_cli("simulate", "s.toml", "--out", "o", "--trace", "none")
    assert "does not look like this motor's" in r.err, r.err
    assert "t.json" in r.err


def test_table_hints_fit_the_command(files, run_cli):
    """A CSV table given to ``--table`` was told to take the lut_measured.json "beside it" (identify's
    lut.csv has none); a model table was told about a scenario key."""
    files(**{"lut.csv": "theta_deg,psi_lut_deg\n0,1\n", "l.json": '{"format": "linsense-lut"}'})
    line = run_cli("tune", "--motor", "small30", "--table", "lut.csv", "--no-verify",
                   "--out", "o.toml").refused("lut.csv", "no stamp", "linsense calibrate",
                                              "beside its lut_measured.csv")
    assert "writes beside it" not in line
    line = run_cli("tune", "--motor", "small30", "--table", "l.json", "--no-verify",
                   "--out", "o.toml").refused("l.json", "format", "no stamp")
    assert "--table" in line



def test_a_renamed_motor_s_table_says_it_is_the_same_data(files, run_cli):
    """The motor file renamed (its data untouched): its table was refused as "valid for the motor data
    it was calibrated for", as if the data differed."""
    files(**{"m.toml": small30_text().replace('name = "small30"', 'name = "mine"'), "t.json": measured()})
    run_cli("tune", "--motor", "m.toml", "--table", "t.json", "--no-verify", "--out", "o.toml").refused(
        "t.json: stamp.motor_sha256", "the same motor data under another name", "'small30' again")


def coarse(n: int) -> str:
    m = load_motor("small30")
    return measured_table_json(build_lut(m, n, f_inj=1000.0, quad=0.9).values,
                               table_stamp(m, "pulsating", 1000.0, 0.9, n))


def test_a_coarse_table_is_said_coarse_not_another_motor_s(files, run_cli):
    """A 12-point measured table (``calibrate --positions 12``), each point right: read by the drive's
    linear interpolation it is 3.5 deg off between its points; ``tune`` said the table "does not look
    like this motor's: check the calibration and the motor file", ``simulate`` and ``calibrate``
    nothing."""
    files(**{"t.json": coarse(12), "s.toml": with_table("t.json")})
    for r in (run_cli("tune", "--motor", "small30", "--table", "t.json", "--no-verify", "--out", "o.toml"),
              run_cli("simulate", "s.toml", "--out", "o", "--trace", "none")):
        assert r.code == 0, r.err
        assert "t.json" in r.err and "a 12-point table" in r.err and "3.5 deg" in r.err, r.err
        assert "does not look like this motor's" not in r.err, r.err
    r = run_cli("calibrate", "--motor", "small30", "--positions", "12", "--fidelity", "average",
                "--out", "cal")
    assert "a 12-point table" in r.err, r.err
    # the calibration's own 56 points: read closely enough, nothing said
    files(**{"t.json": coarse(56)})
    assert "warning" not in run_cli("simulate", "s.toml", "--out", "o", "--trace", "none").err


def test_an_output_s_certificate_is_not_replaced_by_another_output_s(files, run_cli):
    """``tune --format c --out a.h`` then ``tune --no-verify --out a.toml``: the header's certificate
    (``a.verification.json``, the same stem) was deleted without a word (a verified ``--out a.toml``
    replaced it)."""
    root = files()
    assert run_cli("tune", "--motor", "small30", "--format", "c", "--quick", "--out", "a.h").code == 0
    cert = (root / "a.verification.json").read_text()
    assert '"output": "a.h"' in cert
    for more in (("--no-verify",), ("--quick",)):
        run_cli("tune", "--motor", "small30", *more, "--out", "a.toml").refused(
            "a.verification.json: output: 'a.h'", "the certificate of a.h", "--out a.toml")
    assert (root / "a.verification.json").read_text() == cert and not (root / "a.toml").exists()
    # the same output's certificate is its own: replaced by its next run
    assert run_cli("tune", "--motor", "small30", "--format", "c", "--quick", "--out", "a.h").code == 0


def test_tune_and_firmware_export_read_a_scenario_from_standard_input(tmp_path):
    """``linsense tune --out - | linsense tune --scenario -``: ``simulate -`` and ``calibrate --scenario
    -`` read standard input, ``tune`` and ``firmware export`` refused ``-`` as "unknown scenario"."""
    env = {**os.environ, "PYTHONPATH": str(Path(linsense.__file__).resolve().parents[1])}

    def run(*args: str, text: str = "") -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "linsense", *args], input=text, capture_output=True,
                              text=True, cwd=tmp_path, env=env, timeout=300)

    first = run("tune", "--motor", "small30", "--no-verify", "--out", "-")
    assert first.returncode == 0, first.stderr
    again = run("tune", "--motor", "small30", "--scenario", "-", "--no-verify", "--out", "-",
                text=first.stdout)
    assert again.returncode == 0, again.stderr
    assert tomllib.loads(again.stdout) == tomllib.loads(first.stdout)
    fw = run("firmware", "export", "fw", "--motor", "small30", "--scenario", "-", text=first.stdout)
    assert fw.returncode == 0, fw.stderr

"""Scenario files of the simulator: every shipped example loads, and bad input ends with exit code 2
and one line naming the file, the key and the value, with nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest

from linsense.errors import InputError
from linsense.scenario.load import load_scenario, scenario_from_dict
from linsense.sim.build import reference_commands, trapezoid_time

EXAMPLES = sorted((Path(__file__).parents[1] / "src/linsense/examples" / "scenarios").glob("*.toml"))

BASE = """motor = "ecce2010"
[scenario]
name = "t"
duration = 0.2
[reference]
type = "step"
position_mm = 1.0
"""


def test_examples_exist_and_validate():
    names = {p.stem for p in EXAMPLES}
    assert {"step3_lut", "step3_nolut", "step6_lut", "step6_nolut", "fig13_trajectory",
            "fig13_trajectory_switching", "benchmark"} <= names
    for p in EXAMPLES:
        sc = load_scenario(p)
        assert sc.spec.scenario.duration > 0
        assert sc.spec.control.fs in (None, sc.spec.inverter.f_pwm)


def test_defaults_are_the_firmware_and_paper_drive():
    s = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 1.0},
                            "reference": {"position_mm": 1.0}}).spec
    assert (s.inverter.v_dc, s.inverter.f_pwm, s.inverter.dead_time) == (72.0, 16000.0, 0.8e-6)
    assert (s.injection.amplitude, s.injection.frequency) == (12.0, 1000.0)
    # the design's mechanical observer at f_lpf / 20 with its load estimate fed forward
    assert s.control.mode == "sensorless_lut" and s.observer.bandwidth_hz == 15.0
    assert s.observer.type == "mech" and s.observer.load_feedforward is None  # (on with mech)


def test_trajectory_command_times():
    sc = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 2.0},
                             "reference": {"type": "trajectory", "waypoints_mm": [10.0, 10.0, -30.0],
                                           "v_max": 0.2, "a_max": 1.0, "dwell": 0.25, "at": 0.1}})
    cmds, moves = reference_commands(sc)
    assert [c[1] for c in cmds] == pytest.approx([0.01, 0.01, -0.03])
    assert all(c[2] for c in cmds)
    # 10 mm at 1 m/s^2 never reaches 0.2 m/s: triangle, 2 sqrt(D/a); 40 mm: D/v + v/a
    assert trapezoid_time(0.01, 0.2, 1.0) == pytest.approx(2 * (0.01) ** 0.5)
    assert trapezoid_time(-0.04, 0.2, 1.0) == pytest.approx(0.4)
    assert moves[0][1] - moves[0][0] == pytest.approx(0.2)
    assert cmds[1][0] == pytest.approx(0.1 + 0.2 + 2 / 16000 + 0.25)
    assert moves[1][1] == moves[1][0]  # zero-length move
    assert moves[2][1] - moves[2][0] == pytest.approx(0.4)


def _edit(text: str, section: str, line: str) -> str:
    """Add ``line`` to ``[section]`` (creating it), or at the top for section ''."""
    if not section:
        return line + "\n" + text
    head = f"[{section}]\n"
    if head in text:
        return text.replace(head, head + line + "\n")
    return text + head + line + "\n"


BAD = [
    # (section, line or None, replacement of BASE, expected key, fragment of the message)
    ("", None, BASE.replace('motor = "ecce2010"\n', ""), "motor", "missing"),
    ("scenario", None, BASE.replace("duration = 0.2\n", ""), "scenario.duration", "missing"),
    ("scenario", "colour = 3", None, "scenario.colour", "unknown key"),
    ("", None, BASE + "[extra]\nx = 1\n", "extra", "unknown key"),
    ("inverter", 'f_pwm = "16k"', None, "inverter.f_pwm", "16k"),
    ("inverter", "v_dc = nan", None, "inverter.v_dc", "finite"),
    ("inverter", "v_dc = inf", None, "inverter.v_dc", "finite"),
    ("inverter", "dead_time_compensation = 1", None, "inverter.dead_time_compensation", "1"),
    ("inverter", 'fidelity = "exact"', None, "inverter.fidelity", "exact"),
    ("control", "fs = 10000.0", None, "control.fs", "10000"),
    ("control", 'mode = "magic"', None, "control.mode", "magic"),
    ("scenario", None, BASE.replace("duration = 0.2", "duration = -1.0"), "scenario.duration", "-1"),
    ("scenario", "seed = 1.5", None, "scenario.seed", "1.5"),
    ("reference", None, BASE.replace('type = "step"\nposition_mm = 1.0',
                                     'type = "trajectory"\nwaypoints_mm = []'),
     "reference.waypoints_mm", "[]"),
    ("reference", None, BASE.replace('type = "step"\nposition_mm = 1.0',
                                     'type = "trajectory"\nwaypoints_mm = [1.0]\ndwell = -0.1'),
     "reference.dwell", "-0.1"),
    ("reference", None, BASE.replace('type = "step"\nposition_mm = 1.0',
                                     'type = "trajectory"\nwaypoints_mm = [1.0, "x"]'),
     "reference.waypoints_mm.1", "x"),
    ("reference", None, BASE.replace("position_mm = 1.0\n", ""), "reference.position_mm", "missing"),
    ("observer", 'compensation = "none"', None, "observer.compensation", "none"),
    ("observer", "bandwidth_hz = 0", None, "observer.bandwidth_hz", "0"),
    ("observer", "lut_points = 2", None, "observer.lut_points", "2"),
    ("injection", "frequency = 5000.0", None, "injection.frequency", "5000"),
    # (a PWM in kHz: named before the injection's rule that reads it, which said "f_inj <= 5 Hz")
    ("inverter", "f_pwm = 20.0", None, "inverter.f_pwm", "did you type kHz?"),
    ("injection", "amplitude = 40.0", None, "injection.amplitude", "40"),
    ("controller", 'position_type = "pd"', None, "controller.kp_x", "missing"),
    ("controller", "speed_kp = 10.0", None, "controller.speed_ki", "together"),
    ("controller", "i_max = -1.0", None, "controller.i_max", "-1"),
    ("controller.model", "L_d = -1e-3", None, "controller.model.L_d", "-0.001"),
    ("sensors", "current_gain = [1.0, 1.0]", None, "sensors.current_gain", "1.0"),
    ("sensors", "adc_bits = 40", None, "sensors.adc_bits", "40"),
    ("load", 'type = "spring"', None, "load.type", "spring"),
    ("travel", "min_mm = 5.0\nmax_mm = 1.0", None, "travel.max_mm", "1"),
    ("travel", "max_mm = -5.0", None, "initial.position_mm", "-5"),
    ("initial", "position_mm = 2000.0", None, "initial.position_mm", "2000"),
    ("record", "decimate = 0", None, "record.decimate", "0"),
    ("", None, BASE.replace('motor = "ecce2010"', 'motor = "nosuchmotor"'), "motor", "nosuchmotor"),
    ("", None, BASE.replace('motor = "ecce2010"', 'motor = "motors/missing.toml"'), "motor", "missing.toml"),
    ("", None, BASE.replace('motor = "ecce2010"', "motor = 3"), "motor", "3"),
]


@pytest.mark.parametrize("section,line,text,key,fragment", BAD,
                         ids=[b[3] + ":" + (b[1] or "edit") for b in BAD])
def test_bad_scenarios_cli(run_cli, tmp_path, section, line, text, key, fragment):
    src = text if text is not None else _edit(BASE, section, line)
    path = tmp_path / "bad.toml"
    path.write_text(src)
    out = tmp_path / "out"
    r = run_cli("simulate", path, "--out", out)
    assert r.code == 2, (r.out, r.err)
    lines = r.err.strip().splitlines()
    assert len(lines) == 1, r.err
    msg = lines[0]
    assert "Traceback" not in r.err
    assert str(path) in msg and f": {key}:" in msg and fragment in msg, msg
    assert not out.exists()


def test_bad_toml_and_missing_file(run_cli, tmp_path):
    p = tmp_path / "broken.toml"
    p.write_text("motor = \n")
    r = run_cli("simulate", p, "--out", tmp_path / "o")
    assert r.code == 2 and "not valid TOML" in r.err and str(p) in r.err
    r = run_cli("simulate", tmp_path / "absent.toml", "--out", tmp_path / "o")
    assert r.code == 2 and "no such scenario file" in r.err
    assert not (tmp_path / "o").exists()


def test_error_in_motor_file_names_the_motor_file(tmp_path):
    (tmp_path / "m.toml").write_text("[motor]\nname = 'x'\n")
    (tmp_path / "s.toml").write_text(BASE.replace('motor = "ecce2010"', 'motor = "m.toml"'))
    with pytest.raises(InputError, match=r"m\.toml: motor\.R_s: missing"):
        from linsense.sim import simulate

        simulate(tmp_path / "s.toml")


def test_motor_path_relative_to_scenario(tmp_path):
    motors = Path(__file__).parents[1] / "src/linsense/examples" / "motors"
    (tmp_path / "m.toml").write_text((motors / "harmonic.toml").read_text())
    (tmp_path / "s.toml").write_text(BASE.replace('motor = "ecce2010"', 'motor = "m.toml"'))
    from linsense.sim.build import resolve_motor

    assert resolve_motor(load_scenario(tmp_path / "s.toml")).source.endswith("m.toml")


def test_a_faulted_runs_line_shows_no_limit_cycle(run_cli, tmp_path):
    """After a fault the run's end is where it stopped: its line said "limit cycle 3.31e+03 deg" for
    a mover that had run into its end stop."""
    path = tmp_path / "f.toml"
    path.write_text('motor = "ecce2010"\n[scenario]\nname = "f"\nduration = 0.3\n[reference]\ntype = "step"\n'
                    'position_mm = 3.0\nat = 0.05\n[travel]\nmax_mm = 1.0\n')
    r = run_cli("simulate", path, "--out", tmp_path / "o")
    assert r.code == 0 and "(fault travel)" in r.out and "(where the fault stopped it)" in r.out, r.out
    assert "limit cycle" not in r.out.splitlines()[-1]

"""Hostile scenario files: refused before the run with exit 2 and one
line naming the file, the key and the value (a misspelled key with the closest known one); the
output folder is not created."""

from __future__ import annotations

import pytest

BASE = """motor = "ecce2010"

[scenario]
name = "s"
duration = 0.2
seed = 1

[inverter]
v_dc = 72.0

[control]
mode = "sensorless_lut"

[observer]
bandwidth_hz = 40.0

[reference]
type = "step"
position_mm = 3.0
at = 0.05
"""


def edit(old: str, new: str) -> str:
    assert old in BASE
    return BASE.replace(old, new)


# name: (scenario text, words the one-line message must contain)
CASES = {
    "misspelled section": (edit("[observer]", "[obserer]"), ["obserer", "did you mean 'observer'"]),
    "misspelled key": (edit("bandwidth_hz", "bandwith_hz"),
                       ["observer.bandwith_hz", "did you mean 'bandwidth_hz'"]),
    "misspelled top key": (edit('motor = "ecce2010"', 'motr = "ecce2010"'), ["motr", "did you mean 'motor'"]),
    "misspelled mode": (edit('mode = "sensorless_lut"', 'mode = "sensorles_lut"'),
                        ["control.mode", "sensorles_lut"]),
    "duration x rate": (edit("duration = 0.2", "duration = 1e6"), ["scenario.duration", "limit", "1e+10"]),
    "trace beyond memory": (edit("duration = 0.2", "duration = 1e5"),
                            ["record.decimate", "GiB", "at least"]),
    "decimate 0": (BASE + "[record]\ndecimate = 0\n", ["record.decimate", "0"]),
    "decimate 1e7": (BASE + "[record]\ndecimate = 10000000\n", ["record.decimate", "10000000"]),
    "20000 waypoints": (edit('type = "step"\nposition_mm = 3.0', 'type = "trajectory"\nwaypoints_mm = ['
                             + ", ".join(["1.0"] * 20000) + "]"), ["reference.waypoints_mm", "10000"]),
    "bus too low for the injection": (edit("v_dc = 72.0", "v_dc = 15.0"), ["inverter.v_dc", "15"]),
    "injection too large": (BASE + "[injection]\namplitude = 40.0\n", ["injection.amplitude", "40"]),
    "unknown preset": (edit('motor = "ecce2010"', 'motor = "ecce201"'), ["ecce201", "ecce2010"]),
    "motor file missing": (edit('motor = "ecce2010"', 'motor = "nope.toml"'), ["nope.toml"]),
    "nan duration": (edit("duration = 0.2", "duration = nan"), ["scenario.duration", "nan"]),
    "negative seed": (edit("seed = 1", "seed = -1"), ["scenario.seed", "-1"]),
    "string for a number": (edit("v_dc = 72.0", 'v_dc = "72"'), ["inverter.v_dc", "'72'"]),
    "injection above f_pwm / 4": (BASE + "[injection]\nfrequency = 5000.0\n",
                                  ["injection.frequency", "5000"]),
    "lut points 1e6": (edit("bandwidth_hz = 40.0", "bandwidth_hz = 40.0\nlut_points = 1000000"),
                       ["observer.lut_points", "1000000"]),
    "start outside the travel": (BASE + "[initial]\nposition_mm = 5000.0\n", ["initial.position_mm", "5000"]),
    "dead time too long": (edit("v_dc = 72.0", "v_dc = 72.0\ndead_time = 1e-3"), ["inverter.dead_time"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_scenario(run_cli, tmp_path, case):
    text, words = CASES[case]
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "out"
    r = run_cli("simulate", tmp_path / "s.toml", "--out", out, "--no-plot")
    r.refused("s.toml", *words)
    assert not out.exists()


def test_the_base_scenario_runs(run_cli, tmp_path):
    """The base unedited runs: each case above fails for its edit."""
    (tmp_path / "s.toml").write_text(BASE)
    r = run_cli("simulate", tmp_path / "s.toml", "--out", tmp_path / "out", "--no-plot")
    assert r.code == 0, r.err

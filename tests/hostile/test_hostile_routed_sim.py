"""Hostile simulator inputs found by the property suite (tests/properties/): a conversion
of a float to an integer that overflowed (a traceback), a missing section named without its key,
a position the drive cannot hold (a traceback, or a reference silently refused by the drive: the run
held still and reported no fault). Each case: the input through ``linsense simulate``, exit code 2
and the words of its one line (the key the user wrote, the value, the limit)."""

from __future__ import annotations

import pytest

from conftest import scenario_with

BASE = """motor = "ecce2010"

[scenario]
name = "s"
duration = 0.05

[reference]
type = "step"
position_mm = 3.0
at = 0.01
"""
HOLD = BASE.replace('type = "step"\nposition_mm = 3.0\nat = 0.01', 'type = "hold"')
TRAJECTORY = BASE.replace('type = "step"\nposition_mm = 3.0',
                          'type = "trajectory"\nwaypoints_mm = [2.0, 1e300]')


# name: (base, keys added to it, words the one line must contain: the key, the value, the limit)
CASES = {
    # (an OverflowError traceback at the step count, sim/build.py)
    "duration overflows the step count": (BASE.replace("duration = 0.05", "duration = 1e308"), "",
                                          ["scenario.duration", "1e+308", "16000 Hz", "1e+10"]),
    # (round(t_pulse x f_pwm) overflowed before the 60 s limit was checked, scenario/rules.py)
    "a start-up pulse overflows its periods": (
        HOLD, '[control]\nmode = "startup"\n[startup]\nt_pulse = 1e308',
        ["startup.t_pulse", "1e+308", "60 s"]),
    # (an OverflowError traceback in the calibration's hold window, sim/build.py)
    "a subnormal adaptation rate": (HOLD, '[control]\nmode = "calibration"\n[calibration]\n'
                                    'k_int = 5e-324', ["calibration.k_int", "4.94066e-324"]),
    # (a ZeroDivisionError traceback there)
    "a subnormal dither frequency": (HOLD, '[control]\nmode = "calibration"\n[calibration]\n'
                                     'dither_hz = 5e-324',
                                     ["calibration.dither_hz", "4.94066e-324", "k_int"]),
    # (an OverflowError traceback converting the start to an int32 count of periods)
    "a start beyond the drive's range": (BASE, "[travel]\nmax_mm = 1e308\n[initial]\nposition_mm = 1e12",
                                         ["initial.position_mm", "1e+12", "16,777,216 pole pitches"]),
    "a start far beyond it": (BASE, "[travel]\nmin_mm = -1e308\n[initial]\nposition_mm = -1e300",
                              ["initial.position_mm", "-1e+300", "16,777,216"]),
    # (a one-line ls_pos message naming no key of the scenario)
    "a start-up guess beyond it": (HOLD, '[control]\nmode = "startup"\n[saturation]\nenabled = true\n'
                                         '[startup]\nguess_mm = 1e12',
                                   ["startup.guess_mm", "1e+12", "16,777,216"]),
    # (ran, holding still with no fault: the drive's setter refused the target and the run went on)
    "a step target beyond it": (BASE.replace("position_mm = 3.0", "position_mm = 1e300"), "",
                                ["reference.position_mm", "1e+300", "16,777,216"]),
    "a waypoint beyond it": (TRAJECTORY, "", ["reference.waypoints_mm[1]", "1e+300", "16,777,216"]),
    # (named "position_mm" without its section)
    "no [reference]": (BASE.split("[reference]")[0], "",
                       ["reference.position_mm", "missing required key", "no [reference] section"]),
    # (named "scenario" without its key)
    "no [scenario]": (BASE.replace('[scenario]\nname = "s"\nduration = 0.05\n', ""), "",
                      ["scenario.duration", "missing required key", "no [scenario] section"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_routed_sim(run_cli, tmp_path, case):
    base, keys, words = CASES[case]
    path = tmp_path / "s.toml"
    path.write_text(scenario_with(base, keys))
    out = tmp_path / "out"
    r = run_cli("simulate", path, "--out", out, "--trace", "none")
    line = r.refused("s.toml", *words)
    assert "Traceback" not in r.err and "ls_pos" not in line, line
    assert not out.exists()


# (one waypoint: from 9e8 mm the move to the first lasts beyond the run, and a move that would start
# after the end is refused)
@pytest.mark.parametrize("base", [BASE, HOLD, TRAJECTORY.replace("2.0, 1e300", "4.0")])
def test_the_bases_run(run_cli, tmp_path, base):
    """Each base is valid (so each refusal is its case's), and a position within the drive's range
    runs: the limit is the drive's, not tighter."""
    path = tmp_path / "s.toml"
    path.write_text(scenario_with(base, "[travel]\nmax_mm = 1e9\n[initial]\nposition_mm = 9e8"))
    r = run_cli("simulate", path, "--out", tmp_path / "out", "--trace", "none")
    assert r.code == 0, r.err

"""Hostile command lines: exit 2 and one line naming the option and the
value; nothing written."""

from __future__ import annotations

import pytest

from linsense.limits import MAX_POINTS, MAX_POSITIONS

# name: (arguments, words the one-line message must contain)
CASES = {
    "empty motor": (["model", "--motor", "", "--out", "m.csv"], ["--motor", "empty", "ecce2010"]),
    "blank motor": (["model", "--motor", "   ", "--out", "m.csv"], ["--motor", "empty"]),
    "points 3": (["model", "--motor", "ecce2010", "--points", "3", "--out", "m.csv"], ["--points", "3"]),
    "points beyond the limit": (["model", "--motor", "ecce2010", "--points", str(MAX_POINTS + 1),
                                 "--out", "m.csv"], ["--points", f"{MAX_POINTS:,}"]),
    "points 1e11": (["lut", "--motor", "ecce2010", "--points", "100000000000", "--out", "l.csv"],
                    ["--points", "100,000,000,000", "limit"]),
    "points not an integer": (["lut", "--motor", "ecce2010", "--points", "1e11", "--out", "l.csv"],
                              ["--points", "1e11"]),
    "positions 1e10": (["bench-emulate", "--motor", "ecce2010", "--positions", "10000000000",
                        "--out", "b.csv"], ["--positions", "10000000000", f"{MAX_POSITIONS}"]),
    "calibration positions": (["calibrate", "--motor", "ecce2010", "--positions", "5000", "--out", "c"],
                              ["--positions", "5000"]),
    "quad 1": (["lut", "--motor", "ecce2010", "--quad", "1.0", "--out", "l.csv"], ["--quad", "1.0"]),
    "quad nan": (["lut", "--motor", "ecce2010", "--quad", "nan", "--out", "l.csv"], ["--quad", "nan"]),
    "unknown format": (["lut", "--motor", "ecce2010", "--format", "xls", "--out", "l.xls"],
                       ["--format", "xls"]),
    "unknown preset": (["model", "--motor", "ecce2011", "--out", "m.csv"],
                       ["--motor", "ecce2011", "ecce2010"]),
    "noise nan": (["bench-emulate", "--motor", "ecce2010", "--noise", "nan", "--out", "b.csv"],
                  ["--noise", "nan"]),
    "unknown command": (["simulat", "x.toml"], ["simulat"]),
    # (these were once accepted and wrote something wrong)
    "f-inj 1e300": (["lut", "--motor", "ecce2010", "--f-inj", "1e300", "--out", "l.csv"],
                    ["--f-inj", "1e+300", "limit"]),
    "out names a folder": (["model", "--motor", "ecce2010", "--out", "newdir/"],
                           ["--out", "newdir/", "folder"]),
}


def test_a_c_keyword_symbol_is_refused_and_a_valid_one_compiles_as_given(run_cli, tmp_path):
    """`lut --symbol int` (a C keyword) wrote a header that did not compile, then one with
    the array renamed int_t without a word: refused naming the rule; a valid name is used
    as given (case kept) and compiles."""
    import subprocess

    out = tmp_path / "l.h"
    run_cli("lut", "--motor", "ecce2010", "--format", "c", "--symbol", "int", "--out", str(out)).refused(
        "--symbol", "'int'", "keyword")
    assert not out.exists()
    run_cli("lut", "--motor", "ecce2010", "--format", "c", "--symbol", "LutAxis2", "--out", str(out))
    src = tmp_path / "u.c"
    src.write_text('#include "l.h"\n'
                   "int main(void) { return (int)(LutAxis2[0] * 0.0f) + LUTAXIS2_LEN * 0; }\n")
    cc = subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-I", str(tmp_path), str(src), "-o",
                         str(tmp_path / "u")], capture_output=True, text=True)
    assert cc.returncode == 0, cc.stderr


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_command_line(run_cli, tmp_path, monkeypatch, case):
    args, words = CASES[case]
    monkeypatch.chdir(tmp_path)
    run_cli(*args).refused(*words)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_an_override_that_would_change_nothing_is_refused(run_cli, tmp_path):
    """`controller.model.demod_gain` with the gain schedule on changed nothing, byte for byte (before
    this check): it is refused in one line naming both keys; with the schedule off it takes effect."""
    sc = tmp_path / "s.toml"
    body = ('motor = "ecce2010"\n[scenario]\nduration = 0.4\n[reference]\ntype = "hold"\n'
            "[controller.model]\ndemod_gain = -3.0\n")
    sc.write_text(body)
    run_cli("simulate", str(sc), "--out", str(tmp_path / "o")).refused(
        "controller.model.demod_gain", "-3.0", "observer.gain_schedule")
    assert not (tmp_path / "o").exists()
    sc.write_text(body + "[observer]\ngain_schedule = false\n")
    r = run_cli("simulate", str(sc), "--out", str(tmp_path / "o2"), "--check")
    assert r.code == 1 and "fault" in r.out + r.err  # (a gain of the wrong sign: it took effect)


def test_lut_refuses_a_motor_the_drive_cannot_hold(run_cli, tmp_path):
    """A motor with reversed saliency (L_q < L_d on average) is refused by lut as tune, simulate and
    calibrate refuse it, for every injection (lut once wrote it, then still for the
    pulsating injection, and the others blamed i_max): one rule, linsense.tune.design.require_saliency."""
    from importlib import resources

    text = (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()
    text = text.replace("L2 = -0.317e-3", "L2 = 0.9e-3").replace("M2 = -0.317e-3", "M2 = 0.9e-3")
    mot = tmp_path / "rev.toml"
    mot.write_text(text)
    for extra in ([], ["--f-inj", "1000"], ["--f-inj", "1000", "--quad", "0"], ["--injection", "rotating"]):
        run_cli("lut", "--motor", str(mot), *extra, "--out", str(tmp_path / "a.csv")).refused(
            "rev.toml", "motor", "reversed saliency", "L_q", "L_d")
        assert not (tmp_path / "a.csv").exists()


def test_a_pm_harmonic_listed_twice_is_refused(run_cli, tmp_path):
    """Two [pm_flux] entries of one order, once accepted, are refused naming the entry."""
    from importlib import resources

    text = (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()
    mot = tmp_path / "pm.toml"
    mot.write_text(text + "\n[pm_flux]\nharmonics = [ { order = 5, amplitude = 0.02 },"
                          " { order = 5, amplitude = 0.03 } ]\n")
    run_cli("model", "--motor", str(mot), "--out", str(tmp_path / "m.csv")).refused(
        "pm.toml", "pm_flux.harmonics[1].order", "order 5", "twice")


@pytest.mark.parametrize("command", ["simulate", "model"])
def test_a_deeply_nested_toml_is_one_line(run_cli, tmp_path, command):
    """A 1.8 kB file with a 900-deep array was a RecursionError traceback in every reader:
    now one line naming the file and the limit (docs/limits.md), for a scenario and a motor file."""
    from linsense.limits import MAX_TOML_DEPTH

    f = tmp_path / "deep.toml"
    f.write_text('motor = "ecce2010"\nx = ' + "[" * 900 + "]" * 900 + "\n")
    args = ["simulate", str(f), "--out", str(tmp_path / "o")] if command == "simulate" else \
        ["model", "--motor", str(f), "--out", str(tmp_path / "m.csv")]
    run_cli(*args).refused("deep.toml", "nested", str(MAX_TOML_DEPTH))
    f.write_text('motor = "ecce2010"\nx = ' + "[" * (MAX_TOML_DEPTH + 1) + "]" * (MAX_TOML_DEPTH + 1) + "\n")
    run_cli(*args).refused("deep.toml", "nested")

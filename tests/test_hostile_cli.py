"""Hostile command lines (issue 11, class "CLI"): exit 2 and one line naming the option and the
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
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_command_line(run_cli, tmp_path, monkeypatch, case):
    args, words = CASES[case]
    monkeypatch.chdir(tmp_path)
    run_cli(*args).refused(*words)
    assert list(tmp_path.iterdir()) == []  # nothing written

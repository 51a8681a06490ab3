"""Hostile motor files: each is refused with exit 2 and one line naming the
file, the key and the value (and, for a slip of unit, the likely mistake); nothing is written."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

from linsense.model.motor import load_motor

#: the reference motor's file (every case edits one thing of it)
PRESET = (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()
TABLE_HEADER = "theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA\n"


def edit(old: str, new: str) -> str:
    assert old in PRESET
    return PRESET.replace(old, new)


def with_table(name: str = "t.csv") -> str:
    return PRESET.split("L0 =")[0] + f'table = "{name}"\n'


def table_rows(n: int = 12, scale: float = 1.0) -> str:
    """The preset's inductances tabulated at n positions (times scale)."""
    theta = 2.0 * np.pi * np.arange(n) / n
    entries = load_motor("ecce2010").inductance.entries(theta) * scale
    return TABLE_HEADER + "".join(f"{360 * k / n}," + ",".join(repr(float(v)) for v in entries[k]) + "\n"
                                  for k in range(n))


# name: (motor file text, table file text or None, words the one-line message must contain)
PM_1E23 = "[pm_flux]\nharmonics = [ { order = 100000000000000000000000, amplitude = 0.01 } ]\n"
NOT_PD = edit("L0 = 2.75e-3", "L0 = 1e-3").replace("M0 = -0.92e-3", "M0 = -2.5e-3")
CASES = {
    # slips of unit
    "pole pitch in mm": (edit("pole_pitch = 0.056", "pole_pitch = 56"), None,
                         ["motor.pole_pitch", "56", "did you type mm"]),
    "pole pitch 30 m": (edit("pole_pitch = 0.056", "pole_pitch = 30"), None,
                        ["motor.pole_pitch", "30", "mm"]),
    "pole pitch in um": (edit("pole_pitch = 0.056", "pole_pitch = 5e-6"), None,
                         ["motor.pole_pitch", "5e-06"]),
    "inductances in mH": (edit("L0 = 2.75e-3", "L0 = 2.75"), None,
                          ["inductance.L0", "2.75", "did you type mH"]),
    "inductance 2.75e305": (edit("L0 = 2.75e-3", "L0 = 2.75e305"), None, ["inductance.L0", "2.75e+305"]),
    "inductance in nH range": (edit("L0 = 2.75e-3", "L0 = 2.75e-9"), None,
                               ["inductance.L0", "2.75e-09", "uH"]),
    "resistance in milliohm": (edit("R_s = 9.0", "R_s = 9000.0"), None, ["motor.R_s", "9000", "milliohm"]),
    "mass in g": (edit("mass = 1.5", "mass = 15000.0"), None, ["motor.mass", "15000", "did you type g"]),
    "force constant absurd": (edit("force_constant = 20.0", "force_constant = 1e9"), None,
                              ["motor.force_constant", "1e+09"]),
    # impossible windings
    "3x3 not positive definite": (NOT_PD, None, ["inductance", "3x3", "not positive definite"]),
    "3x3 fails at some positions": (edit("L2 = -0.317e-3", "L2 = -1.5e-3"), None,
                                    ["inductance", "3x3", "45.5..74.5"]),
    # misspelled and unknown keys
    "misspelled pole_pitch": (edit("pole_pitch", "pole_pich"), None,
                              ["motor.pole_pich", "unknown key", "did you mean 'pole_pitch'"]),
    "misspelled section": (PRESET.replace("[inductance]", "[inductanse]"), None,
                           ["inductanse", "did you mean 'inductance'"]),
    "misspelled dM0": (edit("dM0", "dm0"), None, ["inductance.dm0", "did you mean 'dM0'"]),
    "harmonic typo": (PRESET + "L_4 = 1e-5\n", None, ["inductance.L_4", "did you mean 'L4'"]),
    "odd harmonic": (PRESET + "L5 = 1e-5\n", None, ["inductance.L5", "L4, M4"]),
    # sizes typed in the file
    "harmonic order 1e9": (PRESET + "L1000000000 = 1e-5\n", None,
                           ["inductance.L1000000000", "limit of 63"]),
    "harmonic order 64": (PRESET + "M64 = 1e-6\n", None, ["inductance.M64", "limit of 63"]),
    "pm order 1e23": (PRESET + PM_1E23, None, ["pm_flux.harmonics.0.order", "63"]),
    "table max order": (with_table() + "table_max_order = 1000\n", table_rows(),
                        ["table_max_order", "63", "1000"]),
    # wrong types and values
    "string for a number": (edit("mass = 1.5", 'mass = "1.5"'), None, ["motor.mass", "'1.5'"]),
    "boolean for a number": (edit("R_s = 9.0", "R_s = true"), None, ["motor.R_s", "True"]),
    "nan": (edit("dM0 = -0.47e-3", "dM0 = nan"), None, ["inductance.dM0", "finite", "nan"]),
    "not toml": ("[motor\nname = 1\n", None, ["not valid TOML"]),
    "empty name": (edit('name = "ecce2010"', 'name = ""'), None, ["motor.name"]),
    # tabulated inductances
    "table 200 kB field": (with_table(), TABLE_HEADER + "0," + "1" * 200_000 + ",1,1,1,1,1\n",
                           ["t.csv", "field larger than field limit"]),
    "table not utf-8": (with_table(), TABLE_HEADER + "0,\xff\xfe,1,1,1,1,1\n", ["t.csv", "cannot read"]),
    "table in mH": (with_table(), table_rows(scale=1e3), ["inductance.table", "2.75", "did you type mH"]),
    "table with nan": (with_table(), table_rows().replace("\n0.0,", "\n0.0,nan,", 1),
                       ["t.csv", "row 2", "nan"]),
    "table too short": (with_table(), table_rows(n=4), ["t.csv", "at least 8"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_motor_file(run_cli, tmp_path, case):
    text, table, words = CASES[case]
    (tmp_path / "m.toml").write_text(text, encoding="utf-8")
    if table is not None:
        (tmp_path / "t.csv").write_bytes(table.encode("latin-1") if "\xff" in table else table.encode())
    out = tmp_path / "model.csv"
    r = run_cli("model", "--motor", tmp_path / "m.toml", "--out", out)
    line = r.refused()
    assert "m.toml" in line or "t.csv" in line, line
    for w in words:
        assert w.lower() in line.lower(), (w, line)
    assert not out.exists()


def test_the_preset_passes_every_check(run_cli, tmp_path):
    """The same text unedited is accepted: the cases above fail for their edit, not for the base."""
    (tmp_path / "m.toml").write_text(PRESET)
    r = run_cli("model", "--motor", tmp_path / "m.toml", "--out", tmp_path / "model.csv")
    assert r.code == 0, r.err
    (tmp_path / "t.csv").write_text(table_rows())
    (tmp_path / "m.toml").write_text(with_table())
    r = run_cli("model", "--motor", tmp_path / "m.toml", "--out", tmp_path / "model2.csv")
    assert r.code == 0, r.err


def test_a_name_with_control_characters_is_refused(run_cli, tmp_path):
    (tmp_path / "m.toml").write_text(PRESET.replace('name = "ecce2010"', 'name = "a\\u0000b"'))
    run_cli("model", "--motor", tmp_path / "m.toml", "--out", tmp_path / "x.csv").refused(
        "m.toml", "motor.name", "control characters")

"""Hostile inputs of the motor model, its tables and the LUT's injection frequency that the property
suite (tests/properties/) found giving a wrong answer without a word: each case the
files it needs, a command line and the words its one line must contain (and must not).

* a harmonic key with a leading zero (``L04 = 0.3e-3``) was accepted and its value dropped (the model
  got L4 = 0): refused naming the key, with the key it stands for;
* a duplicate position was named as ``np.float64(360.0)``: a plain number, and the row it repeats;
* ``lut --f-inj 1e-300`` was refused blaming the motor's saliency: the frequency is named, with the
  lower limit (1 Hz, docs/limits.md);
* an even number of positions (``linsense model --points 8`` of a motor with ``L4``, read back as a
  motor's ``[inductance] table``) was off by L4 at every point: the Nyquist cosine was dropped.
"""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

from linsense.limits import MIN_F_INJ
from linsense.model.motor import load_motor

PRESET = (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()
HEADER = "theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA"


def with_keys(extra: str) -> str:
    """The preset with ``extra`` lines added at the end of its [inductance] section."""
    assert "dM0 =" in PRESET
    head, tail = PRESET.split("dM0 =", 1)
    line, rest = tail.split("\n", 1)
    return f"{head}dM0 ={line}\n{extra}\n{rest}"


def with_table(name: str = "t.csv") -> str:
    return PRESET.split("L0 =")[0] + f'table = "{name}"\n'


def table_rows(theta_deg) -> list[str]:
    ind = load_motor("ecce2010").inductance
    e = ind.entries(np.radians(np.asarray(theta_deg, dtype=float)))
    return [",".join([repr(float(t))] + [repr(float(v)) for v in row])
            for t, row in zip(theta_deg, e, strict=True)]


EIGHT = [45.0 * k for k in range(8)]
MODEL = ["model", "--motor", "m.toml", "--out", "o.csv"]


def lut(f_inj: str, *more: str) -> list[str]:
    return ["lut", "--motor", "ecce2010", "--f-inj", f_inj, *more, "--out", "o.csv"]


# name: (files {name: text}, arguments, words the one line must contain, words it must not)
CASES = {
    # (1) one spelling per key: L04 was accepted and dropped (the model got L4 = 0)
    "L04": ({"m.toml": with_keys("L04 = 0.3e-3")}, MODEL,
            ["m.toml", "inductance.L04", "leading zeros", "did you mean 'L4'?"], []),
    "M04": ({"m.toml": with_keys("M04 = 0.01e-3")}, MODEL, ["inductance.M04", "did you mean 'M4'?"], []),
    "L006": ({"m.toml": with_keys("L006 = 0.01e-3")}, MODEL, ["inductance.L006", "did you mean 'L6'?"], []),
    "L02 beside L2": ({"m.toml": with_keys("L02 = 0.01e-3")}, MODEL,
                      ["inductance.L02", "did you mean 'L2'?"], []),
    "L04 beside L4": ({"m.toml": with_keys("L4 = 0.01e-3\nL04 = 0.3e-3")}, MODEL,
                      ["inductance.L04", "did you mean 'L4'?"], []),
    "a non-ASCII digit": ({"m.toml": with_keys('"L\u0664" = 0.3e-3')}, MODEL,
                          ["inductance.L\u0664", "unknown key"], []),
    # (3) plain numbers in messages
    "duplicate position 360": (
        {"m.toml": with_table(), "t.csv": "\n".join([HEADER] + table_rows(EIGHT + [360.0])) + "\n"}, MODEL,
        ["t.csv", "row 10, column theta_deg", "duplicate position 360.0 deg", "row 2 has 0.0 deg"],
        ["np.", "float64"]),
    "duplicate position 45": (
        {"m.toml": with_table(), "t.csv": "\n".join([HEADER] + table_rows(EIGHT + [45.0])) + "\n"}, MODEL,
        ["t.csv", "column theta_deg", "duplicate position 45.0 deg"], ["np.", "float64"]),
    # (5) the injection frequency, not the motor's saliency
    "f-inj 1e-300": ({}, lut("1e-300"), ["--f-inj", "1e-300 Hz", "lower limit of 125 Hz"], ["saliency"]),
    "f-inj 1e-10": ({}, lut("1e-10"), ["--f-inj", "1e-10 Hz", "lower limit of 125 Hz"],
                    ["saliency", "ecce2010"]),
    "f-inj 0.5": ({}, lut("0.5"), ["--f-inj", "0.5 Hz", "lower limit"], []),
    "f-inj subnormal": ({}, lut("5e-324"), ["--f-inj", "4.94066e-324 Hz", "lower limit"], []),
    "f-inj 1e-300 square": ({}, lut("1e-300", "--injection", "square"), ["--f-inj", "lower limit"], []),
    "f-inj 1e-300 rotating": ({}, lut("1e-300", "--injection", "rotating"), ["--f-inj", "lower limit"], []),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_routed_model(run_cli, tmp_path, monkeypatch, case):
    files, args, words, absent = CASES[case]
    monkeypatch.chdir(tmp_path)
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    line = run_cli(*args).refused(*words)
    for w in absent:
        assert w not in line, (w, line)
    assert not (tmp_path / "o.csv").exists(), "a refused run wrote its output"


def test_the_lower_limit_of_f_inj_is_accepted(run_cli, tmp_path):
    """125 Hz (the documented lower limit; it was 1 Hz before) writes a finite table: the limit refuses
    only what is below."""
    out = tmp_path / "l.csv"
    res = run_cli("lut", "--motor", "ecce2010", "--f-inj", repr(MIN_F_INJ), "--out", out)
    assert res.code == 0, res.err
    assert np.all(np.isfinite(np.loadtxt(out, delimiter=",", skiprows=1, comments="#")))


#: (harmonic keys of the motor, --points): an even number of positions whose Nyquist order N/2 is a
#: harmonic of the motor (8 points, L4; 12 points, L6 and M6; 124 points, L62), and two odd ones
EVEN = {
    "8 points, L4": ("L4 = 0.1e-3", 8),
    "12 points, L6 M6": ("L6 = 0.05e-3\nM6 = -0.02e-3", 12),
    "124 points, L62": ("L62 = 0.005e-3", 124),
    "9 points, L4": ("L4 = 0.1e-3", 9),
    "127 points, L62": ("L62 = 0.005e-3", 127),
}


@pytest.mark.parametrize("case", list(EVEN))
def test_a_table_of_linsense_model_is_passed_through_at_every_point(run_cli, tmp_path, case):
    """`linsense model --points N` of a motor read back as `[inductance] table` is the motor at each of
    the N positions (the documented exact interpolation up to 127 rows; an even N was off by the
    harmonic of order N / 2, 1e-4 H with L4 = 0.1e-3 and 8 points)."""
    keys, n = EVEN[case]
    (tmp_path / "m.toml").write_text(with_keys(keys), encoding="utf-8")
    res = run_cli("model", "--motor", tmp_path / "m.toml", "--points", n, "--out", tmp_path / "t.csv")
    assert res.code == 0, res.err
    (tmp_path / "mt.toml").write_text(with_table("t.csv"), encoding="utf-8")
    motor, tab = load_motor(str(tmp_path / "m.toml")), load_motor(str(tmp_path / "mt.toml"))
    rows = np.loadtxt(tmp_path / "t.csv", delimiter=",", skiprows=1, usecols=range(7), comments="#")
    theta = np.radians(rows[:, 0])
    got = tab.inductance.entries(theta)
    # through the table's points (a square system solved to rounding), and so the motor's values (the
    # CSV holds 12 significant digits of a few mH: 5e-15 H, times the interpolation's gain)
    np.testing.assert_allclose(got, rows[:, 1:], rtol=0, atol=1e-16)
    np.testing.assert_allclose(got, motor.inductance.entries(theta), rtol=0, atol=5e-14)


#: API arguments given as numpy scalars: the message shows the plain number (it showed np.int64(3))
NUMPY_ARGS = {
    "points np.int64(3)": (dict(points=np.int64(3)), "points", "got 3"),
    "f_inj np.float64(nan)": (dict(points=8, f_inj=np.float64("nan")), "f_inj", "got nan"),
    "f_inj np.float64(-1.0)": (dict(points=8, f_inj=np.float64(-1.0)), "f_inj", "got -1.0"),
    "quad np.float64(1.5)": (dict(points=8, f_inj=1000.0, quad=np.float64(1.5)), "quad", "got 1.5"),
}


@pytest.mark.parametrize("case", list(NUMPY_ARGS))
def test_a_numpy_argument_is_named_as_a_plain_number(case):
    from linsense.compensation.lut import build_lut
    from linsense.errors import InputError

    kwargs, key, words = NUMPY_ARGS[case]
    with pytest.raises(InputError) as e:
        build_lut(load_motor("ecce2010"), **kwargs)
    msg = str(e.value)
    assert e.value.key == key and words in msg and "np." not in msg, msg

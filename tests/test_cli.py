"""The `linsense` command: outputs, the acceptance numbers, and every bad-input case
(exit code 2, one line naming file, key and value, no traceback, no output file)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from linsense.compensation.lut import read_c_header, read_lut

MODEL_HEADER = ("theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA,L_d,L_q,L_dq,saliency,psi_lut_deg,"
                "err_nolut_deg,gain_nolut").split(",")

BASE = """[motor]
name = "m1"
R_s = 9.0
pole_pitch = 0.056
force_constant = 20.0
mass = 1.5

[inductance]
L0 = 2.75e-3
L2 = -0.317e-3
M0 = -0.92e-3
M2 = -0.317e-3
dM0 = -0.47e-3
"""


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


def test_model_acceptance(run_cli, tmp_path):
    """`linsense model --motor ecce2010 --points 360`: Psi_LUT peak 4.03 deg, saliency minima at
    60 and 240 deg."""
    out = tmp_path / "m.csv"
    r = run_cli("model", "--motor", "ecce2010", "--points", 360, "--out", out)
    assert r.code == 0, r.err
    header, data = read_csv(out)
    assert header[: len(MODEL_HEADER)] == MODEL_HEADER
    col = {h: data[:, j] for j, h in enumerate(header)}
    assert data.shape[0] == 360
    np.testing.assert_allclose(col["theta_deg"], np.arange(360.0))
    assert np.abs(col["psi_lut_deg"]).max() == pytest.approx(4.03, abs=0.005)
    sal = col["saliency"]
    minima = col["theta_deg"][(sal < np.roll(sal, 1)) & (sal < np.roll(sal, -1))]
    np.testing.assert_allclose(minima, [60.0, 240.0])
    assert col["L_A"].max() < 1e-2  # henry, not millihenry
    np.testing.assert_allclose(col["saliency"], col["L_q"] - col["L_d"], atol=1e-15)
    assert col["gain_nolut"].max() == pytest.approx(2.93, abs=0.01)


def test_model_is_byte_reproducible(run_cli, tmp_path):
    for name in ("a.csv", "b.csv"):
        assert run_cli("model", "--motor", "ecce2010", "--points", 90, "--out", tmp_path / name).code == 0
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


@pytest.mark.parametrize("fmt", ["csv", "json", "c"])
def test_lut_formats(run_cli, tmp_path, fmt, ecce):
    out = tmp_path / f"lut.{ 'h' if fmt == 'c' else fmt}"
    r = run_cli("lut", "--motor", "ecce2010", "--points", 56, "--format", fmt, "--out", out)
    assert r.code == 0, r.err
    if fmt == "c":
        vals = read_c_header(out.read_text())
    else:
        vals = read_lut(out).values
        if fmt == "csv":
            header, _ = read_csv(out)
            assert header == ["theta_deg", "psi_lut_deg"]
    assert vals.size == 56
    assert np.degrees(np.abs(vals)).max() == pytest.approx(4.03, abs=0.01)


def test_plot_writes_figures(run_cli, tmp_path, ecce):
    r = run_cli("plot", "--motor", "ecce2010", "--out", tmp_path / "figs")
    assert r.code == 0, r.err
    names = sorted(p.name for p in (tmp_path / "figs").iterdir())
    assert names == sorted([
        ".linsense-set.json", "fig5_inductances_no_end_effect.png", "fig6_inductances_end_effect.png",
        "fig8a_psi_estimated.png", "fig8b_psi_compensated.png", "fig9_lut.png",
        "uncompensated_observer.png",
    ])
    for p in (tmp_path / "figs").glob("*.png"):
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000


def test_reproduce_writes_everything(run_cli, tmp_path):
    r = run_cli("reproduce", "--model-only", "--out", tmp_path / "out")
    assert r.code == 0, r.err
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["psi_lut_peak_deg"] == pytest.approx(4.03, abs=0.005)
    for name in ("model.csv", "lut.csv", "lut.json", "ls_lut_ecce2010.h", "figures/fig9_lut.png"):
        assert (tmp_path / "out" / name).is_file()


def test_motor_path_works(run_cli, tmp_path):
    f = tmp_path / "m1.toml"
    f.write_text(BASE)
    assert run_cli("lut", "--motor", f, "--format", "c", "--out", tmp_path / "x.h").code == 0
    assert "ls_lut_m1[LS_LUT_M1_LEN]" in (tmp_path / "x.h").read_text()


# ---------------------------------------------------------------------- bad input
def edit(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new)


BAD_MOTORS = {
    # case: (file text, words the one-line message must contain)
    "missing key": (edit(BASE, "dM0 = -0.47e-3\n", ""), ["inductance.dM0", "missing"]),
    "missing section": (BASE.split("[inductance]")[0], ["inductance", "missing"]),
    "unknown key": (edit(BASE, "mass = 1.5", "mass = 1.5\nmas = 2.0"), ["motor.mas", "unknown", "2.0"]),
    "unknown section": (BASE + "\n[extra]\nx = 1\n", ["extra", "unknown"]),
    "odd harmonic": (BASE + "L3 = 1e-4\n", ["inductance.L3", "unknown"]),
    "wrong type": (edit(BASE, "R_s = 9.0", 'R_s = "nine"'), ["motor.R_s", "'nine'"]),
    "bool as number": (edit(BASE, "mass = 1.5", "mass = true"), ["motor.mass", "True"]),
    "harmonic wrong type": (BASE + 'L4 = "big"\n', ["inductance.L4", "'big'"]),
    "nan": (edit(BASE, "L0 = 2.75e-3", "L0 = nan"), ["inductance.L0", "finite", "nan"]),
    "inf": (edit(BASE, "pole_pitch = 0.056", "pole_pitch = inf"), ["motor.pole_pitch", "finite", "inf"]),
    "harmonic inf": (BASE + "M4 = -inf\n", ["inductance.M4", "finite", "-inf"]),
    "negative mass": (edit(BASE, "mass = 1.5", "mass = -1.5"), ["motor.mass", "-1.5"]),
    "not toml": ("[motor\nname=", ["not valid TOML"]),
    "table and params": (BASE + 'table = "t.csv"\n', ["inductance.L0", "not both"]),
    "missing table": (BASE.split("[inductance]")[0] + '[inductance]\ntable = "t.csv"\n',
                      ["inductance.table", "t.csv"]),
    "not positive definite": (edit(BASE, "L2 = -0.317e-3", "L2 = -1.5e-3"),
                              ["inductance", "3x3", "not positive definite", "45.5..74.5", " deg"]),
    "saliency vanishes": (
        edit(edit(edit(BASE, "L2 = -0.317e-3", "L2 = 0.0"), "M2 = -0.317e-3", "M2 = 0.0"),
             "dM0 = -0.47e-3", "dM0 = 0.0"),
        ["inductance", "saliency", "vanishes", "all positions"],
    ),
    # (L0 up with it: the 3x3 matrix stays positive definite, the saliency does not move)
    "saliency changes sign": (edit(edit(BASE, "dM0 = -0.47e-3", "dM0 = -1.0e-3"),
                                   "L0 = 2.75e-3", "L0 = 3.75e-3"),
                              ["inductance", "saliency", "changes sign", "36.5..83.5", "216.5..263.5",
                               "it is the end effect's: dM0 = -0.001 H", "at most 0.000675 H in magnitude"]),
}


@pytest.mark.parametrize("case", sorted(BAD_MOTORS))
@pytest.mark.parametrize("command", ["model", "lut", "plot"])
def test_bad_motor_file(run_cli, tmp_path, case, command):
    text, words = BAD_MOTORS[case]
    f = tmp_path / "bad.toml"
    f.write_text(text)
    out = tmp_path / ("figs" if command == "plot" else "o.csv")
    r = run_cli(command, "--motor", f, "--out", out)
    assert r.code == 2
    assert r.out == ""
    lines = r.err.strip().splitlines()
    assert len(lines) == 1, r.err
    assert lines[0].startswith("linsense: error: ")
    assert "bad.toml" in lines[0] or "t.csv" in lines[0]
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["bad.toml"]  # no stray temporary files


def write_table(path: Path, rows: list[list[str]], header: str = "theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA"):
    path.write_text(header + "\n" + "\n".join(",".join(r) for r in rows) + "\n")


def good_rows(n: int = 24) -> list[list[str]]:
    from linsense.model.motor import load_motor

    m = load_motor("ecce2010")
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    e = m.inductance.entries(th)
    return [[f"{np.degrees(t):.6f}"] + [f"{v:.9g}" for v in e[i]] for i, t in enumerate(th)]


@pytest.mark.parametrize("case", ["ok", "missing column", "not a number", "nan", "duplicate", "gap"])
def test_table_motor_errors(run_cli, tmp_path, case):
    rows = good_rows()
    header = "theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA"
    words = []
    if case == "missing column":
        header = header.replace(",M_CA", "")
        rows = [r[:-1] for r in rows]
        words = ["column M_CA", "missing"]
    elif case == "not a number":
        rows[4][2] = "abc"
        words = ["row 6, column L_B", "'abc'"]
    elif case == "nan":
        rows[2][1] = "nan"
        words = ["row 4, column L_A", "'nan'"]
    elif case == "duplicate":
        rows[7][0] = rows[6][0]
        words = ["column theta_deg", "duplicate"]
    elif case == "gap":
        rows = rows[:12]
        words = ["do not cover one electrical period"]
    write_table(tmp_path / "tab.csv", rows, header)
    (tmp_path / "m.toml").write_text(BASE.split("[inductance]")[0] + '[inductance]\ntable = "tab.csv"\n')
    out = tmp_path / "o.csv"
    r = run_cli("model", "--motor", tmp_path / "m.toml", "--points", 36, "--out", out)
    if case == "ok":
        assert r.code == 0, r.err
        return
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1
    assert "tab.csv" in r.err
    for w in words:
        assert w in r.err, (w, r.err)
    assert not out.exists()


@pytest.mark.parametrize(
    "args, words",
    [
        (["model", "--motor", "nosuch", "--out", "o.csv"], ["--motor", "unknown motor 'nosuch'", "small30"]),
        (["model", "--motor", "ecce2010", "--points", "2", "--out", "o.csv"], ["--points", "2"]),
        (["model", "--motor", "ecce2010", "--points", "many", "--out", "o.csv"], ["--points", "many"]),
        (["lut", "--motor", "ecce2010", "--format", "xml", "--out", "o.csv"], ["--format", "xml"]),
        (["lut", "--motor", "missing.toml", "--out", "o.csv"], ["missing.toml", "no such motor file"]),
        (["model", "--motor", "ecce2010", "--out", "o/"], ["--out", "folder"]),
    ],
)
def test_bad_options(run_cli, tmp_path, args, words):
    os.chdir(tmp_path)
    r = run_cli(*args)
    assert r.code == 2
    assert len(r.err.strip().splitlines()) == 1, r.err
    for w in words:
        assert w in r.err, (w, r.err)
    assert list(tmp_path.iterdir()) == []


def test_failed_run_leaves_existing_output_untouched(run_cli, tmp_path):
    out = tmp_path / "o.csv"
    out.write_text("previous\n")
    f = tmp_path / "bad.toml"
    f.write_text(edit(BASE, "L0 = 2.75e-3", "L0 = nan"))
    assert run_cli("model", "--motor", f, "--out", out).code == 2
    assert out.read_text() == "previous\n"


def test_installed_entry_point_has_no_traceback(tmp_path):
    """Through a real process: exit code 2, one line, no 'Traceback'."""
    f = tmp_path / "bad.toml"
    f.write_text(edit(BASE, "R_s = 9.0", "R_s = [1, 2]"))
    p = subprocess.run([sys.executable, "-m", "linsense", "model", "--motor", str(f), "--out",
                        str(tmp_path / "o.csv")], capture_output=True, text=True)
    assert p.returncode == 2
    assert "Traceback" not in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert "motor.R_s" in p.stderr and "[1, 2]" in p.stderr


def test_a_folder_given_as_a_scenario_is_named_so(run_cli, tmp_path, monkeypatch):
    """`--scenario adir` (a folder) said "unknown scenario 'adir': no such file"; a folder named as a
    packaged example still runs the example."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "adir").mkdir()
    (tmp_path / "fig13_trajectory").mkdir()
    r = run_cli("tune", "--motor", "ecce2010", "--scenario", "adir", "--no-verify", "--out", "x.toml")
    assert r.code == 2 and "adir: is a folder, not a scenario file" in r.err, r.err
    from linsense.examples import resolve

    assert resolve("scenarios", "fig13_trajectory") != "fig13_trajectory"


def test_lut_says_eq12_is_not_the_firmwares_default_injections_table(run_cli, tmp_path):
    """`lut --format c` without --f-inj writes eq. 12, the paper's pulsating injection's table; the
    firmware's default injection is elliptical (kappa 0.9), whose table kappa moves 3-4 x (ecce2010:
    -3.4..3.6 deg against -9.0..13.7 with R_s neglected): said on stderr; `--quad` without `--f-inj`
    gives that R_s = 0 table (it was refused as "kappa changes nothing", and build_lut ignored it)."""
    from linsense.analysis.hf import psi_lut, psi_lut_resistive, table_model
    from linsense.compensation.lut import build_lut
    from linsense.model.motor import load_motor

    m = load_motor("ecce2010")
    th = 2.0 * np.pi * np.arange(8) / 8
    got = build_lut(m, 8, quad=0.9).values
    m0, f0 = table_model(m, None)
    np.testing.assert_allclose(got, psi_lut_resistive(m0, th, f0, quad=0.9))
    assert np.max(np.abs(got)) > 2.5 * np.max(np.abs(psi_lut(m, th)))
    r = run_cli("lut", "--motor", "ecce2010", "--format", "c", "--out", tmp_path / "a.h")
    assert r.code == 0 and "eq. 12's table is the paper's pulsating injection's" in r.err, r.err
    for extra in (("--f-inj", "1000"), ("--quad", "0.9")):
        r = run_cli("lut", "--motor", "ecce2010", "--format", "c", *extra, "--out", tmp_path / "b.h")
        assert r.code == 0 and r.err == "", r.err

"""Bench identification (linsense identify, bench-emulate): the acceptance numbers on emulated
data, exact recovery without noise, amplitude-only input, reciprocity, the outputs, and every
bad-input case (exit code 2, one line naming row and column, nothing written)."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from linsense.analysis.hf import psi_lut
from linsense.analysis.model_table import MODEL_COLUMNS, model_table
from linsense.compensation.lut import read_lut
from linsense.errors import InputError, ModelError
from linsense.identify.bench import PHASOR_COLUMNS, bench_to_csv, emulate_bench, read_bench_csv
from linsense.identify.fit import design_matrix, fit_inductances, parameter_names
from linsense.identify.identification import identify
from linsense.identify.process import process_bench
from linsense.model.inductance import InductanceModel
from linsense.model.motor import load_motor

ROOT = Path(__file__).resolve().parents[1]
FIVE = ("L0", "L2", "M0", "M2", "dM0")

# A third motor, unlike ecce2010: shorter pole pitch, lower resistance, larger inductances and an
# end-effect of the opposite sign (to exercise the fit, not a claim about real motors).
ROD = """[motor]
name = "rod32"
R_s = 3.2
pole_pitch = 0.032
force_constant = 35.0
mass = 2.5

[inductance]
L0 = 6.1e-3
L2 = -0.9e-3
M0 = -2.3e-3
M2 = -0.55e-3
dM0 = 0.35e-3
"""


@pytest.fixture(scope="module")
def motors(tmp_path_factory):
    """(motor, K) for ecce2010, the harmonic example (L4, M4; fitted with K = 2) and rod32."""
    d = tmp_path_factory.mktemp("motors")
    (d / "rod32.toml").write_text(ROD)
    return {
        "ecce2010": (load_motor("ecce2010"), 1),
        "harmonic": (load_motor(ROOT / "src/linsense/examples/motors/harmonic.toml"), 2),
        "rod32": (load_motor(d / "rod32.toml"), 1),
    }


def run_fit(motor, K, noise, seed, positions=56, amplitude_only=False, resistance=None):
    data = emulate_bench(motor, positions, noise, seed, amplitude_only=amplitude_only)
    table = process_bench(data, motor.pole_pitch, resistance)
    return table, fit_inductances(table.theta, table.entries, K)


def rel_errors(fit, motor) -> dict[str, float]:
    true = motor.inductance.params
    return {k: abs(fit.values[k] / true[k] - 1.0) for k in true}


def lut_errors_deg(table, fit, motor) -> tuple[float, float]:
    """(max |LUT from the fit - true| on 360 points, max |LUT from the table - true| at the
    measured positions), electrical degrees."""
    from linsense.identify.measured_outputs import measured_columns

    th = 2 * np.pi * np.arange(360) / 360
    e_fit = np.abs(psi_lut(fit.model(), th) - psi_lut(motor, th)).max()
    psi_meas = np.radians(measured_columns(table.theta, table.entries)["psi_lut_deg"])
    e_meas = np.abs(psi_meas - psi_lut(motor, table.theta)).max()
    return float(np.degrees(e_fit)), float(np.degrees(e_meas))


# ---------------------------------------------------------------------- fit and processing
def test_design_matrix_is_the_model(motors):
    """A p equals from_params(p).entries for random parameters, including harmonics."""
    rng = np.random.default_rng(0)
    th = rng.uniform(0, 2 * np.pi, 17)
    p = rng.normal(size=9) * 1e-3
    names = parameter_names(3)
    assert names == ["L0", "L2", "M0", "M2", "dM0", "L4", "M4", "L6", "M6"]
    v = dict(zip(names, p, strict=True))
    ref = InductanceModel.from_params(v["L0"], v["L2"], v["M0"], v["M2"], v["dM0"],
                                      {4: (v["L4"], v["M4"]), 6: (v["L6"], v["M6"])}).entries(th)
    np.testing.assert_allclose(design_matrix(th, 3) @ p, ref.reshape(-1), rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", ["ecce2010", "harmonic", "rod32"])
def test_noise_free_recovers_parameters(motors, name, tmp_path):
    """Without noise, through the CSV file, every parameter and R_s come back to 1e-9."""
    motor, K = motors[name]
    f = tmp_path / "b.csv"
    f.write_text(bench_to_csv(emulate_bench(motor, 56, 0.0, 5)))
    table = process_bench(read_bench_csv(f), motor.pole_pitch)
    fit = fit_inductances(table.theta, table.entries, K)
    for k, v in motor.inductance.params.items():
        assert fit.values[k] == pytest.approx(v, rel=1e-9), k
    assert table.resistance == pytest.approx(motor.R_s, rel=1e-9)
    assert fit.residual_rms < 1e-9 * motor.inductance.params["L0"]
    assert table.reciprocity_max < 1e-9


def test_missing_harmonic_shows_in_residuals(motors):
    """Fitting the harmonic motor with K = 1 leaves its 4 theta content in the residuals."""
    motor, _ = motors["harmonic"]
    table, fit1 = run_fit(motor, 1, 0.0, 0)
    _, fit2 = run_fit(motor, 2, 0.0, 0)
    assert fit1.residual_rms > 1e4 * fit2.residual_rms
    assert fit1.residual_rms > 0.02 * motor.inductance.params["L4"]


@pytest.mark.parametrize("name", ["ecce2010", "harmonic", "rod32"])
@pytest.mark.parametrize("seed", [2, 3, 4])
def test_acceptance_one_percent_noise(motors, name, seed):
    """1 % noise, 56 positions: the five parameters within 2 % (dM0 within 5 %), the LUT from
    the fit within 0.2 deg and the LUT from the measured table within 1 deg of the true ones.

    The 2 % bound is a statistical one: at this noise the standard error of L2 is 1.07 % for
    ecce2010 (the self inductances carry the resistive drop), so about 8 % of seeds exceed it
    (seed 1 gives 2.07 %, seeds 7 and 9 also fail); ``test_acceptance_statistics`` checks the
    rate over many seeds. Seeds 2-4 are the first three that pass for all three motors.
    """
    motor, K = motors[name]
    table, fit = run_fit(motor, K, 0.01, seed)
    err = rel_errors(fit, motor)
    for k in FIVE:
        assert err[k] < (0.05 if k == "dM0" else 0.02), (k, err[k])
    e_fit, e_meas = lut_errors_deg(table, fit, motor)
    assert e_fit < 0.2
    assert e_meas < 1.0


#: docs/identify.md, "Accuracy on emulated data": seed 2, phasor form; the parameters' signed errors
#: (%) and the two LUTs' largest errors (deg), as written there
ACCURACY_TABLE = {
    "ecce2010": ("+0.09", "-0.84", "+0.12", "+0.02", "+0.11", "0.002", "0.61"),
    "harmonic": ("+0.09", "-0.84", "+0.12", "+0.02", "+0.10", "0.019", "0.61"),
    "rod32": ("+0.06", "-0.40", "+0.13", "-0.03", "+0.19", "0.002", "0.53"),
}


def test_the_documented_accuracy_table(motors):
    """Every number of docs/identify.md's accuracy table (seed 2) is the fit's, to the digits written."""
    got = {}
    for name in ACCURACY_TABLE:
        motor, K = motors[name]
        table, fit = run_fit(motor, K, 0.01, 2)
        true = motor.inductance.params
        pct = [f"{100.0 * (fit.values[k] / true[k] - 1.0):+.2f}" for k in FIVE]
        e_fit, e_meas = lut_errors_deg(table, fit, motor)
        got[name] = (*pct, f"{e_fit:.3f}", f"{e_meas:.2f}")
    assert got == ACCURACY_TABLE

def test_acceptance_statistics(motors):
    """Over 60 seeds on ecce2010: at least 85 % meet every parameter bound, every LUT bound holds,
    and the standard errors are honest (|error| < 2 stderr for about 95 % of L0 and L2)."""
    motor, K = motors["ecce2010"]
    ok, z, lut_fit, lut_meas = 0, [], [], []
    for seed in range(100, 160):
        table, fit = run_fit(motor, K, 0.01, seed)
        err = rel_errors(fit, motor)
        ok += all(err[k] < (0.05 if k == "dM0" else 0.02) for k in FIVE)
        z.append([(fit.values[k] - motor.inductance.params[k]) / fit.stderr[k] for k in ("L0", "L2")])
        e_fit, e_meas = lut_errors_deg(table, fit, motor)
        lut_fit.append(e_fit)
        lut_meas.append(e_meas)
    assert ok >= 0.85 * 60
    assert max(lut_fit) < 0.2 and max(lut_meas) < 1.0
    inside = np.mean(np.abs(np.array(z)) < 2.0)
    assert 0.85 <= inside <= 1.0
    assert 0.7 < np.std(np.array(z)) < 1.4


def test_amplitude_only_gives_the_same_result(motors):
    """The magnitudes of the same noisy phasors, with the resistance supplied, give the same
    parameters within the noise; neglecting the resistance overestimates the self inductances."""
    motor, K = motors["ecce2010"]
    _, ph = run_fit(motor, K, 0.01, 3)
    table, amp = run_fit(motor, K, 0.01, 3, amplitude_only=True, resistance=motor.R_s)
    for k in FIVE:
        assert abs(amp.values[k] - ph.values[k]) < 2 * ph.stderr[k], k
        assert rel_errors(amp, motor)[k] < (0.05 if k == "dM0" else 0.02), k
    assert any("negative" in w for w in table.warnings)
    _, neglect = run_fit(motor, K, 0.0, 3, amplitude_only=True, resistance=0.0)
    assert neglect.values["L0"] > 1.1 * motor.inductance.params["L0"]  # sqrt(wL^2 + R^2)/w
    for k in ("M0", "M2", "dM0"):  # mutuals carry no resistive drop: exact without noise
        assert neglect.values[k] == pytest.approx(motor.inductance.params[k], rel=1e-9)


def test_reciprocity_error(motors):
    motor, K = motors["ecce2010"]
    t0, _ = run_fit(motor, K, 0.0, 1)
    assert t0.reciprocity_max < 1e-12
    t1, _ = run_fit(motor, K, 0.01, 1)
    # two independent ratios, each with ~1.4 % complex relative noise: RMS ~ 1.4 %
    assert 0.008 < t1.reciprocity_rms < 0.025
    assert t1.reciprocity_max < 0.08


def test_end_effect_significance(motors):
    motor, K = motors["ecce2010"]
    _, fit = run_fit(motor, K, 0.01, 2)
    assert fit.end_effect_significant and fit.end_effect_t < -100
    p = dict(motor.inductance.params, dM0=0.0)
    balanced = replace(motor, inductance=InductanceModel.from_params(**p))
    _, fit0 = run_fit(balanced, K, 0.01, 2)
    assert abs(fit0.end_effect_t) < 3 and not fit0.end_effect_significant


def test_positions_over_two_periods_are_merged(motors):
    """Positions one pole pitch apart are the same electrical position: their rows are averaged."""
    motor, _ = motors["ecce2010"]
    d = emulate_bench(motor, 16, 0.0, 0)
    d2 = replace(d, position=np.concatenate([d.position, d.position + motor.pole_pitch]),
                 phase=np.tile(d.phase, 2), freq=np.tile(d.freq, 2), current=np.tile(d.current, 2),
                 voltage=np.tile(d.voltage, (2, 1)), row=None)
    t = process_bench(d2, motor.pole_pitch)
    assert t.theta.size == 16
    np.testing.assert_allclose(t.entries, motor.inductance.entries(t.theta), rtol=1e-12)


def test_harmonics_the_positions_cannot_separate(motors):
    motor, _ = motors["ecce2010"]
    t = process_bench(emulate_bench(motor, 8, 0.0, 0), motor.pole_pitch)
    fit_inductances(t.theta, t.entries, 6)
    with pytest.raises(InputError, match="cannot be separated"):
        fit_inductances(t.theta, t.entries, 7)  # order 14 aliases on 8 positions


def test_fitted_model_refused_by_check_motor(motors, tmp_path):
    """A motor whose saliency changes sign: the fit is refused with the bench file named."""
    motor, _ = motors["ecce2010"]
    # (L0 up with dM0: the 3x3 matrix stays positive definite)
    p = dict(motor.inductance.params, dM0=-1.0e-3, L0=3.75e-3)
    bad = replace(motor, inductance=InductanceModel.from_params(**p))
    f = tmp_path / "bad.csv"
    f.write_text(bench_to_csv(emulate_bench(bad, 56, 0.0, 0)))
    with pytest.raises(ModelError, match="saliency"):
        identify(f, base=motor)


# ---------------------------------------------------------------------- CLI
def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


def test_cli_end_to_end(run_cli, tmp_path, motors):
    """bench-emulate then identify: every file, motor.toml loads everywhere, PNGs are valid."""
    bench = tmp_path / "bench.csv"
    r = run_cli("bench-emulate", "--motor", "ecce2010", "--positions", 56, "--noise", 0.01, "--seed", 2,
                "--out", bench)
    assert r.code == 0, r.err
    assert tuple(bench.read_text().splitlines()[0].split(",")) == PHASOR_COLUMNS
    out = tmp_path / "id"
    r = run_cli("identify", bench, "--out", out, "--motor", "ecce2010")
    assert r.code == 0, r.err
    assert r.err == ""
    assert "end-effect dM0" in r.out and ": significant" in r.out
    names = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())
    assert names == sorted(["motor.toml", "inductances.csv", "lut.csv", "lut_fit.csv", "fit.json",
                            "figures/identify_inductances.png", "figures/identify_lut.png",
                            ".linsense-set.json"])
    for p in (out / "figures").iterdir():
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000

    motor, _ = motors["ecce2010"]
    fitted = load_motor(out / "motor.toml")
    assert fitted.name == "bench"
    assert fitted.R_s == pytest.approx(9.0, rel=0.01)
    assert (fitted.pole_pitch, fitted.force_constant, fitted.mass) == (0.056, 20.0, 1.5)
    for k in FIVE:
        assert fitted.inductance.params[k] == pytest.approx(motor.inductance.params[k],
                                                            rel=0.05 if k == "dM0" else 0.02)
    r = run_cli("model", "--motor", out / "motor.toml", "--points", 36, "--out", tmp_path / "m.csv")
    assert r.code == 0, r.err

    doc = json.loads((out / "fit.json").read_text())
    assert doc["form"] == "phasor" and doc["positions"] == 56 and doc["rows"] == 168
    assert set(doc["fit"]["parameters"]) == set(FIVE) == set(doc["fit"]["standard_errors"])
    assert doc["fit"]["parameters"]["dM0"] == fitted.inductance.params["dM0"]
    assert doc["end_effect"]["significant"] is True
    assert 0.005 < doc["reciprocity"]["rms_relative"] < 0.03
    assert doc["warnings"] == []

    header, tab = read_csv(out / "inductances.csv")
    assert tuple(header) == MODEL_COLUMNS
    assert tab.shape[0] == 56 and np.all(np.diff(tab[:, 0]) > 0)
    lut = read_lut(out / "lut.csv")  # equally spaced measured positions: a valid LUT file
    assert lut.points == 56
    assert np.degrees(np.abs(lut.values - psi_lut(motor, lut.theta))).max() < 1.0
    lut_fit = read_lut(out / "lut_fit.csv")
    assert lut_fit.points == 360
    assert np.degrees(np.abs(lut_fit.values - psi_lut(motor, lut_fit.theta))).max() < 0.2


def test_cli_noise_free_table_is_the_model_table(run_cli, tmp_path, motors):
    """inductances.csv of noise-free data equals `linsense model` of the true motor, every column."""
    motor, _ = motors["harmonic"]
    bench = tmp_path / "b.csv"
    assert run_cli("bench-emulate", "--motor", ROOT / "src/linsense/examples/motors/harmonic.toml",
                   "--positions", 45, "--out", bench).code == 0
    out = tmp_path / "id"
    r = run_cli("identify", bench, "--out", out, "--harmonics", 2, "--pole-pitch", 56,
                "--force-constant", 20, "--mass", 1.5)
    assert r.code == 0, r.err
    header, tab = read_csv(out / "inductances.csv")
    ref = model_table(motor, 45)
    for j, name in enumerate(header):
        scale = np.abs(ref[name]).max()
        np.testing.assert_allclose(tab[:, j], ref[name], rtol=0, atol=1e-9 * scale, err_msg=name)
    fitted = load_motor(out / "motor.toml")
    assert fitted.inductance.params["L4"] == pytest.approx(motor.inductance.params["L4"], rel=1e-9)
    assert fitted.R_s == pytest.approx(motor.R_s, rel=1e-9)


def test_cli_amplitude_only(run_cli, tmp_path):
    bench = tmp_path / "a.csv"
    assert run_cli("bench-emulate", "--motor", "ecce2010", "--noise", 0.01, "--seed", 3, "--amplitude-only",
                   "--out", bench).code == 0
    assert bench.read_text().splitlines()[0] == "position_mm,phase,freq_hz,I,VA,VB,VC"
    out = tmp_path / "id"
    r = run_cli("identify", bench, "--out", out, "--motor", "ecce2010")
    assert r.code == 0, r.err
    warn = r.err.strip().splitlines()
    assert len(warn) == 2 and all(w.startswith("linsense: warning: amplitude-only") for w in warn)
    assert "R = 9 ohm" in warn[1]
    doc = json.loads((out / "fit.json").read_text())
    assert doc["form"] == "amplitude-only"
    assert [f"linsense: warning: {w}" for w in doc["warnings"]] == warn
    assert load_motor(out / "motor.toml").R_s == 9.0
    r = run_cli("identify", bench, "--out", tmp_path / "id0", "--motor", "ecce2010", "--resistance", 0)
    assert r.code == 0 and "overestimated" in r.err


# ---------------------------------------------------------------------- bad input
def good_bench(tmp_path: Path) -> list[list[str]]:
    motor = load_motor("ecce2010")
    text = bench_to_csv(emulate_bench(motor, 24, 0.0, 0))
    return [line.split(",") for line in text.strip().splitlines()]


def _cell(rows, r, col):  # r: file line (header = 1)
    return rows[r - 1], rows[0].index(col)


def bad_cases():
    def set_cell(r, col, value):
        def f(rows):
            row, j = _cell(rows, r, col)
            row[j] = value
            return rows
        return f

    def drop_column(col):
        def f(rows):
            j = rows[0].index(col)
            return [row[:j] + row[j + 1:] for row in rows]
        return f

    def zero_current(rows):
        for col in ("I_re", "I_im"):
            row, j = _cell(rows, 9, col)
            row[j] = "0"
        return rows

    def duplicate(rows):
        return rows[:12] + [list(rows[5])] + rows[12:]

    def gap(rows):  # keep positions 0..10 of 24 (0..150 deg): gap of 210 deg
        return rows[:1] + rows[1:34]

    def never_fed(rows):
        return [rows[0]] + [r for r in rows[1:] if r[1] != "C"]

    def missing_at_one(rows):
        return [r for i, r in enumerate(rows) if i != 8]  # line 9: position 2, phase B

    return {
        # case: (edit, words that must be in the one line)
        "missing column": (drop_column("VB_im"), ["row 1", "column VB_im", "missing column"]),
        "not a number": (set_cell(7, "VA_re", "abc"), ["row 7", "column VA_re", "'abc'"]),
        "empty cell": (set_cell(11, "position_mm", ""), ["row 11", "column position_mm", "not a number"]),
        "nan": (set_cell(5, "VC_im", "nan"), ["row 5", "column VC_im", "not finite", "'nan'"]),
        "inf": (set_cell(6, "freq_hz", "inf"), ["row 6", "column freq_hz", "not finite"]),
        "bad phase": (set_cell(4, "phase", "D"), ["row 4", "column phase", "'D'"]),
        "zero current": (zero_current, ["row 9", "column I_re", "zero current"]),
        "duplicate": (duplicate, ["row 13", "columns position_mm, phase", "duplicate of row 6"]),
        "frequency": (set_cell(20, "freq_hz", "1100"), ["row 20", "column freq_hz", "inconsistent",
                                                        "1100", "row 2"]),
        "negative frequency": (set_cell(3, "freq_hz", "-1000"), ["row 3", "column freq_hz", "positive"]),
        "not one period": (gap, ["row 32", "column position_mm", "do not cover one electrical period",
                                 "gap of 210.0 deg"]),
        "phase never fed": (never_fed, ["column phase", "phase C is never fed"]),
        "phase missing at a position": (missing_at_one, ["row 8", "column phase", "no row with phase B"]),
    }


BAD = bad_cases()


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_bench_file(run_cli, tmp_path, case):
    edit, words = BAD[case]
    rows = edit(good_bench(tmp_path))
    f = tmp_path / "bad.csv"
    f.write_text("\n".join(",".join(r) for r in rows) + "\n")
    out = tmp_path / "out"
    r = run_cli("identify", f, "--out", out, "--motor", "ecce2010")
    assert r.code == 2
    assert r.out == ""
    lines = r.err.strip().splitlines()
    assert len(lines) == 1, r.err
    assert lines[0].startswith("linsense: error: ") and "bad.csv" in lines[0]
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]


def _amplitude_file(tmp_path: Path) -> Path:
    f = tmp_path / "amp.csv"
    f.write_text(bench_to_csv(emulate_bench(load_motor("ecce2010"), 24, 0.0, 0, amplitude_only=True)))
    return f


@pytest.mark.parametrize(
    "case, args, words",
    [
        ("no pole pitch", ["--force-constant", 20, "--mass", 1], ["--pole-pitch", "missing"]),
        ("no mass", ["--pole-pitch", 56, "--force-constant", 20], ["--mass", "missing"]),
        ("bad pole pitch", ["--motor", "ecce2010", "--pole-pitch", "nan"], ["--pole-pitch", "nan"]),
        ("negative mass", ["--motor", "ecce2010", "--mass", -2], ["--mass", "-2"]),
        ("no harmonics", ["--motor", "ecce2010", "--harmonics", 0], ["--harmonics", "0"]),
        ("too many harmonics", ["--motor", "ecce2010", "--harmonics", 12],
         ["--harmonics", "cannot be separated", "24 distinct positions"]),
        ("amplitude without R", ["--pole-pitch", 56, "--force-constant", 20, "--mass", 1.5, "--amp"],
         ["amp.csv", "--resistance"]),
        ("resistance too big", ["--motor", "ecce2010", "--resistance", 50, "--amp"],
         ["amp.csv", "row 2", "column VA", "below the resistance 50 ohm"]),
        ("no such file", ["--motor", "ecce2010", "--missing"], ["nosuch.csv", "no such bench file"]),
        ("bad motor", ["--motor", "nosuch"], ["--motor", "unknown motor"]),
    ],
)
def test_bad_identify_options(run_cli, tmp_path, case, args, words):
    args = list(args)
    if "--amp" in args:
        args.remove("--amp")
        bench = _amplitude_file(tmp_path)
    elif "--missing" in args:
        args.remove("--missing")
        bench = tmp_path / "nosuch.csv"
    else:
        bench = tmp_path / "b.csv"
        bench.write_text(bench_to_csv(emulate_bench(load_motor("ecce2010"), 24, 0.0, 0)))
    before = sorted(p.name for p in tmp_path.iterdir())
    r = run_cli("identify", bench, "--out", tmp_path / "out", *args)
    assert r.code == 2
    lines = r.err.strip().splitlines()
    assert len(lines) == 1, r.err
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_cli_fitted_model_refused(run_cli, tmp_path):
    motor = load_motor("ecce2010")
    # (L0 up with dM0: the 3x3 matrix stays positive definite)
    p = dict(motor.inductance.params, dM0=-1.0e-3, L0=3.75e-3)
    bad = replace(motor, inductance=InductanceModel.from_params(**p))
    f = tmp_path / "bad.csv"
    f.write_text(bench_to_csv(emulate_bench(bad, 56, 0.0, 0)))
    r = run_cli("identify", f, "--out", tmp_path / "out", "--motor", "ecce2010")
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1
    assert "bad.csv" in r.err and "saliency" in r.err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "args, words",
    [
        (["--noise", -0.1], ["--noise", "-0.1"]),
        (["--noise", "nan"], ["--noise", "nan"]),
        (["--positions", 4], ["--positions", "4"]),
        (["--freq", 0], ["--freq", "0"]),
        (["--seed", -1], ["--seed", "-1"]),
    ],
)
def test_bad_emulate_options(run_cli, tmp_path, args, words):
    out = tmp_path / "b.csv"
    r = run_cli("bench-emulate", "--motor", "ecce2010", *args, "--out", out)
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1, r.err
    for w in words:
        assert w in r.err, (w, r.err)
    assert not out.exists()


def test_emulation_is_reproducible_and_randomises_the_current(motors):
    motor, _ = motors["ecce2010"]
    a = emulate_bench(motor, 12, 0.01, 7)
    b = emulate_bench(motor, 12, 0.01, 7)
    c = emulate_bench(motor, 12, 0.01, 8)
    assert bench_to_csv(a) == bench_to_csv(b) != bench_to_csv(c)
    amp = np.abs(a.current)
    assert amp.min() > 0.75 and amp.max() < 1.25 and amp.std() > 0.05
    assert np.std(np.angle(a.current)) > 1.0  # phases spread over the circle


def test_example_bench_file_identifies(run_cli, tmp_path):
    """src/linsense/examples/bench/ecce2010_56_1pct_seed1.csv is what bench-emulate writes for its command."""
    example = ROOT / "src/linsense/examples/bench/ecce2010_56_1pct_seed1.csv"
    out = tmp_path / "b.csv"
    assert run_cli("bench-emulate", "--motor", "ecce2010", "--positions", 56, "--noise", 0.01, "--seed", 1,
                   "--out", out).code == 0
    assert out.read_bytes() == example.read_bytes()


def test_the_documented_numbers_of_the_example_file(motors):
    """docs/identify.md on ecce2010 at 1 % noise, seed 1 (the example bench file): the end effect's
    t about -316; L2 2.07 % high (-0.3236 +- 0.0033 mH against -0.317 mH); the reciprocity error
    1.5 % RMS; the resistance neglected overestimates the self inductances by 13 % at 1 kHz, where
    9 ohm sit next to 17 ohm of reactance."""
    motor, K = motors["ecce2010"]
    table, fit = run_fit(motor, K, 0.01, 1)
    assert f"{fit.values['dM0'] / fit.stderr['dM0']:.0f}" == "-316"
    assert f"{100.0 * (fit.values['L2'] / motor.inductance.params['L2'] - 1.0):.2f}" == "2.07"
    assert (f"{fit.values['L2'] * 1e3:.4f}", f"{fit.stderr['L2'] * 1e3:.4f}") == ("-0.3236", "0.0033")
    assert f"{100.0 * table.reciprocity_rms:.1f}" == "1.5", table.reciprocity_rms
    _, neglect = run_fit(motor, K, 0.0, 3, amplitude_only=True, resistance=0.0)
    assert f"{100.0 * (neglect.values['L0'] / motor.inductance.params['L0'] - 1.0):.0f}" == "13"
    assert motor.R_s == 9.0 and f"{2 * np.pi * 1000.0 * motor.inductance.params['L0']:.0f}" == "17"

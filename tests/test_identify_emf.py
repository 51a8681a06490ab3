"""The open-circuit back-EMF record (linsense.identify.emf_record; `linsense bench-emulate
--open-circuit`, `linsense identify --emf`): the magnets' flux per phase recovered through the file
within a tolerance derived from the record's noise, the standard errors honest, every refusal (exit
code 2, one line naming file, key, value and limit, nothing written), and the CLI path."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from linsense.identify.bench import bench_to_csv, emulate_bench
from linsense.identify.emf_record import (
    STDERR_MAX,
    emf_to_csv,
    emulate_emf,
    pm_phases_from_record,
    read_emf_csv,
)
from linsense.model.motor import PmHarmonic, PmPhases, load_motor

ROOT = Path(__file__).resolve().parents[1]
#: the imbalance to recover: one end phase 4 % weak, its axis 1.5 deg ahead, the other 1 % strong
KEYS = PmPhases((1.0, 0.96, 1.01), (0.0, math.radians(1.5), math.radians(-0.7)))
#: tolerance in standard errors (the errors are Gaussian: 5 sigma fails once in 1.7 million)
Z_MAX = 5.0


def _motor(name="ecce2010", keys=KEYS):
    """``name`` with the imbalance and a 3rd and 5th harmonic (which the fit must not take in)."""
    return dataclasses.replace(load_motor(name), pm_phases=keys,
                               pm_harmonics=(PmHarmonic(3, 0.05, 0.0), PmHarmonic(5, 0.03, 0.2)))


def _sequences(scale, shift):
    c = np.asarray(scale) * np.exp(1j * np.asarray(shift))
    return c.sum() / 3, (c * np.exp(2j * np.pi / 3) ** np.arange(3)).sum() / 3


def _through_file(rec, tmp_path, name="emf.csv"):
    f = tmp_path / name
    f.write_text(emf_to_csv(rec))
    return read_emf_csv(f)


@pytest.mark.parametrize("line_to_line", [False, True])
def test_noise_free_recovers_the_keys(tmp_path, line_to_line):
    """Through the CSV file, 1.37 periods (the harmonics do not average out): exact to 1e-9."""
    m = _motor()
    rec = _through_file(emulate_emf(m, 0.4, 1.37, 8e3, 0.0, 0, line_to_line), tmp_path)
    got = pm_phases_from_record(rec, m.pole_pitch, m.psi_pm)
    if line_to_line:  # (the zero sequence is lost; the sequences that act are exact)
        for x, y in zip(_sequences(got.phases.scale, got.phases.shift), _sequences(KEYS.scale, KEYS.shift),
                        strict=True):
            assert abs(x - y) < 1e-9
    else:
        np.testing.assert_allclose(got.phases.scale, KEYS.scale, atol=1e-9)
        np.testing.assert_allclose(got.phases.shift, KEYS.shift, atol=1e-9)
    assert got.noise_rms < 1e-6


@pytest.mark.parametrize("name, speed, periods, seed", [
    ("ecce2010", 0.5, 1.37, 1), ("ecce2010", -0.3, 2.0, 2), ("small30", 0.25, 1.1, 3),
])
def test_round_trip_with_noise(tmp_path, name, speed, periods, seed):
    """1 % noise on each voltage, through the file: every scale and shift within Z_MAX of its
    standard error, which is the one the noise predicts (``noise sqrt(2/N)`` rad) within 5 %, and
    well inside the limit."""
    m = _motor(name)
    rec = _through_file(emulate_emf(m, speed, periods, 10e3, 0.01, seed), tmp_path)
    got = pm_phases_from_record(rec, m.pole_pitch, m.psi_pm)
    predicted = 0.01 * math.sqrt(2.0 / rec.time.size) / np.array(KEYS.scale)
    np.testing.assert_allclose(got.stderr, predicted, rtol=0.05)
    assert max(got.stderr) < 0.5 * STDERR_MAX
    err_scale = (np.array(got.phases.scale) - KEYS.scale) / np.array(KEYS.scale)
    err_shift = np.array(got.phases.shift) - KEYS.shift
    assert np.all(np.abs(err_scale) < Z_MAX * np.array(got.stderr)), (err_scale, got.stderr)
    assert np.all(np.abs(err_shift) < Z_MAX * np.array(got.stderr)), (err_shift, got.stderr)
    assert got.noise_rms == pytest.approx(0.01 * abs(2 * math.pi * speed / m.pole_pitch) * m.psi_pm, rel=0.05)


def test_the_standard_errors_are_honest():
    """Over 40 seeds the errors divided by their standard errors have a standard deviation near 1
    (0.8 .. 1.3: the harmonics fitted beside the fundamental add a little)."""
    m = _motor()
    z = []
    for seed in range(40):
        got = pm_phases_from_record(emulate_emf(m, 0.5, 1.37, 5e3, 0.01, seed), m.pole_pitch, m.psi_pm)
        s = np.array(got.stderr)
        z += list((np.array(got.phases.shift) - KEYS.shift) / s)
        z += list((np.array(got.phases.scale) / KEYS.scale - 1.0) / s)
    assert 0.8 < np.std(z) < 1.3, np.std(z)
    assert abs(np.mean(z)) < 0.3


# ---------------------------------------------------------------------- CLI
def test_cli_end_to_end(run_cli, tmp_path):
    """bench-emulate --open-circuit of a motor file with the imbalance, then identify --emf:
    motor.toml carries the keys within the tolerance, fit.json the record's entry; the same
    identification without --emf writes the files it wrote before (no [pm_flux], no entry)."""
    motor_file = tmp_path / "imb.toml"
    motor_file.write_text((ROOT / "src/linsense/examples/motors/small30.toml").read_text()
                          + "\n[pm_flux]\nscale_abc = [1.0, 0.96, 1.01]\nshift_deg_abc = [0.0, 1.5, -0.7]\n")
    bench, emf = tmp_path / "bench.csv", tmp_path / "emf.csv"
    r = run_cli("bench-emulate", "--motor", motor_file, "--noise", 0.01, "--seed", 2, "--out", bench)
    assert r.code == 0, r.err
    r = run_cli("bench-emulate", "--motor", motor_file, "--open-circuit", "--speed", 0.3, "--periods", 1.5,
                "--noise", 0.01, "--seed", 3, "--out", emf)
    assert r.code == 0, r.err
    assert emf.read_text().splitlines()[0] == "time_s,position_mm,VA,VB,VC"
    out = tmp_path / "id"
    r = run_cli("identify", bench, "--out", out, "--motor", motor_file, "--emf", emf)
    assert r.code == 0, r.err
    assert r.err == ""
    assert "magnets' flux per phase (emf.csv" in r.out and "scale_abc [" in r.out
    fitted = load_motor(out / "motor.toml")
    doc = json.loads((out / "fit.json").read_text())["open_circuit"]
    s = np.array(doc["stderr"])
    assert np.all(np.abs(np.array(fitted.pm_phases.scale) / KEYS.scale - 1.0) < Z_MAX * s)
    assert np.all(np.abs(np.array(fitted.pm_phases.shift) - KEYS.shift) < Z_MAX * s)
    assert doc["form"] == "phase-to-star" and doc["scale_abc"] == list(fitted.pm_phases.scale)
    assert doc["positive"]["magnitude"] == pytest.approx(abs(_sequences(KEYS.scale, KEYS.shift)[0]), abs=1e-3)

    plain = tmp_path / "plain"
    assert run_cli("identify", bench, "--out", plain, "--pole-pitch", 30, "--force-constant", 9.5,
                   "--mass", 0.8).code == 0
    assert "[pm_flux]" not in (plain / "motor.toml").read_text()
    assert "open_circuit" not in json.loads((plain / "fit.json").read_text())


def test_cli_wrong_force_constant_is_said(run_cli, tmp_path):
    """A force constant 30 % below the motor's: the scales carry it, and a warning says so."""
    bench, emf = tmp_path / "bench.csv", tmp_path / "emf.csv"
    assert run_cli("bench-emulate", "--motor", "ecce2010", "--out", bench).code == 0
    assert run_cli("bench-emulate", "--motor", "ecce2010", "--open-circuit", "--out", emf).code == 0
    r = run_cli("identify", bench, "--out", tmp_path / "id", "--emf", emf, "--pole-pitch", 56,
                "--force-constant", 15.38, "--mass", 1.5)
    assert r.code == 0, r.err
    assert "linsense: warning: the back-EMF of emf.csv links 1.3 times the psi_pm" in r.err
    assert "20 N/A" in r.err


def test_bench_emulate_refuses_the_other_tests_options(run_cli, tmp_path):
    for args, words in ((["--open-circuit", "--positions", 16], "--positions is for the HF bench test"),
                        (["--speed", 1.0], "--speed is for --open-circuit"),
                        (["--open-circuit", "--speed", 0], "speed")):
        r = run_cli("bench-emulate", "--motor", "ecce2010", *args, "--out", tmp_path / "x.csv")
        assert r.code == 2 and len(r.err.strip().splitlines()) == 1 and words in r.err, r.err
    assert not (tmp_path / "x.csv").exists()


def _good_rows(**kw) -> list[list[str]]:
    m = _motor()
    args = dict(speed=0.5, periods=1.5, rate=4e3, noise=0.0, seed=0, line_to_line=False) | kw
    return [line.split(",") for line in emf_to_csv(emulate_emf(m, **args)).strip().splitlines()]


def _swap(a, b):
    def f(rows):
        i, j = rows[0].index(a), rows[0].index(b)
        for r in rows[1:]:  # (the channels swapped, not the names)
            r[i], r[j] = r[j], r[i]
        return rows
    return f


def _negate(col):
    def f(rows):
        j = rows[0].index(col)
        for r in rows[1:]:
            r[j] = repr(-float(r[j]))
        return rows
    return f


def _set(line, col, value):
    def f(rows):
        rows[line - 1][rows[0].index(col)] = value
        return rows
    return f


def _reverse_at(line):
    def f(rows):  # the mover runs back from this row on
        j = rows[0].index("position_mm")
        top = float(rows[line - 2][j])
        for r in rows[line - 1:]:
            r[j] = repr(2 * top - float(r[j]))
        return rows
    return f


BAD = {
    # case: (rows, edit, words that must be in the one line)
    "too little travel": (dict(periods=0.8), None,
                          ["column position_mm", "44.8", "288", "one pole pitch (56 mm)"]),
    "speed too low": (dict(speed=0.002, periods=1.0, rate=20, noise=0.05), None,
                      ["columns VA, VB, VC", "speed too low", "at most 0.1 deg", "record at least", "m/s"]),
    "nan": ({}, _set(7, "VB", "nan"), ["row 7", "column VB", "not finite"]),
    "wrong column count": ({}, lambda rows: rows[:5] + [rows[5][:-1]] + rows[6:], ["row 6", "4 fields",
                                                                                  "5 columns"]),
    "missing column": ({}, lambda rows: [r[:-1] for r in rows], ["row 1, column VC", "missing column",
                                                                 "VAB,VBC,VCA"]),
    "reversed phase": ({}, _negate("VB"), ["columns VA, VB, VC", "do not sum to about zero", "1.99", "0.5",
                                           "wiring"]),
    "time not increasing": ({}, _set(9, "time_s", "0"), ["row 9", "column time_s", "does not increase"]),
    "reversal": ({}, _reverse_at(100), ["row 99", "stops or reverses", "one direction"]),
    "swapped phases": ({}, _swap("VB", "VC"), ["columns VA, VB, VC", "phase B", "[-30, 30] deg", "wiring"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_record(run_cli, tmp_path, case):
    kw, edit, words = BAD[case]
    rows = _good_rows(**kw)
    rows = edit(rows) if edit else rows
    bench, emf = tmp_path / "bench.csv", tmp_path / "bad.csv"
    bench.write_text(bench_to_csv(emulate_bench(load_motor("ecce2010"), 24, 0.0, 0)))
    emf.write_text("\n".join(",".join(r) for r in rows) + "\n")
    out = tmp_path / "out"
    r = run_cli("identify", bench, "--out", out, "--motor", "ecce2010", "--emf", emf)
    assert r.code == 2
    assert r.out == ""
    lines = r.err.strip().splitlines()
    assert len(lines) == 1, r.err
    assert lines[0].startswith("linsense: error: ") and "bad.csv" in lines[0]
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "bench.csv"]


def test_example_record_is_the_generators(run_cli, tmp_path):
    """src/linsense/examples/bench/ecce2010_emf_1pct_seed1.csv is what bench-emulate writes for the
    command of docs/identify.md; identified with the example bench file it gives the balanced
    ecce2010 within Z_MAX standard errors (docs/identify.md quotes these numbers)."""
    example = ROOT / "src/linsense/examples/bench/ecce2010_emf_1pct_seed1.csv"
    out = tmp_path / "e.csv"
    r = run_cli("bench-emulate", "--motor", "ecce2010", "--open-circuit", "--speed", 0.5, "--periods", 1.25,
                "--rate", 2000, "--noise", 0.01, "--seed", 1, "--out", out)
    assert r.code == 0, r.err
    assert out.read_bytes() == example.read_bytes()
    r = run_cli("identify", "ecce2010_56_1pct_seed1", "--motor", "ecce2010",
                "--emf", "ecce2010_emf_1pct_seed1", "--out", tmp_path / "id")
    assert r.code == 0, r.err
    assert ("scale_abc [1.0006, 0.9979, 0.9997], shift_deg_abc [+0.027, +0.083, -0.043] +- 0.047 deg"
            in r.out), r.out
    got = load_motor(tmp_path / "id" / "motor.toml").pm_phases
    s = json.loads((tmp_path / "id" / "fit.json").read_text())["open_circuit"]["stderr"]
    assert np.all(np.abs(np.array(got.scale) - 1.0) < Z_MAX * np.array(s))
    assert np.all(np.abs(np.array(got.shift)) < Z_MAX * np.array(s))


@pytest.mark.parametrize("args, key, words", [
    (dict(rec=None), "rec", ["EmfRecord"]),
    (dict(pole_pitch=56.0), "pole_pitch", ["56", "mm"]),
    (dict(pole_pitch=float("nan")), "pole_pitch", ["nan"]),
    (dict(psi_pm=-1.0), "psi_pm", ["-1"]),
    (dict(cut=True), "rec", ["(N, 3)"]),
])
def test_api_refusals(args, key, words):
    """The API refuses what the command refuses, in one InputError naming the argument."""
    from linsense.errors import InputError

    m = _motor()
    rec = emulate_emf(m, 0.5, 1.5, 4e3)
    if args.pop("cut", False):
        rec = dataclasses.replace(rec, position=rec.position[:-1])
    kw = dict(rec=rec, pole_pitch=m.pole_pitch, psi_pm=m.psi_pm) | args
    with pytest.raises(InputError) as exc:
        pm_phases_from_record(**kw)
    assert exc.value.key == key
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))

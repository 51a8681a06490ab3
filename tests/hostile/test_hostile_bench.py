"""Hostile bench files and identify options: exit 2 and one line naming
the file, the row and column (or the option) and the value; the output folder is not created."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def bench_text(tmp_path_factory) -> str:
    """A valid emulated bench measurement (phasor form), as text."""
    from linsense.identify.bench import bench_to_csv, emulate_bench
    from linsense.model.motor import load_motor

    return bench_to_csv(emulate_bench(load_motor("ecce2010"), 24, 0.0, 0))


def cell(text: str, row: int, col: int, value: str) -> str:
    """``text`` with the cell at (row, col) (0-based, header row 0) replaced by ``value``."""
    lines = text.splitlines()
    cells = lines[row].split(",")
    cells[col] = value
    lines[row] = ",".join(cells)
    return "\n".join(lines) + "\n"


# name: (function of the valid text -> hostile text or bytes, words the message must contain)
CASES = {
    "empty file": (lambda t: "", ["empty bench file"]),
    "header only": (lambda t: t.splitlines()[0] + "\n", ["no data rows"]),
    "missing column": (lambda t: t.replace("I_im", "I_imag", 1), ["I_im", "missing column"]),
    "not a number": (lambda t: cell(t, 3, 3, "abc"), ["row 4", "I_re", "'abc'"]),
    "nan": (lambda t: cell(t, 2, 4, "nan"), ["row 3", "I_im", "nan"]),
    "inf": (lambda t: cell(t, 2, 5, "inf"), ["row 3", "VA_re", "inf"]),
    "unknown phase": (lambda t: cell(t, 2, 1, "D"), ["row 3", "phase", "'D'"]),
    "negative frequency": (lambda t: cell(t, 2, 2, "-1000"), ["row 3", "freq_hz", "-1000"]),
    "200 kB field": (lambda t: cell(t, 2, 3, "1" * 200_000), ["field larger than field limit"]),
    "not utf-8": (lambda t: t.encode() + b"\xff\xfe\n", ["cannot read bench file"]),
    "binary garbage": (lambda t: bytes(range(256)) * 4, ["bench"]),
    "duplicate row": (lambda t: t + t.splitlines()[1] + "\n", ["duplicate"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_bench_file(run_cli, tmp_path, bench_text, case):
    make, words = CASES[case]
    data = make(bench_text)
    f = tmp_path / "bench.csv"
    f.write_bytes(data if isinstance(data, bytes) else data.encode())
    out = tmp_path / "id"
    r = run_cli("identify", f, "--out", out, "--motor", "ecce2010")
    r.refused("bench.csv", *words)
    assert not out.exists()


OPTIONS = {
    "harmonics 0": (["--harmonics", "0"], ["--harmonics", "0"]),
    "harmonics 1000": (["--harmonics", "1000"], ["--harmonics", "1000"]),
    "points 1e6": (["--points", "1000000"], ["--points", "100,000"]),
    "pole pitch nan": (["--pole-pitch", "nan"], ["--pole-pitch", "nan"]),
    "pole pitch 0": (["--pole-pitch", "0"], ["--pole-pitch", "0"]),
}


@pytest.mark.parametrize("case", list(OPTIONS))
def test_hostile_identify_option(run_cli, tmp_path, bench_text, case):
    args, words = OPTIONS[case]
    f = tmp_path / "bench.csv"
    f.write_text(bench_text)
    out = tmp_path / "id"
    r = run_cli("identify", f, "--out", out, *args)
    r.refused(*words)
    assert not out.exists()


def test_the_valid_bench_is_identified(run_cli, tmp_path, bench_text):
    f = tmp_path / "bench.csv"
    f.write_text(bench_text)
    r = run_cli("identify", f, "--out", tmp_path / "id", "--motor", "ecce2010")
    assert r.code == 0, r.err

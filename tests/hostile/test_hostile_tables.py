"""Hostile tables, motor values and outputs (crashes and messages that mislead): each case an input,
its exit code and the words its one line must contain.

* tables: rows, columns and field size bounded while reading (docs/limits.md), a UTF-8 BOM read,
  decimal commas and semicolon separators refused by name (they said "missing column theta_deg");
* motor values off by a unit prefix ("did you type mH?");
* a 10 MB key, section or value quoted in a bounded message (a 50 MB one was a 50 MB line; a
  file beyond 16 MiB is now refused before it is parsed);
* an output that cannot be written (read-only folder, full disk): the user's path and the reason
  in words, not ``[Errno 28]`` and the temporary file's name.
"""

from __future__ import annotations

import errno
import os
import tracemalloc
from importlib import resources

import numpy as np
import pytest

from linsense import limits
from linsense.errors import MAX_MESSAGE_CHARS, InputError, bounded
from linsense.model.motor import load_motor

PRESET = (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()
HEADER = "theta_deg,L_A,L_B,L_C,M_AB,M_BC,M_CA"
BIG = 10_000_000  # (under the 16 MiB a text file may have: MAX_TEXT_FILE_BYTES)


def edit(old: str, new: str) -> str:
    assert old in PRESET
    return PRESET.replace(old, new)


def with_table(name: str = "t.csv") -> str:
    return PRESET.split("L0 =")[0] + f'table = "{name}"\n'


def rows(n: int = 12) -> list[list[str]]:
    """The preset's inductances at n positions, as the cells of a CSV."""
    theta = 2.0 * np.pi * np.arange(n) / n
    e = load_motor("ecce2010").inductance.entries(theta)
    return [[repr(360.0 * k / n)] + [repr(float(v)) for v in e[k]] for k in range(n)]


def csv_text(body: list[list[str]], header: str = HEADER, sep: str = ",") -> str:
    return header.replace(",", sep) + "\n" + "".join(sep.join(r) + "\n" for r in body)


def decimal_commas(body: list[list[str]]) -> list[list[str]]:
    return [[c.replace(".", ",") for c in r] for r in body]


R = rows()
QUOTED = [r[:] for r in R]
QUOTED[0][1] = '"0,002433"'

# name: (motor file, table file or None, exit code, words of the one line)
CASES = {
    # tables: sizes (the table is read line by line, each size checked before it is kept)
    "table too many rows": (with_table(), HEADER + "\n" + "0,1,1,1,1,1,1\n" * (limits.MAX_TABLE_ROWS + 1), 2,
                            ["t.csv", "more than 100,000 rows", "limit of 100,000"]),
    "table too many columns": (with_table(), HEADER + "".join(f",x{j}" for j in range(60)) + "\n", 2,
                               ["t.csv", "row 1", "67 columns", "limit of 64"]),
    "table 101-character field": (with_table(), csv_text([["0", "1" * 101] + R[0][2:]] + R[1:]), 2,
                                  ["t.csv", "row 2, column 2", "field larger than field limit of 100",
                                   "101"]),
    "table 10 MB line": (with_table(), HEADER + "\n0," + "1" * 10_000_000, 2,
                         ["t.csv", "row 2", "field larger than field limit of 100"]),
    "table 10 MB of commas": (with_table(), HEADER + "\n" + "," * 10_000_000, 2,
                              ["t.csv", "row 2", "limit of 64 columns"]),
    # tables: encodings and separators of spreadsheets
    "table with a BOM": (with_table(), "\ufeff" + csv_text(R), 0, []),
    "table with a BOM and CRLF": (with_table(), "\ufeff" + csv_text(R).replace("\n", "\r\n"), 0, []),
    "table with a trailing empty line": (with_table(), csv_text(R) + "\n", 0, []),
    "decimal comma in a quoted field": (with_table(), csv_text(QUOTED), 2,
                                        ["t.csv", "row 2, column L_A", "0,002433",
                                         "decimal commas are not read: use a point"]),
    "decimal commas and semicolons": (with_table(), csv_text(decimal_commas(R), sep=";"), 2,
                                      ["t.csv", "row 1", "semicolon separators are not read",
                                       "decimal commas are not read"]),
    "semicolons with decimal points": (with_table(), csv_text(R, sep=";"), 2,
                                       ["t.csv", "row 1", "semicolon separators are not read"]),
    "decimal commas with comma separators": (with_table(), csv_text(decimal_commas(R)), 2,
                                             ["t.csv", "row 2", "fields for the header's 7 columns",
                                              "decimal commas are not read: use a point"]),
    "semicolon rows under a comma header": (with_table(), csv_text(R, sep=";").replace(";", ",", 6), 2,
                                            ["t.csv", "row 2", "1 fields for the header's 7 columns",
                                             "semicolon separators are not read"]),
    "row with a field missing": (with_table(), csv_text([R[0][:-1]] + R[1:]), 2,
                                 ["t.csv", "row 2", "6 fields for the header's 7 columns"]),
    # motor values off by a unit prefix
    "L0 = 1 (H for mH)": (edit("L0 = 2.75e-3", "L0 = 1"), None, 2,
                          ["inductance.L0", "L0 = 1 H", "Did you type mH"]),
    "L0 = 0.3 with R_s = 1 (time constant)": (
        edit("L0 = 2.75e-3", "L0 = 0.3").replace("R_s = 9.0", "R_s = 1.0"), None, 2,
        ["inductance.L0", "0.3", "time constant", "Did you type mH"]),
    "L0 = 1e-9": (edit("L0 = 2.75e-3", "L0 = 1e-9"), None, 2, ["inductance.L0", "1e-09", "uH or nH"]),
    "R_s = 500 (ohm for milliohm)": (edit("R_s = 9.0", "R_s = 500.0"), None, 2,
                                     ["motor.R_s", "500", "Did you type milliohm"]),
    "R_s negative": (edit("R_s = 9.0", "R_s = -9.0"), None, 2,
                     ["motor.R_s", "greater than or equal to 0", "-9"]),
    # a user's value of 10 MB in a message
    "10 MB unknown key": (edit("[motor]\n", "[motor]\n" + "k" * BIG + " = 1\n"), None, 2,
                          ["unknown key", "kkkk\u2026 (10,000,006 characters)"]),
    "10 MB value of an unknown key": (edit("[motor]\n", '[motor]\nfoo = "' + "v" * BIG + '"\n'), None, 2,
                                      ["motor.foo", "unknown key", "vvvv\u2026' (10,000,000 characters)"]),
    "10 MB section": (PRESET + "\n[" + "s" * BIG + "]\nx = 1\n", None, 2,
                      ["ssss\u2026 (10,000,000 characters)"]),
    "10 MB string for a number": (edit("mass = 1.5", 'mass = "' + "1" * BIG + '"'), None, 2,
                                  ["motor.mass", "1111\u2026' (10,000,000 characters)"]),
    "10 MB value with spaces": (edit("[motor]\n", '[motor]\nfoo = "' + "a " * (BIG // 2) + '"\n'), None, 2,
                                ["motor.foo", "unknown key", "a a \u2026' (10,000,000 characters)"]),
    "50 MB value: the file beyond the size limit": (
        edit("[motor]\n", '[motor]\nfoo = "' + "v" * (5 * BIG) + '"\n'), None, 2,
        ["m.toml", "larger than the limit of 16,777,216 bytes of a motor file"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_table_or_value(run_cli, tmp_path, case):
    text, table, code, words = CASES[case]
    (tmp_path / "m.toml").write_text(text, encoding="utf-8")
    if table is not None:
        (tmp_path / "t.csv").write_bytes(table.encode("utf-8"))
    out = tmp_path / "model.csv"
    r = run_cli("model", "--motor", tmp_path / "m.toml", "--points", 16, "--out", out)
    if code == 0:
        assert r.code == 0 and r.err == "", r.err
        assert out.exists()
        return
    line = r.refused(*words)
    assert "m.toml" in line or "t.csv" in line, line
    assert len(line) < MAX_MESSAGE_CHARS + 600, len(line)  # (the file's path, the key and the message)
    assert not out.exists()


@pytest.mark.slow
def test_a_table_too_long_is_refused_before_it_is_kept(run_cli, tmp_path):
    """Refusing 100,001 rows keeps a few MB (the rows are not kept as text, the fit never starts)."""
    (tmp_path / "m.toml").write_text(with_table())
    (tmp_path / "t.csv").write_text(CASES["table too many rows"][1])
    tracemalloc.start()
    try:
        r = run_cli("model", "--motor", tmp_path / "m.toml", "--out", tmp_path / "x.csv")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    r.refused("limit of 100,000")
    assert peak < 20e6, f"{peak / 1e6:.0f} MB kept before refusing"


@pytest.mark.slow
def test_linsense_reads_the_longest_table_it_writes(run_cli, tmp_path):
    """``linsense model --points`` at its limit writes a table that linsense reads back (a 100,000-row
    table asked for 37 GiB): the table's limit is --points' and the fit's order is bounded."""
    assert limits.MAX_TABLE_ROWS >= limits.MAX_POINTS
    table = tmp_path / "t.csv"
    assert run_cli("model", "--motor", "ecce2010", "--points", limits.MAX_POINTS, "--out", table).code == 0
    (tmp_path / "m.toml").write_text(with_table())
    m = load_motor(tmp_path / "m.toml")
    assert m.inductance.max_order <= limits.MAX_TABLE_ORDER
    theta = np.linspace(0.0, 2.0 * np.pi, 97, endpoint=False)
    np.testing.assert_allclose(m.inductance.entries(theta), load_motor("ecce2010").inductance.entries(theta),
                               atol=1e-12)


# ---------------------------------------------------------------------- outputs
def _no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _read_only(*args, **kwargs):
    raise OSError(errno.EROFS, os.strerror(errno.EROFS))


@pytest.mark.parametrize("fail, words", [(_no_space, ["no space left"]), (_read_only, ["read-only"])])
def test_an_output_file_that_cannot_be_written(run_cli, tmp_path, monkeypatch, fail, words):
    """A full disk or a read-only file system while writing ``--out``: the user's path and the reason
    in words, not ``[Errno 28]`` and the temporary file; nothing left behind."""
    out = tmp_path / "o" / "model.csv"
    monkeypatch.setattr(os, "fsync", fail)
    line = run_cli("model", "--motor", "ecce2010", "--points", 16, "--out", out).refused(
        str(out), "cannot write", *words)
    assert "Errno" not in line and ".tmp" not in line, line
    assert os.listdir(out.parent) == []


def test_an_output_set_on_a_full_disk(run_cli, tmp_path, monkeypatch):
    """The same in an output set (``plot --out folder``): a file of the set as the user will see it."""
    out = tmp_path / "figs"
    monkeypatch.setattr(os, "fsync", _no_space)
    line = run_cli("plot", "--motor", "ecce2010", "--points", 8, "--out", out).refused(
        str(out), "cannot write", "no space left")
    assert "Errno" not in line and ".tmp" not in line, line
    assert not out.exists() and os.listdir(tmp_path) == []


@pytest.mark.parametrize("kind", ["file", "set"])
def test_a_read_only_folder(run_cli, tmp_path, kind):
    """A folder chmod'ed read-only (skipped where chmod does not bind, e.g. as root)."""
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        if os.access(folder, os.W_OK):
            pytest.skip("chmod does not make a folder read-only here (running as root)")
        if kind == "file":
            out = folder / "model.csv"
            r = run_cli("model", "--motor", "ecce2010", "--points", 16, "--out", out)
        else:
            out = folder / "figs"
            r = run_cli("plot", "--motor", "ecce2010", "--points", 8, "--out", out)
        line = r.refused(str(out), "cannot write", "permission denied", "read-only")
        assert "Errno" not in line and ".tmp" not in line, line
        assert os.listdir(folder) == []
    finally:
        folder.chmod(0o755)


# ---------------------------------------------------------------------- the one bound of messages
def test_every_message_is_bounded():
    """The bound is in InputError itself: any message quoting any value, however built."""
    e = InputError("f.toml", "k" * 10_000, "got " + repr("v" * 10**6) + ", beyond the limit of 3")
    assert len(str(e)) < 400
    assert "(10,000 characters)" in str(e) and "vvvv\u2026' (1,000,000 characters)" in str(e)
    assert str(e).endswith(", beyond the limit of 3")  # (what follows the value is kept)
    assert bounded(bounded("x" * 500)) == bounded("x" * 500)
    short = "/a/path/of/a/table.csv: row 2, column L_A: not a number: 'abc'"
    assert bounded(short) == short
    assert len(bounded("a " * 10**6)) < MAX_MESSAGE_CHARS + 40

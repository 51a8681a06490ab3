"""Hostile files through every reader: the bench files and LUTs read through the one
bounded CSV reader (``linsense.io.csv_rows``: a byte-order mark skipped, semicolons and decimal
commas named, rows and fields bounded), and every text file a user gives (motor, scenario, sweep,
JSON LUT) read no further than ``MAX_TEXT_FILE_BYTES``. Each case: the input, the exit code (or the
exception) and the words of its one line."""

from __future__ import annotations

import pytest

import linsense.limits
from linsense.errors import InputError


@pytest.fixture(scope="module")
def bench_text() -> str:
    from linsense.identify.bench import bench_to_csv, emulate_bench
    from linsense.model.motor import load_motor

    return bench_to_csv(emulate_bench(load_motor("ecce2010"), 24, 0.0, 0))


def _semicolons(t: str) -> str:
    return t.replace(",", ";")


def _decimal_comma(t: str) -> str:
    lines = t.splitlines()
    cells = lines[2].split(",")
    cells[3] = '"' + cells[3].replace(".", ",") + '"'
    lines[2] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _unquoted_decimal_comma(t: str) -> str:
    lines = t.splitlines()
    lines[2] = lines[2].replace(".", ",", 1)
    return "\n".join(lines) + "\n"


def _short_row(t: str) -> str:
    lines = t.splitlines()
    lines[3] = ",".join(lines[3].split(",")[:-1])
    return "\n".join(lines) + "\n"


# name: (function of the valid bench text -> hostile text, words the message must contain)
BENCH = {
    "semicolon separators": (_semicolons, ["bench.csv", "row 1", "semicolon"]),
    "a quoted decimal comma": (_decimal_comma, ["bench.csv", "row 3", "decimal commas are not read"]),
    "an unquoted decimal comma": (_unquoted_decimal_comma,
                                  ["bench.csv", "row 3", "fields for the header's", "decimal commas"]),
    "a row short of a field": (_short_row, ["bench.csv", "row 4", "fields for the header's"]),
    "a header of blanks": (lambda t: ",,,\n" + t, ["bench.csv", "missing column"]),
}


@pytest.mark.parametrize("case", list(BENCH))
def test_hostile_bench_through_the_one_reader(run_cli, tmp_path, bench_text, case):
    make, words = BENCH[case]
    f = tmp_path / "bench.csv"
    f.write_text(make(bench_text))
    out = tmp_path / "id"
    run_cli("identify", f, "--out", out, "--motor", "ecce2010").refused(*words)
    assert not out.exists()


def test_a_bench_file_from_a_spreadsheet_is_read(tmp_path, bench_text):
    """A byte-order mark, CRLF line ends and blank lines (a spreadsheet's export) read as the plain
    file does (the BOM said "missing column" before)."""
    from linsense.identify.bench import read_bench_csv

    plain, sheet = tmp_path / "plain.csv", tmp_path / "sheet.csv"
    plain.write_text(bench_text)
    sheet.write_bytes(b"\xef\xbb\xbf" + bench_text.replace("\n", "\r\n\r\n").encode())
    a, b = read_bench_csv(plain), read_bench_csv(sheet)
    assert (a.current == b.current).all() and (a.voltage == b.voltage).all()


def test_a_bench_file_beyond_the_row_limit(run_cli, tmp_path, bench_text, monkeypatch):
    monkeypatch.setattr(linsense.limits, "MAX_TABLE_ROWS", 50)
    lines = bench_text.splitlines()
    f = tmp_path / "bench.csv"
    f.write_text("\n".join([lines[0]] + lines[1:] * 10) + "\n")
    run_cli("identify", f, "--out", tmp_path / "id", "--motor", "ecce2010").refused(
        "bench.csv", "more than 50 rows", "limit")


def _lut_csv(tmp_path, text: str | bytes):
    f = tmp_path / "l.csv"
    f.write_bytes(text if isinstance(text, bytes) else text.encode())
    return f


LUT = {
    "semicolons": ("theta_deg;psi_lut_deg\n0;1\n90;1\n180;1\n270;1\n", ["l.csv", "header"]),
    "a decimal comma": ('theta_deg,psi_lut_deg\n0,"1,5"\n90,1\n180,1\n270,1\n', ["l.csv", "row 2"]),
    "a third field": ("theta_deg,psi_lut_deg\n0,1,7\n90,1\n180,1\n270,1\n", ["l.csv", "row 2", "3 fields"]),
    "no such file": (None, ["l.csv", "no such LUT"]),
    "a 200 kB field": ("theta_deg,psi_lut_deg\n0," + "1" * 200_000 + "\n", ["l.csv", "field limit"]),
}


@pytest.mark.parametrize("case", list(LUT))
def test_hostile_lut_csv(tmp_path, case):
    from linsense.compensation.lut import read_lut

    text, words = LUT[case]
    f = _lut_csv(tmp_path, text) if text is not None else tmp_path / "l.csv"
    with pytest.raises(InputError) as e:
        read_lut(f)
    line = str(e.value)
    assert "\n" not in line
    for w in words:
        assert w in line, (w, line)


def test_a_lut_from_a_spreadsheet_is_read(tmp_path):
    from linsense.compensation.lut import read_lut

    body = "theta_deg,psi_lut_deg\r\n0,1.5\r\n90,2\r\n\r\n180,1.5\r\n270,2\r\n"
    lut = read_lut(_lut_csv(tmp_path, b"\xef\xbb\xbf" + body.encode()))
    assert list(lut.values) == pytest.approx([0.02618, 0.03491, 0.02618, 0.03491], abs=1e-5)


def _big(kind: str, tmp_path, limit: int):
    """A file of ``kind`` a few bytes over ``limit`` (a long comment: valid otherwise)."""
    pad = "#" + "x" * limit + "\n"
    if kind == "motor":
        from importlib import resources

        f = tmp_path / "m.toml"
        f.write_text(pad + (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text())
        return f, ["model", "--motor", f, "--out", tmp_path / "m.csv"]
    if kind == "scenario":
        f = tmp_path / "s.toml"
        f.write_text(pad + 'motor = "ecce2010"\n[scenario]\nduration = 0.1\n')
        return f, ["simulate", f, "--out", tmp_path / "o"]
    f = tmp_path / "w.toml"
    (tmp_path / "s.toml").write_text('motor = "ecce2010"\n[scenario]\nduration = 0.1\n')
    f.write_text(pad + '[sweep]\nscenario = "s.toml"\n[[axis]]\nkey = "injection.amplitude"\n'
                 "values = [10.0, 12.0]\n")
    return f, ["sweep", f, "--out", tmp_path / "o"]


@pytest.mark.parametrize("kind", ["motor", "scenario", "sweep"])
def test_a_text_file_beyond_the_size_limit(run_cli, tmp_path, monkeypatch, kind):
    """Every TOML file is read no further than the limit (a multi-GB file was read whole first);
    the limit is lowered to 4 kB here so that the test writes little."""
    monkeypatch.setattr(linsense.limits, "MAX_TEXT_FILE_BYTES", 4096)
    f, args = _big(kind, tmp_path, 4096)
    run_cli(*args).refused(f.name, "larger than the limit of 4,096 bytes")


def test_a_json_lut_beyond_the_size_limit(tmp_path, monkeypatch):
    from linsense.compensation.lut import read_lut

    monkeypatch.setattr(linsense.limits, "MAX_TEXT_FILE_BYTES", 1000)
    f = tmp_path / "l.json"
    f.write_text('{"format": "linsense-lut", "theta": [' + ", ".join(["0.0"] * 400) + "]}")
    with pytest.raises(InputError, match="larger than the limit of 1,000 bytes"):
        read_lut(f)


# ---------------------------------------------------------------------- measured tables
def _measured_text() -> str:
    from linsense.compensation.lut import build_lut
    from linsense.compensation.measured import measured_table_json, table_stamp
    from linsense.model.motor import load_motor

    m = load_motor("ecce2010")
    return measured_table_json(build_lut(m, 16, f_inj=1000.0, quad=0.9).values,
                               table_stamp(m, "pulsating", 1000.0, 0.9, 16))


def _nan_row(t: str) -> str:
    import json

    doc = json.loads(t)
    doc["psi_lut"][12] = float("nan")
    return json.dumps(doc)  # (Python's json writes NaN, which is not JSON: read, then refused)


# name: (function of a valid table's text -> hostile text or bytes, words of the one line)
MEASURED = {
    "an empty file": (lambda t: "", ["lut.json", "empty file"]),
    "blanks only": (lambda t: " \n\t\n", ["lut.json", "empty file"]),
    "not UTF-8": (lambda t: b"\xff\xfe{" + t.encode(), ["lut.json", "cannot read"]),
    "cut short": (lambda t: t[: len(t) // 2], ["lut.json", "not JSON"]),
    "nested 100000 deep": (lambda t: "[" * 100_000 + "]" * 100_000, ["lut.json", "not JSON"]),
    "a JSON string": (lambda t: '"lut"', ["lut.json", "a JSON str"]),
    "a NaN": (_nan_row, ["lut.json", "psi_lut[12]", "not finite"]),
    "an integer of 400 digits": (lambda t: t.replace('"psi_lut": [', '"psi_lut": [1' + "0" * 400 + ",", 1),
                                 ["lut.json", "psi_lut[0]", "not finite"]),
    "a 100 kB key": (lambda t: t.replace('"format"', '"' + "k" * 100_000 + '": 1, "format"', 1),
                     ["lut.json", "not a key of a measured table"]),
    "the CSV": (lambda t: "theta_deg,psi_lut_deg\n0,1\n90,1\n180,1\n270,1\n", ["lut.json", "CSV"]),
}


@pytest.mark.parametrize("case", list(MEASURED))
def test_hostile_measured_table_through_the_simulator(run_cli, tmp_path, case):
    """A scenario's observer.lut_file: one line naming the scenario, its key, the table file and
    the table's key or row; nothing written."""
    make, words = MEASURED[case]
    data = make(_measured_text())
    f = tmp_path / "lut.json"
    f.write_bytes(data if isinstance(data, bytes) else data.encode())
    s = tmp_path / "s.toml"
    s.write_text('motor = "ecce2010"\n[scenario]\nduration = 0.05\n[reference]\ntype = "hold"\n'
                 '[observer]\nlut_model = "measured"\nlut_file = "lut.json"\n')
    out = tmp_path / "o"
    line = run_cli("simulate", s, "--out", out).refused("s.toml", "observer.lut_file", *words)
    assert len(line) < 1500 and not out.exists()


def test_a_measured_table_with_a_byte_order_mark_is_read(tmp_path):
    from linsense.compensation.measured import read_measured_table
    from linsense.model.motor import load_motor

    f = tmp_path / "lut.json"
    f.write_bytes(b"\xef\xbb\xbf" + _measured_text().encode())
    t = read_measured_table(f, motor=load_motor("ecce2010"), injection="pulsating", f_inj=1000.0, quad=0.9,
                            points=16)
    assert t.values.size == 16


def test_a_measured_table_beyond_the_size_limit(tmp_path, monkeypatch):
    from linsense.compensation.measured import read_measured_table
    from linsense.model.motor import load_motor

    monkeypatch.setattr(linsense.limits, "MAX_TEXT_FILE_BYTES", 500)
    f = tmp_path / "lut.json"
    f.write_text(_measured_text())
    with pytest.raises(InputError, match="larger than the limit of 500 bytes"):
        read_measured_table(f, motor=load_motor("ecce2010"), injection="pulsating", f_inj=1000.0, quad=0.9,
                            points=16)

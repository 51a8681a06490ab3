"""Atomic output: temporary file + rename; special targets written in place, never replaced."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

import pytest

from linsense.io import write_atomic, write_atomic_with


def test_atomic_write_and_failure(tmp_path):
    p = tmp_path / "sub" / "f.txt"
    write_atomic(p, "hello\n")
    assert p.read_text() == "hello\n"

    def boom(f):
        f.write(b"half")
        raise RuntimeError("fail")

    with pytest.raises(RuntimeError):
        write_atomic_with(p, boom)
    assert p.read_text() == "hello\n"
    assert sorted(x.name for x in p.parent.iterdir()) == ["f.txt"]


def test_special_files_are_not_replaced(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    r = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        write_atomic(fifo, "x\n")
        assert os.read(r, 10) == b"x\n"
    finally:
        os.close(r)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    write_atomic(os.devnull, "discarded")
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)


def test_dash_is_stdout(capfdbinary):
    assert write_atomic("-", "to stdout\n") == Path("-")
    assert capfdbinary.readouterr().out == b"to stdout\n"


# ------------------------------------------------------------------ tables and outputs
def test_read_csv_table_reads_spreadsheet_exports(tmp_path):
    """A BOM, CRLF, empty lines and other columns are read; each row keeps its line number."""
    from linsense.io import read_csv_table

    p = tmp_path / "t.csv"
    p.write_bytes("\ufeffb,a,extra\r\n1,2,x\r\n\r\n3,4.5e-3,y\r\n\r\n".encode())
    data, line = read_csv_table(p, ("a", "b"), "table")
    assert data.tolist() == [[2.0, 1.0], [4.5e-3, 3.0]] and line.tolist() == [2, 4]


@pytest.mark.parametrize("text, words", [
    ("a,b\n1,2\n3,4\n5,6\n", ["more than 2 rows", "limit of 2 rows"]),
    ("a,b,c,d\n1,2,3,4\n", ["row 1", "4 columns", "limit of 3 columns"]),
    ("a,b\n1,123456\n", ["row 2, column 2", "field larger than field limit of 5", "6 characters"]),
    ("a,b\n1," + "9" * 10_000 + "\n", ["row 2", "field larger than field limit of 5"]),
    ("a,b\n1,\"2,5\"\n", ["row 2, column b", "decimal commas are not read: use a point", "'2,5'"]),
    ("a;b\n1,5;2,5\n", ["row 1", "semicolon separators are not read"]),
    ("a,b\n1,5,2\n", ["row 2", "3 fields for the header's 2 columns", "decimal commas are not read"]),
])
def test_read_csv_table_refuses_by_name(tmp_path, monkeypatch, text, words):
    from linsense import limits
    from linsense.errors import InputError
    from linsense.io import read_csv_table

    monkeypatch.setattr(limits, "MAX_TABLE_ROWS", 2)
    monkeypatch.setattr(limits, "MAX_TABLE_COLUMNS", 3)
    monkeypatch.setattr(limits, "MAX_TABLE_FIELD_CHARS", 5)
    p = tmp_path / "t.csv"
    p.write_text(text)
    with pytest.raises(InputError) as exc:
        read_csv_table(p, ("a", "b"), "table")
    assert str(exc.value).startswith(str(p))
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))


@pytest.mark.parametrize("err, words", [(errno.ENOSPC, "no space left on the device"),
                                        (errno.EROFS, "read-only file system"),
                                        (errno.EDQUOT, "disk quota exceeded")])
def test_write_atomic_names_the_path_and_the_reason(tmp_path, monkeypatch, err, words):
    """An OSError while writing: OutputError naming the user's path and the reason in words; the
    previous file is kept and no temporary file is left."""
    from linsense.errors import OutputError

    p = tmp_path / "f.txt"
    p.write_text("old\n")

    def fail(fd):
        raise OSError(err, os.strerror(err))

    monkeypatch.setattr(os, "fsync", fail)
    with pytest.raises(OutputError) as exc:
        write_atomic(p, "new\n")
    assert str(exc.value) == f"{p}: cannot write: {words}"
    assert p.read_text() == "old\n" and os.listdir(tmp_path) == ["f.txt"]


def test_a_file_of_an_output_set_is_named_in_its_out_folder(tmp_path, monkeypatch):
    from linsense.errors import OutputError
    from linsense.io import output_set

    out = tmp_path / "out"

    def fail(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OutputError) as exc:
        with output_set(out, "test") as s:
            s.write("a.txt", "a\n")
            monkeypatch.setattr(os, "fsync", fail)
            s.write("sub/b.txt", "b\n")
    assert str(exc.value) == f"{out / 'sub' / 'b.txt'}: cannot write: no space left on the device"
    assert os.listdir(tmp_path) == []


def test_a_read_only_folder_is_named(tmp_path):
    from linsense.errors import OutputError

    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("chmod does not make a folder read-only here (running as root)")
        with pytest.raises(OutputError) as exc:
            write_atomic(ro / "f.txt", "x")
        assert str(exc.value) == f"{ro / 'f.txt'}: cannot write: permission denied: its folder is read-only"
    finally:
        ro.chmod(0o755)


def test_an_input_error_inside_an_output_set_is_not_an_output_error(tmp_path):
    """(only the output's own OSErrors are turned into OutputError)"""
    from linsense.io import output_set

    with pytest.raises(FileNotFoundError):
        with output_set(tmp_path / "w" / "out", "test"):
            open(tmp_path / "elsewhere" / "missing.csv")

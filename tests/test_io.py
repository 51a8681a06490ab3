"""Atomic output: temporary file + rename; special targets written in place, never replaced."""

from __future__ import annotations

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

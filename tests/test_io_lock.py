"""The output lock and the liveness probe of :mod:`linsense.io`, portable.

Two real processes contend for one output folder, with each lock backend: ``flock`` on the folder
(POSIX) and :mod:`filelock`'s lock file (what Windows runs, forced here with
``_Locked.use_flock = False``): the second waits until the first lets go, then writes its set. The
liveness probe (psutil) tells a finished process from a running one.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest

from linsense import io
from linsense.io import MANIFEST, _alive, _Locked, _locked, output_set

#: a process that takes the lock on argv[1] (the backend argv[2]), says so, and keeps it until its
#: stdin closes
HOLDER = """
import sys
from pathlib import Path
from linsense.io import _Locked, _locked
_Locked.use_flock = sys.argv[2] == "flock"
with _locked(Path(sys.argv[1])):
    print("locked", flush=True)
    sys.stdin.read()
"""

BACKENDS = ["flock", "filelock"]


@pytest.fixture(params=BACKENDS)
def backend(request, monkeypatch):
    if request.param == "flock":
        pytest.importorskip("fcntl")
    monkeypatch.setattr(_Locked, "use_flock", request.param == "flock")
    return request.param


def hold(folder, backend: str) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, "-c", HOLDER, str(folder), backend], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "locked"
    return p


def in_thread(fn) -> tuple[threading.Thread, threading.Event, list]:
    done, errors = threading.Event(), []

    def run():
        try:
            fn()
        except BaseException as exc:  # (reported by the test)
            errors.append(exc)
        done.set()

    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t, done, errors


def test_a_second_process_waits_for_the_lock(tmp_path, backend):
    holder = hold(tmp_path, backend)
    try:
        def take():
            with _locked(tmp_path):
                pass

        _, done, errors = in_thread(take)
        assert not done.wait(0.7), f"took the lock ({backend}) another process holds"
        holder.stdin.close()
        assert holder.wait(30) == 0
        assert done.wait(30) and not errors, errors
    finally:
        holder.kill()
        holder.wait()


def test_an_output_set_waits_while_another_process_swaps(tmp_path, backend):
    """A run that finds the parent folder locked (another run swapping its set in) waits, starts
    nothing meanwhile (no temporary sibling), then writes its set."""
    out = tmp_path / "out"
    holder = hold(tmp_path, backend)
    try:
        def write():
            with output_set(out, "test") as s:
                s.write("a.txt", "a\n")

        _, done, errors = in_thread(write)
        assert not done.wait(0.7), "wrote an output set while another process held the lock"
        assert not [p for p in tmp_path.iterdir() if ".tmp-" in p.name]
        holder.stdin.close()
        assert holder.wait(30) == 0
        assert done.wait(30) and not errors, errors
    finally:
        holder.kill()
        holder.wait()
    assert (out / "a.txt").read_text() == "a\n" and (out / MANIFEST).is_file()


def test_the_flock_backend_leaves_no_lock_file(tmp_path):
    pytest.importorskip("fcntl")
    with output_set(tmp_path / "out", "test") as s:
        s.write("a.txt", "a\n")
    assert [p.name for p in tmp_path.iterdir()] == ["out"]
    assert not (tmp_path / "out" / io.LOCK_FILE).exists()


def test_liveness():
    assert _alive(subprocess.os.getpid())
    live = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)
    try:
        assert _alive(live.pid)
    finally:
        live.stdin.close()
        live.wait()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True).stdout.strip()
    time.sleep(0.05)
    assert not _alive(int(dead)), "a finished (reaped) process taken for alive"
    assert not _alive(live.pid)
    assert not _alive(2**40) and not _alive(10**30)  # (no process has such a number)

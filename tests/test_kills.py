"""Output sets: every multi-file command replaces its --out folder as a whole.

Real CLI processes are killed (SIGKILL, through the ``LINSENSE_TEST_KILL_AT`` hook of
:func:`linsense.io.output_set`) at every stage of a run; the folder then holds the complete old
set, the complete new one, or is recovered to the old one by the next run, which also removes the
debris. Write failures half-way leave the old set and exit 2 with one line. User-controlled names
never leave --out. Identical runs write identical bytes (``timing.json`` apart).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from linsense.io import FAIL_ENV, KILL_ENV, MANIFEST, STAGES, recover, safe_name
from test_cli import BASE

SCENARIO = ('motor = "ecce2010"\n[scenario]\nname = "k"\nduration = 0.05\n'
            '[reference]\nposition_mm = {x}\nat = 0.01\n[record]\ndecimate = 8\n')



def snapshot(folder: Path, skip: tuple[str, ...] = ()) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones included) -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name not in skip}


def debris(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if ".tmp-" in p.name or ".old-" in p.name)


def run_proc(*args, env: dict | None = None) -> subprocess.CompletedProcess:
    e = dict(os.environ, PYTHONWARNINGS="ignore", **(env or {}))
    return subprocess.run([sys.executable, "-m", "linsense", *map(str, args)], capture_output=True,
                          text=True, env=e, timeout=120)


@pytest.fixture
def sets(tmp_path, run_cli):
    """An old simulate set in ``out`` (with a user's file beside it) and the new set's reference."""
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text(SCENARIO.format(x=1.0))
    b.write_text(SCENARIO.format(x=2.0))
    out = tmp_path / "w" / "out"
    assert run_cli("simulate", a, "--out", out, "--no-plot").code == 0
    (out / "notes.txt").write_text("the user's own file\n")
    old = snapshot(out)
    new_args = ("simulate", b, "--out", out, "--no-plot", "--mat")
    ref = tmp_path / "ref"
    assert run_cli("simulate", b, "--out", ref, "--no-plot", "--mat").code == 0
    new = snapshot(ref, skip=("timing.json",)) | {"notes.txt": old["notes.txt"]}
    return out, old, new, new_args


@pytest.mark.parametrize("stage", STAGES)
def test_sigkill_at_every_stage(sets, run_cli, monkeypatch, stage):
    out, old, new, args = sets
    p = run_proc(*args, env={KILL_ENV: stage})
    assert p.returncode == -signal.SIGKILL, p.stderr
    left = debris(out.parent)
    assert left, "a killed run leaves its temporaries (SIGKILL cannot clean up)"
    if stage == "after-swap":  # the new set is in place; the old one is garbage
        assert snapshot(out, skip=("timing.json",)) == new
    elif stage in ("carry", "mid-swap"):  # between the two renames: the old set is recoverable
        assert not out.exists() and any(".old-" in n for n in left)
    else:
        assert snapshot(out) == old
    # the next run (here one failing before its swap) recovers and cleans, then leaves that state
    monkeypatch.setenv(FAIL_ENV, "first-file")
    r = run_cli(*args)
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1 and "injected" in r.err, r.err
    assert debris(out.parent) == []
    if stage == "after-swap":
        assert snapshot(out, skip=("timing.json",)) == new
    else:
        assert snapshot(out) == old
    monkeypatch.delenv(FAIL_ENV)
    assert run_cli(*args).code == 0
    assert snapshot(out, skip=("timing.json",)) == new and debris(out.parent) == []


@pytest.mark.parametrize("stage", ["first-file", "before-swap", "carry", "mid-swap"])
def test_failure_half_way_leaves_the_old_set(sets, run_cli, monkeypatch, stage):
    """An OSError at any stage before the swap completes: exit 2, one line, the old set as it was."""
    out, old, _, args = sets
    monkeypatch.setenv(FAIL_ENV, stage)
    r = run_cli(*args)
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1 and "Traceback" not in r.err
    assert str(out) in r.err, r.err
    assert snapshot(out) == old and debris(out.parent) == []


COMMANDS = {
    "plot": lambda t: ("plot", "--motor", "ecce2010", "--points", 8),
    "reproduce": lambda t: ("reproduce", "--model-only"),
    "identify": lambda t: ("identify", t / "bench.csv", "--motor", "ecce2010", "--points", 8),
    "calibrate": lambda t: ("calibrate", "--motor", "ecce2010", "--positions", 8, "--fidelity", "average"),
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_set_command_is_atomic(tmp_path, run_cli, command):
    """Every other multi-file command, killed between the two renames of its swap: the old set comes
    back whole (recover), with nothing left beside it."""
    if command == "identify":
        assert run_cli("bench-emulate", "--motor", "ecce2010", "--positions", 16, "--out",
                       tmp_path / "bench.csv").code == 0
    out = tmp_path / "w" / "out"
    out.mkdir(parents=True)
    (out / "a.txt").write_text("old\n")
    (out / MANIFEST).write_text(json.dumps({"command": "x", "files": ["a.txt"]}))
    old = snapshot(out)
    p = run_proc(*COMMANDS[command](tmp_path), "--out", out, env={KILL_ENV: "mid-swap"})
    assert p.returncode == -signal.SIGKILL, p.stderr
    assert not out.exists() and len(debris(out.parent)) == 2
    recover(out)
    assert snapshot(out) == old and debris(out.parent) == []


# ------------------------------------------------------------------ the --out rule
def test_out_rule(tmp_path, run_cli, sets):
    out, old, new, args = sets
    # a folder no linsense run wrote: refused, untouched
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("x")
    r = run_cli(*args[:2], "--out", mine)
    assert r.code == 2 and "no .linsense-set.json" in r.err and len(r.err.strip().splitlines()) == 1
    assert [p.name for p in mine.iterdir()] == ["thesis.tex"]
    # an empty folder is fine
    empty = tmp_path / "empty"
    empty.mkdir()
    assert run_cli(*args[:2], "--out", empty, "--no-plot").code == 0
    # a user's file inside an entry the set owns: refused before running
    (out / "trace.parquet").unlink()
    (out / "trace.parquet").mkdir()  # a folder where a file of the set goes
    (out / "trace.parquet" / "keep.me").write_text("x")
    before = snapshot(out)
    r = run_cli(*args)
    assert r.code == 2 and "trace.parquet/keep.me" in r.err and len(r.err.strip().splitlines()) == 1
    assert snapshot(out) == before and debris(out.parent) == []


def test_foreign_entry_where_a_new_file_goes(sets, run_cli):
    """The previous set had no sim.png; the user made a folder of that name: found at the swap,
    after the run (half-way), refused with exit 2; the old set and the user's folder intact."""
    out, old, _, args = sets
    (out / "sim.png").mkdir()
    (out / "sim.png" / "x").write_text("x")
    before = snapshot(out)
    r = run_cli(*args[:4], "--plot")
    assert r.code == 2 and "sim.png" in r.err and len(r.err.strip().splitlines()) == 1
    assert snapshot(out) == before and debris(out.parent) == []


def test_debris_of_live_and_dead_runs(sets, run_cli):
    out, old, new, args = sets
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    live = out.parent / f".out.tmp-{os.getpid()}-0123abcd"  # this process: alive
    stale = out.parent / f".out.tmp-{dead}-89abcdef"
    for d in (live, stale):
        d.mkdir()
        (d / "half.csv").write_text("1,2")
    assert run_cli(*args).code == 0
    assert debris(out.parent) == [live.name]


# ------------------------------------------------------------------ names in file names
HOSTILE = ["x/../../../escaped", "/etc/passwd", "", "a" * 300, "moteur é ∆ 电机", "nul\x00byte", "..", "-rf"]


@pytest.mark.parametrize("name", HOSTILE)
def test_safe_name(name):
    s = safe_name(name)
    assert 0 < len(s) <= 64 and s == Path(s).name and s not in (".", "..")
    assert all(c.isascii() and (c.isalnum() or c in "_-") for c in s) and not s.startswith("-")
    assert safe_name(name) == s  # deterministic
    assert safe_name("a" * 300) != safe_name("a" * 299 + "b")  # long names stay distinct


@pytest.mark.parametrize("toml_name", ['"x/../../../escaped"', '"/abs/é' + "n" * 300 + '\\u0000/.."'])
def test_reproduce_keeps_hostile_motor_names_inside_out(tmp_path, run_cli, toml_name):
    """A motor name is the only user-controlled part of a file name (``ls_lut_<name>.h``)."""
    f = tmp_path / "m.toml"
    f.write_text(BASE.replace('name = "m1"', f"name = {toml_name}"))
    out = tmp_path / "a" / "b" / "out"
    r = run_cli("reproduce", "--model-only", "--motor", f, "--out", out)
    if r.code == 2:  # a motor file may refuse such a name: then one line and nothing written
        assert "motor.name" in r.err and len(r.err.strip().splitlines()) == 1
        assert [p for p in tmp_path.rglob("*")] == [f]
        return
    assert r.code == 0, r.err
    inside = {p for p in tmp_path.rglob("*") if p.is_file()} - {f}
    assert inside and all(out in p.parents for p in inside), inside
    headers = [p.name for p in out.glob("ls_lut_*.h")]
    assert len(headers) == 1 and len(headers[0]) <= 64 + 9


# ------------------------------------------------------------------ byte-reproducible runs
@pytest.mark.slow
def test_identical_runs_write_identical_bytes(tmp_path, run_cli):
    """simulate (--mat, with the figure), calibrate and identify twice: every file identical,
    PNG and .mat included; only timing.json (wall-clock) differs."""
    sc = tmp_path / "s.toml"
    sc.write_text(SCENARIO.format(x=2.0))
    bench = tmp_path / "bench.csv"
    assert run_cli("bench-emulate", "--motor", "ecce2010", "--positions", 16, "--noise", 0.01,
                   "--out", bench).code == 0
    runs = {
        "simulate": ("simulate", sc, "--mat", "--plot"),
        "calibrate": ("calibrate", "--motor", "ecce2010", "--positions", 8, "--fidelity", "average"),
        "identify": ("identify", bench, "--motor", "ecce2010", "--points", 8),
    }
    for name, args in runs.items():
        snaps = []
        for k in (1, 2):
            assert run_cli(*args, "--out", tmp_path / f"{name}{k}").code == 0
            snaps.append(snapshot(tmp_path / f"{name}{k}", skip=("timing.json",)))
        assert snaps[0] == snaps[1], name
        assert any(n.endswith(".png") for n in snaps[0]) and MANIFEST in snaps[0]
    assert "trace.mat" in snaps[0] or (tmp_path / "simulate1" / "trace.mat").is_file()
    assert b"Created on" not in (tmp_path / "simulate1" / "trace.mat").read_bytes()[:116]
    assert set(json.loads((tmp_path / "simulate1" / "timing.json").read_text())) == {
        "sim_s", "wall_s", "realtime_factor"}


def test_nested_sets_survive_the_outer_run(tmp_path, run_cli):
    """As make demo: a set inside another one's folder (out/sim/x in out) is the user's entry for
    the outer set: carried over when the outer set is replaced."""
    sc = tmp_path / "s.toml"
    sc.write_text(SCENARIO.format(x=1.0))
    out = tmp_path / "out"
    cal = ("calibrate", "--motor", "ecce2010", "--positions", 8, "--fidelity", "average", "--out", out)
    assert run_cli(*cal).code == 0
    assert run_cli("simulate", sc, "--out", out / "sim" / "x", "--no-plot").code == 0
    inner = snapshot(out / "sim")
    assert run_cli(*cal).code == 0
    assert snapshot(out / "sim") == inner and (out / "lut_measured.csv").is_file()
    assert not [f for f in json.loads((out / MANIFEST).read_text())["files"] if f.startswith("sim/")]

"""A sweep's record of what its rows depend on (docs/sweeps.md, "What a
sweep depends on"): ``DIR/sweep.json`` holds the SHA-256 of the sweep file, the base scenario, its
motor files and their tables, and the code; a resume or a reuse of the folder with anything changed
is refused naming it, ``--restart`` starts over, and unchanged inputs give the same bytes.

Before the fix a killed sweep resumed after an edit of its base exited 0 with rows of both bases in
one table, and a finished sweep rerun after an edit returned the old rows.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from linsense.errors import InputError
from linsense.sweep import engine as engine_mod
from linsense.sweep import load_sweep, sweep

ROOT = Path(__file__).resolve().parents[1]
BASE = """motor = "m.toml"
[scenario]
duration = 0.1
seed = 1
[reference]
type = "step"
position_mm = {x}
at = 0.02
[observer]
type = "pll"
"""
AXES = """[[axis]]
key = "observer.bandwidth_hz"
values = [30.0, 40.0, 50.0, 60.0]
"""


@pytest.fixture
def d(tmp_path) -> Path:
    """A sweep of 4 runs in batches of 1 over a base scenario with its own motor file."""
    shutil.copy(ROOT / "src" / "linsense" / "model" / "presets" / "ecce2010.toml", tmp_path / "m.toml")
    (tmp_path / "base.toml").write_text(BASE.format(x=2.0))
    (tmp_path / "sweep.toml").write_text(f'[sweep]\nname = "t"\nscenario = "base.toml"\nbatch = 1\n{AXES}')
    return tmp_path


def cli(*args, env=None) -> subprocess.CompletedProcess:
    e = dict(os.environ, PYTHONWARNINGS="ignore", **(env or {}))
    return subprocess.run([sys.executable, "-m", "linsense", "sweep", *map(str, args), "--workers", "1",
                           "--no-progress"], capture_output=True, text=True, env=e, timeout=180)


def parts(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "parts").glob("part-*.parquet"))}


@pytest.mark.slow
def test_killed_then_edited_base_is_refused_and_restart_gives_the_new_rows_only(d):
    out = d / "out"
    r = cli(d / "sweep.toml", "--out", out, env={"LINSENSE_TEST_KILL_AFTER_PARTS": "1"})
    assert r.returncode == -signal.SIGKILL, r.stderr
    before = parts(out)
    assert 1 <= len(before) < 4
    (d / "base.toml").write_text(BASE.format(x=3.0))
    r = cli(d / "sweep.toml", "--out", out)
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip()
    assert len(line.splitlines()) == 1 and line.startswith("linsense: error: --out: ")
    for w in (str(out), "base scenario", "base.toml", "changed since it started", "sha256", "--restart"):
        assert w in line, (w, line)
    assert parts(out) == before and not (out / "results.parquet").exists()  # nothing run, nothing mixed
    r = cli(d / "sweep.toml", "--out", out, "--restart")
    assert r.returncode == 0, r.stderr
    assert cli(d / "sweep.toml", "--out", d / "fresh").returncode == 0
    assert (out / "results.parquet").read_bytes() == (d / "fresh" / "results.parquet").read_bytes()
    assert parts(out) == parts(d / "fresh")  # every partition of the new base: none of the old is left


@pytest.mark.slow
def test_killed_and_resumed_unchanged_gives_the_same_bytes(d):
    out = d / "out"
    r = cli(d / "sweep.toml", "--out", out, env={"LINSENSE_TEST_KILL_AFTER_PARTS": "2"})
    assert r.returncode == -signal.SIGKILL, r.stderr
    kept = parts(out)
    assert cli(d / "sweep.toml", "--out", out).returncode == 0
    assert cli(d / "sweep.toml", "--out", d / "fresh").returncode == 0
    assert (out / "results.parquet").read_bytes() == (d / "fresh" / "results.parquet").read_bytes()
    assert {k: v for k, v in parts(out).items() if k in kept} == kept  # not redone


def test_finished_unchanged_is_reused_without_running(d, monkeypatch):
    out = d / "out"
    first = sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "parts").iterdir()}

    def no_run(*a, **k):
        raise AssertionError("a finished sweep of the same inputs ran again")

    monkeypatch.setattr(engine_mod, "run_batch", no_run)  # (the worker threads' and a cluster's task)
    monkeypatch.setattr(engine_mod, "cluster_client", no_run)
    again = sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    pd.testing.assert_frame_equal(first, again)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "parts").iterdir()} == stamps


def test_finished_then_edited_motor_is_refused(d):
    out = d / "out"
    sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    text = (d / "m.toml").read_text()
    assert "mass = 1.5" in text
    (d / "m.toml").write_text(text.replace("mass = 1.5", "mass = 2.5"))
    with pytest.raises(InputError, match=r"motor file .*m\.toml \(sha256 [0-9a-f]{12} -> [0-9a-f]{12}\)"):
        sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    df = sweep(load_sweep(d / "sweep.toml"), out, workers=1, restart=True)
    assert list(df["run"]) == [0, 1, 2, 3]


def test_an_edit_while_the_sweep_runs_keeps_only_the_rows_before_it(d, monkeypatch):
    """The runs read the motor file while the sweep runs: rows finished after an edit are not kept
    (they may be of either file), the sweep stops naming the file, and it cannot be resumed."""
    out = d / "out"
    write = engine_mod._write_partition
    n = {"written": 0}

    def write_then_edit(parts_dir, b, rows):
        path = write(parts_dir, b, rows)
        n["written"] += 1
        if n["written"] == 1:
            (d / "m.toml").write_text((d / "m.toml").read_text() + "\n# edited while running\n")
        return path

    monkeypatch.setattr(engine_mod, "_write_partition", write_then_edit)
    with pytest.raises(InputError, match=r"changed while it ran: motor file .*m\.toml"):
        sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    assert len(parts(out)) == 1
    with pytest.raises(InputError, match="changed since it started"):
        sweep(load_sweep(d / "sweep.toml"), out, workers=1)


def test_the_record_covers_motors_tables_and_the_controllers_motor(tmp_path):
    """sweep_inputs: the sweep file, the base, the plant's motor file and its tables (inductance and
    saturation, relative to the motor file), the controller's motor from the scenario, from ``set``
    and from an axis's values, a preset by its text; a missing file as absent."""
    from linsense.sweep.inputs import sweep_inputs

    sat = ROOT / "src/linsense/examples" / "motors" / "tubular56_thin_sat"
    shutil.copytree(sat, tmp_path / "sat")
    (tmp_path / "base.toml").write_text('motor = "sat/motor.toml"\n[scenario]\nduration = 0.1\n'
                                        '[controller.model]\nmotor = "ecce2010"\n')
    (tmp_path / "s.toml").write_text(
        '[sweep]\nscenario = "base.toml"\nset = { "controller.model.motor" = "c1.toml" }\n'
        '[[axis]]\nkey = "controller.model.motor"\nvalues = ["c2.toml", "sat/motor.toml"]\n')
    (tmp_path / "c1.toml").write_text("[motor]\n")
    rec = sweep_inputs(load_sweep(tmp_path / "s.toml"))
    got = [(e["what"], Path(e["path"]).name) for e in rec]
    assert got == [
        ("sweep file", "s.toml"), ("base scenario", "base.toml"), ("motor file", "motor.toml"),
        ("inductance table", "inductances_0A.csv"),
        *[("saturation table", f"inductances_{c}A.csv") for c in ("0.5", "1", "1.5", "2")],
        ("motor preset", "ecce2010"), ("controller's motor file", "c1.toml"),
        ("controller's motor file", "c2.toml")]
    assert rec[-1]["sha256"] == "absent" and all(len(e["sha256"]) == 64 for e in rec[:-1])
    json.dumps(rec)  # (what sweep.json stores)


def test_the_record_covers_the_measured_table(tmp_path):
    """observer.lut_file of the base scenario, of ``set`` and of an axis, relative to the scenario
    (a resume after the table was measured again would mix rows of two tables)."""
    from linsense.sweep.inputs import sweep_inputs

    (tmp_path / "base.toml").write_text('motor = "ecce2010"\n[scenario]\nduration = 0.1\n'
                                        '[observer]\nlut_model = "measured"\nlut_file = "a.json"\n')
    (tmp_path / "s.toml").write_text(
        '[sweep]\nscenario = "base.toml"\nset = { "observer.lut_file" = "b.json" }\n'
        '[[axis]]\nkey = "observer.lut_file"\nvalues = ["c.json", "a.json"]\n')
    (tmp_path / "a.json").write_text("{}")
    rec = sweep_inputs(load_sweep(tmp_path / "s.toml"))
    got = [(e["what"], Path(e["path"]).name, e["sha256"] == "absent") for e in rec[3:]]
    assert got == [("measured table", "a.json", False), ("measured table", "b.json", True),
                   ("measured table", "c.json", True)]


def test_a_motor_axis_on_a_saturated_motor_finds_its_tables(tmp_path):
    """An edited copy of a motor with [saturation] tables (written under DIR/motors/) reads them
    where the motor file is (every run was refused: 'no such table file DIR/motors/...')."""
    shutil.copytree(ROOT / "src/linsense/examples" / "motors" / "tubular56_thin_sat", tmp_path / "sat")
    (tmp_path / "base.toml").write_text('motor = "sat/motor.toml"\n[scenario]\nduration = 0.05\n'
                                        '[reference]\ntype = "hold"\n')
    (tmp_path / "s.toml").write_text('[sweep]\nscenario = "base.toml"\n'
                                     '[[axis]]\nkey = "motor.motor.mass"\nvalues = [1.5, 2.0]\n')
    df = sweep(load_sweep(tmp_path / "s.toml"), tmp_path / "out", workers=1)
    assert df["error"].isna().all(), df["error"].tolist()


def test_a_folder_of_an_older_linsense_is_refused_then_restarted(d):
    out = d / "out"
    sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    m = json.loads((out / "sweep.json").read_text())
    (out / "sweep.json").write_text(json.dumps({k: v for k, v in m.items()
                                                if k not in ("inputs", "code", "digest")}))
    with pytest.raises(InputError, match="records no digest of its inputs"):
        sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    sweep(load_sweep(d / "sweep.toml"), out, workers=1, restart=True)
    assert json.loads((out / "sweep.json").read_text())["digest"] == m["digest"]


def test_a_killed_restart_leaves_a_consistent_folder(d, monkeypatch):
    """--restart killed after setting the old rows aside: the old manifest and no rows (never
    rows of both), and the next run deletes what was set aside."""
    out = d / "out"
    sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    old_manifest = (out / "sweep.json").read_bytes()
    (d / "base.toml").write_text(BASE.format(x=3.0))

    def killed(path):
        raise KeyboardInterrupt  # (as a kill in shutil.rmtree would leave it)

    monkeypatch.setattr(engine_mod.shutil, "rmtree", killed)
    with pytest.raises(KeyboardInterrupt):
        sweep(load_sweep(d / "sweep.toml"), out, workers=1, restart=True)
    monkeypatch.undo()
    assert (out / "sweep.json").read_bytes() == old_manifest and not (out / "parts").exists()
    assert [p.name for p in out.iterdir() if ".discarded-" in p.name]
    with pytest.raises(InputError, match="base scenario"):
        sweep(load_sweep(d / "sweep.toml"), out, workers=1)
    df = sweep(load_sweep(d / "sweep.toml"), out, workers=1, restart=True)
    assert len(df) == 4 and not [p for p in out.iterdir() if ".discarded-" in p.name]

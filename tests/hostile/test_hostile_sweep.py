"""Hostile sweep folders: a sweep folder reused after something its
rows depend on changed (the sweep file, the base scenario, its motor file or the motor's table, the
linsense version, the C library), a manifest that is corrupt or edited, an --out that is not a
sweep's folder. Each is refused with exit 2 and one line naming the folder and what changed, and the
folder is left byte for byte as it was; `--restart` starts over with the new inputs' rows only.

Before the fix, every edit case exited 0 and returned the old rows (a finished sweep) or mixed old
and new rows in one table (a partial one).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
BASE = """motor = "m.toml"
[scenario]
duration = 0.06
seed = 1
[reference]
type = "step"
position_mm = 2.0
at = 0.01
"""
SWEEP = """[sweep]
name = "h"
scenario = "base.toml"
batch = 1
[[axis]]
key = "observer.bandwidth_hz"
values = [30.0, 50.0]
"""


def snapshot(folder: Path) -> dict[str, bytes | None]:
    """Every entry under ``folder`` (hidden ones included) -> its bytes (None for a folder)."""
    if folder.is_file():
        return {".": folder.read_bytes()}
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None)
            for p in sorted(folder.rglob("*"))}


@pytest.fixture
def finished(tmp_path, run_cli):
    """A finished sweep in ``out`` of a base scenario whose motor file reads an inductance table."""
    motor = (ROOT / "src/linsense/examples" / "motors" / "tabulated.toml").read_text()
    (tmp_path / "m.toml").write_text(motor.replace("ecce2010_table.csv", "t.csv"))
    shutil.copy(ROOT / "src/linsense/examples" / "motors" / "ecce2010_table.csv", tmp_path / "t.csv")
    (tmp_path / "base.toml").write_text(BASE)
    (tmp_path / "sweep.toml").write_text(SWEEP)
    r = run_cli("sweep", tmp_path / "sweep.toml", "--out", tmp_path / "out", "--workers", 1, "--no-progress")
    assert r.code == 0, r.err
    return tmp_path


def replace(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, (old, path)
    path.write_text(text.replace(old, new))


def edit_manifest(d: Path, fn) -> None:
    m = d / "out" / "sweep.json"
    m.write_text(json.dumps(fn(json.loads(m.read_text()))))


def older(m: dict) -> dict:
    """The manifest as a linsense before the digest wrote it."""
    return {k: v for k, v in m.items() if k not in ("inputs", "code", "digest")}


def forged(m: dict) -> dict:
    m["inputs"][1]["sha256"] = "0" * 64  # (the base scenario's, its digest left as it was)
    return m


def out_is_a_file(d: Path) -> None:
    shutil.rmtree(d / "out")
    (d / "out").write_text("my notes\n")


def a_strangers_folder(d: Path) -> None:
    shutil.rmtree(d / "out")
    (d / "out").mkdir()
    (d / "out" / "notes.txt").write_text("mine\n")


def parts_is_a_file(d: Path) -> None:
    shutil.rmtree(d / "out" / "parts")
    (d / "out" / "parts").write_text("x")


def manifest_is_a_folder(d: Path) -> None:
    (d / "out" / "sweep.json").unlink()
    (d / "out" / "sweep.json").mkdir()


# name: (edit of the finished sweep's folder, extra arguments, words the one-line message must contain)
CASES = {
    "edited base scenario": (
        lambda d, mp: replace(d / "base.toml", "position_mm = 2.0", "position_mm = 3.0"),
        [], ["--out", "out", "base scenario", "base.toml", "changed", "sha256", "--restart"]),
    "edited motor file": (lambda d, mp: replace(d / "m.toml", "mass = 1.5", "mass = 2.5"),
                          [], ["motor file", "m.toml", "changed", "--restart"]),
    "edited sweep file": (lambda d, mp: replace(d / "sweep.toml", "50.0", "60.0"),
                          [], ["sweep file", "sweep.toml", "changed", "--restart"]),
    "comment added to the base": (
        lambda d, mp: replace(d / "base.toml", "[scenario]", "# edited\n[scenario]"),
        [], ["base scenario", "base.toml"]),
    "edited table file": (lambda d, mp: replace(d / "t.csv", "0.002433,", "0.002434,"),
                          [], ["inductance table", "t.csv", "changed", "--restart"]),
    "table file removed": (lambda d, mp: (d / "t.csv").unlink(),
                           [], ["inductance table", "t.csv", "-> absent"]),
    "motor switched to another file": (
        lambda d, mp: (shutil.copy(d / "m.toml", d / "m2.toml"),
                       replace(d / "base.toml", 'motor = "m.toml"', 'motor = "m2.toml"')),
        [], ["base scenario", "m2.toml", "not an input before", "m.toml", "no longer an input"]),
    "linsense version changed": (lambda d, mp: mp.setattr("linsense.version.__version__", "9.9.9"),
                                 [], ["linsense version", "-> 9.9.9", "--restart"]),
    "C library rebuilt": (lambda d, mp: mp.setattr("linsense.ctrl.built_digest", lambda: "f" * 64),
                          [], ["compiled C library", "ffffffffffff", "--restart"]),
    "corrupt manifest": (lambda d, mp: (d / "out" / "sweep.json").write_text("{ not json"),
                         [], ["out", "sweep.json", "cannot be read", "--restart"]),
    "manifest not a table": (lambda d, mp: (d / "out" / "sweep.json").write_text("[1, 2]"),
                             [], ["sweep.json", "not a table", "list", "--restart"]),
    "digest edited by hand": (lambda d, mp: edit_manifest(d, forged),
                              [], ["digest", "does not match", "--restart"]),
    "manifest of an older linsense": (lambda d, mp: edit_manifest(d, older), [], ["no digest", "--restart"]),
    "out is a file": (lambda d, mp: out_is_a_file(d), [], ["--out", "out", "file"]),
    "out is a file, restart": (lambda d, mp: out_is_a_file(d), ["--restart"], ["--out", "out", "file"]),
    "a stranger's folder, restart": (lambda d, mp: a_strangers_folder(d), ["--restart"],
                                     ["--out", "not a sweep folder"]),
    "parts is a file, restart": (lambda d, mp: parts_is_a_file(d), ["--restart"], ["'parts'", "folder"]),
    "sweep.json is a folder": (lambda d, mp: manifest_is_a_folder(d), [], ["'sweep.json'", "file"]),
    "restart with a broken base": (lambda d, mp: (d / "base.toml").write_text("motor = \n"), ["--restart"],
                                   ["base.toml", "not valid TOML"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_sweep_folder(finished, run_cli, monkeypatch, case):
    edit, extra, words = CASES[case]
    d = finished
    edit(d, monkeypatch)
    before = snapshot(d / "out")
    r = run_cli("sweep", d / "sweep.toml", "--out", d / "out", "--workers", 1, "--no-progress", *extra)
    r.refused(*words)
    assert snapshot(d / "out") == before  # nothing discarded, nothing written


@pytest.mark.parametrize("case", ["edited base scenario", "edited motor file", "edited table file",
                                  "linsense version changed", "corrupt manifest",
                                  "manifest of an older linsense", "parts is a file, restart"])
def test_restart_starts_over_with_the_new_rows_only(finished, run_cli, monkeypatch, case):
    """--restart after the change: exit 0, the rows of a fresh sweep of the present inputs, byte
    for byte (a file in the way of the sweep's own folders is still refused, never deleted)."""
    edit, _, _ = CASES[case]
    d = finished
    edit(d, monkeypatch)
    args = ("--workers", 1, "--no-progress")
    r = run_cli("sweep", d / "sweep.toml", "--out", d / "out", "--restart", *args)
    if case == "parts is a file, restart":
        r.refused("'parts'")
        return
    assert r.code == 0, r.err
    assert run_cli("sweep", d / "sweep.toml", "--out", d / "fresh", *args).code == 0
    assert (d / "out" / "results.parquet").read_bytes() == (d / "fresh" / "results.parquet").read_bytes()
    assert len(list((d / "out" / "parts").glob("*"))) == 2
    assert not [p for p in (d / "out").iterdir() if ".discarded-" in p.name]
    # and the folder is now the new sweep's: the same command reuses it
    assert run_cli("sweep", d / "sweep.toml", "--out", d / "out", *args).code == 0


def test_restart_changes_the_rows(finished, run_cli):
    """The rows after --restart are the edited base's (the final position follows the step)."""
    d = finished
    old = pd.read_parquet(d / "out" / "results.parquet")
    replace(d / "base.toml", "position_mm = 2.0", "position_mm = 3.0")
    r = run_cli("sweep", d / "sweep.toml", "--out", d / "out", "--restart", "--workers", 1, "--no-progress")
    assert r.code == 0, r.err
    new = pd.read_parquet(d / "out" / "results.parquet")
    assert list(new["run"]) == [0, 1]
    assert new["final_position_mm"][0] > old["final_position_mm"][0] + 0.5  # (run 0 moves within 0.06 s)

"""Hostile environments: the environment the commands run in.

Locales, paths with spaces, unicode, quotes and dashes, long names, symbolic links, a working folder
that is read-only or deleted, temporary folders, terminals, encodings, thread and hash-seed
variables, workers, two runs at once, the umask, relative paths. Each case here failed before its
fix; the rule that prevents its kind:

* a path is never normalised by its text (``..`` after a symbolic link is the link's target's
  parent): a file's relative paths are taken from :func:`linsense.io.folder_of` (the folder of the
  file a link points to), and a sweep records its inputs by their real paths;
* every ``--out`` goes through one resolution, :func:`linsense.io.out_target`: a symbolic link is
  followed (a file's as a folder's: the link kept, its target written), a loop refused naming it;
* a temporary name is bounded (a 255-byte ``--out`` is written), and a name derived from ``--out``
  (the certificate's) is checked before the work;
* the working folder is read through :func:`linsense.io.working_folder` (a deleted one refused
  naming it, before the work), and no output set replaces the folder the command runs in;
* a sweep folder is locked while its rows are computed: a second sweep into it is refused at once;
* the report never fails on a character the terminal's encoding lacks (escaped, as standard
  error does); an unusable ``MPLBACKEND`` is named, matplotlib's noise about its settings folder
  is one linsense warning;
* an empty path (an unset shell variable) is refused by the option's callback
  (``linsense.cli._common.not_empty``); a umask that closes the folders a run makes is named in the
  one write error (``linsense.io.output_error``);
* wall-clock times live in ``timing.json`` only (``linsense.io.TIMING_KEYS``, fea.json's too).
"""

from __future__ import annotations

import fcntl
import os
import shlex
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest

import linsense

SRC = Path(linsense.__file__).resolve().parents[1]


def run(args: list, cwd: Path, env: dict | None = None, before: str = "") -> subprocess.CompletedProcess:
    """``linsense ARGS`` in a child shell started in ``cwd``, after the shell commands ``before``."""
    cmd = " ".join(shlex.quote(str(a)) for a in [sys.executable, "-m", "linsense", *args])
    full = {**os.environ, "PYTHONPATH": str(SRC), **(env or {})}
    return subprocess.run(["sh", "-c", f"{before}{cmd}"], cwd=cwd, env=full, capture_output=True, text=True,
                          timeout=600)


def one_line(p: subprocess.CompletedProcess, *words: str) -> str:
    """Exit code 2 and one ``linsense: error:`` line holding every word: no traceback."""
    assert p.returncode == 2, (p.returncode, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("linsense: error: "), p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def short_scenario(motor: str = "ecce2010", duration: float = 0.3) -> str:
    """step3_lut cut short (a run of a few milliseconds), on ``motor``."""
    text = (resources.files("linsense.examples") / "scenarios" / "step3_lut.toml").read_text()
    return (text.replace('motor = "ecce2010"', f'motor = "{motor}"')
            .replace("duration = 2.0", f"duration = {duration}"))


def tree(root: Path) -> Path:
    """``root/real/{motors,scenarios,sweeps}``: a motor file, a scenario naming it relatively and a
    two-point sweep of that scenario; returns ``root/real``."""
    real = root / "real"
    for d in ("motors", "scenarios", "sweeps"):
        (real / d).mkdir(parents=True)
    motor = (resources.files("linsense.examples") / "motors" / "small30.toml").read_text()
    (real / "motors" / "m.toml").write_text(motor)
    (real / "scenarios" / "s.toml").write_text(short_scenario("../motors/m.toml"))
    (real / "sweeps" / "w.toml").write_text(
        '[sweep]\nname = "w"\nscenario = "../scenarios/s.toml"\n\n'
        '[[axis]]\nkey = "injection.amplitude"\nvalues = [6.0, 8.0]\n')
    return real


# ------------------------------------------------------------------ paths: never normalised by text
def test_a_sweep_in_a_linked_folder_records_its_real_inputs(tmp_path):
    """A sweep file in a linked folder (`lk/sweeps -> real/sweeps`) with `scenario = "../..."`: the
    runs read `real/scenarios/s.toml` but sweep.json recorded `lk/scenarios/s.toml` as absent, and
    no motor file: an edited base scenario was resumed into the same rows, exit 0, rows of two
    scenarios mixed."""
    from linsense.sweep import load_sweep
    from linsense.sweep.inputs import sweep_inputs

    real = tree(tmp_path)
    (tmp_path / "lk").mkdir()
    (tmp_path / "lk" / "sweeps").symlink_to(real / "sweeps")
    inputs = {e["what"]: e for e in sweep_inputs(load_sweep(tmp_path / "lk" / "sweeps" / "w.toml"))}
    assert inputs["base scenario"]["path"] == str(real / "scenarios" / "s.toml")
    assert inputs["base scenario"]["sha256"] != "absent"
    assert inputs["motor file"]["path"] == str(real / "motors" / "m.toml")


def test_a_sweep_resumed_through_a_link_is_the_same_sweep(tmp_path):
    """The same files reached through a linked folder were "inputs changed since it started"."""
    real = tree(tmp_path)
    (tmp_path / "lk").symlink_to(real)
    args = ["sweep", "--workers", "1", "--no-progress", "--out", tmp_path / "o"]
    assert run(["sweep", real / "sweeps" / "w.toml", *args[1:]], tmp_path).returncode == 0
    p = run(["sweep", tmp_path / "lk" / "sweeps" / "w.toml", *args[1:]], tmp_path)
    assert p.returncode == 0, p.stderr


def test_a_linked_scenario_file_reads_its_motor_beside_its_target(tmp_path):
    """`ln -s real/scenarios/s.toml .` then `simulate s.toml`: its `motor = "../motors/m.toml"` was
    looked for beside the link ("no such motor file '../motors/m.toml'")."""
    real = tree(tmp_path)
    (tmp_path / "s.toml").symlink_to(real / "scenarios" / "s.toml")
    (tmp_path / "w.toml").symlink_to(real / "sweeps" / "w.toml")
    p = run(["simulate", "s.toml", "--trace", "none", "--out", "o"], tmp_path)
    assert p.returncode == 0, p.stderr
    p = run(["sweep", "w.toml", "--workers", "1", "--no-progress", "--out", "w"], tmp_path)
    assert p.returncode == 0, p.stderr


def test_a_linked_motor_file_reads_its_table_beside_its_target(tmp_path):
    """`ln -s real/tabulated.toml m.toml`: its `table = "ecce2010_table.csv"` was looked for beside
    the link."""
    from linsense.model.motor import load_motor

    (tmp_path / "real").mkdir()
    motors = resources.files("linsense.examples") / "motors"
    for f in ("tabulated.toml", "ecce2010_table.csv"):
        (tmp_path / "real" / f).write_bytes((motors / f).read_bytes())
    (tmp_path / "m.toml").symlink_to(tmp_path / "real" / "tabulated.toml")
    assert load_motor(tmp_path / "m.toml").name == "tabulated_example"


# ------------------------------------------------------------------ --out through symbolic links
def test_a_link_to_a_file_as_out_writes_its_target(run_cli, tmp_path):
    """`model --out link.csv` (a link to a file) replaced the link with a file of its own and left its
    target as it was, where a link to a folder is followed (docs/cli.md)."""
    target = tmp_path / "target.csv"
    target.write_text("old\n")
    (tmp_path / "link.csv").symlink_to(target)
    assert run_cli("model", "--motor", "ecce2010", "--points", "4", "--out", tmp_path / "link.csv").code == 0
    assert (tmp_path / "link.csv").is_symlink()
    assert target.read_text().startswith("theta_deg,")
    # a dangling link: its target is written, as for a folder
    (tmp_path / "dangling.csv").symlink_to(tmp_path / "new.csv")
    r = run_cli("model", "--motor", "ecce2010", "--points", "4", "--out", tmp_path / "dangling.csv")
    assert r.code == 0, r.err
    assert (tmp_path / "dangling.csv").is_symlink() and (tmp_path / "new.csv").is_file()


@pytest.mark.parametrize("args", [
    ["simulate", "step3_lut", "--trace", "none", "--out"],
    ["model", "--motor", "ecce2010", "--points", "4", "--out"],
    ["sweep", "SWEEP", "--no-progress", "--out"],
    ["examples"],
    ["firmware", "export"],
])
def test_a_symlink_loop_as_out_is_named(run_cli, tmp_path, args):
    """A loop of links as `--out` was "exists and is not a folder", "cannot write: File exists" or
    "Too many levels of symbolic links"."""
    real = tree(tmp_path)
    args = [str(real / "sweeps" / "w.toml") if a == "SWEEP" else a for a in args]
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    extra = ["--motor", "small30", "--unverified"] if args[0] == "firmware" else []
    run_cli(*args, tmp_path / "a", *extra).refused(str(tmp_path / "a"), "a loop of symbolic links")


@pytest.mark.parametrize("args", [["sweep", "SWEEP", "--workers", "1", "--no-progress", "--out"],
                                  ["examples"]])
def test_a_dangling_link_as_out_folder_makes_its_target(run_cli, tmp_path, args):
    """`sweep --out dangling` and `examples dangling` were "cannot write: File exists"; `simulate`
    made the folder the link points to (docs/cli.md): now every folder output does."""
    real = tree(tmp_path)
    args = [str(real / "sweeps" / "w.toml") if a == "SWEEP" else a for a in args]
    (tmp_path / "dangling").symlink_to(tmp_path / "made")
    r = run_cli(*args, tmp_path / "dangling")
    assert r.code == 0, r.err
    assert (tmp_path / "dangling").is_symlink() and (tmp_path / "made").is_dir()
    assert os.listdir(tmp_path / "made")


# ------------------------------------------------------------------ long names
def test_a_file_name_of_255_bytes_is_written(run_cli, tmp_path):
    """`model --out` with a 255-byte name (what the file system allows) was "file name too long":
    the temporary file's name was the name and 14 more."""
    out = tmp_path / ("c" * 251 + ".csv")
    r = run_cli("model", "--motor", "ecce2010", "--points", "4", "--out", out)
    assert r.code == 0, r.err
    assert out.is_file() and sorted(os.listdir(tmp_path)) == [out.name]


def test_a_certificate_name_too_long_is_refused_before_the_work(run_cli, tmp_path):
    """`tune --out <240 characters>.toml`: the scenario's name is valid, the certificate's
    `<stem>.verification.json` is not; the certificate's write failed after the work."""
    out = tmp_path / ("t" * 240 + ".toml")
    run_cli("tune", "--motor", "small30", "--no-verify", "--out", out).refused(
        "--out", "verification.json", "255")
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ the working folder
@pytest.mark.parametrize("args", [
    ["simulate", "step3_lut", "--trace", "none"],
    ["model", "--motor", "ecce2010", "--points", "4", "--out", "rel.csv"],
    ["tune", "--motor", "small30", "--no-verify", "--out", "ABS/t.toml"],
    ["calibrate", "--motor", "small30", "--positions", "4", "--out", "ABS/cal"],
])
def test_a_deleted_working_folder_is_named(tmp_path, args):
    """Run from a folder deleted meanwhile: "No such file or directory" with no path, or
    "rel.csv: cannot write: No such file or directory"."""
    (tmp_path / "gone").mkdir()
    args = [str(a).replace("ABS", str(tmp_path)) for a in args]
    line = one_line(run(args, tmp_path, before="cd gone && rmdir ../gone && "), "working folder",
                    str(tmp_path / "gone"), "deleted")
    assert "No such file" not in line
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("out", [".", "HERE"])
def test_an_out_that_is_the_working_folder_is_refused(run_cli, tmp_path, monkeypatch, out):
    """`simulate S --out .` in an empty folder renamed the working folder aside and put the set in
    its place: exit 0, and the shell left in a deleted folder where `ls` shows nothing."""
    here = tmp_path / "here"
    here.mkdir()
    monkeypatch.chdir(here)
    run_cli("simulate", "step3_lut", "--trace", "none", "--out", here if out == "HERE" else out).refused(
        "working folder")
    assert os.listdir(here) == [] and os.path.samefile(os.getcwd(), here)


def test_an_out_that_holds_the_working_folder_in_a_kept_entry_is_replaced(run_cli, tmp_path, monkeypatch):
    """(The rule's other side: a working folder inside an entry of yours that the set carries over
    stays where it is, as `make demo` runs in `out/`.)"""
    out = tmp_path / "o"
    assert run_cli("simulate", "step3_lut", "--trace", "none", "--out", out).code == 0
    (out / "mine").mkdir()
    monkeypatch.chdir(out / "mine")
    assert run_cli("simulate", "step3_lut", "--trace", "none", "--out", out).code == 0
    assert os.path.samefile(os.getcwd(), out / "mine")


# ------------------------------------------------------------------ two sweeps at once
def test_a_second_sweep_into_a_busy_folder_is_refused(run_cli, tmp_path):
    """Two `sweep --out same` at once: one deleted the other's partition being written ("part-000005.parquet:
    cannot write: No such file or directory")."""
    real = tree(tmp_path)
    out = tmp_path / "o"
    out.mkdir()
    fd = os.open(out, os.O_RDONLY)  # (another process's sweep holds the folder)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        run_cli("sweep", real / "sweeps" / "w.toml", "--workers", "1", "--no-progress", "--out", out).refused(
            str(out), "another linsense sweep")
    finally:
        os.close(fd)
    assert os.listdir(out) == []
    r = run_cli("sweep", real / "sweeps" / "w.toml", "--workers", "1", "--no-progress", "--out", out)
    assert r.code == 0, r.err


# ------------------------------------------------------------------ encodings and terminals
def test_a_report_in_an_ascii_terminal_escapes_what_it_cannot_show(tmp_path):
    """`PYTHONIOENCODING=ascii` and a folder named `out é`: the set was written, then exit 2 "<stdout>:
    cannot write: standard output is closed"."""
    p = run(["simulate", "step3_lut", "--trace", "none", "--out", "out \u00e9"], tmp_path,
            env={"PYTHONIOENCODING": "ascii"})
    assert p.returncode == 0, p.stderr
    assert "out \\xe9/metrics.json" in p.stdout


def test_an_unusable_mplbackend_is_named(tmp_path):
    """`MPLBACKEND=nonsense simulate --plot`: "Key backend: 'nonsense' is not a valid value for
    backend; ..." (matplotlib's words, naming no variable)."""
    p = run(["simulate", "step3_lut", "--trace", "none", "--plot", "--out", "o"], tmp_path,
            env={"MPLBACKEND": "nonsense"})
    one_line(p, "MPLBACKEND", "'nonsense'")


# ------------------------------------------------------------------ the same bytes whatever the machine
def test_fea_json_is_the_same_bytes_run_after_run(tmp_path):
    """`fea --workers 1` and `--workers 2` (or two runs alike) wrote different fea.json: it held the
    solve's wall-clock times, which live in timing.json as for every other set (docs/cli.md)."""
    import json

    from linsense.report.fea import run_fea

    geo = resources.files("linsense.examples") / "fea" / "fig4_three_coils.toml"
    run_fea(str(geo), str(tmp_path / "o"), 12, "coarse", 36)
    doc = json.loads((tmp_path / "o" / "fea.json").read_text())
    assert "times_s" not in doc and "solve_s" not in json.dumps(doc)
    timing = json.loads((tmp_path / "o" / "timing.json").read_text())
    assert timing["times_s"]["solve_s"] > 0


def test_a_home_without_a_settings_folder_is_one_warning(tmp_path):
    """A read-only (or missing) HOME: matplotlib's own two lines ("mkdir -p failed for path ...:
    [Errno 20] Not a directory: ...", "Matplotlib created a temporary cache directory ...") at every
    run with a figure, under `-q` too."""
    (tmp_path / "home").write_text("")  # (a HOME that is a file: no folder can be made in it, even as root)
    env = {"HOME": str(tmp_path / "home"), "MPLCONFIGDIR": "", "XDG_CONFIG_HOME": "", "XDG_CACHE_HOME": ""}
    p = run(["-q", "plot", "--motor", "ecce2010", "--points", "36", "--out", "o"], tmp_path, env=env,
            before="unset MPLCONFIGDIR XDG_CONFIG_HOME XDG_CACHE_HOME; ")
    assert p.returncode == 0, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("linsense: warning: matplotlib has no writable folder"), lines
    assert "Errno" not in p.stderr and "MPLCONFIGDIR" in lines[0]


def test_a_umask_that_closes_the_folders_is_named(tmp_path):
    """`umask 0277`: the folders a run makes are read-only to their owner, the run's own files
    cannot go in them: "um/trace.parquet: cannot write: permission denied", no cause named."""
    prefix = _unprivileged()
    if prefix is None:
        pytest.skip("no way to run without root's override of file modes here")
    p = run(["simulate", "step3_lut", "--out", "um"], tmp_path, before=f"umask 0277; {' '.join(prefix)} ")
    one_line(p, "um/", "permission denied", "umask 0277")


def test_a_sweep_under_a_read_only_folder_is_a_write_error(tmp_path):
    """(A guard of the sweep's lock, which makes the folder: a read-only parent is said as any write.)"""
    prefix = _unprivileged()
    if prefix is None:
        pytest.skip("no way to run without root's override of file modes here")
    real = tree(tmp_path)
    (tmp_path / "ro").mkdir()
    (tmp_path / "ro").chmod(0o555)
    try:
        p = run(["sweep", real / "sweeps" / "w.toml", "--no-progress", "--out", "ro/w"], tmp_path,
                before=f"{' '.join(prefix)} ")
        one_line(p, "ro/w", "cannot write: permission denied: its folder is read-only")
    finally:
        (tmp_path / "ro").chmod(0o755)


def _unprivileged() -> list[str] | None:
    """A prefix that runs a command without root's override of file modes, or None."""
    import shutil

    if os.geteuid() != 0:
        return []
    if shutil.which("setpriv") is None:
        return None
    p = subprocess.run(["setpriv", "--bounding-set=-all", "--inh-caps=-all", "true"], capture_output=True)
    return ["setpriv", "--bounding-set=-all", "--inh-caps=-all"] if p.returncode == 0 else None


@pytest.mark.parametrize("args, option", [
    (["sweep", "SWEEP", "--no-progress", "--out", ""], "--out"),
    (["examples", ""], "FOLDER"),
    (["model", "--motor", "ecce2010", "--out", ""], "--out"),
    (["simulate", "step3_lut", "--out", ""], "--out"),
    (["tune", "--motor", "small30", "--no-verify", "--table", "", "--out", "t.toml"], "--table"),
])
def test_an_empty_path_is_refused(run_cli, tmp_path, monkeypatch, args, option):
    """`--out "$DIR"` with DIR unset: `sweep` and `examples` wrote into the working folder (exit 0),
    `model` said ".: cannot write: Is a directory", `--table ""` ".: is a folder"."""
    real = tree(tmp_path)
    here = tmp_path / "here"
    here.mkdir()
    monkeypatch.chdir(here)
    args = [str(real / "sweeps" / "w.toml") if a == "SWEEP" else a for a in args]
    run_cli(*args).refused(option, "empty")
    assert os.listdir(here) == []

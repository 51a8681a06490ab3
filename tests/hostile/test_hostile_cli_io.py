"""Hostile command lines and file systems.

Each case failed before its fix; the rule that prevents its kind:

* tables for motors nothing else accepts, and C names rewritten silently: one saliency rule
  (``linsense.tune.design.require_saliency``) and one C-name rule (``linsense.compensation.lut.c_symbol``);
* an output set left behind: the output-set writer refuses a folder it cannot replace before the
  work, never says done when it could not finish, and removes its own leftovers
  (``linsense.io.output_set``, ``_rmtree``);
* closed or broken standard streams: one place in the entry (``linsense.cli.main`` with
  ``_common.std_streams``, ``write_stream``), one line and exit code 2;
* readers: one decoder and one TOML parser (``linsense.io.decode_text``, ``parse_toml``): a BOM
  read, an empty input said to be empty;
* writers: every OSError one line naming the user's path and the reason in words
  (``linsense.io.output_error``); copies all or nothing; files 0644 (the umask's), never mkstemp's 0600;
* ``--out`` defaults: one rule for every command (``_common.default_out``).
"""

from __future__ import annotations

import errno
import os
import shutil
import stat
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest

import linsense

SRC = Path(linsense.__file__).resolve().parents[1]


def run(args: list[str], cwd: Path, shell_tail: str = "", env: dict | None = None,
        stdin: str | None = None, prefix: str = "") -> subprocess.CompletedProcess:
    """``linsense ARGS`` in a child shell, with redirections ``shell_tail`` (``>&-``...)."""
    import shlex

    cmd = " ".join(shlex.quote(a) for a in [sys.executable, "-m", "linsense", *map(str, args)])
    full = {**os.environ, "PYTHONPATH": str(SRC), **(env or {})}
    return subprocess.run(["sh", "-c", f"{prefix}{cmd} {shell_tail}"], cwd=cwd, env=full, capture_output=True,
                          text=True, input=stdin, timeout=600)


def one_line(p: subprocess.CompletedProcess, *words: str, code: int = 2) -> str:
    """Exit ``code`` and one ``linsense: error:`` line holding every word: no traceback."""
    assert p.returncode == code, (p.returncode, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("linsense: error: "), p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def scenario_text() -> str:
    return (resources.files("linsense.examples") / "scenarios" / "step3_lut.toml").read_text()


# ------------------------------------------------------------------ C names (never rewritten)
@pytest.mark.parametrize("symbol, words", [
    ("my lut!", ["not a C identifier", "' '"]),
    ("int", ["keyword"]),
    ("int_t", ["POSIX"]),
    ("_lut", ["reserved"]),
    ("class", ["keyword of C (or C++)"]),
    ("sin", ["C standard library"]),
    ("LS_LUT", ["linsense's C library"]),
    ("9lives", ["not a C identifier", "digit"]),
    ("x" * 49, ["49 characters", "63"]),
])
def test_a_c_symbol_is_used_as_given_or_refused(run_cli, tmp_path, symbol, words):
    """`lut --symbol 'my lut!'` wrote `my_lut`, `--symbol int` `int_t`, without a word."""
    out = tmp_path / "l.h"
    run_cli("lut", "--motor", "ecce2010", "--format", "c", "--symbol", symbol, "--out", out).refused(
        "--symbol", *words)
    assert not out.exists()


def test_a_symbol_or_name_that_nothing_uses_is_refused(run_cli, tmp_path):
    """`lut --symbol` with a CSV and `tune --name` with a scenario were ignored without a word."""
    run_cli("lut", "--motor", "ecce2010", "--symbol", "tab", "--out", tmp_path / "l.csv").refused(
        "--symbol", "--format c")
    run_cli("tune", "--motor", "small30", "--name", "axis", "--no-verify",
            "--out", tmp_path / "t.toml").refused("--name", "--format c")
    assert list(tmp_path.iterdir()) == []


def test_a_tune_name_is_checked_before_the_certificate(run_cli, tmp_path):
    """`tune --format c --name 'my drive'` became ls_cfg_my_drive; refused at once now."""
    run_cli("tune", "--motor", "small30", "--format", "c", "--name", "my drive", "--out",
            tmp_path / "c.h").refused("--name", "'my drive'", "ls_cfg_my drive", "not a C identifier")
    run_cli("firmware", "export", tmp_path / "fw", "--motor", "small30", "--name", "a-b").refused(
        "--name", "not a C identifier")
    assert list(tmp_path.iterdir()) == []


def test_a_motor_name_making_a_library_name_is_refused(run_cli, tmp_path):
    """A motor named "step" made the default array ls_lut_step, the C library's function."""
    text = (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()
    (tmp_path / "m.toml").write_text(text.replace('name = "ecce2010"', 'name = "step"'))
    run_cli("lut", "--motor", tmp_path / "m.toml", "--format", "c", "--out", tmp_path / "l.h").refused(
        "'ls_lut_step'", "linsense's C library", "give the symbol")
    assert run_cli("lut", "--motor", tmp_path / "m.toml", "--format", "c", "--symbol", "lut_step",
                   "--out", tmp_path / "l.h").code == 0


# ------------------------------------------------------------------ output sets
def _first_set(run_cli, out: Path) -> None:
    assert run_cli("simulate", "step3_lut", "--trace", "none", "--out", out).code == 0


def test_a_read_only_out_is_refused_before_the_run(run_cli, tmp_path, monkeypatch):
    """`simulate --out DIR` on a read-only DIR holding an earlier set exited 0 and left
    `.DIR.old-PID-TOKEN` beside it for good (the old set could not be emptied)."""
    out = tmp_path / "sim"
    _first_set(run_cli, out)
    before = sorted(os.listdir(tmp_path))
    import linsense.io as lio

    real = os.access
    monkeypatch.setattr(lio.os, "access", lambda p, mode, **kw:
                        False if Path(p) == out and mode & os.W_OK else real(p, mode, **kw))
    run_cli("simulate", "step3_lut", "--trace", "none", "--out", out).refused(
        str(out), "read-only", "choose another --out")
    assert sorted(os.listdir(tmp_path)) == before


def test_an_old_set_that_cannot_be_removed_is_not_reported_done(run_cli, tmp_path, monkeypatch):
    """The swap's last step (removing the old set) failing was ignored: exit 0 and a leftover.
    Now one line naming it, and the next run removes it."""
    out = tmp_path / "sim"
    _first_set(run_cli, out)
    import linsense.io as lio

    real = shutil.rmtree

    def failing(path, ignore_errors=False, **kw):
        if ".sim.old-" in str(path):
            if ignore_errors:
                return None
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real(path, ignore_errors=ignore_errors, **kw)

    monkeypatch.setattr(lio.shutil, "rmtree", failing)
    r = run_cli("simulate", "step3_lut", "--trace", "none", "--out", out)
    line = r.refused(str(out), "written, but the previous set could not be removed", "permission denied",
                     ".sim.old-")
    assert "Errno" not in line
    monkeypatch.setattr(lio.shutil, "rmtree", real)
    (left,) = [p for p in tmp_path.iterdir() if p.name.startswith(".sim.old-")]
    left.rename(tmp_path / f".sim.old-999999999-{left.name.rsplit('-', 1)[1]}")  # (as a dead run's)
    _first_set(run_cli, out)
    assert sorted(os.listdir(tmp_path)) == ["sim"]


def test_a_leftover_that_cannot_be_removed_is_said(run_cli, tmp_path, monkeypatch):
    """A dead run's leftover that cannot be removed was skipped without a word at every run."""
    out = tmp_path / "sim"
    _first_set(run_cli, out)
    left = tmp_path / ".sim.old-999999999-0123abcd"
    shutil.copytree(out, left)
    import linsense.io as lio

    real = shutil.rmtree

    def failing(path, ignore_errors=False, **kw):
        if str(path) == str(left):
            if ignore_errors:
                return None
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real(path, ignore_errors=ignore_errors, **kw)

    monkeypatch.setattr(lio.shutil, "rmtree", failing)
    run_cli("simulate", "step3_lut", "--trace", "none", "--out", out).refused(
        left.name, "leftover", "cannot be removed", "permission denied", "remove it")


def _unprivileged() -> list[str] | None:
    """A prefix that runs a command without root's override of file modes, or None."""
    if os.geteuid() != 0:
        return []
    if shutil.which("setpriv") is None:
        return None
    p = subprocess.run(["setpriv", "--bounding-set=-all", "--inh-caps=-all", "true"], capture_output=True)
    return ["setpriv", "--bounding-set=-all", "--inh-caps=-all"] if p.returncode == 0 else None


def test_a_read_only_out_for_real(tmp_path):
    """The reported case with real file modes (as an ordinary user: root without its capabilities)."""
    prefix = _unprivileged()
    if prefix is None:
        pytest.skip("no way to run without root's override of file modes here")
    pre = " ".join(prefix) + " " if prefix else ""
    args = ["simulate", "step3_lut", "--trace", "none", "--out", "w/sim"]
    assert run(args, tmp_path, prefix=pre).returncode == 0
    (tmp_path / "w" / "sim").chmod(0o555)
    try:
        one_line(run(args, tmp_path, prefix=pre), "w/sim", "read-only")
        assert sorted(os.listdir(tmp_path / "w")) == ["sim"]
        # a leftover of an earlier (dead) run, read-only: the next run removes it
        (tmp_path / "w" / "sim").chmod(0o755)
        left = tmp_path / "w" / ".sim.old-999999999-0123abcd"
        shutil.copytree(tmp_path / "w" / "sim", left)
        left.chmod(0o555)
        assert run(args, tmp_path, prefix=pre).returncode == 0
        assert sorted(os.listdir(tmp_path / "w")) == ["sim"]
    finally:
        for p in (tmp_path / "w").iterdir():
            p.chmod(0o755)


# ------------------------------------------------------------------ standard streams
@pytest.mark.parametrize("args, tail, words", [
    (["simulate", "step3_lut", "--trace", "none", "--json", "--out", "o"], ">&-",
     ["standard output is closed"]),
    (["examples", "--list"], ">&-", ["standard output is closed"]),
    (["model", "--motor", "ecce2010", "--out", "-"], ">&-", ["standard output is closed"]),
    (["simulate", "-", "--trace", "none", "--out", "o"], "<&-", ["<stdin>", "standard input is closed"]),
])
def test_a_closed_standard_stream_is_one_line(tmp_path, args, tail, words):
    """`--json >&-` and `simulate - <&-` ended in an AttributeError traceback after the work."""
    one_line(run(args, tmp_path, tail), *words)
    assert list(tmp_path.iterdir()) == []  # (refused before the work)


def test_a_closed_standard_error_keeps_the_exit_code(tmp_path):
    """(A guard of the same entry: with nowhere to say anything, the exit code still tells.)"""
    assert run(["model", "--motor", "nosuch", "--out", "m.csv"], tmp_path, "2>&-").returncode == 2
    assert run(["model", "--motor", "ecce2010", "--out", "m.csv"], tmp_path, "2>&-").returncode == 0
    assert (tmp_path / "m.csv").is_file()


@pytest.mark.parametrize("unbuffered", ["1", ""])
def test_a_cut_output_is_not_success(tmp_path, unbuffered):
    """`model --out - | reader that goes`: exit 2 and one line, never 0 with the output cut."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    if unbuffered:
        env["PYTHONUNBUFFERED"] = "1"
    else:
        env.pop("PYTHONUNBUFFERED", None)
    writer = subprocess.Popen([sys.executable, "-m", "linsense", "model", "--motor", "ecce2010", "--points",
                               "100000", "--out", "-"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE)
    writer.stdout.read(10)
    writer.stdout.close()  # (the reader goes)
    err = writer.stderr.read().decode()
    assert writer.wait(timeout=300) == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "<stdout>" in lines[0] and "broken pipe" in lines[0], err


def test_a_report_into_a_broken_pipe_is_one_line(tmp_path):
    """The report (logging) into a pipe whose reader went: "--- Logging error ---" tracebacks."""
    writer = subprocess.Popen([sys.executable, "-m", "linsense", "examples", "--list"], cwd=tmp_path,
                              env={**os.environ, "PYTHONPATH": str(SRC)}, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, stdin=subprocess.PIPE)
    writer.stdout.close()  # (before it writes: the first line breaks)
    err = writer.stderr.read().decode()
    assert writer.wait(timeout=300) == 2, err
    assert "Traceback" not in err and "Logging error" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "broken pipe" in lines[0], err


# ------------------------------------------------------------------ readers
@pytest.mark.parametrize("stdin, words", [
    ("", ["<stdin>", "empty"]),
    ("# only a comment\n\n", ["<stdin>", "empty"]),
])
def test_empty_standard_input_is_said_empty(tmp_path, stdin, words):
    """Empty standard input was "reference.position_mm: missing required key"."""
    line = one_line(run(["simulate", "-", "--trace", "none", "--out", "o"], tmp_path, stdin=stdin), *words)
    assert "missing" not in line


def test_an_empty_file_is_said_empty(run_cli, tmp_path):
    """An empty scenario or motor file: "motor: missing required key" and the like."""
    (tmp_path / "e.toml").write_text("# nothing yet\n")
    run_cli("simulate", tmp_path / "e.toml", "--out", tmp_path / "o").refused("e.toml: empty", "no TOML keys")
    run_cli("model", "--motor", tmp_path / "e.toml", "--out", tmp_path / "m.csv").refused(
        "e.toml: empty", "no TOML keys")


BOM = "\ufeff"


@pytest.mark.parametrize("crlf", [False, True])
def test_a_scenario_with_a_bom_is_read(run_cli, tmp_path, crlf):
    """A UTF-8 BOM in a scenario: "Invalid statement at line 1, column 1" (the CSV readers skip it)."""
    text = BOM + scenario_text().replace('motor = "ecce2010"', 'motor = "ecce2010"')
    if crlf:
        text = text.replace("\n", "\r\n")
    (tmp_path / "s.toml").write_bytes(text.encode("utf-8"))
    r = run_cli("simulate", tmp_path / "s.toml", "--trace", "none", "--out", tmp_path / "o")
    assert r.code == 0, r.err
    p = run(["simulate", "-", "--trace", "none", "--out", "o2"], tmp_path, stdin=text)
    assert p.returncode == 0, p.stderr


def test_utf16_is_named(run_cli, tmp_path):
    """A scenario saved as Windows' "Unicode" (UTF-16): "cannot read: 'utf-8' codec can't decode
    byte 0xff in position 0: invalid start byte"."""
    (tmp_path / "s.toml").write_bytes(scenario_text().encode("utf-16"))
    line = run_cli("simulate", tmp_path / "s.toml", "--out", tmp_path / "o").refused("s.toml", "UTF-16",
                                                                                     "as UTF-8")
    assert "codec" not in line


def test_a_table_that_cannot_be_read_says_why_in_words(run_cli, tmp_path, monkeypatch):
    """A motor's table that cannot be read (permission denied): "[Errno 13] Permission denied:
    '/.../t.csv'", the path twice."""
    import builtins

    import linsense.io as lio

    text = (resources.files("linsense.examples") / "motors" / "tabulated.toml").read_text()
    (tmp_path / "m.toml").write_text(text.replace("ecce2010_table.csv", "t.csv"))
    (tmp_path / "t.csv").write_text("theta_deg\n")

    def denied(path, *a, **kw):
        if str(path).endswith("t.csv"):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return builtins.open(path, *a, **kw)

    monkeypatch.setattr(lio, "open", denied, raising=False)
    line = run_cli("model", "--motor", tmp_path / "m.toml", "--out", tmp_path / "m.csv").refused(
        "t.csv", "permission denied")
    assert "Errno" not in line and line.count("t.csv") == 1, line


def test_every_toml_and_json_reader_reads_a_bom(run_cli, tmp_path):
    """Motor files, sweep files, FEA geometries and JSON tables: the same decoder."""
    from linsense.compensation.lut import build_lut, read_lut_json, to_json
    from linsense.fea.geometry import load_geometry
    from linsense.model.motor import load_motor
    from linsense.sweep.spec import load_sweep

    def bom(src: str, name: str) -> Path:
        p = tmp_path / name
        p.write_bytes((BOM + src).encode("utf-8"))
        return p

    motor = bom((resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text(), "m.toml")
    assert load_motor(str(motor)).name == "ecce2010"
    bom(scenario_text(), "base.toml")
    sweep = bom('[sweep]\nname = "b"\nscenario = "base.toml"\n[[axis]]\nkey = "observer.bandwidth_hz"\n'
                "values = [30.0, 50.0]\n", "sw.toml")
    assert load_sweep(sweep).name == "b"
    geo = bom((resources.files("linsense.examples") / "fea" / "tubular56_bh.toml").read_text(), "g.toml")
    load_geometry(geo)
    lut = bom(to_json(build_lut(load_motor("ecce2010"), 36)), "l.json")
    assert read_lut_json(lut).points == 36


# ------------------------------------------------------------------ writers
def test_examples_into_a_full_disk_copy_nothing(run_cli, tmp_path, monkeypatch):
    """`examples DIR` on a full disk: a raw errno naming the package's own file, and the files copied
    so far left although the refusal promised "nothing copied"."""
    import linsense.examples as ex

    real, calls = shutil.copyfile, []

    def full(src, dst, **kw):
        calls.append(dst)
        if len(calls) == 5:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(dst))
        return real(src, dst, **kw)

    monkeypatch.setattr(ex.shutil, "copyfile", full)
    line = run_cli("examples", tmp_path / "ex").refused(str(tmp_path / "ex"), "no space left on the device",
                                                          "nothing copied")
    assert str(ex.ROOT) not in line and "Errno" not in line
    assert not (tmp_path / "ex").exists()
    # with --force over an earlier copy: the files it replaced are put back
    monkeypatch.setattr(ex.shutil, "copyfile", real)
    assert run_cli("examples", tmp_path / "ex").code == 0
    mine = tmp_path / "ex" / "motors" / "small30.toml"
    mine.write_text("# my edit\n")
    before = {p: p.read_bytes() for p in (tmp_path / "ex").rglob("*") if p.is_file()}
    calls.clear()
    monkeypatch.setattr(ex.os, "replace", _fail_at(8, os.replace))
    run_cli("examples", tmp_path / "ex", "--force").refused("nothing copied")
    assert {p: p.read_bytes() for p in (tmp_path / "ex").rglob("*") if p.is_file()} == before


def test_examples_force_never_replaces_a_folder(run_cli, tmp_path):
    """`examples DIR --force` where DIR holds a folder of the user's by an example's name: the
    folder was moved into the temporary copy and deleted with it (before: a raw errno and half a
    copy); refused now, nothing copied, the folder kept."""
    mine = tmp_path / "ex" / "motors" / "small30.toml"
    mine.mkdir(parents=True)
    (mine / "notes.txt").write_text("mine\n")
    run_cli("examples", tmp_path / "ex", "--force").refused(str(mine), "is a folder", "nothing copied")
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == [
        "ex", "ex/motors", "ex/motors/small30.toml", "ex/motors/small30.toml/notes.txt"]


def test_a_folder_output_is_never_named_dash(run_cli, tmp_path, monkeypatch):
    """`simulate --out -` made a folder named "-" (where `--out -` of a file is standard output)."""
    monkeypatch.chdir(tmp_path)
    run_cli("simulate", "step3_lut", "--trace", "none", "--out", "-").refused("--out", "standard output")
    run_cli("examples", "-").refused("FOLDER", "standard output")
    assert list(tmp_path.iterdir()) == []


def _fail_at(n: int, real):
    count = [0]

    def f(a, b, **kw):
        count[0] += 1
        if count[0] == n:
            raise OSError(errno.EIO, os.strerror(errno.EIO), str(b))
        return real(a, b, **kw)

    return f


def test_examples_into_a_read_only_folder(run_cli, tmp_path, monkeypatch):
    """A read-only sub-folder: refused before a file is copied, naming the folder's file."""
    (tmp_path / "ex" / "motors").mkdir(parents=True)
    import linsense.examples as ex

    real = os.access
    ro = tmp_path / "ex" / "motors"
    monkeypatch.setattr(ex.os, "access", lambda p, m, **kw: False if Path(p) == ro else real(p, m, **kw))
    run_cli("examples", tmp_path / "ex").refused(str(ro), "permission denied", "nothing copied")
    assert sorted(p.name for p in (tmp_path / "ex").rglob("*")) == ["motors"]


SWEEP = """[sweep]
name = "h"
scenario = "base.toml"
batch = 1
[[axis]]
key = "observer.bandwidth_hz"
values = [30.0, 50.0]
"""
BASE = ('motor = "ecce2010"\n[scenario]\nduration = 0.05\n[reference]\ntype = "step"\nposition_mm = 2.0\n'
        "at = 0.01\n")


def test_sweep_on_a_full_disk_names_the_partition(run_cli, tmp_path, monkeypatch):
    """pyarrow's "[Errno 28] Error writing bytes to file" without a path; one line naming it now."""
    pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    (tmp_path / "base.toml").write_text(BASE)
    (tmp_path / "sw.toml").write_text(SWEEP)

    def full(table, where, **kw):
        raise OSError(errno.ENOSPC, "Error writing bytes to file. Detail: [errno 28] No space left on device")

    monkeypatch.setattr(pq, "write_table", full)
    line = run_cli("sweep", tmp_path / "sw.toml", "--out", tmp_path / "o", "--workers", 1,
                   "--no-progress").refused("parts", "part-0000", "no space left on the device")
    assert "Errno" not in line and "errno" not in line


def test_sweep_partitions_have_the_mode_of_every_output(run_cli, tmp_path):
    """Partitions were 0600 (mkstemp's) while every other output is 0644 (under the umask 022)."""
    pytest.importorskip("pyarrow")
    (tmp_path / "base.toml").write_text(BASE)
    (tmp_path / "sw.toml").write_text(SWEEP)
    assert run_cli("sweep", tmp_path / "sw.toml", "--out", tmp_path / "o", "--workers", 1,
                   "--no-progress").code == 0
    from linsense.io import FILE_MODE

    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in (tmp_path / "o").rglob("*") if p.is_file()}
    assert modes and set(modes.values()) == {FILE_MODE}, modes


def test_outputs_follow_the_umask(tmp_path):
    """Every file was chmod 0644 whatever the umask (077: private files readable by all)."""
    p = run(["model", "--motor", "ecce2010", "--out", "m.csv"], tmp_path, prefix="umask 077; ")
    assert p.returncode == 0, p.stderr
    assert stat.S_IMODE((tmp_path / "m.csv").stat().st_mode) == 0o600


# ------------------------------------------------------------------ --out defaults
@pytest.mark.parametrize("args, made", [
    (["model", "--motor", "ecce2010"], "ecce2010-model.csv"),
    (["tune", "--motor", "small30", "--no-verify"], "small30-tune.toml"),
    (["simulate", "step3_lut", "--trace", "none"], "step3_lut-simulate"),
    (["lut", "--motor", "ecce2010", "--format", "c"], "ecce2010-lut.h"),
])
def test_out_has_a_default(run_cli, tmp_path, monkeypatch, args, made):
    """`model`, `tune` and `simulate` refused to run without --out."""
    monkeypatch.chdir(tmp_path)
    r = run_cli(*args)
    assert r.code == 0, r.err
    assert (tmp_path / made).exists()
    assert f"no --out given: writing {made}" in r.out


def test_out_default_from_standard_input_is_the_scenario_name(tmp_path):
    text = scenario_text().replace('name = "step3_lut"', 'name = "from a pipe"')
    p = run(["simulate", "-", "--trace", "none"], tmp_path, stdin=text)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "from_a_pipe-simulate" / "metrics.json").is_file()

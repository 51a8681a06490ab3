"""The CLI for scripts and the packaged examples.

Data on standard output, the report on standard error when it does (``--out -``, ``--json``);
``--json`` summaries with the keys docs/cli.md lists; a scenario from standard input; ``--check``
on ``reproduce`` and ``sweep``; ``-q``/``-v``; help lines that read well; every packaged example
reachable by name, ``linsense examples DIR`` copying them out, an unknown name refused in one line.
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from linsense import examples
from linsense.cli import cli
from linsense.cli.runs import failed_claims
from linsense.version import DOCS_URL, SITE_PUBLISHED, docs

ROOT = Path(__file__).resolve().parents[1]

#: the keys of each command's --json summary (docs/cli.md, "JSON summaries")
COMMON = {"command", "files", "ok"}
JSON_KEYS = {
    "examples": COMMON | {"names"},
    "plot": COMMON | {"motor"},
    "identify": COMMON | {"fit", "warnings"},
    "simulate": COMMON | {"metrics", "timing"},
    "calibrate": COMMON | {"metrics", "timing"},
    "tune": COMMON | {"motor", "design", "startup", "warnings", "verification"},
    "reproduce": COMMON | {"motor", "quick", "model_only", "claims", "claims_beyond"},
    "fea": COMMON | {"fea", "warnings"},
    "sweep": COMMON | {"name", "study", "axes", "runs", "stable", "not_stable", "refused", "failed_runs",
                       "summary"},
}


def summary(r, command: str) -> dict:
    """The one JSON object on standard output, with the documented keys."""
    assert r.code in (0, 1), r.err
    doc = json.loads(r.out)  # (the whole of stdout: one object, nothing else)
    assert set(doc) == JSON_KEYS[command], sorted(set(doc) ^ JSON_KEYS[command])
    assert doc["command"] == command
    assert list(doc) == sorted(doc)  # (stable ordering: sorted keys)
    return doc


# ---------------------------------------------------------------------------------- --out -
def test_tune_out_dash_is_valid_toml_and_the_report_goes_to_stderr(run_cli, tmp_path):
    """`tune --out -` (the reported case: the TOML was mixed with the report): stdout parses as
    TOML and is the scenario `--out FILE` writes; the design and the certificate are on stderr."""
    os.chdir(tmp_path)
    r = run_cli("tune", "--motor", "small30", "--quick", "--out", "-")
    assert r.code == 0, r.err
    doc = tomllib.loads(r.out)
    assert doc["motor"] == "small30" and "injection" in doc
    assert "design for small30" in r.err and "verification (quick:" in r.err
    r2 = run_cli("tune", "--motor", "small30", "--no-verify", "--out", "t.toml")
    assert tomllib.loads(Path("t.toml").read_text()) == doc
    assert "design for small30" in r2.out  # (to a file: the report stays on stdout)


def test_lut_and_model_out_dash_write_the_data_alone(run_cli, tmp_path):
    os.chdir(tmp_path)
    r = run_cli("lut", "--motor", "small30", "--format", "c", "--f-inj", "1000", "--out", "-")
    assert r.code == 0 and r.err == "" and r.out.lstrip().startswith(("/*", "//", "#"))
    r = run_cli("lut", "--motor", "small30", "--format", "c", "--out", "-")  # (eq. 12: said on stderr)
    assert r.code == 0 and "eq. 12's table" in r.err and r.out.lstrip().startswith(("/*", "//", "#"))
    r = run_cli("model", "--motor", "harmonic", "--points", 8, "--out", "-")
    assert r.code == 0 and r.err == "" and len(r.out.splitlines()) == 9


# ---------------------------------------------------------------------------------- --json
def test_json_summaries_of_the_cheap_commands(run_cli, tmp_path):
    os.chdir(tmp_path)
    doc = summary(run_cli("simulate", "step3_lut", "--out", "s", "--trace", "none", "--json"), "simulate")
    assert doc["ok"] is True and doc["metrics"]["stable"] is True
    assert doc["metrics"] == json.loads(Path("s/metrics.json").read_text())
    assert doc["files"] == ["s/metrics.json", "s/timing.json"]

    r = run_cli("tune", "--motor", "small30", "--no-verify", "--out", "t.toml", "--json")
    doc = summary(r, "tune")
    assert doc["ok"] is None and doc["verification"] is None and doc["files"] == ["t.toml"]
    assert doc["design"]["f_inj"] == pytest.approx(1000.0) and "design for small30" in r.err

    doc = summary(run_cli("calibrate", "--motor", "small30", "--positions", 4, "--fidelity", "average",
                          "--out", "c", "--json"), "calibrate")
    assert doc["ok"] == doc["metrics"]["completed"] and "c/lut_measured.csv" in doc["files"]

    doc = summary(run_cli("identify", "ecce2010_56_1pct_seed1", "--motor", "ecce2010", "--out", "i",
                          "--json"), "identify")
    assert doc["fit"] == json.loads(Path("i/fit.json").read_text())

    doc = summary(run_cli("examples", "ex", "--json"), "examples")
    assert len(doc["files"]) == len(examples.files()) and "small30" in doc["names"]["motors"]


def test_tune_and_json_on_stdout_together_are_refused(run_cli, tmp_path):
    os.chdir(tmp_path)
    run_cli("tune", "--motor", "small30", "--no-verify", "--out", "-", "--json").refused("--json", "--out -")


@pytest.mark.slow
def test_json_summaries_of_the_model_figures_and_fea(run_cli, tmp_path):
    os.chdir(tmp_path)
    doc = summary(run_cli("plot", "--motor", "small30", "--out", "p", "--json"), "plot")
    assert doc["motor"] == "small30" and all(Path(f).is_file() for f in doc["files"])
    doc = summary(run_cli("reproduce", "--model-only", "--out", "rm", "--json"), "reproduce")
    assert doc["ok"] is True and doc["claims"] == [] and doc["model_only"] is True
    doc = summary(run_cli("fea", "fig4_three_coils", "--mesh", "coarse", "--positions", 12, "--out", "f",
                          "--json"), "fea")
    assert doc["fea"] == json.loads(Path("f/fea.json").read_text())


# ---------------------------------------------------------------------------------- stdin
def test_simulate_reads_the_scenario_from_stdin(tmp_path):
    """`linsense simulate -`: the scenario from standard input, a motor named in it by its example
    name; the metrics are those of the same scenario given as a file."""
    text = examples.path("scenarios", "step3_lut").read_text().replace('motor = "ecce2010"',
                                                                        'motor = "small30"')
    (tmp_path / "sc.toml").write_text(text)

    def cmd(scenario, out):
        return [sys.executable, "-m", "linsense", "simulate", scenario, "--out", out, "--trace", "none",
                "--json"]

    p = subprocess.run(cmd("-", "a"), input=text, capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert p.returncode == 0, p.stderr
    from_stdin = json.loads(p.stdout)["metrics"]
    p = subprocess.run(cmd("sc.toml", "b"), capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["metrics"] == from_stdin
    p = subprocess.run(cmd("-", "c"), input="motor = \n", capture_output=True, text=True, cwd=tmp_path,
                       timeout=120)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "<stdin>" in p.stderr


# ---------------------------------------------------------------------------------- --check
CLAIM = {"claim": "Fig. 11", "paper": "stable", "ours": "stable", "holds": True, "rule": "r"}


def test_failed_claims_maps_the_claim_table():
    """The --check verdict: every claim that does not hold, of the paper's and beyond; none of a
    model-only run."""
    ok = {"claims": [CLAIM, CLAIM], "claims_beyond": [CLAIM]}
    assert failed_claims(ok) == [] and failed_claims({}) == []
    bad = {"claims": [CLAIM, {**CLAIM, "claim": "Fig. 12", "holds": False, "ours": "cycles"}],
           "claims_beyond": [{**CLAIM, "claim": "start-up", "holds": False}]}
    assert failed_claims(bad) == ["Fig. 12: paper stable, ours cycles", "start-up: paper stable, ours stable"]


def test_reproduce_check_on_a_model_only_run_passes(run_cli, tmp_path):
    r = run_cli("reproduce", "--model-only", "--check", "--out", tmp_path / "o")
    assert r.code == 0, r.err


@pytest.mark.slow
def test_reproduce_check_exits_1_when_a_claim_fails(run_cli, tmp_path):
    """A quick reproduction with --check: the exit code is 1 exactly when a claim of its own
    metrics.json does not hold (docs/reproduce.md: on ecce2010 one of the paper's claims and one
    beyond it do not hold), and the one error line names them."""
    r = run_cli("reproduce", "--quick", "--check", "--out", tmp_path / "o", "--json")
    doc = summary(r, "reproduce")
    metrics = json.loads((tmp_path / "o" / "metrics.json").read_text())
    failed = failed_claims(metrics)
    assert [c["holds"] for c in doc["claims"]] == [c["holds"] for c in metrics["claims"]]
    assert r.code == (1 if failed else 0) and doc["ok"] == (not failed)
    if failed:
        line = r.err.strip().splitlines()[-1]
        assert line.startswith(f"linsense: {len(failed)} claim(s) do not hold")
        assert all(f.split(":")[0] in line for f in failed)


def test_sweep_check_exits_1_when_a_point_fails(run_cli, tmp_path):
    """Two points of step3_lut: with its table (stable) and without (a limit cycle): --check exits
    1 naming the failing run; without --check (the same folder: resumed, nothing run again) 0."""
    sw = tmp_path / "sw.toml"
    sw.write_text(f'[sweep]\nname = "two"\nscenario = "{examples.path("scenarios", "step3_lut")}"\n'
                  'sampling = "grid"\n\n[[axis]]\nkey = "control.mode"\n'
                  'values = ["sensorless_lut", "sensorless_nolut"]\n')
    out = tmp_path / "o"
    r = run_cli("sweep", sw, "--out", out, "--workers", 1, "--no-progress", "--check", "--json")
    assert r.code == 1, r.err
    doc = summary(r, "sweep")
    assert (doc["runs"], doc["stable"], doc["not_stable"], doc["refused"]) == (2, 1, 1, 0)
    assert doc["ok"] is False and doc["failed_runs"] == [1]
    assert r.err.strip().splitlines()[-1] == "linsense: 1 of 2 sweep points not stable or refused (runs 1)"
    r = run_cli("sweep", sw, "--out", out, "--workers", 1, "--no-progress")
    assert r.code == 0 and "two: 2 runs: 1 stable, 1 not, 0 refused" in r.out


# ---------------------------------------------------------------------------------- -q / -v
def test_quiet_prints_nothing_and_verbose_adds_detail(run_cli, tmp_path):
    os.chdir(tmp_path)
    r = run_cli("-q", "simulate", "step3_lut", "--out", "q", "--trace", "none")
    assert (r.code, r.out, r.err) == (0, "", "")
    assert Path("q/metrics.json").is_file()
    r = run_cli("-q", "examples", "ex")
    assert (r.code, r.out, r.err) == (0, "", "")
    plain = run_cli("simulate", "step3_lut", "--out", "n", "--trace", "none")
    loud = run_cli("-v", "simulate", "step3_lut", "--out", "v", "--trace", "none")
    assert plain.code == loud.code == 0
    assert len(loud.out.splitlines()) > len(plain.out.splitlines())
    assert "the packaged example" in loud.out and "s CPU" in loud.out
    # errors are always shown
    r = run_cli("-q", "simulate", "nosuch", "--out", "x")
    assert r.code == 2 and r.err.startswith("linsense: error:") and r.out == ""
    run_cli("-q", "-v", "examples", "--list").refused("-q and -v")


# ---------------------------------------------------------------------------------- --help
def test_help_lines_are_whole_sentences_and_link_the_docs_site(run_cli):
    """`linsense --help` lists each command with a complete line (click cut "Draw paper Figs.");
    the help texts link the guides where they can be read: docs/*.md of the source tree until the
    site is published (linsense.version.SITE_PUBLISHED), never an address that resolves nowhere."""
    r = run_cli("--help")
    assert r.code == 0
    listed = re.findall(r"^  ([a-z-]+)\s{2,}(.+)$", r.out.split("Commands:")[1], flags=re.M)
    assert {name for name, _ in listed} == set(cli.commands)
    for name, line in listed:
        assert line.endswith(".") and not line.endswith("...") and len(line) <= 60, (name, line)
    assert docs("cli") in r.out
    for name in cli.commands:
        text = run_cli(name, "--help").out
        if not SITE_PUBLISHED:
            assert DOCS_URL not in text and "example.org" not in text, name
        for page in re.findall(r"docs/([a-z-]+)\.md", text):
            assert (ROOT / "docs" / f"{page}.md").is_file(), (name, page)


def test_shell_completion_script(tmp_path):
    """docs/cli.md's completion: `_LINSENSE_COMPLETE=bash_source linsense` prints the script."""
    env = {**os.environ, "_LINSENSE_COMPLETE": "bash_source"}
    p = subprocess.run([sys.executable, "-c", "from linsense.__main__ import entry; entry()"],
                       capture_output=True, text=True, env=env, timeout=60)
    assert p.returncode == 0 and "complete -o nosort -F" in p.stdout, p.stderr


# ---------------------------------------------------------------------------------- examples
def test_examples_copies_every_packaged_file_and_refuses_to_overwrite(run_cli, tmp_path):
    dest = tmp_path / "ex"
    r = run_cli("examples", dest)
    assert r.code == 0, r.err
    copied = sorted(p.relative_to(dest).as_posix() for p in dest.rglob("*") if p.is_file())
    assert copied == examples.files() and len(copied) >= 40
    for rel in copied:
        assert (dest / rel).read_bytes() == (examples.ROOT / rel).read_bytes()
        assert str(dest / rel) in r.out.splitlines()
    on_disk = sorted(p.relative_to(examples.ROOT).as_posix() for p in examples.ROOT.rglob("*")
                     if p.is_file() and p.suffix not in (".py", ".pyc"))
    assert copied == on_disk  # (every file of the folder, nothing left out)
    (dest / "motors" / "small30.toml").write_text("mine")
    run_cli("examples", dest).refused("exists", "--force")
    assert (dest / "motors" / "small30.toml").read_text() == "mine"  # (nothing overwritten)
    assert run_cli("examples", dest, "--force").code == 0
    assert (dest / "motors" / "small30.toml").read_bytes() == examples.path("motors", "small30").read_bytes()
    # the copies refer to each other: a copied sweep finds its copied scenario
    from linsense.sweep import load_sweep

    assert load_sweep(dest / "sweeps" / "injection.toml").scenario_path.resolve() == \
        (dest / "scenarios" / "step3_lut.toml").resolve()


def test_every_example_is_in_the_wheel():
    """pyproject's package data for linsense.examples matches every example file (else a pip user
    would lack it)."""
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"][
        "linsense.examples"]
    for rel in examples.files():
        assert any(fnmatch.fnmatch(rel, g) and rel.count("/") == g.count("/") for g in globs), rel


def test_every_example_resolves_by_name(tmp_path):
    from linsense.fea.geometry import load_geometry
    from linsense.identify.bench import read_bench_csv
    from linsense.identify.emf_record import read_emf_csv
    from linsense.model.motor import load_motor
    from linsense.scenario.load import load_scenario
    from linsense.sweep import load_sweep

    assert examples.names("motors") == ["harmonic", "m100_edge", "m20_hv", "m30_low", "m45_24v", "m60_pos20k",
                                        "m90_heavy", "small30", "tabulated", "tubular56_thin_sat"]
    for name in examples.names("motors"):
        assert load_motor(name).source == f"example {name}"
    for name in examples.names("scenarios"):
        assert load_scenario(examples.resolve("scenarios", name)).spec.scenario.name == name
    for name in examples.names("sweeps"):
        assert load_sweep(examples.resolve("sweeps", name)).scenario_path.is_file()
    for name in examples.names("fea"):
        load_geometry(examples.resolve("fea", name))
    for name in examples.names("bench"):  # (HF bench files, and open-circuit records: time_s first)
        path = examples.resolve("bench", name)
        (read_emf_csv if Path(path).read_text().startswith("time_s") else read_bench_csv)(path)
    assert examples.names("firmware") == [] and "firmware/main.c" in examples.files()
    # a file that exists wins over a name; a folder of that name does not hide it (a sweep's --out
    # named after the sweep, run again from the same place)
    os.chdir(tmp_path)
    Path("injection").mkdir()
    assert examples.resolve("sweeps", "injection") == str(examples.path("sweeps", "injection"))
    Path("small30").write_text("")
    assert examples.resolve("motors", "small30") == "small30"


def test_a_scenario_names_an_example_motor(run_cli, tmp_path):
    """`motor = "tubular56_thin_sat"` in a scenario anywhere: the packaged motor with its tables."""
    from linsense.errors import InputError
    from linsense.scenario.load import scenario_from_dict
    from linsense.sim.build import resolve_motor

    data = tomllib.loads(examples.path("scenarios", "step3_lut").read_text())
    sc = scenario_from_dict({**data, "motor": "tubular56_thin_sat"}, "t.toml", tmp_path)
    motor = resolve_motor(sc)
    assert motor.saturation is not None and len(motor.saturation.tables) == 5
    with pytest.raises(InputError, match="unknown preset 'nosuch'.*small30"):
        resolve_motor(scenario_from_dict({**data, "motor": "nosuch"}, "t.toml", tmp_path))


@pytest.mark.parametrize("args, kind", [
    (["simulate", "nosuch", "--out", "o"], "scenario"),
    (["sweep", "nosuch", "--out", "o"], "sweep"),
    (["fea", "nosuch", "--out", "o"], "geometry"),
    (["identify", "nosuch", "--out", "o"], "bench"),
    (["tune", "--motor", "nosuch", "--out", "o.toml"], "motor"),
    (["calibrate", "--scenario", "nosuch", "--out", "o"], "scenario"),
])
def test_an_unknown_name_is_one_line_listing_the_names(run_cli, tmp_path, args, kind):
    os.chdir(tmp_path)
    line = run_cli(*args).refused(f"unknown {kind} 'nosuch'", "linsense examples DIR")
    kinds = {"scenario": "scenarios", "sweep": "sweeps", "geometry": "fea", "bench": "bench",
             "motor": "motors"}
    for name in examples.names(kinds[kind]):
        assert name in line
    assert not Path("o").exists() and not Path("o.toml").exists()


def test_docs_list_every_json_key():
    """docs/cli.md's table of --json summaries names each command's keys (a key added to a summary
    and not documented fails here)."""
    rows = {}
    for line in (ROOT / "docs" / "cli.md").read_text().splitlines():
        m = re.match(r"^\| `([a-z-]+)` \| (.*)$", line)
        if m and m.group(1) in JSON_KEYS:
            rows[m.group(1)] = m.group(2)
    assert set(rows) == set(JSON_KEYS)
    for command, keys in JSON_KEYS.items():
        for key in keys - COMMON:
            assert f"`{key}`" in rows[command], (command, key)


def test_the_command_runs_blas_on_one_thread_unless_told(monkeypatch, capsys):
    # (OpenBLAS's pool, started at numpy's import, costs ~50 ms of CPU per process; the command's
    # linear algebra is small and a sweep runs in parallel by runs)
    from linsense.__main__ import entry

    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    with pytest.raises(SystemExit):
        entry(["--version"])
    assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "3")
    with pytest.raises(SystemExit):
        entry(["--version"])
    assert os.environ["OPENBLAS_NUM_THREADS"] == "3"  # (the user's setting wins)
    capsys.readouterr()

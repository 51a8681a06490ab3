"""Lean by default: the core install runs without the extras' packages.

A subprocess hides the extras' modules (pyarrow, pandas, dask, distributed, skfem, jinja2,
markupsafe, rich) behind a ``sys.meta_path`` finder that refuses them, as in a venv made by a bare
``pip install linsense``. There the core commands (model, lut, tune with its verification, simulate
with the CSV trace and --plot, calibrate, bench-emulate, identify, reproduce --model-only: the
model figures of ``plot``) run, and each feature of an extra stops with exit code 2 and one line
naming the extra to install. The dependency lists of
pyproject.toml are checked against :data:`linsense._extras.EXTRAS`.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

from linsense._extras import EXTRAS, available, require, require_extras
from linsense.errors import LinsenseError, MissingExtraError

ROOT = Path(__file__).resolve().parents[1]
#: the examples: in the package (src/linsense/examples) or, before they moved there, beside it
EXAMPLES = next(p for p in (ROOT / "src" / "linsense" / "examples", ROOT / "examples") if p.is_dir())
SCENARIO = EXAMPLES / "scenarios" / "step3_lut.toml"
#: every module an extra brings (what the core must never import)
BLOCKED = sorted({m for mods in EXTRAS.values() for m in mods})
#: distribution (pyproject.toml) -> the top-level modules linsense imports from it
MODULES_OF = {"pyarrow": {"pyarrow"}, "pandas": {"pandas"}, "dask": {"dask", "distributed"},
              "scikit-fem": {"skfem"}, "jinja2": {"jinja2", "markupsafe"}, "rich": {"rich"}}

# run in the subprocess before anything else: the extras' modules cannot be imported
BLOCKER = textwrap.dedent("""
    import sys
    BLOCKED = set({blocked!r})

    class _NotInstalled:
        def find_spec(self, name, path=None, target=None):
            if name.partition(".")[0] in BLOCKED:
                raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
            return None

    sys.meta_path.insert(0, _NotInstalled())
""")

# one process runs the CLI commands in turn (sys.exit caught), records each one's exit code and
# stderr, and finally which blocked modules were imported (none can be)
SESSION = textwrap.dedent("""
    import contextlib, io, json, os, sys
    from linsense.cli import main

    out = {{}}
    for name, argv in json.loads(sys.argv[1]):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                main(argv)
                rc = 0
            except SystemExit as e:
                rc = e.code if isinstance(e.code, int) else 1
            except Exception as e:  # (escaped the CLI's handling: a traceback for a user)
                rc = f"raised {{type(e).__name__}}: {{e}}"
        out[name] = {{"rc": rc, "stderr": err.getvalue()}}
    out["_imported"] = sorted(m for m in sys.modules if m.partition(".")[0] in BLOCKED)
    print(json.dumps(out))
""")


def _session(commands: list[tuple[str, list[str]]], cwd: Path, blocked=BLOCKED) -> dict:
    code = BLOCKER.format(blocked=list(blocked)) + SESSION.format()
    r = subprocess.run([sys.executable, "-c", code, json.dumps(commands)], capture_output=True, text=True,
                       cwd=cwd, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


CORE = [
    ("model", ["model", "--motor", "ecce2010", "--points", "36", "--out", "model.csv"]),
    ("lut", ["lut", "--motor", "ecce2010", "--points", "36", "--format", "c", "--out", "lut.h"]),
    ("tune", ["tune", "--motor", "ecce2010", "--quick", "--out", "tuned.toml"]),
    ("simulate csv", ["simulate", str(SCENARIO), "--trace", "csv", "--out", "sim_csv"]),
    ("simulate default", ["simulate", str(SCENARIO), "--out", "sim_default", "--plot"]),
    ("calibrate", ["calibrate", "--motor", "ecce2010", "--positions", "4", "--fidelity", "average",
                   "--out", "cal"]),
    ("bench-emulate", ["bench-emulate", "--motor", "ecce2010", "--positions", "16", "--out", "bench.csv"]),
    ("identify", ["identify", "bench.csv", "--motor", "ecce2010", "--out", "ident"]),
    ("reproduce --model-only", ["reproduce", "--model-only", "--out", "repro_model"]),
]

# each feature of an extra, and the extras its one line must name
GATED = [
    ("simulate parquet", ["simulate", str(SCENARIO), "--trace", "parquet", "--out", "sim_pq"], "parquet"),
    ("fea", ["fea", "tubular56", "--positions", "12", "--mesh", "coarse", "--out", "fea"], "fea"),
    ("sweep", ["sweep", str(EXAMPLES / "sweeps" / "SWEEP"), "--out", "sweep"], "sweep"),
    ("reproduce", ["reproduce", "--quick", "--out", "repro"], "report,sweep"),
]


@pytest.fixture(scope="module")
def core_session(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("core")
    sweeps = sorted((EXAMPLES / "sweeps").glob("*.toml"))
    assert sweeps, "no example sweep"
    gated = [(n, [a.replace("SWEEP", sweeps[0].name) for a in argv]) for n, argv, _ in GATED]
    return cwd, _session(CORE + gated, cwd)


def test_no_module_of_an_extra_is_imported_by_the_core(core_session):
    _, out = core_session
    assert out["_imported"] == []


@pytest.mark.parametrize("name", [n for n, _ in CORE])
def test_core_command_runs_without_the_extras(core_session, name):
    cwd, out = core_session
    res = out[name]
    # (tune exits 1 when a check of its certificate fails: a verdict, as with every extra installed)
    assert res["rc"] in ((0, 1) if name == "tune" else (0,)), res["stderr"]
    assert "linsense: error" not in res["stderr"] and "Traceback" not in res["stderr"], res["stderr"]


def test_core_outputs_are_written(core_session):
    cwd, _ = core_session
    for rel in ("model.csv", "lut.h", "tuned.toml", "tuned.verification.json", "sim_csv/trace.csv",
                "sim_default/trace.csv", "sim_default/sim.png", "cal/lut_measured.csv", "ident/motor.toml",
                "repro_model/lut.csv"):
        assert (cwd / rel).exists(), rel
    assert not (cwd / "sim_default" / "trace.parquet").exists()
    header = (cwd / "sim_csv" / "trace.csv").read_text().splitlines()[0]
    assert header.startswith("t_s,x_m,")


def test_default_trace_without_pyarrow_is_csv_with_a_note(core_session):
    _, out = core_session
    err = out["simulate default"]["stderr"]
    assert "trace.csv" in err and "pip install -e '.[parquet]'" in err
    assert "note" not in out["simulate csv"]["stderr"]  # (asked for: no note)


@pytest.mark.parametrize("name,extras", [(n, e) for n, _, e in GATED])
def test_feature_of_an_extra_stops_in_one_line_naming_it(core_session, name, extras):
    cwd, out = core_session
    res = out[name]
    assert res["rc"] == 2, res
    lines = res["stderr"].splitlines()
    assert len(lines) == 1, res["stderr"]
    assert lines[0].startswith("linsense: error: ") and f"pip install -e '.[{extras}]'" in lines[0]
    assert "Traceback" not in res["stderr"]


def test_a_refused_feature_leaves_no_output(core_session):
    cwd, _ = core_session
    for _, argv, _ in GATED:
        out = argv[argv.index("--out") + 1]
        assert not (cwd / out).exists(), out


def test_the_api_stops_in_one_line_too(tmp_path):
    code = BLOCKER.format(blocked=BLOCKED) + textwrap.dedent("""
        import importlib
        from linsense.errors import MissingExtraError
        from linsense.report.html import render_report
        from linsense.sim.simulation import simulate
        from linsense.scenario.load import load_scenario
        from linsense.sim.trace import write_trace
        r = simulate(load_scenario(sys.argv[1]).replace(scenario={"duration": 0.05}, reference={"at": 0.01}))
        got = []
        for call in (r.to_dataframe, lambda: write_trace(r, "t.parquet", "parquet"),
                     lambda: render_report({}, {}, {}),
                     lambda: importlib.import_module("linsense.fea.solver"),
                     lambda: importlib.import_module("linsense.sweep")):
            try:
                call()
                got.append("ran")
            except MissingExtraError as e:
                got.append(str(e))
        print("\\n".join(got))
    """)
    r = subprocess.run([sys.executable, "-c", code, str(SCENARIO)], capture_output=True, text=True,
                       cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    src = "in linsense's source tree (make install installs every extra)"
    assert r.stdout.splitlines() == [
        "Result.to_dataframe needs pandas, which is not installed: pip install -e '.[parquet]' " + src,
        "the Parquet trace needs pyarrow, which is not installed: pip install -e '.[parquet]' " + src,
        "the HTML report needs jinja2, which is not installed: pip install -e '.[report]' " + src,
        "the FEA (linsense fea) needs skfem, which is not installed: pip install -e '.[fea]' " + src,
        "the sweep engine (linsense sweep) needs dask, distributed, pandas, pyarrow, rich, which are not "
        "installed: pip install -e '.[sweep]' " + src,
    ]


def test_the_blocker_is_what_stops_them(tmp_path):
    # the same session with nothing hidden: the gated features get past their checks (they fail, if
    # at all, on their arguments, never on a missing extra), so the refusals above come from the
    # missing modules
    out = _session([("simulate parquet", GATED[0][1])], tmp_path, blocked=[])
    assert out["simulate parquet"]["rc"] == 0, out
    assert (tmp_path / "sim_pq" / "trace.parquet").is_file()


# --- the helper itself


def test_require_names_the_extra_and_the_feature():
    with pytest.raises(MissingExtraError) as e:
        require("linsense_no_such_module.sub", extra="parquet", feature="the thing")
    assert str(e.value) == ("the thing needs linsense_no_such_module, which is not installed: "
                            "pip install -e '.[parquet]' in linsense's source tree (make install installs "
                            "every extra)")
    assert isinstance(e.value, LinsenseError) and isinstance(e.value, ImportError)
    assert require("json", extra="report", feature="x") is sys.modules["json"]
    with pytest.raises(ValueError, match="unknown extra"):
        require("json", extra="nonsense", feature="x")


def test_require_tells_a_broken_module_from_a_missing_one(tmp_path, monkeypatch):
    # an installed module that fails to import (a missing dependency of its own) is not "not installed"
    (tmp_path / "linsense_broken_mod.py").write_text("import linsense_absent_dependency\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(MissingExtraError, match=r"needs linsense_broken_mod, which fails to import "
                                                r"\(No module named 'linsense_absent_dependency'\): pip"):
        require("linsense_broken_mod", extra="fea", feature="the thing")


def test_require_extras_names_every_missing_module_once(monkeypatch):
    import linsense._extras as ex

    monkeypatch.setattr(ex, "available", lambda m: m not in ("pandas", "jinja2"))
    with pytest.raises(MissingExtraError) as e:
        require_extras("report", "sweep", "parquet", feature="it")
    assert str(e.value) == ("it needs jinja2, pandas, which are not installed: pip install -e "
                            "'.[report,sweep,parquet]' in linsense's source tree (make install installs "
                            "every extra)")
    monkeypatch.setattr(ex, "available", lambda m: True)
    require_extras("report", "sweep", feature="it")


def test_available_does_not_import():
    assert available("json") and not available("linsense_no_such_module")
    assert not available("")


# --- pyproject.toml


def _project() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _name(req: str) -> str:
    return re.split(r"[\s\[<>=!~;]", req, maxsplit=1)[0].lower()


def test_core_dependencies_hold_none_of_the_extras_packages():
    proj = _project()
    core = {_name(r) for r in proj["dependencies"]}
    extras = proj["optional-dependencies"]
    for extra in EXTRAS:
        assert not core & {_name(r) for r in extras[extra]}, extra
    assert not core & set(MODULES_OF)


def test_pyproject_extras_bring_the_modules_extras_names():
    extras = _project()["optional-dependencies"]
    # (the developers' extras: dev for the tests and lint, docs for the site and its browser check;
    # no feature of the package is gated on them)
    assert set(extras) == set(EXTRAS) | {"all", "dev", "docs"}
    for extra, modules in EXTRAS.items():
        brought = set().union(*(MODULES_OF[_name(r)] for r in extras[extra]))
        assert brought == set(modules), extra
    assert extras["all"] == [f"linsense[{','.join(EXTRAS)}]"]

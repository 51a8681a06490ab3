"""The layers of the package: what ``lint-imports`` (.importlinter) cannot say.

``make lint`` checks the layers contract; these tests add: no import cycle between linsense's
modules (lazy imports inside functions count, as for import-linter), no private name (``_x``)
imported from outside the package that holds it, ``import linsense`` (and its lower layers)
loads neither the C extension nor matplotlib, and no two modules share a basename (nor are ``x.py``
and ``xs.py``).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "linsense"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def _package_of(module: str) -> str:
    """The package a module belongs to: itself for a package's ``__init__``, else its parent."""
    return module if MODULES.get(module, Path()).name == "__init__.py" else module.rpartition(".")[0]


def _imports(module: str) -> list[tuple[int, str, str | None]]:
    """(line, imported module, imported name or None) of every import in ``module``, at any depth
    (imports inside functions too), relative imports resolved."""
    tree = ast.parse(MODULES[module].read_text(), str(MODULES[module]))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name, None) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = _package_of(module).split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            out += [(node.lineno, base, a.name) for a in node.names]
    return out


def _targets(module: str) -> set[str]:
    """linsense modules that ``module`` imports (a ``from pkg import sub`` names the module ``sub``)."""
    found = set()
    for _, mod, name in _imports(module):
        if name is not None and f"{mod}.{name}" in MODULES:
            found.add(f"{mod}.{name}")
        elif mod in MODULES:
            found.add(mod)
    found.discard(module)
    return found


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    sccs = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                scc = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    scc.append(w)
                    if w == v:
                        break
                if len(scc) > 1:
                    sccs.append(sorted(scc))
    return sccs


def test_cycle_finder_finds_a_cycle():
    # the finder itself: a -> b -> c -> a is one cycle, d -> a none
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(g) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle():
    graph = {m: _targets(m) for m in MODULES}
    assert graph["linsense.sim.simulation"], "the graph sees no import: the walker is broken"
    assert _cycles(graph) == []


def _private_imports() -> list[str]:
    bad = []
    for module in MODULES:
        for line, mod, name in _imports(module):
            if not (mod == "linsense" or mod.startswith("linsense.")):
                continue
            # the private part: a module of the path (``linsense.x._y``) or the imported name
            path = mod.split(".") + ([name] if name else [])
            for k, part in enumerate(path):
                if part.startswith("_") and not part.startswith("__"):
                    owner = ".".join(path[:k])  # the package or module that holds the private name
                    holder = owner if owner in MODULES and MODULES[owner].name == "__init__.py" else \
                        _package_of(owner) if owner in MODULES else owner
                    home = _package_of(module)
                    if not (home == holder or home.startswith(holder + ".")):
                        bad.append(f"{module}:{line} imports {'.'.join(path[: k + 1])}")
                    break
    return bad


def test_private_name_rule_catches_one(monkeypatch):
    # the rule itself, on a module that takes a private helper of another package
    fake = PKG / "fea" / "outputs.py"
    text = "from linsense.report.figures import _position_axis\nfrom linsense.analysis.hf import psi_lut\n"
    monkeypatch.setattr(Path, "read_text", lambda self, *a, **k: text if self == fake else
                        Path.read_bytes(self).decode())
    assert any("linsense.fea.outputs:1 imports linsense.report.figures._position_axis" in b
               for b in _private_imports())


def test_no_private_name_imported_across_packages():
    # ``_x`` is private to the package that holds it: linsense._digest to linsense, a ``_helper`` of
    # linsense.report.figures to linsense.report
    assert _private_imports() == []


# each below sim (importing a module imports what it imports: these cover the lower layers' modules)
LIGHT = ("linsense", "linsense.model.motor", "linsense.model.tolerance", "linsense.analysis.model_table",
         "linsense.analysis.summary", "linsense.analysis.rotating", "linsense.analysis.square",
         "linsense.analysis.stability", "linsense.compensation.lut", "linsense.tune",
         "linsense.tune.injection", "linsense.identify.identification", "linsense.fea.per_load")


@pytest.mark.parametrize("module", LIGHT)
def test_import_loads_no_c_extension_and_no_matplotlib(module):
    code = (f"import sys, {module}\n"
            "bad = [m for m in ('linsense._ctrl', 'matplotlib') if m in sys.modules]\n"
            "assert not bad, bad\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr


PACKAGES_WITHOUT_TABLES = ["linsense.sim", "linsense.scenario", "linsense.studies", "linsense.verify",
                           "linsense.sweep", "linsense.firmware", "linsense.identify", "linsense.fea",
                           "linsense.reproduce", "linsense.cli"]


@pytest.mark.parametrize("package", PACKAGES_WITHOUT_TABLES)
def test_a_package_import_loads_no_table_or_cluster_library(package):
    """``import linsense.sweep`` (or any package) leaves pandas, pyarrow and dask to the functions
    that use them: the package's re-export of ``sweep_to`` once loaded pandas and pyarrow (68 MB,
    and make bench's peak RSS of every later child, which is forked from the bench's process)."""
    code = (f"import sys, {package}\n"
            "bad = [m for m in ('pandas', 'pyarrow', 'dask') if m in sys.modules]\n"
            "assert not bad, bad\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr


def test_only_the_binding_and_the_simulator_import_the_c_extension():
    # the compiled extension (linsense._ctrl, not a module import-linter sees) is reached through the
    # binding (linsense.ctrl), the simulator's own calls (linsense.sim) and limits' lazy read of C's sizes
    users = {m for m in MODULES for _, mod, name in _imports(m)
             if mod == "linsense._ctrl" or (mod == "linsense" and name == "_ctrl")}
    assert "linsense.ctrl" in users
    assert {m for m in users if not m.startswith("linsense.sim.")} <= {"linsense.ctrl", "linsense.limits"}


def test_the_check_sees_the_c_extension_when_loaded():
    # the same check fails where the extension is needed: the simulator
    code = "import sys, linsense.sim.core\nassert 'linsense._ctrl' in sys.modules\n"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr


def test_every_module_of_the_package_sits_in_a_layer():
    """.importlinter's layers name every top-level module and package of linsense (a new one that
    sits in no layer would escape the contract), and nothing that does not exist."""
    import configparser

    cfg = configparser.ConfigParser()
    cfg.read(SRC.parent / ".importlinter")
    named = {name.strip().removeprefix("linsense.") for line in cfg["importlinter:contract:layers"]["layers"]
             .split("\n") for name in line.split("|") if name.strip()}
    pkg = PKG
    present = ({p.stem for p in pkg.glob("*.py") if p.stem != "__init__"}
               | {p.name for p in pkg.iterdir() if (p / "__init__.py").is_file()})
    assert present - named == set(), f"modules in no layer of .importlinter: {sorted(present - named)}"
    assert named - present == set(), f".importlinter names what does not exist: {sorted(named - present)}"


def _name_clashes(paths: list[Path]) -> list[str]:
    """Modules that share a basename, and ``X.py`` beside ``Xs.py`` (packages' ``__init__`` and
    ``__main__`` apart): a name says which module it is without its package."""
    by_stem: dict[str, list[str]] = {}
    for p in paths:
        if p.stem not in ("__init__", "__main__"):
            by_stem.setdefault(p.stem, []).append(str(p.relative_to(SRC)))
    clashes = [f"{stem}: {sorted(where)}" for stem, where in sorted(by_stem.items()) if len(where) > 1]
    clashes += [f"{stem} and {stem}s: {sorted(by_stem[stem] + by_stem[stem + 's'])}"
                for stem in sorted(by_stem) if stem + "s" in by_stem]
    return clashes


def test_name_clash_rule_catches_both_kinds():
    # the rule itself: a second tables.py, and a runs.py beside a run.py
    paths = [PKG / "a" / "tables.py", PKG / "b" / "tables.py", PKG / "a" / "run.py", PKG / "b" / "runs.py",
             PKG / "a" / "__init__.py", PKG / "b" / "__init__.py"]
    assert _name_clashes(paths) == ["tables: ['linsense/a/tables.py', 'linsense/b/tables.py']",
                                    "run and runs: ['linsense/a/run.py', 'linsense/b/runs.py']"]


def test_every_module_name_is_unique():
    """No two modules of linsense share a basename, nor are ``X.py`` and ``Xs.py``."""
    assert _name_clashes(list(MODULES.values())) == []

"""Every public definition of linsense has a numpydoc docstring that the API reference renders cleanly.

Public, precisely
-----------------
- A *public module* is a module of the ``linsense`` package none of whose dotted-path parts begins with
  ``_`` (``linsense.model.motor`` is public, ``linsense._digest`` is not), except ``linsense.cli`` and its
  submodules (their docstrings are click help texts) and ``linsense.__main__``. A package counts through its
  ``__init__``.
- Its *public names*: every class and function defined in the module (not imported into it) whose
  name does not begin with ``_`` (what the site renders: its filter is ``!^_``), and the classes and
  functions its ``__all__`` names (re-exports: ``linsense.sim.Result`` is
  :class:`linsense.sim.result.Result`, checked where it is defined; a name served lazily by a module
  ``__getattr__``, such as ``linsense.Motor``, must be defined in some public module).
- Of each public class, every method and property defined in its body whose name does not begin with
  ``_``; ``__init__`` is documented in the class docstring (the numpydoc convention).
- Constants and other module attributes are not definitions here (they carry ``#:`` comments).

What is checked
---------------
The API reference of the docs site is rendered by mkdocstrings-python, which parses docstrings with
griffe's numpy parser (``docstring_style: numpy``); the site is built with ``--strict``, where any
warning of that parser fails the build (a documented parameter not in the signature does). So this
test uses the same parser: griffe, pinned in the dev extra, loading the sources statically (no
import: about a second). ``numpydoc.validate`` was not chosen: its rules (a period after every
summary, See Also formats...) are not what the site renders, it imports every object (the whole
package, its C extension), and what it accepts griffe may still warn about. For every public module,
class, function, method and property:

1. it has a docstring with a one-line summary;
2. griffe's numpy parser reads it without a warning (unknown parameter, unparseable line, confusing
   indentation, empty section), and every documented parameter has a type (in the docstring or the
   signature);
3. a function's or method's ``Parameters`` (and ``Other Parameters``) name exactly the parameters of
   its signature, each once, in any order, ``self``/``cls`` aside; a class with its own ``__init__``
   documents exactly that ``__init__``'s (in the class docstring or the ``__init__``'s);
4. a function that returns a value (a non-``None`` return annotation, or a ``return <value>`` in its
   own body) has ``Returns``; a generator has ``Yields``;
5. every field of a record class (the annotated class attributes of a dataclass, pydantic model,
   NamedTuple or TypedDict: its constructor's parameters) is documented: in the class's
   ``Parameters`` or ``Attributes``, by its own attribute docstring, or by a pydantic
   ``Field(description=...)`` (the keys' one home: docs/simulator.md is written from them);
6. its sections come in numpydoc's order (Parameters, Attributes, Returns/Yields, Other Parameters,
   Raises, Warns, ..., Examples).

The checker itself is tested below on a small module and on broken copies of it.
"""

from __future__ import annotations

import ast
import logging
import textwrap
from pathlib import Path

import griffe
import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
#: modules (and their submodules) left to other owners: click help texts, the console entry
EXCLUDED_MODULES = {"linsense.cli", "linsense.__main__"}
#: numpydoc's order of the sections a reader looks for (the rest: anywhere)
SECTION_ORDER = {"parameters": 0, "attributes": 1, "returns": 2, "yields": 2, "receives": 3,
                 "other parameters": 4, "raises": 5, "warns": 6, "examples": 9}
#: the compiled cffi extension: exported by linsense.ctrl, no Python source
COMPILED = "linsense._ctrl."
#: annotations that mean "returns nothing"
NO_RETURN = {"None", "NoReturn", "Never", "typing.NoReturn", "typing.Never"}


class _Collect(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.WARNING:
            self.messages.append(record.getMessage())


def parse(obj) -> tuple[list, list[str]]:
    """The numpy sections of ``obj``'s docstring and the warnings griffe's parser logged reading it."""
    handler = _Collect()
    log = logging.getLogger("griffe")
    level, propagate = log.level, log.propagate
    log.addHandler(handler)
    log.setLevel(logging.WARNING)  # (whatever another test or plugin set: the warnings must reach us)
    log.propagate = False
    try:
        assert log.isEnabledFor(logging.WARNING), "logging is disabled: griffe's warnings would be lost"
        sections = obj.docstring.parse("numpy")
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
        log.propagate = propagate
    return sections, handler.messages


def _modules(module):
    yield module
    for sub in module.modules.values():
        if not sub.is_alias:
            yield from _modules(sub)


def is_public_module(module) -> bool:
    """Whether ``module`` is a public module as defined in this file's docstring."""
    path = module.path
    excluded = any(path == m or path.startswith(m + ".") for m in EXCLUDED_MODULES)
    return not excluded and not any(p.startswith("_") for p in path.split("."))


def _is_definition(obj) -> bool:
    return obj.is_function or obj.is_class


def public_api(package) -> tuple[list, list, list[str]]:
    """The public modules and definitions of ``package`` (griffe objects), as defined above, and the
    problems met enumerating them (an exported name defined nowhere public)."""
    modules = [m for m in _modules(package) if is_public_module(m)]
    found: dict[str, object] = {}
    problems: list[str] = []
    lazy: list[tuple[str, str]] = []
    for module in modules:
        exports = module.exports
        if exports is not None:
            for name in (str(e) for e in exports):
                member = module.members.get(name)
                if member is None:
                    lazy.append((module.path, name))
                    continue
                try:
                    target = member.final_target if member.is_alias else member
                except griffe.AliasResolutionError:
                    # only the compiled extension (cffi's ffi and lib) has no source to read
                    if not member.target_path.startswith(COMPILED):
                        problems.append(f"{module.path}.{name}: cannot resolve {member.target_path}")
                    continue
                if _is_definition(target):
                    found.setdefault(target.path, target)
        for name, member in module.members.items():
            if not member.is_alias and not name.startswith("_") and _is_definition(member):
                found.setdefault(member.path, member)
    for cls in [o for o in found.values() if o.is_class]:
        for name, member in cls.members.items():
            if member.is_alias or name.startswith("_"):
                continue
            if member.is_function or (member.is_attribute and "property" in member.labels):
                found.setdefault(member.path, member)
    names = {o.name for o in found.values()}
    problems += [f"{path}.{name}: exported but defined in no public module"
                 for path, name in lazy if name not in names and not name.startswith("__")]
    return modules, list(found.values()), problems


def _documented(sections, *kinds: str) -> list[str]:
    out = []
    for section in sections:
        if section.kind.value in kinds:
            out.extend(item.name.lstrip("*") for item in section.value)
    return out


def _signature_names(func) -> list[str]:
    names = [p.name for p in func.parameters]
    if func.parent is not None and func.parent.is_class and "staticmethod" not in func.labels and names:
        names = names[1:]  # self or cls
    return names


def _own_body(func) -> ast.AST | None:
    try:
        tree = ast.parse(textwrap.dedent(func.source))
    except (SyntaxError, ValueError, OSError, AttributeError):
        return None
    return tree.body[0] if tree.body else None


def _returns_and_yields(node) -> tuple[bool, bool]:
    """Whether the function ``node`` has a ``return <value>`` (not ``None``) and a ``yield`` in its own
    body (not in nested functions, classes or lambdas)."""
    returns = yields = False
    stack = list(ast.iter_child_nodes(node))
    while stack:
        n = stack.pop()
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            continue
        if isinstance(n, ast.Return) and n.value is not None and not (
                isinstance(n.value, ast.Constant) and n.value.value is None):
            returns = True
        if isinstance(n, (ast.Yield, ast.YieldFrom)):
            yields = True
        stack.extend(ast.iter_child_nodes(n))
    return returns, yields


#: base classes that make a class a record (its annotated class attributes are its fields)
RECORD_BASES = ("BaseModel", "NamedTuple", "TypedDict")


def _fields(cls) -> list:
    """The record fields of ``cls`` (a dataclass, pydantic model, NamedTuple or TypedDict; none for
    another class): annotated attributes of its own body, not ClassVar, not private, not pydantic's
    ``model_config``."""
    bases = [str(b).rsplit(".", 1)[-1] for b in cls.bases]
    if "dataclass" not in cls.labels and not any(b in RECORD_BASES for b in bases):
        return []
    out = []
    for name, member in cls.members.items():
        if member.is_alias or not member.is_attribute or name.startswith("_") or name == "model_config":
            continue
        if "property" in member.labels or member.annotation is None:
            continue
        if "ClassVar" in str(member.annotation):
            continue
        out.append(member)
    return out


def _field_self_documented(member) -> bool:
    if member.docstring is not None and member.docstring.value.strip():
        return True
    value = str(member.value) if member.value is not None else ""
    return value.startswith(("Field(", "pydantic.Field(")) and "description=" in value


def check(obj) -> list[str]:
    """The problems of ``obj``'s docstring (a griffe module, class, function or property), empty when
    it is fine; see this file's docstring for the rules."""
    where = obj.path
    if obj.docstring is None or not obj.docstring.value.strip():
        return [f"{where}: no docstring"]
    problems = []
    if not obj.docstring.value.strip().splitlines()[0].strip():
        problems.append(f"{where}: no one-line summary")
    sections, warnings = parse(obj)
    problems += [f"{where}: griffe: {w}" for w in warnings]
    if obj.is_module or (obj.is_attribute and "property" in obj.labels):
        return problems
    documented = _documented(sections, "parameters", "other parameters")
    for section in sections:
        if section.kind.value in ("parameters", "other parameters"):
            problems += [f"{where}: parameter without a type: {item.name}" for item in section.value
                         if item.annotation is None]
    if obj.is_class:
        fields = _fields(obj)
        init = obj.members.get("__init__")  # (griffe writes a dataclass's: a record, below)
        if init is not None and not init.is_alias and "dataclass" not in obj.labels:
            # the class documents its own __init__ (or __init__ itself does)
            if init.docstring is not None:
                documented += _documented(parse(init)[0], "parameters", "other parameters")
            expected = _signature_names(init)
        else:
            # a record (dataclass, pydantic model) takes its fields: checked below, in Parameters or
            # Attributes; griffe's parser flags a Parameters entry that is not one
            expected = None
        if expected is not None:
            problems += _compare(where, documented, expected)
        attributes = set(documented) | set(_documented(sections, "attributes"))
        for f in fields:
            if f.name not in attributes and not _field_self_documented(f):
                problems.append(f"{where}: field {f.name!r} documented nowhere (Parameters, Attributes, "
                                "its own docstring or Field(description=...))")
        return problems
    problems += _compare(where, documented, _signature_names(obj))
    kinds = {s.kind.value for s in sections}
    order = [SECTION_ORDER[s.kind.value] for s in sections if s.kind.value in SECTION_ORDER]
    if order != sorted(order):
        problems.append(f"{where}: sections out of numpydoc's order "
                        f"({', '.join(s.kind.value for s in sections if s.kind.value in SECTION_ORDER)})")
    node = _own_body(obj)
    returns, yields = _returns_and_yields(node) if node is not None else (False, False)
    annotation = str(obj.returns) if obj.returns is not None else None
    if annotation is not None and not yields and annotation not in NO_RETURN:
        returns = True
    if yields and "yields" not in kinds:
        problems.append(f"{where}: a generator without a Yields section")
    elif returns and not yields and "returns" not in kinds:
        problems.append(f"{where}: returns a value (annotation {annotation}) but has no Returns section")
    return problems


def _compare(where: str, documented: list[str], expected: list[str]) -> list[str]:
    problems = []
    missing = [n for n in expected if n not in documented]
    extra = [n for n in documented if n not in expected]
    twice = sorted({n for n in documented if documented.count(n) > 1})
    if missing:
        problems.append(f"{where}: parameters not documented: {', '.join(missing)}")
    if extra:
        problems.append(f"{where}: documented parameters not in the signature: {', '.join(extra)}")
    if twice:
        problems.append(f"{where}: parameters documented twice: {', '.join(twice)}")
    return problems


def load(name: str = "linsense", search_paths=(SRC,)):
    """The package ``name`` loaded statically by griffe from ``search_paths``, aliases resolved."""
    return griffe.load(name, search_paths=[str(p) for p in search_paths], resolve_aliases=True,
                       resolve_external=False, docstring_parser=None)


@pytest.fixture(scope="module")
def api():
    return public_api(load())


def test_the_public_api_is_what_the_definition_says(api):
    modules, definitions, problems = api
    assert not problems, "\n".join(problems)
    paths = {o.path for o in definitions}
    mods = {m.path for m in modules}
    # a re-export counts once, where it is defined; cli and private modules are out
    assert "linsense.sim.result.Result" in paths and "linsense.sim.Result" not in paths
    assert "linsense.cli" not in mods and "linsense._digest" not in mods and "linsense.model" in mods
    assert "linsense.model.inductance.InductanceModel.from_params" in paths
    assert not any(p.rsplit(".", 1)[-1].startswith("_") for p in paths)
    assert len(definitions) > 300


def test_every_public_docstring_is_numpydoc(api):
    modules, definitions, _ = api
    problems = [p for obj in [*modules, *definitions] for p in check(obj)]
    assert not problems, f"{len(problems)} docstring problems:\n" + "\n".join(problems)


# ---------------------------------------------------------------------------- the checker itself
GOOD = '''
"""A module."""


def area(width: float, height: float = 1.0) -> float:
    """Area of a rectangle.

    Parameters
    ----------
    width : float
        Width, m.
    height : float, optional
        Height, m.

    Returns
    -------
    float
        The area, m^2.
    """
    return width * height


class Box:
    """A box.

    Parameters
    ----------
    side : float
        Side, m.
    """

    def __init__(self, side: float) -> None:
        self.side = side

    def volume(self):
        """The volume.

        Returns
        -------
        float
            m^3.
        """
        return self.side ** 3
'''


def _problems_of(code: str) -> list[str]:
    with griffe.temporary_visited_module(textwrap.dedent(code)) as module:
        objs = [module, *[m for m in module.members.values() if not m.is_alias]]
        for cls in [o for o in objs if o.is_class]:
            objs += [m for n, m in cls.members.items() if not n.startswith("_") and m.is_function]
        return [p for o in objs for p in check(o)]


def test_checker_passes_a_good_module():
    assert _problems_of(GOOD) == []


HEIGHT = "    height : float, optional\n        Height, m.\n"
AREA_RETURNS = "\n    Returns\n    -------\n    float\n        The area, m^2.\n"
VOLUME_RETURNS = "        Returns\n        -------\n        float\n            m^3.\n"
BOX_PARAMETERS = "    Parameters\n    ----------\n    side : float\n        Side, m.\n"
VOLUME_DOC = ('        """The volume.\n\n        Returns\n        -------\n        float\n            m^3.\n'
              '        """\n')
BROKEN = {
    "missing parameter": (GOOD.replace(HEIGHT, ""), "parameters not documented: height"),
    "unknown parameter": (GOOD.replace("    width : float\n", "    depth : float\n"),
                          "does not appear in the function signature"),
    "parameter twice": (GOOD.replace(HEIGHT, HEIGHT + HEIGHT), "parameters documented twice: height"),
    "no Returns": (GOOD.replace(AREA_RETURNS, ""), "no Returns section"),
    "no type anywhere": (GOOD.replace("    side : float\n", "    side\n").replace("side: float", "side"),
                         "parameter without a type: side"),
    "bad indentation": (GOOD.replace("        Width, m.", "      Width, m."), "Confusing indentation"),
    "empty section": (GOOD.replace(VOLUME_RETURNS, "        Returns\n        -------\n"),
                      "Empty returns section"),
    "section order": (GOOD.replace(AREA_RETURNS, "").replace("    Parameters\n    ----------\n    width",
                                                             AREA_RETURNS.lstrip("\n")
                                                             + "\n    Parameters\n    ----------\n    width"),
                      "sections out of numpydoc's order"),
    "class parameter": (GOOD.replace(BOX_PARAMETERS, ""), "Box: parameters not documented: side"),
    "no docstring": (GOOD.replace(VOLUME_DOC, ""), "Box.volume: no docstring"),
}


@pytest.mark.parametrize("name", BROKEN)
def test_checker_fails_a_broken_docstring(name):
    broken, expected = BROKEN[name]
    assert broken != GOOD, "the breakage did not apply"
    problems = _problems_of(broken)
    assert any(expected in p for p in problems), problems


def test_checker_wants_record_fields_documented():
    code = '''
    """A module."""
    from dataclasses import dataclass


    @dataclass
    class Point:
        """A point.

        Attributes
        ----------
        x : float
            m.
        """

        x: float
        y: float
    '''
    assert any("field 'y' documented nowhere" in p for p in _problems_of(code))
    assert not any("field" in p for p in _problems_of(code.replace("y: float", 'y: float\n        """m."""')))


def test_checker_wants_yields_for_a_generator():
    code = '''
    """A module."""


    def count(n: int):
        """Count.

        Parameters
        ----------
        n : int
            How far.
        """
        yield from range(n)
    '''
    assert any("without a Yields section" in p for p in _problems_of(code))


def test_every_package_says_what_it_is_for():
    """A package's docstring says what the package is for, not only its name (four were
    ``\"\"\"linsense.fea.\"\"\"`` before this check): its first sentence holds more than the dotted name."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "src" / "linsense"
    bare = []
    for init in sorted(root.rglob("__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))) or ""
        name = ".".join(("linsense",) + init.parent.relative_to(root).parts)
        words = doc.split("\n\n")[0].replace(name, "").replace(":", "").strip(" .\n")
        if len(words.split()) < 4:
            bare.append(f"{init.relative_to(root.parent)}: {doc.splitlines()[0] if doc else '(none)'}")
    assert not bare, bare


def test_the_source_names_no_issue_numbers():
    """The source explains itself without the tracker: no "issue N" in src/ or csrc/ (before this check
    53 comments and docstrings pointed at issues a reader of the code cannot see)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    found = []
    for folder in ("src/linsense", "csrc"):
        for f in sorted((root / folder).rglob("*")):
            if f.suffix in (".py", ".c", ".h", ".toml", ".cmake") and f.is_file():
                for n, line in enumerate(f.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
                    if re.search(r"\b[Ii]ssues? \d+", line):
                        found.append(f"{f.relative_to(root)}:{n}: {line.strip()[:80]}")
    assert not found, found


#: where a reader meets the project's text without the tracker: the docs (the site and the
#: repository's pages), the README, the tools and the tests
READER_TEXT = ("README.md", ".importlinter", "docs", "tools", "tests")
#: the kinds of file read there
READER_SUFFIXES = (".md", ".py", ".ipynb", ".sh", ".c", ".js", ".css", "")


def test_the_docs_tools_and_tests_name_no_issue_numbers():
    """A reader of the docs, the tools and the tests cannot see the tracker either: no "issue N" (or
    "issues N", "issue #N", also across a line break) in README.md, .importlinter, docs/, tools/ or
    tests/; a sentence says what it means (the rule, or "before this check" where the history
    explains it)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    number = re.compile(r"\b[Ii]ssues?\s+#?\d+")
    files = []
    for name in READER_TEXT:
        path = root / name
        files += sorted(path.rglob("*")) if path.is_dir() else [path] if path.is_file() else []
    found = []
    for f in files:
        rel = f.relative_to(root).as_posix()
        if not f.is_file() or f.suffix not in READER_SUFFIXES or "__pycache__" in f.parts:
            continue
        text = f.read_text(encoding="utf-8", errors="replace")
        hits = [text.count("\n", 0, m.start()) + 1 for m in number.finditer(text)]
        if hits:
            found.append(f"{rel}:{hits}")
    assert not found, found

"""The first hour: a new user with a fresh clone, then the wheel, following the README as
written. Each family has one rule, checked here on every instance:

* install commands: every ``pip install`` of the README and the home page installs from the clone
  or the wheel that ``make dist`` builds (the package is not on PyPI);
* links: no link of README.md or docs/*.md goes to a placeholder host, and every relative link names
  a file and heading that exist (tests/doclinks.py);
* what ``make test`` needs: every Debian package that the Makefile and .ci/run install is named in
  the README's set-up section, and ``make test``'s tools need no valgrind (only ``make bench`` uses
  it);
* the extras: every extra a command requires (``require``/``require_extras`` in the sources) is
  named beside that command in the install section;
* the Python snippets: every ``python`` block of the README and the home page runs and prints the
  number its comment states, and "Python in three lines" is three lines;
* MANIFEST.in: every path it names exists.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from doclinks import broken_links, markdown_pages, placeholder_links

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
HOME = ROOT / "docs" / "index.md"
NUMBERS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6}


def section(text: str, title: str) -> str:
    """The body of the ``## title...`` section of ``text`` (up to the next ``##`` heading)."""
    m = re.search(rf"^## {re.escape(title)}.*?$(.*?)(?=^## |\Z)", text, re.M | re.S)
    assert m, f"no section '## {title}'"
    return m[1]


def blocks(text: str, lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", text, re.M | re.S)


# ---------------------------------------------------------------------------------- installing


@pytest.mark.parametrize("page", [README, HOME], ids=lambda p: p.name)
def test_every_pip_install_installs_from_the_clone_or_the_wheel(page):
    """``pip install linsense`` finds nothing (not published): each ``pip install`` of the page's
    commands names the clone (``-e .``, ``.``) or a wheel of dist/."""
    text = page.read_text()
    cmds = [ln.split("#")[0] for b in blocks(text, "sh") for ln in b.splitlines() if "pip install" in ln]
    assert cmds, f"{page.name} says nowhere how to install"
    bad = []
    for cmd in cmds:
        targets = [t.strip("\"'") for t in cmd.split("pip install", 1)[1].split() if not t.startswith("-")]
        if not targets or not all(re.match(r"(\.|dist/|\$\(ls dist/|\./)", t) for t in targets):
            bad.append(cmd.strip())
    assert not bad, f"{page.name}: installs from a registry that does not have linsense: {bad}"


def test_the_install_section_names_the_extras_each_command_requires():
    """``reproduce`` needs ``[report,sweep]`` (``require_extras`` in its pipeline): every command's
    extras, as the sources require them, are named on a line of the install section that names the
    command."""
    needs: dict[str, set[str]] = {}
    call = re.compile(r"require(?:_extras)?\(([^)]*?)feature=\s*[\"'][^\"']*\(linsense (\w+)\)[\"']", re.S)
    for f in (ROOT / "src" / "linsense").rglob("*.py"):
        for args, cmd in call.findall(f.read_text()):
            named = re.findall(r"extra=\s*[\"'](\w+)[\"']", args) or re.findall(r"[\"'](\w+)[\"']", args)
            needs.setdefault(cmd, set()).update(named)
    assert needs.get("reproduce") == {"report", "sweep"}, needs  # (the rule finds the calls)
    for page in (README, HOME):
        install = section(page.read_text(), "Install")
        for cmd, extras in sorted(needs.items()):
            want = "[" + ",".join(sorted(extras)) + "]"
            lines = [ln for ln in install.splitlines() if re.search(rf"\b{cmd}\b", ln) and want in ln]
            assert lines, f"{page.name}: the install section does not say that {cmd} needs {want}"


def test_the_setup_section_lists_what_make_test_installs():
    """Every Debian package that ``make test`` (its ``tools`` target and the ``apt_need`` calls of
    ``cmake-tool`` and ``docs-tools``) and .ci/run install is named in the README's set-up section,
    with the time it takes."""
    make, ci = (ROOT / "Makefile").read_text(), (ROOT / ".ci" / "run").read_text()
    packages: set[str] = set()
    for lists in re.findall(r'(?:missing|optional)="(?:\$\$\w+ )?([a-z0-9 .+-]+)"', make):
        packages |= set(lists.split())
    for lists in re.findall(r"apt-get install -y -qq ([a-z0-9][a-z0-9 .+-]*?)(?: >|\)|$)", make, re.M):
        packages |= set(lists.split())
    for lists in re.findall(r"\$\(call apt_need,[^,]*,([a-z0-9 .+-]+)\)", make):  # (not apt_want's: optional)
        packages |= set(lists.split())
    for lists in re.findall(r"need\+=\(([^)]*)\)", ci):
        packages |= set(lists.split())
    must = {"cmake", "gcc-arm-none-eabi", "qemu-system-arm", "chromium", "python3-venv", "libjs-katex"}
    assert must <= packages, packages  # (the parse finds them)
    setup = section(README.read_text(), "Set-up from a clone")
    missing = sorted(p for p in packages if not re.search(rf"(?<![\w-]){re.escape(p)}(?![\w-])", setup))
    assert not missing, f"the README's set-up section does not name {missing}"
    assert re.search(r"\b\d+ min\b", setup), "the set-up section says not how long make test takes"


def _stub(folder: Path, name: str, body: str = "exit 0") -> None:
    p = folder / name
    p.write_text(f"#!/bin/sh\n{body}\n")
    p.chmod(0o755)


@pytest.mark.skipif(shutil.which("make") is None, reason="make not installed")
@pytest.mark.parametrize("absent", ["valgrind", "arm-none-eabi-gcc"])
def test_make_tests_tools_need_no_valgrind(tmp_path, absent):
    """``make tools`` (a prerequisite of ``make test``) for a user who is not root, with every tool
    on PATH but ``absent``: without valgrind it passes (only ``make bench`` counts instructions with
    it), without the cross compiler it stops naming the package (the check still works)."""
    bin_ = tmp_path / "bin"
    bin_.mkdir()
    for tool in ("arm-none-eabi-gcc", "qemu-system-arm", "cmake", "chromium", "valgrind"):
        if tool != absent:
            _stub(bin_, tool)
    _stub(bin_, "id", "echo 1000")  # (not root: nothing is installed, a missing tool stops make)
    r = subprocess.run([shutil.which("make"), "-s", "--no-print-directory", "tools", "FUZZ_CC=true"],
                       cwd=ROOT, env={"PATH": str(bin_), "HOME": str(tmp_path), "LC_ALL": "C"},
                       capture_output=True, text=True, timeout=60)
    if absent == "valgrind":
        assert r.returncode == 0, r.stdout + r.stderr
        assert "valgrind" not in r.stdout + r.stderr
    else:
        assert r.returncode != 0, r.stdout + r.stderr
        assert "please install: gcc-arm-none-eabi libnewlib-arm-none-eabi" in r.stderr, r.stderr


# ------------------------------------------------------------------------------------- links


@pytest.mark.parametrize("page", markdown_pages(ROOT), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_link_goes_to_a_placeholder_host(page):
    assert placeholder_links(page.read_text()) == []


@pytest.mark.parametrize("page", markdown_pages(ROOT), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_names_a_file_and_heading_that_exist(page):
    assert broken_links(page, ROOT) == []


def test_the_link_rule_finds_each_kind_of_broken_link(tmp_path):
    """The rule itself: a missing file, a missing heading, a heading whose anchor GitHub and the
    site spell differently, a placeholder host; links inside code are not links."""
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "a.md").write_text("# A\n\n## Output folders (`--out DIR`)\n\n## Plain one\n")
    page = tmp_path / "README.md"
    page.write_text("[x](docs/a.md#plain-one) [y](docs/none.md) [z](docs/a.md#nothing)\n"
                    "[w](docs/a.md#output-folders-out-dir) ![p](docs/a.md) <https://site.example.org/a/>\n"
                    "`[c](docs/none.md)`\n\n```\n[d](docs/none.md)\n```\n")
    bad = broken_links(page, tmp_path)
    assert [b.split(": ", 2)[1] for b in bad] == ["docs/none.md", "docs/a.md#nothing",
                                                  "docs/a.md#output-folders-out-dir"], bad
    assert "(for GitHub)" in bad[2]
    assert placeholder_links(page.read_text()) == ["https://site.example.org/a/"]


def test_the_readme_links_the_guides_and_says_how_to_build_the_site():
    """The README's documentation links are the Markdown pages of docs/ (they render where the
    repository is read), one for each guide, and it says how to build the site."""
    text = README.read_text()
    guides = {p.name for p in (ROOT / "docs").glob("*.md") if p.name != "index.md"}
    linked = set(re.findall(r"\]\(docs/([\w-]+\.md)(?:#[\w-]+)?\)", text))
    assert guides <= linked, f"guides the README does not link: {sorted(guides - linked)}"
    assert "make docs" in text and "make docs-build" in text


# -------------------------------------------------------------------------- the Python snippets


def _python_blocks() -> list[tuple[str, str]]:
    return [(f"{p.name}:{i}", b) for p in (README, HOME)
            for i, b in enumerate(blocks(p.read_text(), "python"))]


def test_python_in_three_lines_is_three_lines():
    m = re.search(r"^## Python in (\w+) lines?\n+```python\n(.*?)^```", README.read_text(), re.M | re.S)
    assert m, "no 'Python in N lines' section with its block"
    lines = [ln for ln in m[2].splitlines() if ln.strip()]
    assert len(lines) == NUMBERS[m[1]], f"'Python in {m[1]} lines' is {len(lines)} lines"


@pytest.mark.parametrize("name,code", _python_blocks(), ids=[n for n, _ in _python_blocks()])
def test_every_python_block_prints_what_its_comment_says(tmp_path, name, code):
    """The block runs in a fresh interpreter (in an empty folder) and prints the number that its
    last line's comment states, to the comment's digits."""
    last = code.rstrip().splitlines()[-1]
    said = re.search(r"#\s*(-?\d+(?:\.(\d+))?)", last)
    assert said, f"{name}: the last line states no result: {last!r}"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    printed = re.search(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", r.stdout)
    assert printed, r.stdout
    digits = len(said[2] or "")
    assert round(float(printed[0]), digits) == float(said[1]), (r.stdout, said[1])


# -------------------------------------------------------------------------------- MANIFEST.in


def test_every_path_manifest_in_names_exists():
    """A ``graft examples`` of a folder that moved adds nothing (and warns while building the
    sdist): every folder and file pattern of MANIFEST.in names something of the tree."""
    bad = []
    for line in (ROOT / "MANIFEST.in").read_text().splitlines():
        words = line.split("#")[0].split()
        if not words or words[0] in ("global-include", "global-exclude"):
            continue
        cmd, args = words[0], words[1:]
        if cmd in ("graft", "prune", "recursive-include", "recursive-exclude"):
            if not (ROOT / args[0]).is_dir():
                bad.append(line)
        elif cmd in ("include", "exclude"):
            bad += [f"{line} ({a})" for a in args if not list(ROOT.glob(a))]
        else:
            bad.append(f"{line} (unknown directive)")
    assert not bad, bad

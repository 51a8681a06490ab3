"""mkdocs hook: the API reference, one page per public package, generated from the docstrings.

Each page (``api/<package>.md``) holds the package's docstring and, for every public module of the
package (a name without a leading underscore), that module's docstring and public members, rendered
by mkdocstrings (numpy docstring style, ``mkdocs.yml``). The module list is read from the source
tree at build time, so that a new module is documented without editing anything. The navigation's
``API reference`` entry (``api/index.md``) is expanded to the index and the package pages.
"""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.structure.files import File, Files

INDEX = "api/index.md"
#: the public packages of linsense, in their layer order (bottom first: docs/architecture.md)
PACKAGES = ("model", "analysis", "compensation", "scenario", "tune", "sim", "studies", "identify", "fea",
            "verify", "sweep", "firmware", "report", "reproduce")


#: the shared modules under the layers (docs/architecture.md), on one page of their own
SHARED = ("errors", "version", "io", "limits", "validation", "ctrl")


def _src(config) -> Path:
    return Path(config.config_file_path).resolve().parent / "src" / "linsense"


def modules(src: Path, package: str) -> list[str]:
    """The public modules of ``linsense.<package>`` (files and sub-packages), sorted."""
    names = []
    for p in sorted((src / package).iterdir()):
        if p.name.startswith("_"):
            continue
        if p.suffix == ".py" or (p.is_dir() and (p / "__init__.py").is_file()):
            names.append(p.stem)
    return names


def on_config(config):
    """Expand the ``API reference`` entry of the navigation to the index and one page per package."""
    pages = [INDEX, *({f"linsense.{p}": f"api/{p}.md"} for p in PACKAGES),
             {"Shared modules": "api/shared.md"}]
    for item in config.nav or []:
        if isinstance(item, dict):
            for title, value in item.items():
                # (the entry, or the list it became when this config was expanded before)
                if value == INDEX or (isinstance(value, list) and value[:1] == [INDEX]):
                    item[title] = pages
                    return config
    raise ValueError(f"mkdocs.yml: the nav has no {INDEX} entry for the API reference")


def page(src: Path, package: str) -> str:
    """The Markdown of one package's page: mkdocstrings directives, one per module."""
    parts = [f"# linsense.{package}\n",
             f"::: linsense.{package}\n    options:\n      show_root_heading: false\n      members: false\n"]
    for mod in modules(src, package):
        parts.append(f"::: linsense.{package}.{mod}\n")
    return "\n".join(parts)


#: a Sphinx role of a docstring as the page renders it, ``:func:<code>~linsense.sim.simulate</code>``
_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|data|exc|obj|const):<code>(~?)([^<]*)</code>")


def _role(m: re.Match) -> str:
    # (``~a.b.c`` shows ``c``, as Sphinx does)
    return f"<code>{m[2].rsplit('.', 1)[-1] if m[1] else m[2]}</code>"


def on_page_content(html: str, page, config, files) -> str:
    """The numpydoc docstrings' Sphinx roles (``:func:`x```), which Markdown leaves as text, shown as
    the code they name."""
    if not page.file.src_uri.startswith("api/"):
        return html
    return _ROLE.sub(_role, html)


def on_files(files: Files, config) -> Files:
    """Add the index and the package pages to the site."""
    src = _src(config)
    rows = []
    for package in PACKAGES:
        files.append(File.generated(config, f"api/{package}.md", content=page(src, package)))
        mods = ", ".join(f"`{m}`" for m in modules(src, package))
        rows.append(f"| [linsense.{package}]({package}.md) | {mods} |")
    intro = ("The modules under every layer: the one exception hierarchy, the version and the docs' "
             "address, files and atomic writes, the size limits, the key checks, the C binding.\n")
    shared = "\n".join(["# Shared modules\n", intro, *(f"::: linsense.{m}\n" for m in SHARED)])
    files.append(File.generated(config, "api/shared.md", content=shared))
    rows.append("| [shared modules](shared.md) | " + ", ".join(f"`linsense.{m}`" for m in SHARED) + " |")
    index = ("# API reference\n\nGenerated from the docstrings (numpy style) of the public modules of each "
             "package, in the layer order of [the architecture](../architecture.md): each package imports "
             "only from those above it in this list, and from the shared modules (`linsense.errors`, "
             "`linsense.io`, `linsense.limits`, ...).\n\n"
             "The top-level names `linsense.load_motor`, `linsense.simulate` and `linsense.simulate_many` "
             "are documented under [linsense.model](model.md) and [linsense.sim](sim.md), the exceptions "
             "(`linsense.LinsenseError`, `InputError`, `ModelError`) under [shared modules](shared.md).\n\n"
             "| package | modules |\n|---|---|\n" + "\n".join(rows) + "\n")
    files.append(File.generated(config, INDEX, content=index))
    return files

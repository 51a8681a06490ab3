"""mkdocs hook: the API reference, one page per public package, generated from the docstrings.

Each page (``api/<package>.md``) holds the package's docstring and, for every public module of the
package (a name without a leading underscore), that module's docstring and public members, rendered
by mkdocstrings (numpy docstring style, ``mkdocs.yml``). The module list is read from the source
tree at build time, so that a new module is documented without editing anything. The navigation's
``API reference`` entry (``api/index.md``) is expanded to the index and the package pages.
"""

from __future__ import annotations

from pathlib import Path

from mkdocs.structure.files import File, Files

INDEX = "api/index.md"
#: the public packages of linsense, in their layer order (bottom first: docs/architecture.md)
PACKAGES = ("model", "analysis", "compensation", "tune", "sim", "identify", "fea", "sweep", "report",
            "reproduce")


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
    pages = [INDEX] + [{f"linsense.{p}": f"api/{p}.md"} for p in PACKAGES]
    for item in config.nav or []:
        if isinstance(item, dict):
            for title, value in item.items():
                if value == INDEX:
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


def on_files(files: Files, config) -> Files:
    """Add the index and the package pages to the site."""
    src = _src(config)
    rows = []
    for package in PACKAGES:
        files.append(File.generated(config, f"api/{package}.md", content=page(src, package)))
        mods = ", ".join(f"`{m}`" for m in modules(src, package))
        rows.append(f"| [linsense.{package}]({package}.md) | {mods} |")
    index = ("# API reference\n\nGenerated from the docstrings (numpy style) of the public modules of each "
             "package, in the layer order of [the architecture](../architecture.md): each package imports "
             "only from those above it in this list, and from the shared modules (`linsense.errors`, "
             "`linsense.io`, `linsense.limits`, ...).\n\n"
             "The top-level names `linsense.load_motor`, `linsense.simulate` and `linsense.simulate_many` "
             "are documented under [linsense.model](model.md) and [linsense.sim](sim.md).\n\n"
             "| package | modules |\n|---|---|\n" + "\n".join(rows) + "\n")
    files.append(File.generated(config, INDEX, content=index))
    return files

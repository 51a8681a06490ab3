"""One version, shown with the C library's: ``src/linsense/version.py`` is the
one source (pyproject reads it), the C library's ``LS_VERSION_*`` carry the same number, and
``linsense --version`` shows both with the build's LS_REAL."""

from __future__ import annotations

import importlib.metadata
import re
import tomllib
from pathlib import Path

from click.testing import CliRunner

import linsense
from linsense.cli import cli

ROOT = Path(__file__).resolve().parents[1]


def _c_version() -> str:
    text = (ROOT / "csrc" / "include" / "linsense" / "ls_types.h").read_text()
    parts = [re.search(rf"#define LS_VERSION_{k} (\d+)", text)[1] for k in ("MAJOR", "MINOR", "PATCH")]
    return ".".join(parts)


def test_one_version_for_the_package_and_the_c_library():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in meta["project"] and "version" in meta["project"]["dynamic"]
    assert meta["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "linsense.version.__version__"}
    assert importlib.metadata.version("linsense") == linsense.__version__  # (what pip installed)
    assert _c_version() == linsense.__version__


def test_version_option_shows_both():
    r = CliRunner().invoke(cli, ["--version"])
    assert r.exit_code == 0, r.output
    assert r.output == f"linsense {linsense.__version__} (C library {_c_version()}, LS_REAL float)\n"


def test_licence_is_mit_and_shipped():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert meta["license"] == "MIT" and meta["license-files"] == ["LICENSE"]
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert "include LICENSE" in (ROOT / "MANIFEST.in").read_text()

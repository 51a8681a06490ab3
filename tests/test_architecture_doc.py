"""docs/architecture.md's picture (docs/img/architecture.svg) is drawn from the code: the layers of
.importlinter and the two paths of tools/gen_architecture.py, each step a function that exists and
that an earlier step imports."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _gen():
    spec = importlib.util.spec_from_file_location("gen_architecture", ROOT / "tools" / "gen_architecture.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_picture_is_up_to_date():
    """The committed SVG is what the script draws from today's code (run python
    tools/gen_architecture.py after a layer or a path step changes)."""
    gen = _gen()
    assert (ROOT / "docs" / "img" / "architecture.svg").read_text() == gen.render()
    assert "img/architecture.svg" in (ROOT / "docs" / "architecture.md").read_text()


def test_every_layer_package_is_drawn():
    gen = _gen()
    svg = gen.render()
    for row in gen.layers():
        for pkg in row:
            label = "__main__" if pkg == "linsense.__main__" else pkg.removeprefix("linsense.")
            assert f">{label}</text>" in svg


def test_a_step_the_code_does_not_take_is_refused(monkeypatch):
    """A path step whose function does not exist, or that no earlier step imports, is refused."""
    gen = _gen()
    steps = dict(gen.PATHS)
    first = steps["tune"][0]
    monkeypatch.setattr(gen, "PATHS", {"tune": (first, ("linsense.model.motor", "no_such_function", ""))})
    with pytest.raises(SystemExit, match="has no no_such_function"):
        gen.render()
    monkeypatch.setattr(gen, "PATHS", {"tune": (first, ("linsense.sweep", "sweep", ""))})
    with pytest.raises(SystemExit, match="imported by no step before it"):
        gen.render()

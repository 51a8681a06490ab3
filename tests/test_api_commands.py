"""The Python API of the commands: ``linsense.sim.simulate_to`` and ``linsense.verify.tune`` write
and return what ``linsense simulate`` and ``linsense tune`` write, byte for byte (timing aside); the
command line is a thin layer over them."""

from __future__ import annotations

from pathlib import Path

import pytest

import linsense.sim
from linsense.sim.scenario import load_scenario


def _toml(path: Path, duration: float = 0.4) -> Path:
    path.write_text(f'motor = "ecce2010"\n[scenario]\nname = "t"\nduration = {duration}\n'
                    '[reference]\nposition_mm = 1.0\nat = 0.02\n')
    return path


@pytest.mark.parametrize("trace", ["csv", "none"])
def test_simulate_to_writes_what_the_cli_writes(run_cli, tmp_path, trace):
    """simulate_to from Python and ``linsense simulate`` give the same files (timing.json aside)."""
    p = _toml(tmp_path / "s.toml")
    r = run_cli("simulate", p, "--out", tmp_path / "cli", "--trace", trace, "--mat", "--decimate", 2)
    assert r.code == 0, r.err
    done = linsense.sim.simulate_to(tmp_path / "api", load_scenario(p), trace=trace, mat=True, decimate=2)
    names = sorted(f.name for f in (tmp_path / "cli").iterdir())
    assert names == sorted(f.name for f in (tmp_path / "api").iterdir())
    assert {f.name for f in done.files} == set(names) - {".linsense-set.json"}
    for name in names:
        if name not in ("timing.json", ".linsense-set.json"):
            assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "api" / name).read_bytes(), name
    assert done.metrics["samples"] == 6400 and "wall_s" in done.timing
    assert done.stable == done.metrics["stable"]


def test_simulate_to_draws_with_the_figure_given(tmp_path):
    """The figure is drawn by the function given (the simulator is below the figures)."""
    drawn = []
    linsense.sim.simulate_to(tmp_path / "o", load_scenario(_toml(tmp_path / "s.toml")), trace="none",
                             plot=lambda data, path: drawn.append((data, path)))
    assert len(drawn) == 1 and drawn[0][0] is not None and drawn[0][1].name == "sim.png"

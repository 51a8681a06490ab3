"""`linsense simulate --pil`: the drive on the Cortex-M4F under QEMU, the plant on
the host; its metrics equal the host's, its refusals are one line (docs/firmware.md, "Processor in
the loop")."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest

from linsense.errors import InputError
from linsense.firmware import pil

SCENARIO = """motor = "ecce2010"
[scenario]
name = "pil_step"
duration = 0.5
seed = 1
[control]
mode = "sensorless_lut"
[reference]
type = "step"
position_mm = 1.0
at = 0.05
"""


def cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "linsense", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


@pytest.mark.parametrize("extra,named", [(["--plot"], "--plot"), (["--trace", "csv"], "--trace"),
                                         (["--decimate", "4"], "--decimate")])
def test_pil_runs_the_scenario_as_it_is(tmp_path, extra, named):
    (tmp_path / "s.toml").write_text(SCENARIO)
    r = cli("simulate", "s.toml", "--pil", "--out", "o", *extra, cwd=tmp_path)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, r.stderr
    assert "--pil" in r.stderr and named in r.stderr
    assert not (tmp_path / "o").exists()


def test_pil_refuses_standard_input(tmp_path):
    r = subprocess.run([sys.executable, "-m", "linsense", "simulate", "-", "--pil", "--out", "o"],
                       input=SCENARIO, capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert r.returncode == 2 and "standard input" in r.stderr and len(r.stderr.splitlines()) == 1


def test_without_a_source_tree_pil_says_what_it_needs(tmp_path, monkeypatch):
    monkeypatch.setattr(pil, "source_tree", lambda: None)
    with pytest.raises(InputError, match="source tree"):
        pil.closed_loop(tmp_path / "s.toml", tmp_path / "o")


@pytest.mark.slow
@pytest.mark.skipif(pil.source_tree() is None or any(shutil.which(t) is None for t in pil.TOOLS),
                    reason="needs a source tree with the ARM cross compiler and QEMU (make tools)")
def test_pil_metrics_equal_the_host_run(tmp_path):
    (tmp_path / "s.toml").write_text(SCENARIO)
    r = cli("simulate", "s.toml", "--pil", "--out", "pil", "--check", "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert set(doc) == {"command", "files", "ok", "metrics", "timing", "pil"} and doc["ok"]
    rec = json.loads((tmp_path / "pil" / "pil.json").read_text())
    assert rec["identical_steps"] and rec["pass"]
    assert rec["metric_differences"] == {} and rec["metric_mismatches"] == {}
    assert rec["steps"] == 8000 and rec["libm"] == "newlib on the target, glibc on the host"
    assert cli("simulate", "s.toml", "--trace", "none", "--out", "host", cwd=tmp_path).returncode == 0
    host = json.loads((tmp_path / "host" / "metrics.json").read_text())
    fw = json.loads((tmp_path / "pil" / "metrics.json").read_text())
    assert fw == host  # (key for key: the firmware under QEMU computes what the simulator does)
    assert fw["stable"]

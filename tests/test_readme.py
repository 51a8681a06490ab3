"""Every command of the README's command block runs as written and exits 0, in order, in a fresh
folder (a new user's first minutes: the `tune` example ends verified)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def readme_commands() -> list[str]:
    """The lines of the README's command block (the ``sh`` block that starts with ``linsense
    examples``), comments kept (the shell drops them)."""
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)```", text, flags=re.S)
    block = next(b for b in blocks if b.startswith("linsense examples"))
    return [ln for ln in block.splitlines() if ln.strip()]


def test_the_block_is_found():
    cmds = readme_commands()
    assert len(cmds) >= 15 and any(c.startswith("linsense tune --motor small30 ") for c in cmds)


@pytest.mark.slow
def test_every_readme_command_exits_0(tmp_path):
    """The whole block as one shell script (``set -e``: the first failure ends it), with the
    installed ``linsense`` on the PATH."""
    script = "set -e\n" + "\n".join(f"echo '>>> {c[:60]}'\n{c}" for c in readme_commands()) + "\n"
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    r = subprocess.run(["bash", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, (r.stdout[-3000:], r.stderr[-3000:])
    assert "verified: every check passed" in r.stdout
    assert (tmp_path / "small30.verification.json").exists() and (tmp_path / "fw" / "CMakeLists.txt").exists()
    assert (tmp_path / "cal30" / "lut_measured.json").exists() and (tmp_path / "small30m.toml").exists()

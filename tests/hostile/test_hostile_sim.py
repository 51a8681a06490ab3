"""Hostile simulator inputs (issue 23): scenario keys out of the range the controller library
accepts, keys another key makes meaningless, and Ctrl-C at start-up. Each case: the input, the exit
code and the words of its one line (the key the user wrote, the value, the limit)."""

from __future__ import annotations

import signal
import subprocess
import sys

# the console entry under a stalled import of numpy: Ctrl-C arrives while it imports, always
_STALLED_IMPORT = r'''
import sys, time

class Stall:
    def find_spec(self, name, path=None, target=None):
        if name == "numpy":
            print("importing numpy", flush=True)
            time.sleep(60)
        return None

sys.meta_path.insert(0, Stall())
from linsense.__main__ import entry
entry(["--version"])
'''


def test_ctrl_c_while_importing_is_one_line_and_130():
    p = subprocess.Popen([sys.executable, "-c", _STALLED_IMPORT], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "importing numpy"  # (the interrupt lands in the import)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
    finally:
        p.kill()
    assert p.returncode == 130, (p.returncode, err)
    assert err == "linsense: interrupted\n", err


def test_the_entry_is_light_and_is_the_script():
    """``import linsense`` imports no numpy (the entry imports it inside its handling), and the
    ``linsense`` script is that entry."""
    code = "import sys, linsense.__main__; print('numpy' in sys.modules, 'click' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout.split() == ["False", "False"], r
    import tomllib
    from pathlib import Path

    pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
    scripts = tomllib.loads(pyproject.read_text())["project"]["scripts"]
    assert scripts["linsense"] == "linsense.__main__:entry"
    r = subprocess.run([sys.executable, "-m", "linsense", "--version"], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0 and "linsense" in r.stdout, r

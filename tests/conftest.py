"""Shared fixtures: the reference motor, random motors, and an in-process CLI runner."""

from __future__ import annotations

import signal
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from linsense.cli import main
from linsense.model.inductance import InductanceModel
from linsense.model.motor import Motor, load_motor
from linsense.tune.design import DriveData

# A run launched in the background of a shell without job control (`cmd &` in a script) starts with
# SIGINT ignored (POSIX), and its children inherit that: the Ctrl-C tests (tests/hostile) would fail
# for the launcher's sake. Python's own handler, as a run from a terminal has it (children start
# with the default again).
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

ECCE = dict(L0=2.75e-3, L2=-0.317e-3, M0=-0.92e-3, M2=-0.317e-3, dM0=-0.47e-3)

#: the class motors' files and their drives (drives.toml)
CLASS = Path(__file__).resolve().parents[1] / "src" / "linsense" / "examples" / "motors" / "class"


def class_drive(name: str) -> tuple[str, DriveData]:
    """A shipped motor's spec and drive data: ecce2010 with the defaults, a class motor with its
    drives.toml entry."""
    if name == "ecce2010":
        return "ecce2010", DriveData()
    data = tomllib.loads((CLASS / "drives.toml").read_text())[name]
    return str(CLASS / f"{name}.toml"), DriveData(**data)


@pytest.fixture(scope="session")
def ecce() -> Motor:
    return load_motor("ecce2010")


def make_motor(inductance: InductanceModel, name: str = "test") -> Motor:
    return Motor(name=name, R_s=9.0, pole_pitch=0.056, force_constant=20.0, mass=1.5,
                 inductance=inductance, source=name)


@st.composite
def salient_params(draw):
    """Random eq. (3) parameter sets with a clear, single-signed saliency (mH scale)."""
    L0 = draw(st.floats(1e-3, 10e-3))
    M0 = draw(st.floats(-0.45, -0.1)) * L0
    L2 = draw(st.floats(-0.2, -0.02)) * L0
    M2 = draw(st.floats(-0.2, 0.0)) * L0
    # saliency Lq - Ld = -L2 - 2 M2 + (4/3) dM0 cos(.): keep |(4/3) dM0| below 60 % of its mean
    mean_sal = -L2 - 2 * M2
    dM0 = draw(st.floats(-0.45, 0.45)) * mean_sal
    return dict(L0=L0, L2=L2, M0=M0, M2=M2, dM0=dM0)


class CliResult:
    def __init__(self, code: int, out: str, err: str) -> None:
        self.code, self.out, self.err = code, out, err

    def refused(self, *words: str) -> str:
        """Assert exit code 2 and one ``linsense: error:`` line containing every word; return it."""
        assert self.code == 2, (self.code, self.err)
        lines = self.err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("linsense: error: "), self.err
        for w in words:
            assert w in lines[0], (w, lines[0])
        return lines[0]


@pytest.fixture
def run_cli(capsys):
    """Run ``linsense ARGS`` in-process; return exit code, stdout and stderr."""

    def run(*args: str) -> CliResult:
        capsys.readouterr()
        with pytest.raises(SystemExit) as exc:
            main([str(a) for a in args])
        cap = capsys.readouterr()
        return CliResult(int(exc.value.code or 0), cap.out, cap.err)

    return run


def scenario_with(base: str, text: str) -> str:
    """The scenario text ``base`` with ``text`` (sections and keys) added; a section the base has
    is merged (its keys added under its header)."""
    out, extra = base, []
    for block in text.strip().split("\n[") if text.strip() else []:
        block = block if block.startswith("[") else "[" + block
        head, _, body = block.partition("\n")
        if head in out:
            out = out.replace(head + "\n", head + "\n" + body + "\n")
        else:
            extra.append(block)
    return out + "\n" + "\n".join(extra) + "\n"


def shown(value: float, text: str) -> bool:
    """``value`` written with as many decimals as ``text`` is ``text`` (the rounding the docs show)."""
    decimals = len(text.split(".")[1]) if "." in text else 0
    return f"{value:.{decimals}f}" == text


def theta_grid(n: int = 721) -> np.ndarray:
    return np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)

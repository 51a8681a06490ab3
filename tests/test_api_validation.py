"""The Python API refuses what the command line refuses (issue 23): one error of the project's
hierarchy naming the argument and the value, instead of a silent table of nonsense or a run out of
memory."""

from __future__ import annotations

import pytest

from linsense.analysis.hf import hf_current, psi_lut_resistive
from linsense.compensation.lut import build_lut
from linsense.errors import InputError
from linsense.limits import MAX_POINTS
from linsense.model.motor import load_motor


@pytest.fixture(scope="module")
def ecce():
    return load_motor("ecce2010")


@pytest.mark.parametrize("kw, key", [
    ({"points": 4.5}, "points"),
    ({"points": 10**9}, "points"),  # (ran the machine out of memory)
    ({"points": True}, "points"),
    ({"points": None}, "points"),
    ({"points": 3}, "points"),
    ({"points": 360, "f_inj": -1000.0}, "f_inj"),
    ({"points": 360, "f_inj": 1000 + 1j}, "f_inj"),
    ({"points": 360, "f_inj": float("nan")}, "f_inj"),
    ({"points": 360, "f_inj": 1e300}, "f_inj"),  # (an all-zero table)
    ({"points": 360, "f_inj": 1000.0, "quad": 1.0}, "quad"),
    ({"points": 360, "f_inj": 1000.0, "quad": None}, "quad"),
    ({"points": 360, "injection": "sine"}, "injection"),
])
def test_build_lut_refuses(ecce, kw, key):
    with pytest.raises(InputError) as e:
        build_lut(ecce, **kw)
    msg = str(e.value)
    assert key in msg and len(msg.splitlines()) == 1, msg
    if key == "points" and kw["points"] == 10**9:
        assert f"{MAX_POINTS:,}" in msg


@pytest.mark.parametrize("f", [-1000.0, 0.0, None, 1000 + 1j, float("inf"), True])
def test_a_frequency_must_be_one(ecce, f):
    with pytest.raises(InputError, match="f_inj"):
        psi_lut_resistive(ecce, 0.3, f)
    with pytest.raises(InputError, match="f_inj"):
        hf_current(ecce, 0.3, 12.0, f)


def test_the_valid_calls_still_work(ecce):
    assert build_lut(ecce, 360, f_inj=1000.0, quad=0.9).values.shape == (360,)
    assert build_lut(ecce, 4).values.shape == (4,)
    assert abs(float(psi_lut_resistive(ecce, 0.3, 1000))) < 0.2  # (an int frequency is a frequency)

"""The Python API refuses what the command line refuses (issue 23): one error of the project's
hierarchy naming the argument and the value, instead of a silent table of nonsense or a run out of
memory."""

from __future__ import annotations

import numpy as np
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


# ------------------------------------------------------------------ Drive.step / Drive.run
@pytest.fixture
def drive():
    from linsense import ctrl

    d = ctrl.Drive()
    d.set_mode("sensorless_nolut")
    return d


@pytest.mark.parametrize("args, key, words", [
    (([0.0, 0.0], 60.0), "i_abc", ["shape (3,)", "got shape (2,)"]),  # (ran with i_c = 0)
    (([0.0, 0.0, 0.0, 9.0], 60.0), "i_abc", ["got shape (4,)"]),  # (the 4th dropped)
    (([[0.0, 0.0, 0.0]], 60.0), "i_abc", ["got shape (1, 3)"]),
    ((["0", "0", "0"], 60.0), "i_abc", ["real numbers", "'0'"]),  # (strings converted)
    (([0.0, 0.0, 1j], 60.0), "i_abc", ["real numbers", "complex"]),  # (imaginary part dropped)
    (([True, False, True], 60.0), "i_abc", ["real numbers", "bool"]),
    ((None, 60.0), "i_abc", ["real numbers", "None"]),
    (([[0.0, 0.0], [0.0]], 60.0), "i_abc", ["shape (3,)"]),
    (([0.0, 0.0, 0.0], [60.0, 60.0]), "v_dc", ["got shape (2,)"]),
    (([0.0, 0.0, 0.0], "60"), "v_dc", ["real numbers", "'60'"]),
    (([0.0, 0.0, 0.0], 60.0, 2.5), "enc_count", ["2.5", "not an integer"]),  # (truncated to 2)
    (([0.0, 0.0, 0.0], 60.0, float("nan")), "enc_count", ["nan", "not an integer"]),
    (([0.0, 0.0, 0.0], 60.0, 2**31), "enc_count", ["2147483648", "int32"]),  # (wrapped)
    (([0.0, 0.0, 0.0], 60.0, [1, 2]), "enc_count", ["got shape (2,)"]),
    (([0.0, 0.0, 0.0], 60.0, "5"), "enc_count", ["'5'"]),
])
def test_drive_step_refuses(drive, args, key, words):
    with pytest.raises(InputError) as e:
        drive.step(*args)
    msg = str(e.value)
    assert msg.startswith(f"Drive.step: {key}: ") and len(msg.splitlines()) == 1, msg
    for w in words:
        assert w in msg, (w, msg)


@pytest.mark.parametrize("args, key, words", [
    ((np.zeros(6), 60.0), "i_abc", ["(n, 3)", "got shape (6,)"]),  # (read as 2 periods)
    ((np.zeros((4, 2)), 60.0), "i_abc", ["got shape (4, 2)"]),
    ((np.zeros((4, 3), complex), 60.0), "i_abc", ["real numbers", "complex"]),
    ((np.zeros((4, 3)), np.zeros(3)), "v_dc", ["shape (4,)", "got shape (3,)"]),
    ((np.zeros((4, 3)), 60.0, np.array([1.5, 2.0, 3.0, 4.0])), "enc_count", ["1.5", "not an integer"]),
    ((np.zeros((4, 3)), 60.0, [1, 2]), "enc_count", ["got shape (2,)"]),
    ((np.zeros((4, 3)), 60.0, np.array([0, 2**40, 0, 0])), "enc_count", ["1099511627776", "int32"]),
])
def test_drive_run_refuses(drive, args, key, words):
    with pytest.raises(InputError) as e:
        drive.run(*args)
    msg = str(e.value)
    assert msg.startswith(f"Drive.run: {key}: ") and len(msg.splitlines()) == 1, msg
    for w in words:
        assert w in msg, (w, msg)


def test_drive_takes_what_it_should(drive):
    """Real numbers of any real dtype, integral counts, scalar or per-period bus voltage; a NaN
    current is a measurement the drive trips on (LS_FAULT_NONFINITE), not a refusal."""
    from linsense import ctrl

    assert drive.step(np.zeros(3, np.float32), np.float32(60.0), np.int64(5)).enable
    assert drive.step((0, 0, 0), 60, 7.0).enable
    out = drive.run(np.zeros((4, 3)), np.full(4, 60.0), np.arange(4))
    assert out.enable.all() and out.duty.shape == (4, 3)
    assert drive.run(np.zeros((4, 3)), 60.0, 3).enable.all()
    cmd = drive.step([float("nan"), 0.0, 0.0], 60.0)
    assert cmd.fault & ctrl.lib.LS_FAULT_NONFINITE

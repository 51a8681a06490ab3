"""The Python API refuses what the command line refuses: one error of the project's
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
    ({"points": 360, "f_inj": 1e-300}, "f_inj"),  # (an all-zero table: below MIN_F_INJ, 1 Hz)
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
    import blocks  # (the drive stepped from Python: tests/blocks.py)

    d = blocks.Drive()
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


# ------------------------------------------------------------------ simulate, the firmware blocks (found
# by tests/properties/test_prop_api.py)
SHORT = {"motor": "ecce2010", "scenario": {"duration": 0.005}, "reference": {"position_mm": 1.0, "at": 0.001}}


def _with(section: str, key: str, value) -> dict:
    return {**SHORT, section: {**SHORT.get(section, {}), key: value}}


@pytest.mark.parametrize("doc, key, words", [
    (_with("controller", "kp_x", None), "controller.kp_x", ["None", "TOML has no null"]),  # (TypeError)
    (_with("scenario", "seed", None), "scenario.seed", ["None"]),
    (_with("reference", "position_mm", np.True_), "reference.position_mm", ["True"]),  # (run as 1.0)
    (_with("scenario", "duration", np.True_), "scenario.duration", ["True"]),
    (_with("reference", "position_mm", (1.0,)), "reference.position_mm", ["tuple"]),
    (_with("inverter", "v_dc", 60 + 0j), "inverter.v_dc", ["complex"]),
    (_with("reference", "position_mm", np.array([1.0, 2.0])), "reference.position_mm", ["ndarray"]),
    ({**SHORT, "reference": {"type": "trajectory", "waypoints_mm": [1.0, None]}}, "reference.waypoints_mm[1]",
     ["None"]),
    ({k: v for k, v in SHORT.items() if k != "reference"}, "reference.position_mm",
     ["missing required key", "no [reference] section"]),  # (named "position_mm")
    ({k: v for k, v in SHORT.items() if k != "scenario"}, "scenario.duration",
     ["missing required key", "no [scenario] section"]),
    (_with("scenario", "duration", 1e308), "scenario.duration", ["1e+308", "1e+10"]),  # (OverflowError)
])
def test_simulate_of_a_dict_refuses_as_the_file_would(doc, key, words):
    import linsense

    for record in ("trace", "metrics"):
        with pytest.raises(InputError) as e:
            linsense.simulate(doc, record=record)
        msg = str(e.value)
        assert e.value.source == "<dict>" and e.value.key == key and "\n" not in msg, msg
        for w in words:
            assert w in msg, (w, msg)


def test_simulate_of_a_dict_takes_numpy_reals_as_numbers():
    """A numpy scalar of a real dtype is the number it holds (as TOML's would be), and runs."""
    import linsense

    doc = {**SHORT, "scenario": {"duration": np.float32(0.005), "seed": np.int64(3)},
           "reference": {"position_mm": np.float64(1.0), "at": np.float64(0.001)},
           "record": {"decimate": np.uint8(2)}}
    r = linsense.simulate(doc)
    sp = r.scenario.spec
    assert sp.scenario.seed == 3 and type(sp.scenario.seed) is int and sp.record.decimate == 2
    assert type(sp.reference.position_mm) is float and r.metrics["steps"] == 80


@pytest.mark.parametrize("call, source, key, words", [
    (lambda ls: ls.simulate(42), "simulate", "scenario", ["int", "42"]),  # (TypeError)
    (lambda ls: ls.simulate(None), "simulate", "scenario", ["None"]),
    (lambda ls: ls.simulate(SHORT, record="x"), "simulate", "record", ["'trace'", "'x'"]),  # (ValueError)
    (lambda ls: ls.simulate(SHORT, record=None), "simulate", "record", ["None"]),
    (lambda ls: ls.simulate_many([SHORT], workers=0), "simulate_many", "workers", ["0"]),
    (lambda ls: ls.simulate_many([SHORT], workers="2"), "simulate_many", "workers", ["'2'"]),  # (TypeError)
    (lambda ls: ls.simulate_many([SHORT, 42]), "simulate_many", "scenario", ["int"]),
    (lambda ls: ls.simulate_many(SHORT), "simulate_many", "scenarios", ["dict", "use simulate"]),
    (lambda ls: ls.simulate_many([SHORT], record="x"), "simulate_many", "record", ["'x'"]),
])
def test_simulate_names_its_argument(call, source, key, words):
    import linsense

    with pytest.raises(InputError) as e:
        call(linsense)
    msg = str(e.value)
    assert (e.value.source, e.value.key) == (source, key) and "\n" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


FS = dict(fs=16000.0)
OBS = dict(fs=16000.0, pole_pitch=0.056, omega_max=1000.0)


@pytest.mark.parametrize("make, source, key, words", [
    (lambda c: c.Biquad(None, f0=100.0, **FS), "Biquad", "type", ["'lowpass'", "None"]),  # (TypeError)
    (lambda c: c.Biquad(True, f0=100.0, **FS), "Biquad", "type", ["True"]),  # (the enum 1)
    (lambda c: c.Biquad(f0=None, **FS), "Biquad", "f0", ["real number", "None"]),  # (TypeError)
    (lambda c: c.Biquad(f0="x", **FS), "Biquad", "f0", ["real number", "'x'"]),
    (lambda c: c.Biquad(f0=1j, **FS), "Biquad", "f0", ["real number", "complex"]),
    (lambda c: c.Biquad(f0=True, **FS), "Biquad", "f0", ["real number", "bool"]),  # (taken as 1 Hz)
    (lambda c: c.Biquad(f0=np.array([1.0, 2.0]), **FS), "Biquad", "f0", ["ndarray"]),
    (lambda c: c.Biquad(f0=10**400, **FS), "Biquad", "f0", ["double"]),  # (OverflowError)
    (lambda c: c.Biquad(f0=100.0, q=None, **FS), "Biquad", "q", ["None"]),
    (lambda c: c.Injection(amplitude=None, freq=1000.0, **FS), "Injection", "amplitude", ["None"]),
    (lambda c: c.Injection(amplitude=1.0, freq="1000", **FS), "Injection", "freq", ["'1000'"]),
    (lambda c: c.Injection(amplitude=1.0, freq=1000.0, on="yes", **FS), "Injection", "on", ["'yes'"]),
    (lambda c: c.Observer(None, f_bw=20.0, **OBS), "Observer", "type", ["'pll'", "None"]),  # (TypeError)
    (lambda c: c.Observer("pll", f_bw="x", **OBS), "Observer", "f_bw", ["'x'"]),
    (lambda c: c.Observer("pll", **OBS), "Observer", "f_bw", ["k1"]),  # (ValueError)
    (lambda c: c.Observer("pll", f_bw=20.0, fs=16000.0, pole_pitch=None, omega_max=1000.0), "Observer",
     "pole_pitch", ["None"]),
    (lambda c: c.Lut("abcd"), "Lut", "values", ["'abcd'"]),  # (ValueError)
    (lambda c: c.Lut(np.zeros((4, 4))), "Lut", "values", ["shape (4, 4)"]),  # (flattened to 16 points)
    (lambda c: c.Lut([True] * 8), "Lut", "values", ["bool"]),  # (taken as 1.0)
    (lambda c: c.Lut(None), "Lut", "values", ["None"]),
    (lambda c: c.Lut([0.0, 1e300, 0.0, 0.0]), "Lut", "values[1]", ["1e+300", "float32"]),  # (inf)
    (lambda c: c.Demodulator(fs=16000.0, gain=None), "Demodulator", "gain", ["None"]),
    (lambda c: c.Demodulator(fs=16000.0, gain=1.0, comp="abcd"), "Demodulator", "comp", ["'abcd'"]),
])
def test_the_firmware_blocks_name_their_argument(make, source, key, words):
    import blocks  # (the firmware's blocks one by one: tests/blocks.py; Lut is linsense.ctrl's)

    with pytest.raises(InputError) as e:
        make(blocks)
    msg = str(e.value)
    assert (e.value.source, e.value.key) == (source, key) and "\n" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


def test_the_firmware_blocks_take_real_numbers():
    """Ints and numpy scalars of a real dtype are numbers; a compensation table is a table."""
    import blocks
    from linsense.compensation.lut import build_lut

    assert np.all(np.isfinite(blocks.Biquad("notch", f0=np.float32(1000.0), q=2, fs=16000).run(np.ones(8))))
    assert blocks.Injection(amplitude=np.int64(12), freq=1000, fs=16000.0).run(4)[0].shape == (4,)
    obs = blocks.Observer("mech", f_bw=np.int64(20), mass=1.5, force_max=100, **OBS)
    assert np.all(np.isfinite(obs.run(np.zeros(4)).theta))
    assert blocks.Lut(build_lut(load_motor("ecce2010"), 16)).len == 16
    assert blocks.Lut(np.arange(8)).len == 8

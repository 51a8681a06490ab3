"""Properties of the Python API: any argument (valid, or a wrong type, NaN, inf, a boolean, None,
a complex number, a string, huge, negative) gives either a finite result of the documented shape or
one :class:`~linsense.errors.InputError` naming the argument; the API refuses what the command line
refuses (docs/limits.md, docs/cli.md). Scenario and sweep dictionaries (``simulate``,
``scenario_from_dict``, ``sweep_from_dict``) end the same way."""

from __future__ import annotations

import math
import numbers

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from prop_strategies import HOSTILE, attempt, mostly, prop_settings

from linsense.analysis.hf import hf_current, hf_current_amplitude, psi_lut_resistive
from linsense.analysis.model_table import model_table
from linsense.analysis.rotating import psi_rotating
from linsense.analysis.square import psi_square
from linsense.analysis.summary import summarize
from linsense.compensation.lut import build_lut
from linsense.errors import InputError
from linsense.identify.bench import emulate_bench
from linsense.limits import MAX_F_INJ, MIN_F_INJ
from linsense.model.motor import load_motor
from linsense.plausible import KINDS

#: odd values an API caller can pass where a number belongs
ODD = st.one_of(HOSTILE, st.none(), st.complex_numbers(max_magnitude=1e6), st.just(np.float64("nan")),
                st.just(np.array([1.0, 2.0])), st.just(np.int64(360)), st.just(np.float32(1000.0)))


def real(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool | np.bool_) and math.isfinite(v)


def integral(v) -> bool:
    return isinstance(v, numbers.Integral) and not isinstance(v, bool | np.bool_)


#: argument: (valid values, the documented range as a predicate)
ARGS = {
    "points": (st.integers(4, 400), lambda v: integral(v) and 4 <= v <= 100_000),
    # (the injection frequency of a table and of the HF model: docs/limits.md)
    "f_inj": (st.floats(1.0, 500_000.0), lambda v: real(v) and 0 < v <= 500_000 and math.isfinite(1 / v)),
    "quad": (st.floats(0.0, 0.99), lambda v: real(v) and 0 <= v < 1),
    "v_inj": (st.floats(0.1, 100.0), lambda v: real(v) and v > 0),
    "positions": (st.integers(8, 100), lambda v: integral(v) and 8 <= v <= 10_000),
    "noise": (st.floats(0.0, 0.1), lambda v: real(v) and 0 <= v <= KINDS["relative_noise"].high),
    "seed": (st.integers(0, 2**32), lambda v: integral(v) and v >= 0),
    "freq": (st.floats(1.0, 1e5), lambda v: real(v) and v > 0),
    "current": (st.floats(0.01, 10.0), lambda v: real(v) and v > 0),
}
THETA = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)


@pytest.fixture(scope="module")
def ecce():
    return load_motor("ecce2010")


def _finite(obj) -> bool:
    if isinstance(obj, dict):
        return all(_finite(v) for v in obj.values())
    if isinstance(obj, list | tuple):
        return all(_finite(v) for v in obj)
    if isinstance(obj, np.ndarray | float | complex | numbers.Number) and not isinstance(obj, bool):
        return bool(np.all(np.isfinite(obj)))
    return True


#: function: (call, its arguments drawn from ARGS, the check of a result[, ranges other than ARGS'])
CALLS = {
    "build_lut": (lambda m, a: build_lut(m, a["points"], a["f_inj"], quad=a["quad"]),
                  ("points", "f_inj", "quad"), lambda r, a: r.values.shape == (a["points"],),
                  {"f_inj": lambda v: v is None or (ARGS["f_inj"][1](v) and MIN_F_INJ <= v <= MAX_F_INJ)}),
                  # (None: eq. 12; a table's injection within MIN_F_INJ .. MAX_F_INJ: 1e-300 Hz gave an
                  # all-zero table)
    "psi_lut_resistive": (lambda m, a: psi_lut_resistive(m, THETA, a["f_inj"], a["quad"]),
                          ("f_inj", "quad"), lambda r, a: r.shape == THETA.shape),
    "hf_current": (lambda m, a: hf_current(m, THETA, a["v_inj"], a["f_inj"], 0.0, a["quad"]),
                   ("v_inj", "f_inj", "quad"), lambda r, a: r.shape == THETA.shape + (2,)),
    "hf_current_amplitude": (lambda m, a: hf_current_amplitude(m, THETA, a["v_inj"], a["f_inj"]),
                             ("v_inj", "f_inj"), lambda r, a: r.shape == THETA.shape and np.all(r > 0)),
    "psi_rotating": (lambda m, a: psi_rotating(m, THETA, a["f_inj"]), ("f_inj",),
                     lambda r, a: r.shape == THETA.shape),
    "psi_square": (lambda m, a: psi_square(m, THETA, a["f_inj"]), ("f_inj",),
                   lambda r, a: r.shape == THETA.shape),
    "summarize": (lambda m, a: summarize(m, a["v_inj"], a["f_inj"]), ("v_inj", "f_inj"),
                  lambda r, a: r["hf_current_mean_A"] > 0),
    "model_table": (lambda m, a: model_table(m, a["points"]), ("points",),
                    lambda r, a: all(v.shape == (a["points"],) for v in r.values())),
    "emulate_bench": (lambda m, a: emulate_bench(m, a["positions"], a["noise"], a["seed"], a["freq"],
                                                 a["current"]),
                      ("positions", "noise", "seed", "freq", "current"), lambda r, a: True),
}


@pytest.mark.slow
@prop_settings(scale=4)
@given(name=st.sampled_from(sorted(CALLS)), data=st.data())
def test_an_api_call_gives_a_finite_result_or_names_the_argument(ecce, name, data):
    call, names, check, *ranges = CALLS[name]
    valid = {n: (ranges[0] if ranges else {}).get(n, ARGS[n][1]) for n in names}
    args = {n: data.draw(mostly(ARGS[n][0], ODD, one_in=3), label=n) for n in names}
    bad = [n for n in names if not valid[n](args[n])]
    # (beyond any drive, where floating point overflows or underflows: a refusal naming it is as good as
    # a finite result)
    huge = [n for n in names if n not in bad and real(args[n]) and not 1e-100 < abs(args[n]) < 1e100
            and args[n] != 0]
    status, value = attempt(call, ecce, args)
    event(f"{name}: {status}")
    if status == "refused":
        assert isinstance(value, InputError), repr(value)
        assert bad or huge, f"{name} refused valid arguments {args}: {value}"
        assert any(n in str(value) for n in bad + huge), (bad, huge, str(value))
        return
    assert not bad, f"{name} accepted {bad} = {[args[n] for n in bad]!r}"
    assert _finite(getattr(value, "values", value)), name
    assert check(value, args) or huge, name


#: what the properties found, each now one InputError naming the argument: a subnormal
#: frequency (the square wave's table all NaN), NaN, None or a string amplitude (NaN currents or a numpy
#: traceback), model_table's and emulate_bench's arguments (ValueError,
#: TypeError, numpy tracebacks)
FOUND = [
    ("psi_square", lambda m: psi_square(m, THETA, 5e-324), "f_inj"),
    ("build_lut square", lambda m: build_lut(m, 8, 5e-324, injection="square"), "f_inj"),
    ("psi_rotating", lambda m: psi_rotating(m, THETA, float("nan")), "f_inj"),
    ("hf_current v_inj nan", lambda m: hf_current(m, THETA, float("nan"), 1000.0), "v_inj"),
    ("hf_current v_inj str", lambda m: hf_current(m, THETA, "12", 1000.0), "v_inj"),
    ("hf_current quad", lambda m: hf_current(m, THETA, 12.0, 1000.0, 0.0, None), "quad"),
    ("summarize", lambda m: summarize(m, None, 1000.0), "v_inj"),
    ("model_table 3", lambda m: model_table(m, 3), "points"),
    ("model_table 4.5", lambda m: model_table(m, 4.5), "points"),
    ("model_table 1e9", lambda m: model_table(m, 10**9), "points"),
    ("bench positions", lambda m: emulate_bench(m, 4), "positions"),
    ("bench seed", lambda m: emulate_bench(m, 8, 0.0, float("nan")), "seed"),
    ("bench noise", lambda m: emulate_bench(m, 8, None), "noise"),
    ("bench freq", lambda m: emulate_bench(m, 8, 0.0, 0, 1 + 1j), "freq"),
    ("bench current", lambda m: emulate_bench(m, 8, 0.0, 0, 1000.0, -1.0), "current"),
]


@pytest.mark.parametrize("what, call, key", FOUND, ids=[f[0] for f in FOUND])
def test_what_the_properties_found_is_refused_naming_the_argument(ecce, what, call, key):
    with pytest.raises(InputError) as e:
        call(ecce)
    assert e.value.key == key and "\n" not in str(e.value), str(e.value)


def test_the_amplitude_of_huge_currents_is_finite(ecce):
    # (found: 1e308 V at 1 Hz, currents of 1.1e307 A, had an amplitude of inf: the squares overflowed)
    assert np.all(np.isfinite(hf_current_amplitude(ecce, THETA, 1e308, 1.0)))


#: Python values a dict can carry and a TOML file cannot (tuples, numpy scalars, bytes, sets, None).
#: Found by these properties: None for an optional key (controller.kp_x = None) was a TypeError traceback in
#: build, np.True_ was accepted as the number 1.0
PY_ODD = st.one_of(ODD, st.tuples(st.floats(), st.floats()), st.binary(max_size=4), st.just({1.0}),
                   st.just(np.int64(7)), st.just(np.float64(0.02)), st.just(np.True_), st.just(np.False_))
#: what ``simulate`` is given instead of a scenario, and instead of a record mode
NOT_A_SCENARIO = st.one_of(st.none(), st.integers(), st.floats(), st.binary(max_size=4), st.lists(st.none()),
                           st.just(np.zeros(3)))
RECORD = mostly(st.sampled_from(["trace", "metrics"]),
                st.one_of(st.none(), st.text(max_size=8), st.integers(), st.just(b"trace"), st.just(True)),
                one_in=4)


@prop_settings()
@given(section=st.sampled_from(["scenario", "inverter", "observer", "reference", "record", "controller"]),
       key=st.sampled_from(["duration", "seed", "v_dc", "bandwidth_hz", "position_mm", "decimate", "kp_x",
                            "lut_points", "at"]),
       value=PY_ODD, record=RECORD, scenario=mostly(st.none(), NOT_A_SCENARIO, one_in=8))
def test_simulate_of_a_dict_runs_as_given_or_names_the_key(section, key, value, record, scenario):
    import linsense

    # (found: simulate(42) was a TypeError and simulate(d, record="x") a ValueError, not InputError)
    # (the step within the run: one after its end is refused)
    doc = {"motor": "ecce2010", "scenario": {"duration": 0.005},
           "reference": {"position_mm": 1.0, "at": 0.001}}
    doc[section] = {**doc.get(section, {}), key: value}
    status, res = attempt(linsense.simulate, doc if scenario is None else scenario, record=record)
    event(f"{status}")
    if record not in ("trace", "metrics") or isinstance(record, bytes):
        assert status == "refused" and (res.source, res.key) == ("simulate", "record"), (record, res)
        return
    if scenario is not None:
        assert status == "refused" and (res.source, res.key) == ("simulate", "scenario"), (scenario, res)
        return
    if status == "refused":
        assert isinstance(res, InputError) and res.source == "<dict>", repr(res)
        # (the key, or named in the message of a rule between keys: an event after the run's end names
        # the event and scenario.duration, an end window too short the loop's key)
        assert res.key.startswith(f"{section}.{key}") or f"{section}.{key} " in str(res), \
            (section, key, value, str(res))
        return
    # accepted: a value of the documented type (a finite real, an int for counts), and a run of it
    assert not isinstance(value, bool | np.bool_ | str | bytes | tuple | set | complex | np.ndarray) \
        and value is not None, f"{section}.{key} = {value!r} accepted"
    assert real(value), f"{section}.{key} = {value!r} accepted"
    m = res.metrics
    sc = res.scenario.spec
    assert abs(m["steps"] - sc.scenario.duration * sc.inverter.f_pwm) <= 1 or m["fault"] != "none"
    got = getattr(getattr(sc, section), key)
    assert got == (float(value) if isinstance(got, float) else value), (got, value)


#: the firmware's blocks from Python (tests/blocks.py): a constructor with these arguments, and a short run
CTRL = {
    "Lut": (lambda c, a: c.Lut(a["values"]), lambda o: o(np.linspace(-7.0, 7.0, 9))),
    "Biquad": (lambda c, a: c.Biquad(a["type"], f0=a["f0"], q=a["q"], fs=a["fs"]),
               lambda o: o.run(np.sin(np.arange(16.0)))),
    "Injection": (lambda c, a: c.Injection(amplitude=a["amplitude"], freq=a["f0"], fs=a["fs"]),
                  lambda o: o.run(16)[0]),
    "Observer": (lambda c, a: c.Observer(a["type"], fs=a["fs"], pole_pitch=a["pole_pitch"],
                                         omega_max=a["omega_max"], f_bw=a["f0"]),
                 lambda o: o.run(np.full(16, 0.01)).theta),
}
#: real numbers (NaN, inf, huge, negative, zero included), and what is not one: None, a string, a
#: boolean, a complex number, an array, a huge int (found by these properties: Biquad(f0=None),
#: Injection(amplitude="x"), Observer(None, ...) were TypeErrors, Lut("abcd") a ValueError, a 2-D
#: Lut flattened into one table; now one InputError naming the argument)
REALS = st.one_of(st.floats(), st.sampled_from([0.0, -1.0, 1e308, 5e-324, 1e-300]), st.integers(-10, 10**6))
NOT_REAL = st.one_of(st.none(), st.text(max_size=4), st.booleans(), st.complex_numbers(max_magnitude=1e6),
                     st.just(np.array([1.0, 2.0])), st.just(np.True_), st.just(10**400))
#: the arguments each block reads
USED = {"Lut": ("values",), "Biquad": ("type", "f0", "q", "fs"), "Injection": ("amplitude", "f0", "fs"),
        "Observer": ("type", "fs", "pole_pitch", "omega_max", "f0")}
CTRL_ARGS = {
    "values": mostly(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=64),
                     st.one_of(st.lists(REALS, max_size=6), NOT_REAL, st.just(np.zeros((4, 4))),
                               st.lists(st.booleans(), min_size=4, max_size=8))),
    "type": mostly(st.sampled_from(["lowpass", "bandpass", "notch", "pll", "mech"]),
                   st.one_of(NOT_REAL, st.just("zz"))),
    "f0": mostly(st.floats(10.0, 2000.0), st.one_of(REALS, NOT_REAL)),
    "q": mostly(st.floats(0.3, 5.0), st.one_of(REALS, NOT_REAL)),
    "fs": mostly(st.floats(8000.0, 40000.0), st.one_of(REALS, NOT_REAL)),
    "amplitude": mostly(st.floats(0.0, 20.0), st.one_of(REALS, NOT_REAL)),
    "pole_pitch": mostly(st.floats(0.01, 0.1), st.one_of(REALS, NOT_REAL)),
    "omega_max": mostly(st.floats(10.0, 1000.0), st.one_of(REALS, NOT_REAL)),
}


@prop_settings()
@given(block=st.sampled_from(sorted(CTRL)), args=st.fixed_dictionaries(CTRL_ARGS))
def test_a_firmware_block_runs_finite_or_is_refused_in_one_line(block, args):
    import blocks  # (tests/blocks.py; Lut is linsense.ctrl's)

    make, run = CTRL[block]
    status, obj = attempt(make, blocks, args)
    event(f"{block}: {status}")
    if status == "refused":
        # an argument that is not a real number (a table: not one dimension of them) is named
        if isinstance(obj, InputError):
            key = obj.key.split("[")[0]
            # (the strategy's f0 is Injection's freq)
            assert obj.source == block and {"freq": "f0"}.get(key, key) in args, (block, str(obj))
        return
    for name in USED[block]:  # (accepted: every number the block reads is a real number)
        v = args[name]
        if name not in ("values", "type"):
            assert isinstance(v, int | float) and not isinstance(v, bool), (block, name, v)
    out = run(obj)
    assert np.all(np.isfinite(out)), (block, args, out)

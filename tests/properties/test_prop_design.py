"""Properties of the design's refusals: the drive data of the
reference drive with one or two inputs changed to any float (NaN, inf, negative, subnormal, tiny,
huge, or anywhere over 24 decades) is either designed or refused naming one of the inputs that were
changed, with a limit the design accepts when it gives one: never another input (the dead time for
a 1 mA current limit, the saliency for a dead time longer than the PWM period), never a traceback.

The rule (:data:`linsense.tune.design.DRIVE_RULES`): each input against its own range, then pairs of
inputs, then the quantities derived from them, a refusal naming the first input of its rule the
user gave.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from importlib import resources

from hypothesis import event, given
from hypothesis import strategies as st
from prop_strategies import prop_settings

from linsense.errors import InputError
from linsense.model.motor import load_motor
from linsense.tune.design import DriveData, design

ECCE = load_motor("ecce2010")
_CLASS = resources.files("linsense.examples") / "motors" / "class"
#: the test motors of the class linsense designs for, each with its own drive (drives.toml)
CLASS = {name: (load_motor(str(_CLASS / f"{name}.toml")), DriveData(**drive))
         for name, drive in tomllib.loads((_CLASS / "drives.toml").read_text()).items()}
#: the numeric drive data (DriveData's fields; quad and shape have their own properties elsewhere)
NUMERIC = ("v_dc", "f_pwm", "dead_time", "i_max", "v_max", "a_max", "load", "travel", "v_inj", "f_inj")
#: any float, and positive values spread over 24 decades (where the pairs and derived rules act)
VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, -1.0, 5e-324, 1e-300, 1e300, 1.7e308]),
    st.floats(-12.0, 12.0).map(lambda e: 10.0**e),
)


@prop_settings(scale=3)
@given(changes=st.dictionaries(st.sampled_from(NUMERIC), VALUES, min_size=1, max_size=2))
def test_a_refusal_names_an_input_that_was_changed(changes):
    d = dataclasses.replace(DriveData(), **changes)
    try:
        design(ECCE, d, "prop", analyse=False)
    except InputError as exc:
        event(f"refused: {exc.key}")
        assert exc.key in changes, (changes, str(exc))
        assert "\n" not in str(exc)
        return
    event("designed")
    for key, value in changes.items():  # (accepted: within the documented ranges)
        assert value is None or (math.isfinite(value) and (value > 0 or key == "dead_time")), (key, value)


@prop_settings(scale=3)
@given(name=st.sampled_from(sorted(CLASS)),
       changes=st.dictionaries(st.sampled_from(NUMERIC), VALUES, min_size=1, max_size=2))
def test_a_refusal_names_an_input_given_on_the_test_motors(name, changes):
    """The class's motors with their drives: a refusal names an input changed, or one the motor's
    drive gives away from the default (the rule names the first input of the rule the user gave)."""
    motor, base = CLASS[name]
    given = {k for k in NUMERIC if getattr(base, k) != getattr(DriveData(), k)}
    try:
        design(motor, dataclasses.replace(base, **changes), "prop", analyse=False)
    except InputError as exc:
        event(f"refused: {exc.key}")
        assert exc.key in set(changes) | given, (name, changes, str(exc))
        return
    event("designed")


#: the scenario keys the design reads (linsense.sim.build.drive_data), and the balanced load
SCENARIO_KEYS = (("inverter", "v_dc"), ("inverter", "f_pwm"), ("inverter", "dead_time"),
                 ("controller", "i_max"),
                 ("reference", "v_max"), ("reference", "a_max"), ("injection", "amplitude"),
                 ("injection", "frequency"), ("load", "force"))


@prop_settings()
@given(changes=st.dictionaries(st.sampled_from(SCENARIO_KEYS), VALUES, min_size=1, max_size=2))
def test_a_scenario_refusal_names_a_key_it_gives(changes):
    """A hold on ecce2010 with one or two of the drive's keys (and a balanced load) changed is built,
    or refused naming one of them (found: a subnormal injection.amplitude was refused naming the
    ramp_rate designed from it)."""
    from linsense.scenario.load import scenario_from_dict
    from linsense.sim.build import build

    doc = {"motor": "ecce2010", "scenario": {"duration": 0.01}, "reference": {"type": "hold"},
           "initial": {"load_balanced": True}}
    for (sec, key), value in changes.items():
        doc.setdefault(sec, {})[key] = value
    try:
        build(scenario_from_dict(doc, "p.toml"))
    except InputError as exc:
        event(f"refused: {exc.key}")
        assert exc.key.split(" ")[0] in {f"{s}.{k}" for s, k in changes}, (changes, str(exc))
        return
    event("built")

"""Messages that blamed another cause than the input that is wrong: each case an input of
``linsense tune``, ``calibrate``, ``firmware export`` or ``simulate``, the key its one line must
name (the input the user can change), words it must contain (the value, the limit) and words it must
not (the cause it blamed before).

The rule behind them (:data:`linsense.tune.design.DRIVE_RULES`): the design checks its inputs in
one ordered table, (1) each input against its own range, (2) pairs of inputs (the dead time against
the PWM period, the injection against the bus, the force the application needs against the current
limit...), (3) the quantities derived from them (the injection the dead time needs, the bus's
headroom, the speed the bus allows); a rule that reads several inputs names the first one the user
gave (a value that is not the default), and its message gives that input's limit.
"""

from __future__ import annotations

import re
from importlib import resources

import pytest

from conftest import scenario_with
from linsense.model.motor import load_motor
from linsense.tune.design import DriveData, design

PRESET = (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()
#: ecce2010 with the signs of its saliency terms turned: the mean L_d above L_q
REVERSED = PRESET.replace("L2 = -0.317e-3", "L2 = 0.317e-3").replace("M2 = -0.317e-3", "M2 = 0.317e-3")
#: ecce2010 with a [saturation] section that has no magnet-polarity signal
NO_POLARITY = "\n".join(line for line in PRESET.splitlines() if not line.startswith("polarity"))
EXAMPLE_MOTORS = resources.files("linsense.examples") / "motors"

HOLD = """motor = "ecce2010"

[scenario]
name = "s"
duration = 0.05

[reference]
type = "hold"
"""
STARTUP = HOLD + '\n[control]\nmode = "startup"\n'


def tune(*args: str, motor: str = "ecce2010") -> tuple:
    return ("tune", "--motor", motor, "--out", "o.toml", "--no-verify", *args)


def calibrate(*args: str, motor: str = "ecce2010") -> tuple:
    return ("calibrate", "--motor", motor, "--out", "cal", *args)


def export(*args: str) -> tuple:
    return ("firmware", "export", "fw", "--motor", "ecce2010", *args)


def simulate(text: str) -> tuple:
    return ("simulate", "s.toml", "--out", "o", "--trace", "none", text)


def section(sec: str, keys: str) -> str:
    return scenario_with(HOLD, f"[{sec}]\n{keys}")


# name: (command, the key named, words the line must contain, words it must not)
CASES = {
    # ---- the reported cases
    "reversed saliency, tune": (tune(motor="rev.toml"), "motor",
                                ["reversed saliency", "L_d = 4.46 mH", "L_q = 3.51 mH", "L2 and M2"],
                                ["i_max", "no injection"]),
    "reversed saliency, calibrate": (calibrate(motor="rev.toml"), "motor",
                                     ["reversed saliency", "L_d = 4.46 mH"], ["i_max"]),
    "reversed saliency, simulate": (simulate(HOLD.replace('"ecce2010"', '"rev.toml"')), "motor",
                                    ["reversed saliency"], ["i_max"]),
    "i_max 1e-3": (tune("--i-max", "1e-3"), "i_max", ["0.001 A", "at least 0.53", "HF current", "load"],
                   ["dead_time:", "at this bus"]),
    "dead time 1e-4": (tune("--dead-time", "1e-4"), "dead_time",
                       ["0.0001 s", "10 % of the PWM period", "6.25e-06 s"], ["saliency"]),
    "f_pwm 200 kHz with the default dead time": (tune("--f-pwm", "200000"), "f_pwm",
                                                 ["200000 Hz", "10 % of the PWM period", "125000 Hz"],
                                                 ["saliency"]),
    "start-up on the linear plant": (simulate(STARTUP), "control.mode",
                                     ["\"startup\"", "saturated plant", "saturation.enabled = true"], []),
    # ---- found: the same families
    "i_max 0.05": (tune("--i-max", "0.05"), "i_max", ["0.05 A", "at least 0.53"], ["dead_time:"]),
    "i_max 0.2, harmonic": (tune("--i-max", "0.2", motor=str(EXAMPLE_MOTORS / "harmonic.toml")), "i_max",
                            ["0.2 A", "at least"], ["dead_time:"]),
    "i_max subnormal": (tune("--i-max", "5e-324"), "i_max", ["at least 0.53"], ["no injection"]),
    "i_max 1e6": (tune("--i-max", "1e6"), "i_max", ["1e+06 A", "at most 3.285 A"], ["v_dc:"]),
    "v_dc 1e6": (tune("--v-dc", "1e6"), "v_dc", ["1e+06 V", "at most"], ["dead_time:", "saliency is too"]),
    "f_pwm 100 Hz": (tune("--f-pwm", "100"), "f_pwm", ["100 Hz", "at least 500 Hz"], ["f_inj:"]),
    "f_pwm 50 kHz": (tune("--f-pwm", "50000"), "f_pwm", ["50000 Hz", "at most 33"], ["dead_time:"]),
    "f_pwm 1e9": (tune("--f-pwm", "1e9"), "f_pwm", ["1e+09", "at most 1e+06 Hz"], ["saliency"]),
    "f_pwm 40 kHz, tabulated": (tune("--f-pwm", "40000", motor=str(EXAMPLE_MOTORS / "tabulated.toml")),
                                "f_pwm", ["40000 Hz", "at most"], ["dead_time:"]),
    "dead time 1 s": (tune("--dead-time", "1"), "dead_time", ["10 % of the PWM period"], ["saliency"]),
    "dead time 3 us": (tune("--dead-time", "3e-6"), "dead_time", ["3e-06 s", "at most 1.696e-06 s"],
                       ["at this bus"]),
    "a_max 1e6": (tune("--a-max", "1e6"), "a_max", ["1e+06 m/s^2", "at most 16.66 m/s^2"], ["load:"]),
    "a_max 20": (tune("--a-max", "20"), "a_max", ["20 m/s^2", "at most 16.66 m/s^2"], ["load:"]),
    "f_inj 125 Hz, small30": (tune("--f-inj", "125", motor=str(EXAMPLE_MOTORS / "small30.toml")), "f_inj",
                              ["125 Hz", "at least"], ["dead_time:"]),
    "calibrate, i_max 1e-3": (calibrate("--i-max", "1e-3"), "controller.i_max", ["0.001 A", "at least"],
                              ["dead_time"]),
    "calibrate, f_pwm 200 kHz": (calibrate("--f-pwm", "200000"), "inverter.f_pwm",
                                 ["200000 Hz", "125000 Hz"], ["inverter.dead_time"]),
    "calibrate, load 1e6": (calibrate("--load", "1e6"), "load.force",
                            ["1e+06 N", "K_f controller.i_max = 50 N"], ["encoder"]),
    "tune, rotating with quad": (tune("--injection", "rotating", "--quad", "0.5"), "quad",
                                 ["0.5", "pulsating"], []),
    "tune, square with f_inj": (tune("--injection", "square", "--f-inj", "2000"), "f_inj",
                                ["2000 Hz", "f_pwm / 2 = 8000 Hz"], []),
    "export, i_max 1e-3": (export("--i-max", "1e-3"), "i_max", ["0.001 A", "at least"], ["dead_time:"]),
    "export, dead time 1e-4": (export("--dead-time", "1e-4"), "dead_time", ["10 % of the PWM period"],
                               ["saliency"]),
    "scenario, i_max 1e-3": (simulate(section("controller", "i_max = 1e-3")), "controller.i_max",
                             ["0.001 A", "at least"], ["dead_time"]),
    "scenario, v_dc 1e6": (simulate(section("inverter", "v_dc = 1e6")), "inverter.v_dc",
                           ["at most"], ["dead_time:", "saliency is too"]),
    "scenario, a_max 1e6": (simulate(section("reference", "a_max = 1e6")), "reference.a_max",
                            ["at most 16.66 m/s^2"], ["load:"]),
    "scenario, v_max 10": (simulate(section("reference", "v_max = 10")), "reference.v_max",
                           ["2.22 m/s"], ["--v-max"]),
    "scenario, v_max 100": (simulate(section("reference", "v_max = 100")), "reference.v_max",
                            ["its speed cap, 1.25 v_max = 125 m/s",
                             "at most 2.221 m/s, what the 72 V bus allows"],
                            ["--v-max"]),
    "scenario, dead time 3 us": (simulate(section("inverter", "dead_time = 3e-6")), "inverter.dead_time",
                                 ["at most 1.696e-06 s"],
                                 ["at this bus", "refused by the design (dead_time"]),
    # (found by a random search of one or two drive keys of a scenario: the designed ramp was named)
    "scenario, a subnormal injection": (simulate(section("injection", "amplitude = 5e-324")),
                                        "injection.amplitude", ["5e-324 V", "float32"], ["ramp_rate"]),
    "calibration, t_max below one window": (
        simulate(scenario_with(HOLD, '[control]\nmode = "calibration"\n[calibration]\nt_max = 0.002')),
        "calibration.t_max", ["0.002 s", "t_hold = 0.272727 s", "at least 0.272727 s"], []),
    "start-up without a polarity signal": (
        simulate(STARTUP + "\n[saturation]\nenabled = true\npolarity = 0.0\n"), "saturation.polarity",
        ["control.mode = \"startup\"", "polarity"], []),
    "start-up, a motor file without one": (
        simulate(STARTUP.replace('"ecce2010"', '"nopol.toml"') + "\n[saturation]\nenabled = true\n"),
        "saturation.polarity", ["control.mode = \"startup\"", "polarity = 0"], []),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_message_names_the_input_at_fault(run_cli, tmp_path, monkeypatch, case):
    args, key, words, absent = CASES[case]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rev.toml").write_text(REVERSED, encoding="utf-8")
    (tmp_path / "nopol.toml").write_text(NO_POLARITY, encoding="utf-8")
    if args[0] == "simulate":
        (tmp_path / "s.toml").write_text(args[-1], encoding="utf-8")
        args = args[:-1]
    line = run_cli(*args).refused(*words)
    named = line.removeprefix("linsense: error: ").split(": ")[1]
    assert named == key or named.startswith(key + " ("), (key, line)
    for w in absent:
        assert w not in line, (w, line)


#: a limit in a message: the side, the number, its unit
LIMIT = re.compile(r"(at least|at most|below|above) ([0-9][-+0-9.e]*) (s|Hz|A|V|m/s\^2|m/s|N)\b")
#: drive data that the design refuses, whose message states the named input's limit ("at least X",
#: "at most X"): the limit given back is accepted by that rule
LIMITS = {
    "i_max 1e-3": dict(i_max=1e-3),
    "i_max 1e6": dict(i_max=1e6),
    "v_dc 1e6": dict(v_dc=1e6),
    "v_dc 5": dict(v_dc=5.0),
    "f_pwm 100": dict(f_pwm=100.0),
    "f_pwm 50 kHz": dict(f_pwm=50e3),
    "f_pwm 200 kHz": dict(f_pwm=200e3),
    "dead time 3 us": dict(dead_time=3e-6),
    "dead time 1e-4": dict(dead_time=1e-4),
    "a_max 20": dict(a_max=20.0),
    "load 49": dict(load=49.0),
    "v_max 3": dict(v_max=3.0),
    "v_inj 30": dict(v_inj=30.0),
    "f_inj 5 kHz": dict(f_inj=5000.0),
    "v_max 1e-6": dict(v_max=1e-6),
    "a_max 1e-9": dict(a_max=1e-9),
}


@pytest.mark.parametrize("case", list(LIMITS))
def test_the_limit_a_message_states_is_accepted(case):
    motor = load_motor("ecce2010")
    drive = LIMITS[case]
    (key, _), = drive.items()
    with pytest.raises(Exception) as exc:
        design(motor, DriveData(**drive), analyse=False)
    assert exc.value.key == key, str(exc.value)
    found = LIMIT.findall(exc.value.message)
    assert found, str(exc.value)
    side, limit, _ = found[-1]
    # (rounded to 4 digits on the side that is accepted; "below" and "above" are strict: a hair inside)
    inside = float(limit) * {"at least": 1.0, "at most": 1.0, "below": 0.999, "above": 1.001}[side]
    try:
        design(motor, DriveData(**{key: inside}), analyse=False)
    except Exception as again:  # another rule may refuse the new value, not this one for this input
        assert getattr(again, "key", None) != key or again.message.split(":")[0] != exc.value.message.split(
            ":")[0], (str(exc.value), str(again))


#: drive data the design's API refused naming another input, or accepted (a negative dead time), or
#: ended in a traceback (an OverflowError)
API = {
    "dead time NaN": (dict(dead_time=float("nan")), "dead_time"),
    "dead time negative": (dict(dead_time=-1e-6), "dead_time"),
    "v_dc subnormal": (dict(v_dc=5e-324), "v_dc"),
    "f_pwm subnormal": (dict(f_pwm=5e-324), "f_pwm"),
    "a_max 1e300": (dict(a_max=1e300), "a_max"),
    # (v_max's own range, its speed cap within linear motors' speeds, runs first: stage 1)
    "v_max and a_max 1e300": (dict(v_max=1e300, a_max=1e300), "v_max"),
    "i_max 1e300": (dict(i_max=1e300, load=1.0), "i_max"),
    # (found by tests/properties/test_prop_design.py: the designed f_inj beyond 500 kHz, named as
    # "linsense.analysis.hf: f_inj")
    "f_pwm 8 MHz without dead time": (dict(f_pwm=8000001.0, dead_time=0.0), "f_pwm"),
}


def test_a_subnormal_injection_is_warned_not_divided_by():
    """``v_inj = 5e-324`` (positive, as documented) was a ZeroDivisionError traceback: the dead-time
    ratio is infinite, and said so."""
    dz = design(load_motor("ecce2010"), DriveData(v_inj=5e-324), "api", analyse=False)
    assert dz.dead_time_ratio == float("inf")
    assert any("inf times the weakest HF error signal" in w for w in dz.warnings), dz.warnings


@pytest.mark.parametrize("case", list(API))
def test_the_api_names_the_input_at_fault(case):
    from linsense.errors import InputError

    drive, key = API[case]
    with pytest.raises(InputError) as exc:
        design(load_motor("ecce2010"), DriveData(**drive), "api", analyse=False)
    assert exc.value.key == key, str(exc.value)


def test_the_rules_are_in_stage_order():
    """Inputs against their own ranges, then pairs, then derived quantities: a later rule never runs
    before an earlier stage is through."""
    from linsense.tune.design import DRIVE_RULES

    stages = [r.stage for r in DRIVE_RULES]
    assert stages == sorted(stages) and set(stages) == {1, 2, 3}


def test_a_huge_current_noise_is_a_warning_not_a_traceback(run_cli, tmp_path, monkeypatch):
    """``tune --current-noise 1e300`` (within its documented range, >= 0) was an OverflowError
    traceback in the start-up's design (its square): the pulse pairs it needs are said, limited."""
    monkeypatch.chdir(tmp_path)
    res = run_cli(*tune("--current-noise", "1e300"))
    assert res.code == 0, res.err
    assert "needs inf pulse pairs" in res.err and "limited to 64" in res.err, res.err

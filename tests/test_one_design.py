"""One design: composed in one place (linsense.tune.design_drive) and mapped onto scenario keys in
one place (DriveDesign.scenario_keys), which the simulator's designed scenario, the scenario tune
writes and the C header all read."""

from __future__ import annotations

import inspect
import math
import re
from pathlib import Path

import pytest

from linsense.errors import InputError
from linsense.model.motor import load_motor
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import DESIGNED, designed, drive_data
from linsense.tune import DriveDesign, design_drive
from linsense.tune.cfgmap import ROW
from linsense.tune.design import DriveData, design
from linsense.tune.export import c_header, scenario_dict, scenario_toml, written

SRC = Path(__file__).resolve().parent.parent / "src" / "linsense"

#: a call of one of the design's parts: only linsense.tune composes them (design_drive)
_PART_CALL = re.compile(r"(?<![\w])(design|design_startup|uncompensated_speed_factor)\(")


def part_calls(files) -> list[str]:
    """``path:line`` of each call of a design part in ``files`` (``(path, text)`` pairs)."""
    out = []
    for path, text in files:
        for n, line in enumerate(text.splitlines(), 1):
            code = line.split("#", 1)[0]
            if re.match(r"\s*def ", code):
                continue
            if _PART_CALL.search(code):
                out.append(f"{path}:{n}: {line.strip()}")
    return out


#: the one module that composes the design
COMPOSER = Path("tune", "drive_design.py")


def test_the_design_is_composed_only_in_tune():
    """No module but linsense/tune/drive_design.py calls design(), design_startup() or
    uncompensated_speed_factor(), within linsense.tune too (the C defaults' generator,
    tune/defaults.py, composed its own): they call linsense.tune.design_drive."""
    files = [(p.relative_to(SRC), p.read_text(encoding="utf-8")) for p in SRC.rglob("*.py")
             if p.relative_to(SRC) != COMPOSER]
    assert files
    assert part_calls(files) == []
    # (the check sees a second composition)
    assert part_calls([("x.py", "    dz = design(motor, dd, src, analyse=False)\n"),
                       ("y.py", "    su = design_startup(motor, v_dc=1.0)\n")]) != []


@pytest.fixture(scope="module")
def made() -> DriveDesign:
    motor = load_motor("ecce2010")
    return design_drive(motor, analyse=False)


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def test_scenario_dict_writes_the_design_keys(made):
    """Every value of the design in tune's scenario is its key's (given inputs as given, the rest
    to 6 digits), a start-up's too."""
    keys = made.scenario_keys()
    assert made.startup is not None  # (ecce2010 has saturation data)
    sc = _flat(scenario_dict(made, motor_ref="ecce2010", base={"control": {"mode": "startup"}}))
    own = {"motor", "scenario.name", "scenario.duration", "reference.type", "control.mode",
           "inverter.fidelity"}
    assert set(sc) - own <= set(keys), set(sc) - own - set(keys)
    # the inverter model the certificate judged: simulating the file shows the verified drive
    assert sc["inverter.fidelity"] == "switching"
    given = scenario_dict(made, motor_ref="ecce2010", base={"inverter": {"fidelity": "average"}})
    assert given["inverter"]["fidelity"] == "average"
    for key in set(sc) - own:
        assert sc[key] == written(keys, key), key
    assert {k for k in keys if k.startswith("startup.")} <= set(sc)


def test_header_writes_the_design_keys(made):
    """Each field of the C header read straight from one key holds that key's value."""
    keys = made.scenario_keys(uncompensated=False)
    text = c_header(made)
    vals = {m.group(1): float(m.group(2) or m.group(3)) for m in re.finditer(
        r"^    cfg->([\w.]+) = (?:LS_R\(([^)]*)\)|(\d+)u);$", text, re.M)}
    compared = 0
    for field, got in vals.items():
        r = ROW[field]
        if r.rule is not None or r.keys[0] not in keys or isinstance(keys[r.keys[0]], str):
            continue
        want = float(keys[r.keys[0]])
        if r.conv == "deg":
            want = math.radians(want)
        assert math.isclose(got, want, rel_tol=1e-8, abs_tol=1e-15), (field, got, want)
        compared += 1
    assert compared > 30


def test_designed_scenario_takes_the_design_keys():
    """The simulator's designed scenario sets each key it designs to the design's value, the same
    as tune's scenario (to its 6 digits) and the C header."""
    motor = load_motor("ecce2010")
    sc = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 0.01},
                             "reference": {"type": "hold"}}, "d.toml")
    made = design_drive(motor, drive_data(sc), analyse=False, startup=False)
    keys = made.scenario_keys()
    out = designed(sc, motor).spec
    tuned = _flat(scenario_dict(made, motor_ref="ecce2010"))
    for sec, names in DESIGNED.items():
        for k in names:
            key = f"{sec}.{k}"
            got = getattr(getattr(out, sec), k)
            assert got == keys[key], key
            if key in tuned:
                assert tuned[key] == written(keys, key), key


def test_widened_trips_without_the_table():
    """A drive without its table has the trips and clamp on the estimate widened; its C header (the
    drive runs its table) has not."""
    motor = load_motor("ecce2010")
    lut = design_drive(motor, analyse=False, startup=False)
    nolut = design_drive(motor, analyse=False, startup=False, uncompensated=True)
    assert nolut.k_est > 1.0
    for key in ("observer.omega_max", "protection.omega_max"):
        assert nolut.scenario_keys()[key] == pytest.approx(nolut.k_est * lut.scenario_keys()[key])
        assert nolut.scenario_keys(uncompensated=False)[key] == lut.scenario_keys()[key]


#: the writers of a designed drive: they take what design_drive composed, and nothing else
_WRITERS = {"scenario_dict": lambda x: scenario_dict(x, motor_ref="ecce2010"),
            "scenario_toml": lambda x: scenario_toml(x, "ecce2010", Path("t.toml")),
            "c_header": c_header}


@pytest.mark.parametrize("name", list(_WRITERS))
def test_the_writers_refuse_a_plain_design(name):
    """scenario_dict, scenario_toml and c_header refuse a Design (a second way to put the drive's
    design together, with its drive, start-up and table given beside it): call design_drive."""
    dz = design(load_motor("ecce2010"), DriveData(), analyse=False)
    with pytest.raises(InputError) as e:
        _WRITERS[name](dz)
    assert f"linsense.tune.export.{name}" in str(e.value) and "design_drive" in str(e.value)


@pytest.mark.parametrize("name", list(_WRITERS))
def test_the_writers_take_no_loose_parts(name, made):
    """The writers take the DriveDesign alone: no drive, motor, start-up, widening or pole pitch
    beside it (the DriveDesign holds them), and they write it."""
    import linsense.tune.export as ex

    params = inspect.signature(getattr(ex, name)).parameters
    assert list(params)[0] == "made"
    assert not {"drive", "motor", "startup", "k_est", "pole_pitch", "dz"} & set(params), list(params)
    assert not hasattr(ex, "as_drive_design")
    assert _WRITERS[name](made)

"""The scenario's vocabulary is spelt once: the design's modules write only keys the schema has
(:func:`linsense.scenario.keys.key`), the bounds the design shares with the rules have one home, and
the package sits below the design."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from linsense.scenario.keys import all_keys, checked, in_a_section, key

SRC = Path(__file__).resolve().parents[1] / "src" / "linsense"

#: the modules of the design that write dotted scenario keys as strings (tune/startup.py writes its
#: section's keys bare, checked when written: :func:`test_the_designs_keys_are_keys_of_the_schema`)
WRITERS = ("tune/cfgmap.py", "tune/export.py", "tune/drive_design.py")

#: a string spelt as a dotted key (``injection.amplitude``)
_DOTTED = re.compile(r"[a-z_]+(\.[A-Za-z_][A-Za-z0-9_]*)+")


def _dotted_strings(path: Path) -> list[tuple[int, str]]:
    """(line, text) of each string constant of ``path`` spelt as a key of a scenario's section."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and _DOTTED.fullmatch(n.value)
            and in_a_section(n.value)]


def _unknown(strings: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """Of ``strings``, those neither a scenario key nor a field of ``ls_drive_cfg`` that the mapping
    fills (``startup.err_lock`` is a C field, its key ``startup.err_lock_deg``)."""
    from linsense.tune.cfgmap import ROWS

    fields = {r.field for r in ROWS}
    return [(line, s) for line, s in strings if s not in all_keys() and s not in fields]


def test_key_returns_a_key_and_refuses_a_misspelt_one():
    assert key("injection.amplitude") == "injection.amplitude"
    assert key("controller.model.L_d") == "controller.model.L_d"
    assert key("motor") == "motor"
    for bad in ("injection.amplitdue", "controller.model", "injection"):
        with pytest.raises(KeyError, match="not a key of a scenario file"):
            key(bad)


def test_checked_refuses_a_misspelt_key_of_a_section_only():
    assert checked({"startup.t_lock": 1.0, "motor.pole_pitch": 0.056}) == {"startup.t_lock": 1.0,
                                                                            "motor.pole_pitch": 0.056}
    with pytest.raises(KeyError, match="startup.t_lok"):
        checked({"t_lok": 1.0}, "startup")


@pytest.mark.parametrize("module", WRITERS)
def test_the_design_writes_only_keys_of_the_schema(module):
    strings = _dotted_strings(SRC / module)
    assert strings, f"{module}: no scenario key found (the scan is broken)"
    unknown = _unknown(strings)
    assert unknown == [], f"{module}: keys no scenario file has: {unknown}"


def test_the_scan_sees_a_misspelt_key(tmp_path):
    # a scratch copy of a writer with one key misspelt fails the rule above
    text = (SRC / "tune/drive_design.py").read_text(encoding="utf-8")
    assert '"injection.amplitude"' in text
    bad = tmp_path / "drive_design.py"
    bad.write_text(text.replace('"injection.amplitude"', '"injection.amplitdue"', 1), encoding="utf-8")
    assert _unknown(_dotted_strings(bad)) == [(next(i + 1 for i, ln in enumerate(text.splitlines())
                                                    if '"injection.amplitude"' in ln), "injection.amplitdue")]


def test_the_mapping_to_the_c_configuration_names_keys_of_the_schema():
    from linsense.tune.cfgmap import ROWS

    unknown = {k for r in ROWS for k in r.keys if in_a_section(k) and k not in all_keys()}
    assert unknown == set()


def test_the_designs_keys_are_keys_of_the_schema():
    from linsense.model.motor import load_motor
    from linsense.tune import design_drive

    keys = design_drive(load_motor("ecce2010")).scenario_keys()
    assert {k for k in keys if not k.startswith("motor.")} <= all_keys()


#: the bounds the design shares with the scenario's rules: assigned in linsense.scenario.bounds only
SHARED = ("DEAD_TIME_SHARE_MAX", "F_INJ_PWM_DIV", "V_DC_MIN_FRACTION", "V_DC_MAX_FRACTION")


def _assigned(name: str) -> list[str]:
    out = []
    for path in SRC.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets = (node.targets if isinstance(node, ast.Assign)
                       else [node.target] if isinstance(node, ast.AnnAssign) else [])
            if any(isinstance(t, ast.Name) and t.id == name for t in targets):
                out.append(str(path.relative_to(SRC)))
    return out


@pytest.mark.parametrize("name", SHARED)
def test_a_shared_bound_has_one_home(name):
    assert _assigned(name) == ["scenario/bounds.py"]


def test_no_second_scenario_module():
    # the vocabulary is the package: no sim/scenario.py beside it, and its module names are unique
    assert not (SRC / "sim" / "scenario.py").exists()
    names = [p.name for p in (SRC / "scenario").glob("*.py") if p.name != "__init__.py"]
    others = {p.name for p in SRC.rglob("*.py") if p.parent.name != "scenario"}
    assert set(names) & others == set()

"""The one scenario -> ls_drive_cfg mapping (linsense.tune.cfgmap): the simulator's build, the C
header of ``tune --format c``, the refusal search and the docs' table all read it."""

from __future__ import annotations

import importlib.util
import math
import re
from pathlib import Path

import pytest

from linsense import ctrl
from linsense.scenario.keys import _sections
from linsense.scenario.load import ScenarioFile, scenario_from_dict
from linsense.sim.build import build
from linsense.sim.drive_cfg import value_of
from linsense.sim.refusal import FIELDS, FS_FIELDS
from linsense.tune import DriveData, design_drive
from linsense.tune.cfgmap import ROW, ROWS, header_rows
from linsense.tune.export import c_header, scenario_dict

ROOT = Path(__file__).resolve().parent.parent


def _gen_docs():
    spec = importlib.util.spec_from_file_location("gen_docs", ROOT / "tools" / "gen_docs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_docs_table_is_the_generated_one():
    """docs/simulator.md holds the table tools/gen_docs.py writes from the mapping (run the script
    after a change to linsense.tune.cfgmap)."""
    gen = _gen_docs()
    page = gen.PAGE.read_text(encoding="utf-8")
    assert gen.render(page) == page, "docs/simulator.md's key table differs: run python tools/gen_docs.py"
    # (the check sees a drift: a row edited by hand is written back)
    row = "| `inject.amplitude` | `injection.amplitude` | V |"
    edited = page.replace(row, "| `inject.amplitude` | x | V |")
    assert edited != page and gen.render(edited) == page
    # the table of scenario keys likewise (a default edited by hand is written back)
    row = "| `v_dc` | V | 72 | > 0 | DC bus |"
    edited = page.replace(row, "| `v_dc` | V | 48 | > 0 | DC bus |")
    assert edited != page and gen.render(edited) == page


def _leaf_fields():
    """Every scenario key: (dotted key, its pydantic field)."""
    out = [("motor", ScenarioFile.model_fields["motor"])]
    for path, model in _sections(ScenarioFile).values():
        out += [(f"{path}.{n}", f) for n, f in model.model_fields.items()
                if f"{path}.{n}" not in {p for p, _ in _sections(ScenarioFile).values()}]
    return out


def test_docs_keys_table_has_every_key_with_its_meaning():
    """The generated table of scenario keys has one row per key of the schema, each with a meaning."""
    gen = _gen_docs()
    rows = gen.keys_table().splitlines()[2:]
    keys = _leaf_fields()
    assert len(rows) == len(keys) == 144
    for key, field in keys:
        assert field.description, f"{key}: no description (its meaning in docs/simulator.md)"
    names = [r.split(" | ")[0].strip("| `").split("] ")[-1] for r in rows]
    assert sorted(names) == sorted(k.rsplit(".", 1)[-1] for k, _ in keys)
    # (numbers as the table writes them; the values a key accepts from its type and bounds)
    shown = [gen.number(x) for x in (8e-7, 16000.0, 0.05, 1e6, -1000.0)]
    assert shown == ["0.8e-6", "16000", "0.05", "1e6", "-1000"]
    assert gen.number(20.106192982974676, 3) == "20.1"
    cells = {r.split(" | ")[0].strip("| `").split("] ")[-1]: r.split(" | ")[3] for r in rows}
    assert cells["hf_delay_s"] == "[0, 0.1]" and cells["lut_points"] == "integer [4, 65536]"
    assert cells["quadrature"] == "[0, 1)" and cells["seed"] == "integer [0, 2^63)"


@pytest.mark.parametrize("mode", ["sensorless_lut", "calibration"])
def test_designed_keys_say_so_in_the_docs(mode):
    """A key the design fills where the file leaves it out carries a default note (its schema default is
    not what runs): on a drive other than the default one every designed value differs from it."""
    from linsense.model.motor import load_motor
    from linsense.sim.build import designed

    data = {"motor": "ecce2010", "scenario": {"duration": 1.0},
            "control": {"mode": mode}, "inverter": {"v_dc": 96.0, "f_pwm": 20000.0},
            "controller": {"i_max": 2.0}, "reference": {"type": "hold", "v_max": 0.3}}
    sc = scenario_from_dict(data)
    after = designed(sc, load_motor("ecce2010")).spec
    fields = dict(_leaf_fields())
    changed = []
    for key, field in fields.items():
        sec, _, name = key.rpartition(".")
        if not sec:
            continue
        owner_a, owner_b = sc.spec, after
        for part in sec.split("."):
            owner_a, owner_b = getattr(owner_a, part), getattr(owner_b, part)
        if getattr(owner_a, name) != getattr(owner_b, name):
            changed.append(key)
            extra = field.json_schema_extra or {}
            assert "default_note" in extra, f"{key} is designed but its docs' default is the schema's"
    assert len(changed) >= 10  # (the check sees the design)


def test_every_key_of_the_mapping_is_a_scenario_key():
    """A renamed or removed scenario key cannot stay in the mapping (nor in the docs and refusals)."""
    sections = {path for path, _ in _sections(ScenarioFile).values()}
    known = {"motor"}
    for path, model in _sections(ScenarioFile).values():
        known |= {f"{path}.{name}" for name in model.model_fields}
    for r in ROWS:
        for k in r.keys:
            assert k in known, f"{r.field}: {k!r} is not a scenario key"
            assert k not in sections, f"{r.field}: {k!r} is a section, not a key"


def test_refusal_search_reads_the_mapping():
    assert set(FIELDS) == {r.field for r in ROWS if r.sim and r.blame}
    assert all(FIELDS[f] == (ROW[f].keys, ROW[f].scale) for f in FIELDS)
    assert FS_FIELDS[0] == "fs" and all(ROW[f].keys == ("inverter.f_pwm",) for f in FS_FIELDS)
    assert len(ROW) == len(ROWS)  # (each field once)


def _field(cfg, path: str):
    return ctrl.cfg_get(cfg, path)


def _header_values(text: str) -> list[tuple[str, float]]:
    out = []
    for m in re.finditer(r"^    cfg->([\w.\[\]]+) = (?:LS_R\(([^)]*)\)|(\d+)u);$", text, re.M):
        out.append((m.group(1), float(m.group(2) or m.group(3))))
    return out


@pytest.fixture(scope="module")
def tuned():
    from linsense.model.motor import load_motor

    motor = load_motor("ecce2010")
    return design_drive(motor, DriveData(), analyse=False, startup=False)


def test_header_writes_the_mapping_rows_in_order(tuned):
    got = [f for f, _ in _header_values(c_header(tuned))]
    assert got == [r.field for r in header_rows(False)]


def test_header_and_simulator_set_the_same_values(tuned):
    """The design's scenario (tune --format toml's keys, rounded to 6 digits) built by the simulator
    gives every field the header writes the header's value (to the rounding)."""
    text = c_header(tuned)
    sc = scenario_from_dict(scenario_dict(tuned, motor_ref="ecce2010"), "tuned.toml")
    b = build(sc)
    compared = 0
    for path, want in _header_values(text):
        r = ROW[path]
        if not r.sim or r.when is not None:  # (the header's own, or the simulator's in calibration only)
            continue
        got = float(_field(b.drive.cfg, path))
        assert math.isclose(got, want, rel_tol=2e-5, abs_tol=1e-12), (path, got, want)
        compared += 1
    assert compared > 50
    assert value_of(b.scenario.spec, "inverter.f_pwm") == tuned.drive.f_pwm


def test_build_fills_every_row_it_owns():
    """Each field the simulator sets holds its row's value (the build has no second copy)."""
    sc = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 0.01},
                             "reference": {"type": "hold"}, "observer": {"min_level": 0.004},
                             "controller": {"kp_x": 12.0}, "inverter": {"dead_time": 0.5e-6}}, "m.toml")
    b = build(sc)
    assert float(_field(b.drive.cfg, "demod.min_level")) == pytest.approx(0.004, rel=1e-6)
    assert float(_field(b.drive.cfg, "pos.kp_x")) == pytest.approx(12.0, rel=1e-6)
    assert float(_field(b.drive.cfg, "mod.dead_time")) == pytest.approx(0.5e-6, rel=1e-6)
    assert float(_field(b.drive.cfg, "traj.pole_pitch")) == pytest.approx(b.motor.pole_pitch, rel=1e-6)

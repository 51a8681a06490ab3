"""Measured compensation tables (linsense.compensation.measured): the stamped lut_measured.json that
linsense calibrate writes and the simulator runs (observer.lut_model = "measured"): the round trip,
the resampling to the drive's length, every refusal naming the file and the key or row, the
scenario's keys, a measured table equal to the model's running as the model's, and a calibration
on an off-nominal plant whose table the drive then runs."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from linsense.compensation.lut import build_lut, interpolate
from linsense.compensation.measured import (
    FORMAT,
    PSI_MAX,
    MeasuredTable,
    TableStamp,
    measured_table_json,
    read_measured_table,
    table_stamp,
)
from linsense.compensation.stamp import data_digest
from linsense.errors import InputError
from linsense.io import split_timing
from linsense.model.motor import load_motor, motor_to_toml
from linsense.model.tolerance import perturbed
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import designed
from linsense.sim.simulation import simulate
from linsense.studies.calibrate import Calibration, calibrate, measured_json

F_INJ, QUAD = 1000.0, 0.9  # (the ecce2010 design's pulsating-elliptical injection)


@pytest.fixture(scope="module")
def motor():
    return load_motor("ecce2010")


def _drive(base, **over) -> dict:
    d = {"motor": base, "injection": "pulsating", "f_inj": F_INJ, "quad": QUAD, "points": 56}
    d.update(over)
    return d


def _doc(motor, n: int = 56) -> dict:
    values = build_lut(motor, n, f_inj=F_INJ, quad=QUAD).values
    return json.loads(measured_table_json(values, table_stamp(motor, "pulsating", F_INJ, QUAD, n)))


def _write(tmp_path: Path, doc) -> Path:
    f = tmp_path / "lut.json"
    f.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return f


# ---------------------------------------------------------------------- writing and reading
def test_round_trip_is_exact_and_deterministic(tmp_path, motor):
    values = build_lut(motor, 56, f_inj=F_INJ, quad=QUAD).values
    stamp = table_stamp(motor, "pulsating", F_INJ, QUAD, 56)
    text = measured_table_json(values, stamp, {"metrics": {"completed": True}})
    assert text == measured_table_json(values, stamp, {"metrics": {"completed": True}})
    doc = json.loads(text)
    assert list(doc) == sorted(doc) and doc["format"] == FORMAT and doc["unit"] == "rad"
    assert doc["stamp"] == {"motor_sha256": data_digest(motor=motor), "motor": "ecce2010",
                            "injection": "pulsating", "f_inj": F_INJ, "quad": QUAD, "points": 56}
    assert doc["theta"] == [2.0 * math.pi * k / 56 for k in range(56)]
    t = read_measured_table(_write(tmp_path, text), **_drive(motor))
    assert isinstance(t, MeasuredTable) and isinstance(t.stamp, TableStamp)
    assert np.array_equal(t.values, values)  # (bit for bit: repr floats)
    assert t.stamp == stamp and t.stamp.as_dict() == doc["stamp"]
    assert (t.resampled, t.note, t.source) == (False, "", str(tmp_path / "lut.json"))
    assert not t.values.flags.writeable


def test_another_length_is_resampled_as_the_firmware_reads_it(tmp_path, motor):
    f = _write(tmp_path, _doc(motor, 56))
    t = read_measured_table(f, **_drive(motor, points=256))
    table = build_lut(motor, 56, f_inj=F_INJ, quad=QUAD).values
    want = interpolate(table, 2.0 * np.pi * np.arange(256) / 256)
    assert np.array_equal(t.values, want) and t.values.size == 256
    assert t.resampled and t.stamp.points == 56
    assert t.note == ("56-point table resampled to 256 points with the firmware's periodic linear "
                      "interpolation")


def test_the_writer_refuses_what_the_reader_would(motor):
    stamp = table_stamp(motor, "pulsating", F_INJ, QUAD, 8)
    good = np.zeros(8)
    for psi, key in ((np.r_[good[:7], np.nan], "psi[7]"), (np.r_[good[:7], 1.0], "psi[7]"),
                     (np.zeros(7), "psi")):
        with pytest.raises(InputError) as e:
            measured_table_json(psi, stamp)
        assert e.value.key == key
    with pytest.raises(InputError, match="not an informational key"):
        measured_table_json(good, stamp, {"theta": [1.0]})


# ---------------------------------------------------------------------- refusals
def _set(path: str, value):
    def edit(doc: dict) -> dict:
        keys = path.split(".")
        d = doc
        for k in keys[:-1]:
            d = d[k]
        if value is _DROP:
            d.pop(keys[-1])
        else:
            d[keys[-1]] = value(d[keys[-1]]) if callable(value) else value
        return doc
    return edit


_DROP = object()


def _row(key: str, i: int, value):
    def edit(doc: dict) -> dict:
        doc[key][i] = value
        return doc
    return edit


def _short(doc: dict) -> dict:  # the last 6 of 56 rows lost
    doc["theta"], doc["psi_lut"] = doc["theta"][:50], doc["psi_lut"][:50]
    doc["stamp"]["points"] = 50
    return doc


def _closed(doc: dict) -> dict:  # the first row repeated at 2 pi
    n = len(doc["theta"])
    doc["theta"] = [2.0 * math.pi * k / (n - 1) for k in range(n)]
    return doc


def _theta_deg(doc: dict) -> dict:
    doc["theta"] = [math.degrees(t) for t in doc["theta"]]
    return doc


def _psi_deg(doc: dict) -> dict:
    doc["psi_lut"] = [math.degrees(p) for p in doc["psi_lut"]]
    return doc


# name: (edit of a valid document, or the file's text; the key named; words of the message)
REFUSED = {
    "an empty file": ("", "", ["empty file"]),
    "not JSON": ("{format: 1", "", ["not JSON"]),
    "the CSV beside it": ("theta_deg,psi_lut_deg\n0,1\n", "", ["CSV", "lut_measured.json"]),
    "a JSON list": ("[1, 2]", "", ["a JSON list"]),
    "a model LUT": (_set("format", "linsense-lut"), "format", ["'linsense-lut'", "no stamp"]),
    "no format": (_set("format", _DROP), "format", ["missing"]),
    "degrees as the unit": (_set("unit", "deg"), "unit", ["'deg'", "rad"]),
    "an unknown key": (lambda d: {**d, "units": "rad"}, "units", ["did you mean 'unit'"]),
    "no stamp": (_set("stamp", _DROP), "stamp", ["missing"]),
    "a stamp key missing": (_set("stamp.quad", _DROP), "stamp.quad", ["missing"]),
    "an unknown stamp key": (_set("stamp.kappa", 0.9), "stamp.kappa", ["not a stamp key"]),
    "a bad digest": (_set("stamp.motor_sha256", "abc"), "stamp.motor_sha256", ["64"]),
    "a boolean frequency": (_set("stamp.f_inj", True), "stamp.f_inj", ["True"]),
    "stamp points not the length": (_set("stamp.points", 57), "stamp.points", ["57", "56 values"]),
    "no table": (_set("psi_lut", _DROP), "psi_lut", ["missing"]),
    "a NaN": (_row("psi_lut", 12, float("nan")), "psi_lut[12]", ["not finite", "nan"]),
    "an infinite position": (_row("theta", 3, float("inf")), "theta[3]", ["not finite"]),
    "an integer beyond the floats": (_row("psi_lut", 4, 10**400), "psi_lut[4]", ["not finite"]),
    "a string": (_row("psi_lut", 5, "0.1"), "psi_lut[5]", ["not a number"]),
    "lengths differ": (lambda d: {**d, "psi_lut": d["psi_lut"][:-1]}, "psi_lut", ["55 values for 56"]),
    "three points": (lambda d: {**d, "theta": [0.0, 2.0, 4.0], "psi_lut": [0.0] * 3,
                                "stamp": {**d["stamp"], "points": 3}}, "stamp.points", ["at least 4"]),
    "a short grid": (_short, "theta[1]", ["2 pi k / 56 with only 50 of its 56 rows",
                                          "does not cover the whole period"]),
    "a closed grid": (_closed, "theta[1]", ["repeats the first at 2 pi"]),
    "an uneven grid": (_row("theta", 20, 2.0 * math.pi * 20.5 / 56), "theta[20]", ["2 pi k / N"]),
    "positions in degrees": (_theta_deg, "theta[1]", ["looks like degrees", "360 k / N"]),
    "values in degrees": (_psi_deg, "psi_lut[0]",
                          ["beyond +-45 electrical deg", "degrees written as radians?"]),
    "a value beyond any angle": (_row("psi_lut", 7, 100.0), "psi_lut[7]", ["beyond +-45"]),
    "just beyond 45 deg": (_row("psi_lut", 9, PSI_MAX * 1.001), "psi_lut[9]", ["beyond +-45"]),
}


@pytest.mark.parametrize("case", list(REFUSED))
def test_refusals_name_the_file_and_the_key(tmp_path, motor, case):
    edit, key, words = REFUSED[case]
    f = _write(tmp_path, edit if isinstance(edit, str) else edit(_doc(motor)))
    with pytest.raises(InputError) as e:
        read_measured_table(f, **_drive(motor))
    line = str(e.value)
    assert e.value.source == str(f) and e.value.key == key, line
    assert "\n" not in line
    for w in words:
        assert w in line, (w, line)
    if case == "a value beyond any angle":
        assert "degrees written" not in line


def test_no_such_file_and_a_folder(tmp_path, motor):
    for f, said in ((tmp_path / "none.json", "no such measured table"),
                    (tmp_path, "is a folder, not a measured table")):
        with pytest.raises(InputError, match=said) as e:
            read_measured_table(f, **_drive(motor))
        assert e.value.source == str(f)


def test_the_model_table_is_within_the_bound():
    """The bound of 45 deg is well beyond every table linsense computes (the largest: 23.8 deg, the
    rotating vector's on the harmonic example)."""
    from linsense.model.motor import preset_names

    for m in [load_motor(p) for p in preset_names()] + [load_motor("harmonic"), load_motor("small30")]:
        for inj, q in (("pulsating", 0.0), ("pulsating", 0.9), ("rotating", 0.0), ("square", 0.0)):
            assert np.abs(build_lut(m, 64, f_inj=F_INJ, quad=q, injection=inj).values).max() < 0.6 * PSI_MAX


# name: (the drive reading, the key named, words)
OTHER_DRIVE = {
    "another motor": ({"motor": "small30"}, "stamp.motor_sha256", ["'ecce2010'", "'small30'"]),
    "the same name, other data": ({"motor": "perturbed"}, "stamp.motor_sha256",
                                  ["'ecce2010'", "an edited motor file?"]),
    "another injection": ({"injection": "rotating", "quad": 0.0}, "stamp.injection",
                          ["'pulsating'", "'rotating'"]),
    "another frequency": ({"f_inj": 1000.01}, "stamp.f_inj", ["1000 Hz", "1000.01 Hz"]),
    "another kappa": ({"quad": 0.9 + 1e-8}, "stamp.quad", ["kappa 0.9,", "kappa 0.90000001"]),
}


@pytest.mark.parametrize("case", list(OTHER_DRIVE))
def test_a_table_of_another_drive_is_refused(tmp_path, motor, case):
    over, key, words = OTHER_DRIVE[case]
    if over.get("motor") == "small30":
        over = {**over, "motor": load_motor("small30")}
    elif over.get("motor") == "perturbed":
        over = {**over, "motor": perturbed(motor, 1.0, 1.0, 1.25)}
    f = _write(tmp_path, _doc(motor))
    with pytest.raises(InputError) as e:
        read_measured_table(f, **_drive(motor, **over))
    line = str(e.value)
    assert e.value.source == str(f) and e.value.key == key, line
    for w in words:
        assert w in line, (w, line)
    if key == "stamp.motor_sha256":  # (both digests' first 12 hex digits)
        for m in (motor, over["motor"]):
            assert data_digest(motor=m)[:12] in line


def test_within_the_tolerances_is_the_same_drive(tmp_path, motor):
    f = _write(tmp_path, _doc(motor))
    t = read_measured_table(f, **_drive(motor, f_inj=F_INJ * (1 + 5e-7), quad=QUAD + 5e-10))
    assert t.values.size == 56
    # (a copy of the motor's data is the same motor: the digest is over its values)
    copy = tmp_path / "copy.toml"
    copy.write_text(motor_to_toml(motor))
    read_measured_table(f, **_drive(load_motor(copy)))


# ---------------------------------------------------------------------- the scenario
HOLD = {"motor": "ecce2010", "scenario": {"duration": 0.4}, "inverter": {"fidelity": "average"},
        "reference": {"type": "hold"}, "initial": {"position_mm": 10.0}}


def _scenario(tmp_path: Path, observer: dict, **over):
    data = json.loads(json.dumps(HOLD))
    data["observer"] = observer
    data.update(over)
    return scenario_from_dict(data, str(tmp_path / "s.toml"), tmp_path)


@pytest.mark.parametrize("observer, words", [
    ({"lut_model": "measured"}, ["missing", "lut_model = \"measured\""]),
    ({"lut_file": "lut.json"}, ["'lut.json'", "observer.lut_model = 'resistive'"]),
    ({"lut_model": "eq12", "lut_file": "lut.json"}, ["observer.lut_model = 'eq12'"]),
])
def test_the_scenario_keys_go_together(tmp_path, observer, words):
    with pytest.raises(InputError) as e:
        _scenario(tmp_path, observer)
    assert e.value.key == "observer.lut_file"
    for w in words:
        assert w in str(e.value)


def test_the_simulator_names_its_key_and_the_table(tmp_path):
    sub = tmp_path / "cal"
    sub.mkdir()
    (sub / "lut.json").write_text("")
    sc = _scenario(tmp_path, {"lut_model": "measured", "lut_file": "cal/lut.json"})
    with pytest.raises(InputError) as e:
        simulate(sc)
    assert e.value.source == str(tmp_path / "s.toml") and e.value.key == "observer.lut_file"
    assert str(sub / "lut.json") in str(e.value) and "empty file" in str(e.value)


def test_a_measured_model_table_runs_as_the_model(tmp_path, motor):
    """The model's own table written as a measured table (relative to the scenario's folder) runs
    bit for bit as lut_model = "resistive" at the same length: the same table, the same slopes and
    gains."""
    points = 64
    sc = _scenario(tmp_path, {"lut_model": "resistive", "lut_points": points})
    inj = designed(sc, motor).spec.injection
    values = build_lut(motor, points, f_inj=inj.frequency, quad=inj.quadrature).values
    (tmp_path / "t").mkdir()
    (tmp_path / "t" / "lut.json").write_text(
        measured_table_json(values, table_stamp(motor, "pulsating", inj.frequency, inj.quadrature, points)))
    model = split_timing(simulate(sc).metrics)[0]
    measured = split_timing(simulate(_scenario(tmp_path, {"lut_model": "measured", "lut_file": "t/lut.json",
                                                          "lut_points": points})).metrics)[0]
    assert measured == model


# ---------------------------------------------------------------------- a calibration, then its table run
def test_calibrate_an_off_nominal_plant_and_run_its_table(tmp_path, motor):
    """The drive believes in ecce2010 and runs on a plant with a 25 % larger end effect: the table is
    the plant's, stamped with the drive's motor, and a hold on that plant with it is several times
    less biased than with the drive's own model table."""
    plant = perturbed(motor, 1.0, 1.0, 1.25)
    data = {"motor": "ecce2010", "scenario": {"duration": 1.0}, "reference": {"type": "hold"}}
    sc = scenario_from_dict(data, str(tmp_path / "s.toml"), tmp_path)
    cal = calibrate(scenario=sc, positions=16, fidelity="average", plant=plant)
    m = cal.metrics
    assert cal.completed and m["points_done"] == 16
    assert cal.stamp == table_stamp(motor, "pulsating", m["f_inj_hz"], m["injection_quad"], 16)
    own = build_lut(plant, 16, f_inj=m["f_inj_hz"], quad=m["injection_quad"]).values
    assert np.array_equal(cal.psi_model, own)  # (the plant's true table)
    nominal = build_lut(motor, 16, f_inj=m["f_inj_hz"], quad=m["injection_quad"]).values
    err_plant = np.degrees(np.abs(cal.psi_measured - own)).max()
    assert err_plant == pytest.approx(m["max_diff_deg"], abs=1e-6) and err_plant < 0.3
    assert np.degrees(np.abs(own - nominal)).max() > 10 * err_plant  # (the plant's table, not the model's)
    (tmp_path / "lut_measured.json").write_text(measured_json(cal))
    # the plant as a motor file (the end effect dM0 scaled as perturbed() scales it), the drive's
    # model the preset
    text = motor_to_toml(motor)
    dm0 = motor.inductance.params["dM0"]
    (tmp_path / "plant.toml").write_text(text.replace(f"dM0 = {dm0!r}", f"dM0 = {dm0 * 1.25!r}"))
    bias = {}
    for lut in ("resistive", "measured"):
        obs = {"lut_model": lut, **({"lut_file": "lut_measured.json"} if lut == "measured" else {})}
        r = simulate(_scenario(tmp_path, obs, motor="plant.toml", controller={"model": {"motor": "ecce2010"}},
                               scenario={"duration": 1.0}, initial={"position_mm": 20.0}))
        bias[lut] = abs(r.metrics["bias_deg"])
    assert bias["measured"] < 0.3 * bias["resistive"], bias


def test_measured_json_refuses_an_incomplete_calibration(motor):
    theta = 2.0 * np.pi * np.arange(4) / 4
    stamp = table_stamp(motor, "pulsating", F_INJ, QUAD, 4)
    psi = np.array([0.1, 0.2, np.nan, np.nan])
    cal = Calibration(theta, psi, psi, psi, {"completed": False, "points": 4, "points_done": 2,
                                             "fault": "observer"}, motor, stamp)
    with pytest.raises(InputError, match="did not complete .2 of 4 points, fault observer"):
        measured_json(cal)
    cal.metrics["completed"] = True
    with pytest.raises(InputError) as e:
        measured_json(cal)
    assert e.value.key == "psi_measured[2]"


def test_the_command_writes_the_stamped_table(run_cli, tmp_path):
    out = tmp_path / "cal"
    r = run_cli("calibrate", "--motor", "ecce2010", "--positions", "4", "--fidelity", "average", "--out", out)
    assert r.code == 0, r.err
    doc = json.loads((out / "lut_measured.json").read_text())
    assert doc["stamp"]["points"] == 4 and doc["stamp"]["motor"] == "ecce2010"
    assert "wall_s" not in doc["metrics"] and doc["metrics"]["completed"] is True
    rows = (out / "lut_measured.csv").read_text().splitlines()[1:]
    assert [float(r.split(",")[1]) for r in rows] == pytest.approx(np.degrees(doc["psi_lut"]), abs=1e-6)


def test_the_numbers_of_the_docs(tmp_path, motor):
    """docs/simulator.md, "Measured tables": ecce2010 with its end effect 25 % above the file, 56
    positions on the switching inverter; holds at 8 positions over the period on that plant, with
    the drive's model table and with the measured one (each number at the digits written there)."""
    plant = perturbed(motor, 1.0, 1.0, 1.25)
    data = {"motor": "ecce2010", "scenario": {"duration": 1.0}, "reference": {"type": "hold"}}
    cal = calibrate(scenario=scenario_from_dict(data, str(tmp_path / "s.toml"), tmp_path), positions=56,
                    plant=plant)
    m = cal.metrics
    assert cal.completed and m["fidelity"] == "switching"
    nominal = build_lut(motor, 56, f_inj=m["f_inj_hz"], quad=m["injection_quad"]).values
    assert f"{np.degrees(np.abs(cal.psi_model - nominal)).max():.1f}" == "4.4"
    assert f"{m['max_diff_deg']:.2f}" == "0.21"
    (tmp_path / "lut.json").write_text(measured_json(cal))
    text, dm0 = motor_to_toml(motor), motor.inductance.params["dM0"]
    (tmp_path / "plant.toml").write_text(text.replace(f"dM0 = {dm0!r}", f"dM0 = {dm0 * 1.25!r}"))
    bias = {}
    for lut in ("resistive", "measured"):
        obs = {"lut_model": lut, **({"lut_file": "lut.json"} if lut == "measured" else {})}
        b = [abs(simulate(_scenario(tmp_path, obs, motor="plant.toml", inverter={"fidelity": "switching"},
                                    controller={"model": {"motor": "ecce2010"}}, scenario={"duration": 1.0},
                                    initial={"position_mm": 7.0 * k})).metrics["bias_deg"]) for k in range(8)]
        bias[lut] = (max(b), float(np.mean(b)))
    assert (f"{bias['resistive'][0]:.1f}", f"{bias['resistive'][1]:.1f}") == ("6.5", "3.6"), bias
    assert (f"{bias['measured'][0]:.2f}", f"{bias['measured'][1]:.2f}") == ("0.11", "0.04"), bias


def test_a_key_given_twice_is_refused(tmp_path, motor):
    """json keeps the last of two equal keys silently: a table whose psi_lut is given twice is
    refused naming the key."""
    text = json.dumps(_doc(motor, 8))
    twice = text[:-1] + ', "psi_lut": ' + json.dumps([0.1] * 8) + "}"
    f = tmp_path / "twice.json"
    f.write_text(twice)
    with pytest.raises(InputError, match="given twice") as e:
        read_measured_table(f, **_drive(motor, points=8))
    assert e.value.key == "psi_lut"

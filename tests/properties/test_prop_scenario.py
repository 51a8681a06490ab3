"""Properties of scenario files: any generated scenario (valid, or with keys set to wrong types,
out-of-range, NaN and inf, huge or negative values, deleted, misspelled or added, a section replaced
by a value, broken text) is either a run whose outputs agree with the file, or one refusal naming
the file (and the key); through the loader and the build (sizes and design), and through
``linsense simulate`` for short runs."""

from __future__ import annotations

import json
import math
import tomllib

from hypothesis import event, example, given
from hypothesis import strategies as st
from prop_strategies import (
    HOSTILE,
    MAX_TOML_DEPTH,
    attempt,
    cli_outcome,
    finite_number,
    is_number,
    mostly,
    mutated,
    nesting,
    prop_settings,
    text_mutation,
    toml_text,
)

from linsense.scenario.load import load_scenario
from linsense.sim.build import build


def pos(v, doc) -> bool:
    return finite_number(v) and v > 0


def nonneg(v, doc) -> bool:
    return finite_number(v) and v >= 0


def real(v, doc) -> bool:
    return finite_number(v)


def integer(lo, hi):
    return lambda v, doc: isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi


def enum(*values):
    return lambda v, doc: isinstance(v, str) and v in values


def unit(v, doc) -> bool:
    return finite_number(v) and 0 <= v < 1


#: the keys the properties vary and what docs/simulator.md and docs/limits.md allow for each
KEYS = {
    "scenario": {"duration": pos, "seed": integer(0, 2**63 - 1),
                 "name": lambda v, d: isinstance(v, str) and len(v) > 0},
    "inverter": {"fidelity": enum("average", "switching"), "v_dc": pos, "f_pwm": pos, "dead_time": nonneg},
    "control": {"mode": enum("sensorless_lut", "sensorless_nolut", "sensored", "calibration", "startup")},
    "injection": {"amplitude": nonneg, "frequency": pos, "quadrature": unit},
    "observer": {"lut_points": integer(4, 65_536), "bandwidth_hz": pos, "hf_delay_s": lambda v, d:
                 finite_number(v) and 0 <= v <= 0.1, "type": enum("pll", "mech")},
    "controller": {"kp_x": pos, "i_max": pos},
    "reference": {"position_mm": real, "at": nonneg, "dwell": nonneg},
    "load": {"force": real},
    "sensors": {"current_noise": nonneg},
    "record": {"decimate": integer(1, 1_000_000)},
    "protection": {"i_max": pos},
    "metrics": {"bound_deg": pos},
}
SECTIONS = {"": ("motor", "scenario", "inverter", "control", "reference", "record", "observer")}
SECTIONS.update({s: tuple(k) for s, k in KEYS.items()})


@st.composite
def scenario_doc(draw) -> dict:
    """A short valid scenario on the reference motor (the hostile suite's base, 1-20 ms)."""
    doc = {
        "motor": "ecce2010",
        "scenario": {"name": "s", "duration": draw(st.floats(0.001, 0.02)), "seed": draw(st.integers(0, 5))},
        "inverter": {"v_dc": draw(st.floats(50.0, 80.0)),
                     "fidelity": draw(st.sampled_from(["average", "switching"]))},
        "control": {"mode": draw(st.sampled_from(["sensorless_lut", "sensorless_nolut", "sensored"]))},
        "observer": {"bandwidth_hz": draw(st.floats(5.0, 60.0))},
        "reference": {"position_mm": draw(st.floats(-10, 10)), "at": draw(st.floats(0.0, 0.01))},
    }
    if draw(st.booleans()):
        doc["record"] = {"decimate": draw(st.integers(1, 50))}
    return doc


def violations(doc) -> list[str]:
    """Keys of ``doc`` that break what the documentation says (empty: valid as documented, which
    may still be refused by a rule between keys, e.g. a bus too low for the injection)."""
    if not isinstance(doc, dict) or nesting(doc) > MAX_TOML_DEPTH:
        return ["<file>"]
    bad = [k for k in doc if k not in SECTIONS[""] + tuple(KEYS)]
    if not (isinstance(doc.get("motor"), str) and doc["motor"]):
        bad.append("motor")
    for sec in set(doc) - {"motor"}:
        if not isinstance(doc[sec], dict):
            bad.append(sec)
            continue
        for k, v in doc[sec].items():
            ok = KEYS.get(sec, {}).get(k)
            if ok is None and not (sec == "reference" and k == "type"):
                bad.append(f"{sec}.{k}")  # (an unknown key: the generator adds only unknown ones)
            elif ok is not None and not ok(v, doc):
                bad.append(f"{sec}.{k}")
    sc = doc.get("scenario") if isinstance(doc.get("scenario"), dict) else {}
    if "duration" not in sc:
        bad.append("scenario.duration")
    ref = doc.get("reference") if isinstance(doc.get("reference"), dict) else {}
    if ref.get("type", "step") == "step" and "position_mm" not in ref:
        bad.append("reference.position_mm")
    inv = doc.get("inverter") if isinstance(doc.get("inverter"), dict) else {}
    f_pwm = inv.get("f_pwm", 16000.0)
    if pos(f_pwm, doc):
        if pos(sc.get("duration"), doc) and sc["duration"] * f_pwm > 1e10:
            bad.append("scenario.duration")  # (docs/limits.md: PWM periods of one run)
        if nonneg(inv.get("dead_time", 0.0), doc) and inv.get("dead_time", 0.0) * f_pwm >= 0.1:
            bad.append("inverter.dead_time")
        inj = doc.get("injection") if isinstance(doc.get("injection"), dict) else {}
        if pos(inj.get("frequency"), doc) and inj["frequency"] > f_pwm / 4:
            bad.append("injection.frequency")
    return bad


def _steps_overflow(doc) -> bool:
    """Whether duration x f_pwm of the parsed file overflows to infinity."""
    try:
        d, f = doc["scenario"]["duration"], doc.get("inverter", {}).get("f_pwm", 16000.0)
        return finite_number(d) and finite_number(f) and not math.isfinite(d * f)
    except (TypeError, KeyError, AttributeError):
        return False


def names_key(key: str, msg: str, doc: dict) -> bool:
    """Whether a refusal names ``key`` (or its section)."""
    # (found: a scenario without [reference] was refused as "FILE: position_mm: missing required key",
    # the section not named: the default ReferenceSection failed outside its section)
    return key in msg or key.split(".")[0] in msg


def check_given(sc, doc: dict) -> None:
    """Every value the file gave is the scenario's, unchanged (no silent coercion or clipping)."""
    for sec, keys in KEYS.items():
        for k in keys:
            if isinstance(doc.get(sec), dict) and k in doc[sec]:
                got, want = getattr(getattr(sc.spec, sec), k), doc[sec][k]
                if isinstance(got, float) and is_number(want):  # (an integer where a float belongs)
                    assert got == float(want), (sec, k, got, want)
                else:
                    assert got == want and type(got) is type(want), (sec, k, got, want)


@prop_settings(scale=3)
@given(data=st.data())
def test_a_scenario_loads_and_builds_within_the_limits_or_is_refused_in_one_line(tmp_path, data):
    doc, _ = data.draw(mutated(data.draw(scenario_doc()), SECTIONS))
    if data.draw(st.integers(0, 5)) == 0 and isinstance(doc.get("scenario"), dict):
        # around the limit of PWM periods of one run, 10^10 (docs/limits.md): built, never run
        doc["scenario"]["duration"] = data.draw(st.sampled_from([6.25e5, 6.2500001e5, 1e6, 3e5, 1e300,
                                                                 1e308]))
    text = toml_text(doc)
    if data.draw(st.integers(0, 4)) == 0:
        text = data.draw(text_mutation(text))
    path = tmp_path / "scenario.toml"
    path.write_text(text, encoding="utf-8")
    try:
        parsed = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):
        parsed = None
    # (found: a duration whose product with f_pwm overflows, scenario.duration = 1e308, was an
    # OverflowError traceback in build, and in simulate)
    if _steps_overflow(parsed):
        event("duration x f_pwm overflows")
    status, value = attempt(load_scenario, path)
    if status == "ok":
        status, value = attempt(build, value, trace_in_memory=False)
    event(f"{status}: {type(value).__name__}")
    bad = ["<text>"] if parsed is None else violations(parsed)
    if status == "refused":
        msg = str(value)
        assert msg.startswith(str(path)) or "ecce2010" in msg, msg
        if len(set(bad)) == 1 and bad[0] not in ("<file>", "<text>"):
            assert names_key(bad[0], msg, parsed), (bad, msg)
        return
    assert not bad, f"accepted a scenario outside the documented ranges: {bad}"
    sc = load_scenario(path)
    check_given(sc, parsed)
    f_pwm = sc.spec.inverter.f_pwm
    assert abs(value.n_steps - sc.spec.scenario.duration * f_pwm) <= 1, (value.n_steps, f_pwm)
    assert value.n_steps >= 1


SHORT = {"motor": "ecce2010", "scenario": {"name": "s", "duration": 0.005},
         "reference": {"position_mm": 1.0, "at": 0.001}}


@prop_settings()
# (found: controller.i_max = 5e-324 was a ZeroDivisionError traceback in the design)
@example(doc=SHORT, edit=("controller", "i_max"), value=5e-324, trace="none", decimate=None)
# (found: scenario.duration = 1e308 was an OverflowError traceback at the step count, exit 1)
@example(doc=SHORT, edit=("scenario", "duration"), value=1e308, trace="none", decimate=None)
@given(doc=scenario_doc(), edit=st.sampled_from(sorted((s, k) for s, ks in KEYS.items() for k in ks
                                                       if (s, k) not in (("scenario", "duration"),
                                                                         ("inverter", "f_pwm")))),
       value=mostly(st.none(), HOSTILE, one_in=2), trace=st.sampled_from(["none", "csv", "parquet"]),
       decimate=mostly(st.none(), st.sampled_from(["0", "1", "7", "1000001", "x"]), one_in=3))
def test_simulate_writes_outputs_that_agree_with_the_file_or_refuses(run_cli, tmp_path, doc, edit, value,
                                                                     trace, decimate):
    doc = dict(doc)
    if value is not None:
        doc[edit[0]] = {**doc.get(edit[0], {}), edit[1]: value}
    path = tmp_path / "scenario.toml"
    path.write_text(toml_text(doc), encoding="utf-8")
    out = tmp_path / "out"
    args = ["simulate", path, "--out", out, "--trace", trace]
    if decimate is not None:
        args += ["--decimate", decimate]
    existed = out.exists()
    res = run_cli(*args)
    status = cli_outcome(res, (str(path), "--decimate", "ecce2010"))
    event(status)
    bad = violations(doc)
    if decimate is not None and not (decimate.isdigit() and 1 <= int(decimate) <= 1_000_000):
        bad.append("--decimate")
    if status == "refused":
        assert out.exists() == existed, "a refused run changed its output folder"
        if len(bad) == 1 and bad[0] != "<file>":
            assert names_key(bad[0], res.err, doc), (bad, res.err)
        return
    assert not bad, f"ran a scenario outside the documented ranges: {bad}"
    assert decimate is None or 1 <= int(decimate) <= 1_000_000
    m = json.loads((out / "metrics.json").read_text(), parse_constant=lambda c: math.nan)
    timing = json.loads((out / "timing.json").read_text())
    manifest = json.loads((out / ".linsense-set.json").read_text())
    want = {"metrics.json", "timing.json"} | ({f"trace.{trace}"} if trace != "none" else set())
    assert set(manifest["files"]) == want and all((out / f).is_file() for f in want)
    sc = load_scenario(path)
    duration, f_pwm = sc.spec.scenario.duration, sc.spec.inverter.f_pwm
    assert m["sim_s"] == timing["sim_s"]
    # the metrics read every period whatever the record keeps: samples and block_s are the
    # metrics' own, not the record's
    assert m["block_s"] == round(1 / f_pwm, 9), m["block_s"]
    if m["fault"] == "none":  # the whole run, every period read
        assert abs(m["steps"] - duration * f_pwm) <= 1, (m["steps"], duration * f_pwm)
        assert m["samples"] == m["steps"], (m["samples"], m["steps"])
    else:  # a trip ends the run there (and records the period it tripped in); its time is known to
        # one period, block_s (docs/simulator.md, "Metrics")
        assert m["steps"] <= duration * f_pwm + 1
        assert abs(m["fault_time_s"] - m["sim_s"]) <= m["block_s"] * (1 + 1e-9), m
        assert m["samples"] == m["steps"] + 1, (m["samples"], m["steps"])
    assert abs(m["sim_s"] - m["steps"] / f_pwm) <= 1e-9 + 1e-6 * m["sim_s"], (m["sim_s"], m["steps"])
    assert m["mode"] == sc.spec.control.mode and m["fidelity"] == sc.spec.inverter.fidelity
    assert m["scenario"] == sc.spec.scenario.name and m["motor"] == "ecce2010"
    for k, v in m.items():  # (no NaN or infinity reaches metrics.json: a number, null, or text)
        assert not (isinstance(v, float) and not math.isfinite(v)), (k, v)

"""Properties of sweep files: any generated sweep (valid, or mutated: wrong types, NaN and inf,
huge ranges, missing or extra keys, a grid beyond the limit, broken text) is either a sweep whose
points are the documented product or samples of its axes, every value finite and within its axis,
or one refusal naming the file (docs/sweeps.md)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from prop_strategies import (
    HOSTILE,
    MAX_TOML_DEPTH,
    attempt,
    finite_number,
    is_number,
    mostly,
    mutated,
    nesting,
    prop_settings,
    text_mutation,
    toml_text,
)

from linsense.sweep import load_sweep
from linsense.sweep.points import points

BASE = 'motor = "ecce2010"\n[scenario]\nduration = 0.01\n[reference]\nposition_mm = 1.0\n'
MAX_RUNS = 1_000_000  # (the most runs of one sweep file)
HUGE = 1.7976931348623157e308  # (the largest float)
KEYS = ["reference.position_mm", "observer.bandwidth_hz", "injection.amplitude", "motor.inductance.dM0",
        "lut_motor.inductance.L0", "controller.kp_x", "inverter.fidelity"]


@st.composite
def axis(draw, key: str, sampling: str) -> dict:
    a = {"key": key}
    relative = key.startswith(("motor.", "lut_motor.")) and draw(st.booleans())
    if relative:
        a["relative"] = True
    if draw(st.booleans()):
        a["values"] = draw(st.lists(st.floats(-1e3, 1e3) if key != "inverter.fidelity" or relative
                                    else st.sampled_from(["average", "switching"]), min_size=1, max_size=5))
    else:
        lo = draw(st.floats(1e-3, 1e3))
        a["min"], a["max"] = lo, lo * draw(st.floats(1.01, 100.0))
        if sampling == "grid":
            a["n"] = draw(st.integers(1, 6))
        if draw(st.booleans()):
            a["log"] = True
    return a


@st.composite
def sweep_doc(draw) -> dict:
    sampling = draw(st.sampled_from(["grid", "random", "lhs"]))
    keys = draw(st.lists(st.sampled_from(KEYS), min_size=1, max_size=3, unique=True))
    sw = {"name": "p", "scenario": "base.toml", "sampling": sampling, "seed": draw(st.integers(0, 9))}
    if sampling != "grid":
        sw["samples"] = draw(st.integers(1, 40))
    if draw(st.booleans()):
        sw["batch"] = draw(st.integers(1, 16))
    return {"sweep": sw, "axis": [draw(axis(k, sampling)) for k in keys]}


SWEEP_KEYS = ("name", "scenario", "sampling", "samples", "seed", "study", "batch", "trace", "set")
AXIS_KEYS = ("key", "values", "min", "max", "n", "log", "relative")


def _int(v, lo, hi) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi


def violations(doc) -> list[str]:
    """What docs/sweeps.md (and the limit of runs) refuses, from the parsed file."""
    if not isinstance(doc, dict) or nesting(doc) > MAX_TOML_DEPTH:
        return ["<file>"]
    bad = [k for k in doc if k not in ("sweep", "axis")]
    sw = doc.get("sweep")
    if not isinstance(sw, dict):
        return bad + ["sweep"]
    bad += [f"sweep.{k}" for k in sw if k not in SWEEP_KEYS]
    sampling = sw.get("sampling", "grid")
    if sampling not in ("grid", "random", "lhs"):
        bad.append("sweep.sampling")
    if not (isinstance(sw.get("scenario"), str) and sw["scenario"]):
        bad.append("sweep.scenario")
    if "name" in sw and not (isinstance(sw["name"], str) and sw["name"]):
        bad.append("sweep.name")
    if "seed" in sw and not _int(sw["seed"], 0, 2**63 - 1):
        bad.append("sweep.seed")
    if "batch" in sw and not _int(sw["batch"], 1, 10**9):
        bad.append("sweep.batch")
    if "trace" in sw and not isinstance(sw["trace"], bool):
        bad.append("sweep.trace")
    if "study" in sw and sw["study"] not in ("stability-map", "lut-robustness", "injection"):
        bad.append("sweep.study")
    if sampling == "grid" and "samples" in sw:
        bad.append("sweep.samples")
    if sampling != "grid" and not _int(sw.get("samples"), 1, MAX_RUNS):
        bad.append("sweep.samples")
    axes = doc.get("axis")
    if not (isinstance(axes, list) and axes):
        return bad + ["axis"]
    runs, keys = 1, []
    for a in axes:
        if not isinstance(a, dict):
            bad.append("axis")
            continue
        bad += [f"axis.{k}" for k in a if k not in AXIS_KEYS]
        key = a.get("key")
        if not (isinstance(key, str) and len(key.split(".")) >= 2 and all(key.split("."))):
            bad.append("axis.key")
        keys.append(key)
        for k in ("log", "relative"):
            if k in a and not isinstance(a[k], bool):
                bad.append(f"axis.{k}")
        if "values" in a:
            vals = a["values"]
            if not (isinstance(vals, list) and vals) or any(k in a for k in ("min", "max", "n")) \
                    or a.get("log"):
                bad.append("axis.values")
            elif any(isinstance(v, float) and not math.isfinite(v) for v in vals) or not all(
                    isinstance(v, int | float | str | bool) for v in vals):
                bad.append("axis.values")
            elif a.get("relative") and not all(is_number(v) for v in vals):
                bad.append("axis.values")
            else:
                runs *= len(vals)
        else:
            lo, hi = a.get("min"), a.get("max")
            if not (finite_number(lo) and finite_number(hi) and lo < hi):
                bad.append("axis.min")
            elif a.get("log") is True and lo <= 0:
                bad.append("axis.min")
            if "n" in a and not _int(a["n"], 1, 10**9):
                bad.append("axis.n")
            if sampling == "grid":
                if "n" not in a:
                    bad.append("axis.n")
                elif _int(a["n"], 1, 10**9):
                    runs *= a["n"]
    if len(set(map(str, keys))) != len(keys):
        bad.append("axis")
    if sampling == "grid" and runs > MAX_RUNS:
        bad.append("axis")
    return bad


def check_points(sw, doc: dict) -> None:
    """The runs are the grid's product (or the samples), each value finite and within its axis."""
    pts = points(sw)
    axes = doc["axis"]
    if doc["sweep"].get("sampling", "grid") == "grid":
        want = int(np.prod([len(a["values"]) if "values" in a else a["n"] for a in axes]))
    else:
        want = doc["sweep"]["samples"]
    assert len(pts) == want, (len(pts), want)
    again = points(load_sweep(sw.source))
    assert again == pts, "the points of a sweep file change from one call to the next"
    for p in pts:
        assert list(p) == [a["key"] for a in axes]
        for a in axes:
            v = p[a["key"]]
            if "values" in a:
                assert v in a["values"], (v, a)
            else:
                assert finite_number(v) and a["min"] <= v <= a["max"], (v, a)


@pytest.mark.slow
@prop_settings(scale=3)
@given(data=st.data())
def test_a_sweep_file_gives_its_documented_points_or_is_refused_in_one_line(tmp_path, data):
    doc, _ = data.draw(mutated(data.draw(sweep_doc()), {"": ("sweep", "axis"), "sweep": SWEEP_KEYS}))
    if data.draw(st.booleans()):  # (an axis edited: a hostile value, a huge range, a key dropped)
        a = data.draw(st.sampled_from(doc["axis"])) if isinstance(doc.get("axis"), list) and doc["axis"] \
            and isinstance(doc["axis"][0], dict) else None
        if isinstance(a, dict):
            k = data.draw(st.sampled_from(AXIS_KEYS))
            kind = data.draw(st.sampled_from(["value", "drop", "huge"]))
            if kind == "value":
                a[k] = data.draw(mostly(HOSTILE, st.lists(HOSTILE, max_size=3)))
            elif kind == "drop":
                a.pop(k, None)
            else:
                # (the whole range of floats: found, an axis whose max - min overflows, min = -1.7e308,
                # max = 1.7e308, gave a grid and samples holding inf and nan)
                a.pop("values", None)
                a.update(min=data.draw(st.sampled_from([-HUGE, -1.7e308, -1e308, -1e307, -1e300, 5e-324,
                                                        1e-300])),
                         max=data.draw(st.sampled_from([1e308, 1.7e308, HUGE])),
                         n=data.draw(st.sampled_from([2, 3, 1001, 10**6])))
    text = toml_text(doc)
    if data.draw(st.integers(0, 4)) == 0:
        text = data.draw(text_mutation(text))
    (tmp_path / "base.toml").write_text(BASE, encoding="utf-8")
    path = tmp_path / "sweep.toml"
    path.write_text(text, encoding="utf-8")
    try:
        parsed = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):
        parsed = None
    status, value = attempt(load_sweep, path)
    if status == "ok":
        status, pts = attempt(points, value)
        if status == "refused":
            value = pts
    event(f"{status}: {type(value).__name__}")
    bad = ["<text>"] if parsed is None else violations(parsed)
    if status == "refused":
        assert str(value).startswith(str(path)), str(value)
        return
    assert not bad, f"accepted a sweep outside the documented ranges: {bad}"
    check_points(value, parsed)

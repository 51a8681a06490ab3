"""Properties of motor files: any generated file (valid, or mutated: wrong types, out-of-range, NaN and
inf, huge, negative, missing, extra or misspelled keys, deep nesting, broken text) is either a motor
within the documented ranges with a positive-definite winding and a one-signed saliency, or one
refusal naming the file (and the key); through the loader and through ``linsense model``."""

from __future__ import annotations

import csv
import math
import tomllib
from pathlib import Path

import numpy as np
from hypothesis import event, example, given
from hypothesis import strategies as st
from prop_strategies import (
    L0_RANGE,
    MOTOR_RANGES,
    MOTOR_SECTIONS,
    attempt,
    check_grid,
    cli_outcome,
    dq_of,
    eq3_matrix,
    mostly,
    motor_doc,
    motor_violations,
    mutated,
    prop_settings,
    text_mutation,
    toml_text,
    winding_check,
)

from linsense.errors import ModelError
from linsense.model.motor import load_motor

#: tolerance of the independent winding check against the loader's (relative, near the boundary)
TOL = 1e-9


def check_loaded(motor, doc: dict) -> None:
    """A loaded motor is the file's: every value as given, within the documented ranges, and a
    winding that exists and keeps its saliency (computed here from the documented eq. 3)."""
    assert not motor_violations(doc), motor_violations(doc)
    m = doc["motor"]
    for k in ("R_s", "pole_pitch", "force_constant", "mass"):
        assert getattr(motor, k) == m[k], (k, getattr(motor, k), m[k])
    assert motor.name == m["name"]
    for k, v in doc["inductance"].items():
        assert motor.inductance.params[k] == v, (k, motor.inductance.params.get(k), v)
    theta = check_grid(doc["inductance"])
    eig, sal = winding_check(eq3_matrix(doc["inductance"], theta), theta)
    assert eig > -TOL and sal > -TOL, (eig, sal)
    orders = [h["order"] for h in doc.get("pm_flux", {}).get("harmonics", [])]
    assert [h.order for h in motor.pm_harmonics] == orders


def check_refused(err, doc, path: Path) -> None:
    """A refusal names the file; of a file valid as documented, only a winding that cannot exist (the
    independent check agrees) or cannot be held; with exactly one documented problem, that key."""
    msg = str(err)
    assert msg.startswith(str(path)), msg
    bad = motor_violations(doc)
    if not bad:
        assert isinstance(err, ModelError), msg
        theta = check_grid(doc["inductance"])
        eig, sal = winding_check(eq3_matrix(doc["inductance"], theta), theta)
        assert eig < TOL or sal < TOL, (eig, sal, msg)
    elif len(set(bad)) == 1 and bad[0] != "<file>":
        key = bad[0]
        # (the message names the key, or its section when the section itself is wrong)
        assert key in msg or key.split(".")[0] in msg, (key, msg)


BASE_DOC = {"motor": {"name": "m", "R_s": 9.0, "pole_pitch": 0.056, "force_constant": 20.0, "mass": 1.5},
            "inductance": {"L0": 2.75e-3, "L2": -0.317e-3, "M0": -0.92e-3, "M2": -0.317e-3, "dM0": -0.47e-3}}


@prop_settings(scale=2)
@given(data=st.data())
@example(data=None)  # (the base case: a plain valid motor must load)
# (found: a harmonic key with a leading zero, L04, was accepted and its value dropped: the model got L4 = 0)
@example(data={**BASE_DOC, "inductance": {**BASE_DOC["inductance"], "L04": 0.3e-3}})
def test_a_motor_file_loads_within_the_ranges_or_is_refused_in_one_line(tmp_path, data):
    if data is None or isinstance(data, dict):  # (an @example's document)
        doc = BASE_DOC if data is None else data
    else:
        doc, _ = data.draw(mutated(data.draw(motor_doc()), MOTOR_SECTIONS))
        if data.draw(st.integers(0, 2)) == 0 and isinstance(doc.get("motor"), dict) \
                and isinstance(doc.get("inductance"), dict):
            # at and around a documented range's ends (docs/limits.md, "Plausibility of a motor")
            key = data.draw(st.sampled_from(sorted(MOTOR_RANGES) + ["L0"]))
            lo, hi = L0_RANGE if key == "L0" else MOTOR_RANGES[key]
            value = data.draw(st.sampled_from([lo, hi, hi * 1.01, hi * 2.0, hi * 1e3,
                                               lo * 0.5 if lo else -1e-9]))
            (doc["inductance"] if key == "L0" else doc["motor"])[key] = value
    path = tmp_path / "motor.toml"
    path.write_text(toml_text(doc), encoding="utf-8")
    parsed = tomllib.loads(path.read_text(encoding="utf-8"))  # (what the file says, as TOML reads it)
    status, value = attempt(load_motor, str(path))
    event(f"{status}: {type(value).__name__}")
    if status == "ok":
        check_loaded(value, parsed)
    else:
        check_refused(value, parsed, path)


@prop_settings(scale=2)
@given(data=st.data())
def test_a_broken_motor_text_is_a_motor_or_one_line(tmp_path, data):
    text = data.draw(text_mutation(toml_text(data.draw(motor_doc()))))
    path = tmp_path / "motor.toml"
    path.write_text(text, encoding="utf-8")
    status, value = attempt(load_motor, str(path))
    event(f"{status}: {type(value).__name__}")
    try:
        parsed = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):
        assert status == "refused", "a text that is not TOML was loaded"
        assert str(value).startswith(str(path)), str(value)
        return
    if status == "ok":
        check_loaded(value, parsed)
    else:
        check_refused(value, parsed, path)


POINTS = mostly(st.integers(4, 400), st.sampled_from([-3, 0, 3, 100_001, 10**12, "4.5", "1e3", "", "nan",
                                                     "0x10", " 12", "-0"]))


@prop_settings()
@given(data=st.data(), points=POINTS)
def test_model_writes_the_documented_table_or_refuses(run_cli, tmp_path, data, points):
    doc, _ = data.draw(mutated(data.draw(motor_doc()), MOTOR_SECTIONS, max_edits=1))
    path = tmp_path / "motor.toml"
    path.write_text(toml_text(doc), encoding="utf-8")
    out = tmp_path / "model.csv"
    out.unlink(missing_ok=True)
    res = run_cli("model", "--motor", path, "--points", points, "--out", out)
    status = cli_outcome(res, (str(path), "--points"))
    event(status)
    if status == "refused":
        assert not out.exists(), "a refused run wrote its output"
        return
    n = int(points)
    assert 4 <= n <= 100_000 and not motor_violations(doc)
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    assert head[:14] == ["theta_deg", "L_A", "L_B", "L_C", "M_AB", "M_BC", "M_CA", "L_d", "L_q", "L_dq",
                         "saliency", "psi_lut_deg", "err_nolut_deg", "gain_nolut"]
    assert head[14:] == ["L_alpha", "L_beta", "L_alphabeta"]
    t = np.array(rows[1:], dtype=float)
    assert t.shape == (n, 17) and np.all(np.isfinite(t))
    theta = np.radians(t[:, 0])
    assert np.allclose(theta, 2 * np.pi * np.arange(n) / n, atol=1e-9)
    L = eq3_matrix(doc["inductance"], theta)
    scale = float(np.max(np.abs(L)))
    want = np.stack([L[:, 0, 0], L[:, 1, 1], L[:, 2, 2], L[:, 0, 1], L[:, 1, 2], L[:, 2, 0]], -1)
    assert np.allclose(t[:, 1:7], want, rtol=1e-9, atol=1e-11 * scale)
    L_dq = dq_of(L, theta)
    assert np.allclose(t[:, 7:10], np.stack([L_dq[:, 0, 0], L_dq[:, 1, 1], L_dq[:, 0, 1]], -1),
                       rtol=1e-9, atol=1e-11 * scale)
    assert np.allclose(t[:, 10], t[:, 8] - t[:, 7], rtol=1e-9, atol=1e-11 * scale)
    psi = np.degrees(np.arctan2(-L_dq[:, 0, 1], L_dq[:, 1, 1]))
    assert np.allclose(t[:, 11], psi, atol=1e-8)
    assert all(math.isfinite(v) for v in t[:, 12:14].ravel())

"""The compensation LUT: interpolation rule, exports, round-trips, and the C header compiled
and read by the C library with the same interpolation as Python."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linsense.analysis.hf import psi_lut
from linsense.compensation.lut import (
    Lut,
    build_lut,
    export,
    interpolate,
    read_c_header,
    read_lut,
    to_c_header,
)
from linsense.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


def test_nodes_and_wraparound():
    tab = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 3.0, 2.0, -1.0])
    step = 2 * np.pi / 8
    np.testing.assert_allclose(interpolate(tab, np.arange(8) * step), tab, atol=1e-12)
    assert interpolate(tab, 7.25 * step) == pytest.approx(-0.75)
    assert interpolate(tab, -0.25 * step) == pytest.approx(-0.25)
    assert interpolate(tab, 2 * np.pi) == pytest.approx(0.0)
    assert interpolate(tab, 2.5 * step - 6 * np.pi) == pytest.approx(2.5)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=4, max_size=40), st.floats(-100, 100))
def test_interpolation_stays_between_neighbours(values, theta):
    tab = np.array(values)
    n = tab.size
    u = np.mod(theta / (2 * np.pi) * n, n)
    k = int(np.floor(u)) % n
    lo, hi = sorted((tab[k], tab[(k + 1) % n]))
    v = interpolate(tab, theta)
    assert lo - 1e-12 <= v <= hi + 1e-12


def test_lut_converges_to_model(ecce):
    th = np.linspace(0, 2 * np.pi, 5000)
    err = {n: np.abs(build_lut(ecce, n)(th) - psi_lut(ecce, th)).max() for n in (56, 360)}
    assert np.degrees(err[56]) < 0.03  # 56 points (the paper's count) is already fine
    assert np.degrees(err[360]) < 1e-3
    assert err[360] < err[56] / 20  # second-order convergence of linear interpolation


def test_csv_json_round_trip(ecce, tmp_path):
    lut = build_lut(ecce, 360)
    (tmp_path / "l.csv").write_text(export(lut, "csv"))
    (tmp_path / "l.json").write_text(export(lut, "json"))
    np.testing.assert_allclose(read_lut(tmp_path / "l.csv").values, lut.values, rtol=1e-11, atol=1e-14)
    back = read_lut(tmp_path / "l.json")
    np.testing.assert_array_equal(back.values, lut.values)
    assert back.provenance["dM0"] == -0.47e-3
    doc = json.loads((tmp_path / "l.json").read_text())
    assert doc["angle_unit"].startswith("rad") and doc["points"] == 360


def test_c_header_round_trip_and_content(ecce):
    lut = build_lut(ecce, 64)
    text = to_c_header(lut)
    np.testing.assert_array_equal(read_c_header(text).astype(np.float32), lut.values.astype(np.float32))
    assert "static const float ls_lut_ecce2010[LS_LUT_ECCE2010_LEN]" in text
    assert "#define LS_LUT_ECCE2010_LEN 64" in text
    assert "dM0 = -0.00047" in text and "name = 'ecce2010'" in text
    assert "rad" in text


def test_exports_are_byte_reproducible(ecce):
    for fmt in ("csv", "json", "c"):
        assert export(build_lut(ecce, 100), fmt) == export(build_lut(ecce, 100), fmt)


def test_too_short_lut_refused():
    with pytest.raises(InputError, match="at least 4"):
        Lut(np.zeros(3))


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler")
def test_c_library_interpolates_like_python(ecce, tmp_path):
    """Compile csrc/ctrl/ls_lut.c with a generated header; compare with Python at many angles,
    across the wrap-around and several periods away."""
    lut = build_lut(ecce, 360)
    (tmp_path / "ls_lut_ecce2010.h").write_text(to_c_header(lut))
    exe = tmp_path / "lut_probe"
    subprocess.run(
        ["cc", "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-DLS_REAL_DOUBLE",
         f"-I{ROOT / 'csrc/include'}", f"-I{ROOT / 'csrc/tests'}", f"-I{tmp_path}",
         str(ROOT / "csrc/tests/test_lut.c"), str(ROOT / "csrc/ctrl/ls_lut.c"), "-lm", "-o", str(exe)],
        check=True,
    )
    rng = np.random.default_rng(3)
    th = np.concatenate([rng.uniform(-20, 20, 300), [0.0, 2 * np.pi - 1e-9, -1e-9, 2 * np.pi]])
    args = [str(exe), *[repr(float(t)) for t in th]]
    out = subprocess.run(args, capture_output=True, text=True, check=True)
    c_vals = np.array([float(v) for v in out.stdout.split()])
    py_vals = interpolate(lut.values.astype(np.float32).astype(float), th)
    np.testing.assert_allclose(c_vals, py_vals, atol=1e-9)

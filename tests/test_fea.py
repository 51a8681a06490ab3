"""Axisymmetric FEA (linsense.fea): validation against closed forms, convergence, end-effect, files.

Coarse meshes throughout; docs/fea.md gives the figures of the default and fine meshes.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from scipy.special import ellipe, ellipk
from skfem import asm

from linsense.errors import InputError
from linsense.fea.geometry import GeometryFile, geometry_from_doc, geometry_from_toml, load_geometry
from linsense.fea.solver import MU0, Solver, _density, energy_of, run

PRESET = tomllib.loads((resources.files("linsense.fea") / "presets" / "tubular56.toml").read_text())


def _geom(doc: dict):
    return geometry_from_doc(GeometryFile.model_validate(doc), "test")


def _air(sequence="A+ B+ C-", turns=100, far=8.0):
    return {"motor": {"name": "air", "pole_pitch": 0.056},
            "rod": {"radius": 0.0125, "magnet_length": 0.01, "remanence": 0.0, "mu_r_magnet": 1.0,
                    "mu_r_iron": 1.0},
            "armature": {"air_gap": 0.001, "coil_depth": 0.006, "back_iron": 0.006, "mu_r_iron": 1.0,
                         "sequence": sequence, "turns": turns},
            "domain": {"far": far}}


# ------------------------------------------------------------------ closed form (Maxwell)
def _m_filaments(a, b, d):
    """Mutual inductance of coaxial circular filaments (radii a, b, axial distance d), Maxwell."""
    k2 = 4 * a * b / ((a + b) ** 2 + d ** 2)
    k = np.sqrt(k2)
    return MU0 * np.sqrt(a * b) * ((2 / k - k) * ellipk(k2) - 2 / k * ellipe(k2))


def _m_coils(c1, c2, n1=20, n2=21):
    """Filament formula integrated over both cross-sections by Gauss-Legendre (n1 != n2: the points
    never coincide, so a coil's self inductance is the same integral)."""

    def pts(c, n):
        x, w = np.polynomial.legendre.leggauss(n)
        r = c.r0 + (x + 1) / 2 * (c.r1 - c.r0)
        z = c.z0 + (x + 1) / 2 * (c.z1 - c.z0)
        R, Z = np.meshgrid(r, z, indexing="ij")
        return R.ravel(), Z.ravel(), (np.outer(w, w) / 4).ravel()

    ra, za, wa = pts(c1, n1)
    rb, zb, wb = pts(c2, n2)
    m = _m_filaments(ra[:, None], rb[None, :], za[:, None] - zb[None, :])
    return c1.sign * c2.sign * c1.turns * c2.turns * float((wa[:, None] * wb[None, :] * m).sum())


def test_air_cored_coils_match_maxwell():
    g = _geom(_air())
    ref = np.array([[_m_coils(a, b) for b in g.coils] for a in g.coils])
    L = Solver(g, "coarse").solve(0.0).L
    err = np.abs(L - ref) / np.abs(ref)
    assert err.max() < 0.005, err  # the test's tolerance (docs/fea.md)
    # README.md's "0.2 %" and docs/fea.md's 0.18 % (coarse), the self inductances within 0.03 %
    assert f"{100 * err.max():.1f}" == "0.2" and f"{100 * err.max():.2f}" == "0.18", err.max()
    assert np.diag(err).max() <= 0.0003, np.diag(err)
    assert L[0, 1] > 0 > L[0, 2]  # signs follow the coil signs


def test_energy_from_field_equals_half_iLi():
    s = Solver(load_geometry("tubular56"), "coarse")
    sol = s.solve(0.013, keep=True)
    w, wl = energy_of(s, sol, [1.0, -0.4, 0.7])
    assert w == pytest.approx(wl, rel=1e-9)
    assert np.all(np.linalg.eigvalsh(sol.L) > 0)
    assert np.allclose(sol.L, sol.L.T)


def test_mesh_convergence():
    g = load_geometry("tubular56")
    a = Solver(g, "coarse", 56).solve(0.003).L
    b = Solver(g, "default", 56).solve(0.003).L
    change = np.abs((a - b) / b).max()
    assert change < 0.005 and f"{100 * change:.2f}" == "0.40", change  # docs/fea.md (default to fine: 0.21 %)


def test_long_armature_has_no_end_effect_inside():
    # 8 periods of coils on a long back iron, no rod saliency: the per-period phase mutuals of an
    # interior period (linkage of its coils with the whole phase currents) are equal
    d = _air("A+ C- B+ A- C+ B-", far=4.0)
    d["armature"].update(repeat=8, mu_r_iron=1000.0, end_length=0.01)
    g = _geom(d)
    s = Solver(g, "coarse")
    sol = s.solve(0.0, keep=True)
    psi = sol.fields["psi"][:, :3]
    mid = g.coils[24:30]  # period 5 of 8

    def link(phase, k):
        tot = 0.0
        for c in mid:
            if c.phase == phase:
                inside = (s.r > c.r0) & (s.r < c.r1) & (s.z > c.z0) & (s.z < c.z1)
                j = np.where(inside, c.sign * c.turns / c.area, 0)
                tot += 2 * math.pi * asm(_density, s.basis, j=j) @ psi[:, k]
        return tot

    m_ab, m_bc, m_ca = link("A", 1), link("B", 2), link("C", 0)
    m = np.array([m_ab, m_bc, m_ca])
    assert np.ptp(m) / abs(m.mean()) < 0.01, m
    # the whole short armature's phase mutuals are not equal
    whole = sol.L
    assert abs(whole[0, 1] - whole[1, 2]) / abs(whole[1, 2]) > 0.005


def test_short_armature_end_effect_and_model_file(tmp_path):
    from linsense.fea import outputs
    from linsense.model.motor import load_motor

    res = run(load_geometry("tubular56"), 14, "coarse")
    fit = outputs.eq3_fit(res)["values_H"]
    assert fit["dM0"] < 0
    assert 2.0e-3 < fit["L0"] < 3.5e-3
    (tmp_path / "inductances.csv").write_text(outputs.inductances_csv(res))
    (tmp_path / "motor.toml").write_text(outputs.motor_toml(res))
    m = load_motor(tmp_path / "motor.toml")  # plausibility: 3x3 PD, saliency sign
    assert m.pole_pitch == pytest.approx(0.056)
    assert res.energy_error < 1e-9
    # the end effect on the magnets' flux: each phase's fundamental, relative to phase A's
    # (theta = 0 at its peak); the end phases differ by a fraction of a percent and about a degree
    assert m.pm_phases.scale[0] == 1.0 and m.pm_phases.shift[0] == 0.0 and not m.pm_phases.balanced
    assert max(abs(math.degrees(d)) for d in m.pm_phases.shift) > 0.3
    # the motor file's per-phase flux is the FEA's, up to its harmonics (a few % of the amplitude)
    theta, _, pm = outputs.table(res)
    fit = m.psi_pm_abc(theta)
    assert np.abs(fit - pm).max() < 0.05 * res.psi_pm_amplitude
    # and its fundamental exactly: the DFT of the difference has no first harmonic left
    diff = (pm - fit) * np.exp(-1j * theta)[:, None]
    assert np.abs(diff.mean(axis=0)).max() < 2e-6 * res.psi_pm_amplitude
    # a motor without magnets has no per-phase flux to write
    assert outputs.pm_phases(dataclasses.replace(res, psi_pm_amplitude=0.0)) is None


def test_fig4_three_coils_middle_coil_couples_equally():
    g = load_geometry(Path(__file__).resolve().parents[1] / "src/linsense/examples/fea/fig4_three_coils.toml")
    res = run(g, 8, "coarse")
    m = res.L.mean(axis=0)
    assert abs(m[1, 2] - m[2, 0]) / abs(m[2, 0]) < 0.02  # M_BC = M_CA (C in the middle)
    assert abs(m[0, 1]) < 0.5 * abs(m[2, 0])  # M_AB smaller


def test_cli_writes_the_output_set(tmp_path):
    from linsense.cli import main
    from linsense.model.motor import load_motor

    out = tmp_path / "fea"
    with pytest.raises(SystemExit) as e:
        main(["fea", "tubular56", "--out", str(out), "--positions", "14", "--mesh", "coarse",
              "--lut-points", "36", "--load-current", "0"])
    assert e.value.code == 0
    # a single --load-current: the output set of before the load sweep, no per-load files
    assert {f.name for f in out.iterdir() if not f.name.startswith(".")} == {
        "inductances.csv", "motor.toml", "lut.csv", "geometry.json", "fea.json", "timing.json",
        "field_lines.png", "inductances_fea.png", "inductances_model.png", "lut.png"}
    load_motor(out / "motor.toml")
    doc = json.loads((out / "fea.json").read_text())
    assert doc["mesh"]["triangles"] > 0 and doc["positions"] == 14 and "lut_vs_load" not in doc
    geo = json.loads((out / "geometry.json").read_text())
    assert len(geo["coils"]) == 24 and geo["coils"][0]["phase"] == "A"


# ------------------------------------------------------------------ hostile geometry files
def _text(mut) -> str:
    import tomli_w

    d = copy.deepcopy(PRESET)
    mut(d)
    return tomli_w.dumps(d)


@pytest.mark.parametrize("mut, expect", [
    (lambda d: d["rod"].update(radus=0.01), "rod.radus: unknown key (value 0.01) (did you mean 'radius'?)"),
    (lambda d: d["rod"].update(magnet_length=0.04), "rod.magnet_length"),
    (lambda d: d["rod"].update(remanence="1.2"), "rod.remanence"),
    (lambda d: d["rod"].update(radius=float("nan")), "rod.radius: expected a finite number"),
    (lambda d: d["rod"].update(radius=-0.01), "rod.radius"),
    (lambda d: d["armature"].update(sequence="A+ D-"), "armature.sequence: token 'D-'"),
    (lambda d: d["armature"].update(repeat=1000), "armature.repeat"),
    (lambda d: d["armature"].pop("turns"), "armature.turns: missing"),
    (lambda d: d["armature"].update(coils=[{"phase": "A", "sign": 1, "turns": 5}]), "armature.sequence"),
    (lambda d: d["armature"].update(air_gap=True), "armature.air_gap"),
    (lambda d: d.pop("rod"), "rod: missing required key"),
    (lambda d: d["motor"].update(name="a\x00b"), "motor.name: control characters"),
    (lambda d: d["rod"].update(radius=50.0), "check the units"),
])
def test_hostile_geometry_refused_in_one_line(mut, expect):
    with pytest.raises(InputError) as e:
        geometry_from_toml(_text(mut), "g.toml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("g.toml: ") and expect in msg, msg


def test_geometry_not_toml_and_missing_file(tmp_path):
    with pytest.raises(InputError, match="not valid TOML"):
        geometry_from_toml("[rod", "g.toml")
    with pytest.raises(InputError, match="no such"):
        load_geometry(tmp_path / "none.toml")
    with pytest.raises(InputError, match="preset"):
        load_geometry("nopreset")


def test_no_saliency_still_writes_the_table_and_says_so(tmp_path):
    from linsense.report.fea import run_fea

    geo = Path(__file__).resolve().parents[1] / "src/linsense/examples" / "fea" / "fig4_three_coils.toml"
    files, lines, warnings = run_fea(str(geo), str(tmp_path / "o"), 14, "coarse", 36)
    names = {f.name for f in files}
    assert {"inductances.csv", "motor.toml", "fea.json"} <= names and "lut.csv" not in names
    assert len(warnings) == 1 and "saliency" in warnings[0] and ".tmp-" not in warnings[0]
    doc = json.loads((tmp_path / "o" / "fea.json").read_text())
    assert doc["hf_sensorless"]["ok"] is False


# ------------------------------------------------------------------ saturating iron (B-H curve, Newton)
def _bh_doc(bh, sequence="A+ C- B+ A- C+ B-"):
    d = copy.deepcopy(PRESET)
    d["rod"].pop("mu_r_iron")
    d["armature"].pop("mu_r_iron")
    d["rod"]["bh"] = bh
    d["armature"]["bh"] = bh
    d["armature"].update(sequence=sequence, repeat=1)
    return d


def test_incremental_inductances_are_the_derivative_of_the_flux_linkage():
    # a soft curve that saturates hard: L_inc from the Jacobian against central differences of the
    # total flux linkage (magnets + currents) at a loaded state
    soft = {"B": [0.0, 0.2, 0.4, 0.6], "H": [0.0, 100.0, 1000.0, 10000.0]}
    s = Solver(_geom(_bh_doc(soft)), "coarse", 14)
    i0 = np.array([0.0, 3.0, -3.0])
    base = s.solve_nonlinear(0.004, i0, tol=1e-10)
    lin = Solver(_geom(_bh_doc(None)), "coarse", 14).solve(0.004).L
    assert base.L[0, 0] < 0.97 * lin[0, 0]  # saturated: less inductance than with mu_r 1000
    d = 0.01
    e = np.array([0.0, 1.0, 0.0])
    up = s.solve_nonlinear(0.004, i0 + d * e, tol=1e-10, psi0=s.last_state).psi_pm
    dn = s.solve_nonlinear(0.004, i0 - d * e, tol=1e-10, psi0=s.last_state).psi_pm
    fd = (up - dn) / (2 * d)
    assert np.abs(fd - base.L[:, 1]).max() < 1e-5 * np.abs(base.L).max()  # measured 5e-9


def test_linear_curve_gives_the_linear_inductances():
    mu_r = 1000.0
    h = 1.0 / (MU0 * mu_r)
    lin_bh = {"B": [0.0, 1.0, 2.0, 3.0], "H": [0.0, h, 2 * h, 3 * h]}
    a = Solver(_geom(_bh_doc(lin_bh)), "coarse", 14).solve_nonlinear(0.006)
    b = Solver(_geom(_bh_doc(None)), "coarse", 14).solve(0.006)
    assert np.allclose(a.L, b.L, rtol=1e-6)
    assert np.allclose(a.psi_pm, b.psi_pm, rtol=1e-6)


def test_load_current_refused_with_linear_iron(tmp_path):
    from linsense.report.fea import run_fea

    with pytest.raises(InputError, match="linear iron"):
        run_fea("tubular56", str(tmp_path / "o"), 14, "coarse", 36, load_current=1.0)
    assert not (tmp_path / "o").exists()


def test_bh_table_validated():
    d = _bh_doc({"B": [0.0, 1.0, 0.5], "H": [0.0, 10.0, 20.0]})
    with pytest.raises(InputError, match="rod.bh.B: B and H must increase"):
        geometry_from_toml(_dump(d), "g.toml")
    d = _bh_doc("default")
    d["rod"]["mu_r_iron"] = 500.0
    with pytest.raises(InputError, match="rod.bh: give either"):
        geometry_from_toml(_dump(d), "g.toml")


def _dump(d):
    import tomli_w

    return tomli_w.dumps(d)


@pytest.mark.slow
def test_load_current_run_in_two_processes():
    from linsense.fea.solver import q_currents

    d = tomllib.loads((Path(__file__).resolve().parents[1] / "src/linsense/examples/fea/fig4_three_coils.toml"
                       ).read_text())
    d["rod"]["bh"] = "default"
    d["armature"]["bh"] = "default"
    g = _geom(d)
    res = run(g, 7, "coarse", load_current=1.5, workers=2)
    assert res.newton["max"] >= 1 and res.energy_error is None
    k = 5
    ref = Solver(g, "coarse", 7).solve_nonlinear(float(res.positions[k]), q_currents(res.theta[k], 1.5))
    assert np.allclose(res.L[k], ref.L, rtol=1e-9)
    # the q-axis current: amplitude-invariant Park of the phase currents
    th = res.theta[k]
    i = q_currents(th, 1.5)
    i_q = -2 / 3 * (i[0] * np.sin(th) + i[1] * np.sin(th - 2 * np.pi / 3) + i[2] * np.sin(th + 2 * np.pi / 3))
    assert i_q == pytest.approx(1.5)


# ------------------------------------------------------------------ load sweep, fast assembly, Newton start
def test_vectorised_assembly_equals_scikit_fem_forms():
    from linsense.fea.solver import _internal, _tangent

    s = Solver(_geom(_bh_doc("default")), "coarse", 14)
    rng = np.random.default_rng(1)
    psi = rng.standard_normal(s.basis.N) * 1e-3
    nu = s.nu_fixed * (1 + rng.random(s.nu_fixed.shape))
    dnu = np.where(s.arm_iron, rng.standard_normal(nu.shape) * 1e3, 0.0)
    field = s.basis.interpolate(psi)
    ref = asm(_tangent, s.basis, nu=nu, dnu=dnu, psi=field)[s.I][:, s.I]
    g = s.asm.grad(psi)
    assert abs(s.asm.tangent(nu, dnu, g) - ref).max() < 1e-12 * abs(ref).max()
    r = asm(_internal, s.basis, nu=nu, psi=field)
    assert np.abs(s.asm.residual(nu, g) - r).max() < 1e-12 * np.abs(r).max()


def test_newton_from_the_previous_load_matches_the_linear_start():
    from linsense.fea.solver import q_currents

    s = Solver(_geom(_bh_doc("default")), "coarse", 14)
    cur = q_currents(0.7, 2.0)
    s.solve_nonlinear(0.01, np.zeros(3))
    warm = s.solve_nonlinear(0.01, cur, psi0=s.last_state)
    cold = s.solve_nonlinear(0.01, cur)
    assert warm.newton < cold.newton
    assert np.abs(warm.L - cold.L).max() < 1e-9 * np.abs(cold.L).max()
    assert np.abs(warm.psi_pm - cold.psi_pm).max() < 1e-9 * np.abs(cold.psi_pm).max()


@pytest.mark.parametrize("option, value, expect", [
    ("--load-current", "1,x", "'x' is not a number"),
    ("--load-current", "0,1,1", "1 A is given twice"),
    ("--load-current", "0,nan", "must be finite currents"),
    ("--load-current", "inf", "must be finite currents"),
    ("--load-current", "", "no current given"),
    ("--load-current", "0,,1", "'' is not a number"),
    ("--polarity", "1,x", "'x' is not a number (d-axis pulse amplitudes"),
    ("--polarity", "1,-2", "must be positive amplitudes"),
    ("--polarity", "0", "must be positive amplitudes"),
    ("--polarity", "1,1", "1 A is given twice"),
    ("--polarity", "", "no current given"),
])
def test_load_current_list_refused_in_one_line(run_cli, tmp_path, option, value, expect):
    r = run_cli("fea", "tubular56", "--out", tmp_path / "o", option, value, "--mesh", "coarse")
    assert r.code == 2
    assert len(r.err.strip().splitlines()) == 1 and expect in r.err and option in r.err, r.err
    assert not (tmp_path / "o").exists()


def test_load_current_list_parsed():
    from linsense.fea.per_load import parse_currents

    assert parse_currents("0, 1,2.5") == [0.0, 1.0, 2.5]
    assert parse_currents(2.0) == [2.0] and parse_currents("-0") == [0.0]
    assert parse_currents([0, -1]) == [0.0, -1.0]


def test_linear_iron_takes_only_zero(run_cli, tmp_path):
    r = run_cli("fea", "tubular56", "--out", tmp_path / "o", "--load-current", "0,1", "--mesh", "coarse")
    assert r.code == 2 and "linear iron" in r.err and len(r.err.strip().splitlines()) == 1


@pytest.mark.slow
def test_load_sweep_writes_per_load_files_and_the_lut_against_load(tmp_path):
    from linsense.report.fea import run_fea

    d = _bh_doc("default")
    d["armature"]["repeat"] = 4
    d["rod"]["magnet_length"] = 0.056 / 6  # the rod aligned on the coarse mesh with 12 positions
    geo = tmp_path / "bh.toml"
    geo.write_text(_dump(d))
    files, lines, warnings = run_fea(str(geo), str(tmp_path / "o"), 12, "coarse", 36, load_current="0,2",
                                     workers=2)
    names = {f.name for f in files}
    for f in ("inductances.csv", "motor.toml", "lut.csv", "lut_vs_load.png", "inductances_0A.csv",
              "inductances_2A.csv", "lut_0A.csv", "lut_2A.csv", "motor_2A.toml"):
        assert f in names, f
    doc = json.loads((tmp_path / "o" / "fea.json").read_text())
    v = doc["lut_vs_load"]
    assert v["currents_A"] == [0.0, 2.0] and v["max_diff_deg"][0] == 0.0
    assert 0 <= v["max_diff_deg"][1] < 0.05  # the paper's Fig. 9 claim on this slotless design
    kf = tomllib.loads((tmp_path / "o" / "motor.toml").read_text())["motor"]["force_constant"]
    assert v["force_N"] == pytest.approx([0.0, 2 * kf])
    assert v["newton_iterations"][1]["mean"] < v["newton_iterations"][0]["mean"]  # warm start
    out = tmp_path / "o"
    assert (out / "inductances.csv").read_text() == (out / "inductances_0A.csv").read_text()
    assert lines[-1].startswith("LUT against load (vs 0 A): 0 A") and "max difference" in lines[-1]
    assert not warnings


# ------------------------------------------------------------------ d-axis current, polarity signal
EXAMPLES = Path(__file__).resolve().parents[1] / "src/linsense/examples" / "fea"


def test_d_axis_current_strengthens_the_pm_flux():
    from linsense.fea.solver import dq_currents, q_currents

    g = load_geometry("tubular56")
    res = run(g, 14, "coarse")  # theta's origin: 0 where phase A's PM flux linkage peaks
    x0 = float(np.mod(res.theta_offset / res.direction * g.pole_pitch / (2 * np.pi), g.pole_pitch))
    s = Solver(g, "coarse", 14)
    psi = {i: s.solve_nonlinear(x0, dq_currents(0.0, i, 0.0)).psi_pm for i in (-1.0, 0.0, 1.0)}
    side = [s.solve(x0 + dx, energy=False).psi_pm[0] for dx in (-g.pole_pitch / 8, g.pole_pitch / 8)]
    assert psi[0.0][0] > max(side) and psi[0.0][0] > 0.9 * res.psi_pm_amplitude  # phase A at its PM peak
    assert psi[1.0][0] > psi[0.0][0] > psi[-1.0][0]  # +i_d along the magnets' flux
    # amplitude-invariant Park of the phase currents gives (i_d, i_q) back; i_d = 0 is q_currents
    th = 1.1
    i = dq_currents(th, 0.7, -0.4)
    ph = th - np.array([0.0, 2 * np.pi / 3, -2 * np.pi / 3])
    assert 2 / 3 * (i * np.cos(ph)).sum() == pytest.approx(0.7)
    assert -2 / 3 * (i * np.sin(ph)).sum() == pytest.approx(-0.4)
    assert np.array_equal(dq_currents(th, 0.0, 1.5), q_currents(th, 1.5))


@pytest.mark.slow
def test_polarity_signal_with_saturating_and_linear_iron():
    from linsense.fea.polarity import polarity_signal

    # a 1 mm back iron saturates: +d saturates it further, L_d(-I) > L_d(+I) at every position,
    # more so with I (coarse, 4 positions)
    thin = polarity_signal(load_geometry(EXAMPLES / "tubular56_bh_thin.toml"), [1, 4], 4, "coarse", workers=2)
    a, b = thin["rows"]
    assert 0 < a["diff_min_H"] and a["diff_mean_H"] < b["diff_min_H"]
    assert 0.005 < a["rel"] < b["rel"] < 0.2
    assert b["psi_d_plus_Wb"] > a["psi_d_plus_Wb"] > a["psi_d_minus_Wb"] > b["psi_d_minus_Wb"]
    # linear iron (mu_r 1000), the same Newton solves: no signal, to the last bit
    lin = polarity_signal(load_geometry("tubular56"), [4], 4, "coarse", workers=2)["rows"][0]
    assert lin["diff_mean_H"] == 0 and lin["diff_min_H"] == 0 and lin["newton_max"] <= 2
    assert lin["psi_d_plus_Wb"] > lin["psi_d_minus_Wb"]
    with pytest.raises(ValueError, match="positive"):
        polarity_signal(load_geometry("tubular56"), [0.0], 3, "coarse")


@pytest.mark.slow
def test_cli_polarity_writes_the_csv(run_cli, tmp_path):
    out = tmp_path / "o"
    r = run_cli("fea", "tubular56", "--out", out, "--positions", "14", "--mesh", "coarse", "--lut-points",
                "36", "--polarity", "2,1", "--polarity-positions", "4")
    assert r.code == 0, r.err
    rows = (out / "polarity.csv").read_text().splitlines()
    assert rows[0].startswith("I_A,L_d_plus_H,L_d_minus_H,diff_mean_H,diff_min_H,rel") and len(rows) == 3
    assert rows[1].startswith("1,") and rows[2].startswith("2,")
    doc = json.loads((out / "fea.json").read_text())
    assert doc["polarity"]["currents_A"] == [1.0, 2.0] and doc["polarity"]["positions"] == 4
    assert "polarity (L_d(-I) - L_d(+I), i_q = 0): 1 A 0 % (0 uH, min 0), 2 A 0 %" in r.out


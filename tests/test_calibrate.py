"""linsense calibrate on the drive that will run the table: the scenario's or the
design's drive, the model of the injection the drive actually runs (after the design), the
calibration's own timings following the design, and the bar of 0.3 deg against that model for
ecce2010 and the test motors of src/linsense/examples/motors/class (switching inverter with the
drive's dead time).
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from linsense.compensation.lut import build_lut
from linsense.errors import InputError
from linsense.model.motor import load_motor
from linsense.sim.build import calibration_timing, designed, resolve_motor
from linsense.studies.calibrate import DRIVE_KEYS, calibrate, calibration_scenario
from linsense.tune.design import DriveData, design

ROOT = Path(__file__).parents[1]
CLASS = ROOT / "src/linsense/examples" / "motors" / "class"
DRIVES = tomllib.loads((CLASS / "drives.toml").read_text())
CLASS_MOTORS = sorted(p.stem for p in CLASS.glob("*.toml") if p.stem in DRIVES)
BAR_DEG = 0.3
#: docs/simulator.md, "Calibration": every drive within 0.1 deg with the pulsating injection
BAR_PULSATING_DEG = 0.1
#: docs/simulator.md's table (max |measured - model LUT with R_s|, deg, 56 points, 0 N unless named):
#: pulsating, the design's elliptical injection; each asserted at the two decimals written there
TABLE = {"ecce2010": ("0.03", "0.22"), "ecce2010 20 N": ("0.04", "0.26"), "ecce2010 40 N": ("0.03", "0.30"),
         "m100_edge": ("0.03", "0.17"), "m20_hv": ("0.02", "0.27"), "m30_low": ("0.01", "0.06"),
         "m45_24v": ("0.01", "0.17"), "m60_pos20k": ("0.02", "0.11"), "m90_heavy": ("0.02", "0.11")}


def _table(name: str, load: float, column: int) -> str:
    return TABLE[name if load == 0.0 else f"{name} {load:g} N"][column]

#: measured above the bar at the time of writing, for reasons outside the calibration (its timings
#: follow the design; see docs/simulator.md, "Calibration"):
#: xfail, not strict, so that a design that brings them within the bar shows as XPASS
ABOVE_BAR_ELLIPTICAL: dict = {}
# (m20_hv, 1.5 us of dead time at 8 kHz, was 0.62 deg with the interpolating dead-time residual;
# the forward model brings it within the bar)
# (with the former 150 Hz dither, which leaks more through the HF band-pass: ecce2010 0.39 / 0.29 /
# 0.30 deg at 0 / 20 / 40 N, m100_edge 0.69, m60_pos20k 0.29, m90_heavy 0.30; with 55 Hz ecce2010
# 0.29 / 0.28 / 0.29, m100_edge 0.24, m60_pos20k 0.24, m90_heavy 0.28)
#: (m20_hv's points were not held with the former 4 Hz speed loop; now 0.12 deg)
ABOVE_BAR_PULSATING: dict = {}


def _drive(name: str) -> dict:
    """The test motor's drive data (v_dc, f_pwm, dead_time, i_max of drives.toml)."""
    return {k: float(DRIVES[name][k]) for k in ("v_dc", "f_pwm", "dead_time", "i_max")}


def _class_params(above: dict) -> list:
    return [pytest.param(n, marks=pytest.mark.xfail(reason=above[n], strict=False)) if n in above else n
            for n in CLASS_MOTORS]


def _bar(name: str, above: dict) -> list:
    return [pytest.param(x, marks=pytest.mark.xfail(reason=above[name], strict=False)) if name in above else x
            for x in (0.0, 20.0, 40.0)]


# ---------------------------------------------------------------------- the model it is compared with
def test_the_model_is_for_the_injection_the_drive_runs():
    """The model table is computed for the frequency and kappa after the design: a 20 kHz drive
    injects at the design's f_pwm / 16, not the scenario default's 1 kHz (before the fix the
    comparison was made at 1 kHz; the two tables differ by more than the bar)."""
    name = "m30_low"
    motor = load_motor(CLASS / f"{name}.toml")
    dz = design(motor, DriveData(**_drive(name)), analyse=False)
    cal = calibrate(str(CLASS / f"{name}.toml"), 8, 0.0, "average", drive=_drive(name))
    m = cal.metrics
    assert m["f_inj_hz"] == pytest.approx(dz.f_inj) and m["injection_quad"] == pytest.approx(dz.quad)
    assert m["v_inj"] == pytest.approx(dz.v_inj) and m["f_pwm_hz"] == _drive(name)["f_pwm"]
    own = build_lut(motor, 8, f_inj=dz.f_inj, quad=dz.quad).values
    np.testing.assert_allclose(cal.psi_model, own, rtol=0, atol=1e-12)
    wrong = build_lut(motor, 8, f_inj=1000.0, quad=dz.quad).values
    assert dz.f_inj != 1000.0 and np.degrees(np.abs(own - wrong)).max() > BAR_DEG


def test_motor_alone_is_the_design_drive():
    """--motor alone: DriveData's drive and the design's injection and kappa (read, not restated)."""
    dd, dz = DriveData(), design(load_motor("ecce2010"), DriveData(), analyse=False)
    cal = calibrate("ecce2010", 4, 0.0, "average")
    m = cal.metrics
    assert (m["v_dc"], m["f_pwm_hz"], m["dead_time_s"], m["i_max_a"]) == pytest.approx(
        (dd.v_dc, dd.f_pwm, dd.dead_time, dd.i_max))
    assert (m["v_inj"], m["f_inj_hz"], m["injection_quad"]) == pytest.approx((dz.v_inj, dz.f_inj, dz.quad))
    assert (m["dither_a"], m["dither_hz"]) == pytest.approx((dz.dither_a, dz.dither_hz))


# ---------------------------------------------------------------------- the scenario's drive
def _scenario(tmp_path: Path, quad: float) -> Path:
    """ecce2010 on a 60 V, 20 kHz drive injecting at 1250 Hz with kappa ``quad``, ideal switches
    and so no dither (the test is about which injection is used), average fidelity and a step and
    a load that the calibration replaces by its own."""
    p = tmp_path / f"drive_{quad:g}.toml"
    p.write_text(f"""motor = "ecce2010"
[scenario]
name = "drive"
duration = 2.0
[inverter]
fidelity = "average"
v_dc = 60.0
f_pwm = 20000.0
dead_time = 0.0
[injection]
frequency = 1250.0
quadrature = {quad}
[reference]
type = "step"
position_mm = 3.0
[load]
force = 10.0
[observer]
compensation = "lut"
[calibration]
dither_a = 0.0
""")
    return p


def test_scenario_kappa_and_frequency_are_used(tmp_path, run_cli):
    """--scenario: its bus, PWM, dead time, frequency and kappa. A scenario with kappa 0 and the
    design's kappa give tables that match their own models within the bar, not each other's (the
    two models differ by several degrees)."""
    motor = load_motor("ecce2010")
    kappa = DriveData().quad
    models = {q: build_lut(motor, 14, f_inj=1250.0, quad=q).values for q in (0.0, kappa)}
    assert np.degrees(np.abs(models[0.0] - models[kappa])).max() > 5.0
    for q, other in ((0.0, kappa), (kappa, 0.0)):
        out = tmp_path / f"out_{q:g}"
        r = run_cli("calibrate", "--scenario", _scenario(tmp_path, q), "--positions", 14, "--out", out)
        assert r.code == 0, r.err
        # (the summary names the injection: kappa 0.9 was called "pulsating")
        assert ("elliptical injection" if q else "pulsating injection") in r.out, r.out
        m = json.loads((out / "metrics.json").read_text())
        assert m["injection_quad"] == pytest.approx(q) and m["f_inj_hz"] == 1250.0
        assert (m["v_dc"], m["f_pwm_hz"], m["dead_time_s"]) == (60.0, 20000.0, 0.0)
        # the calibration's own run settings: switching, its load, not the scenario's
        assert m["fidelity"] == "switching" and m["load_n"] == 0.0 and m["completed"]
        assert m["dither_a"] == 0.0  # (the scenario's [calibration])
        rows = (out / "lut_measured.csv").read_text().splitlines()[1:]
        table = np.radians([float(r.split(",")[1]) for r in rows])
        assert np.degrees(np.abs(table - models[q])).max() <= BAR_DEG
        assert m["max_diff_deg"] <= BAR_DEG
        assert np.degrees(np.abs(table - models[other])).max() > 3.0


def test_options_over_the_scenario_and_the_design(tmp_path, run_cli):
    """The drive-data options over the scenario's (and --quad over its kappa); with --motor alone
    over the design's drive, whose injection follows (f_pwm / 16)."""
    sc = _scenario(tmp_path, 0.0)
    r = run_cli("calibrate", "--scenario", sc, "--quad", 0.5, "--dead-time", 0.4e-6, "--v-dc", 66,
                "--positions", 4, "--fidelity", "average", "--out", tmp_path / "a")
    assert r.code == 0, r.err
    m = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert (m["injection_quad"], m["dead_time_s"], m["v_dc"], m["f_inj_hz"]) == (0.5, 0.4e-6, 66.0, 1250.0)
    r = run_cli("calibrate", "--motor", "ecce2010", "--f-pwm", 20000, "--i-max", 3, "--positions", 4,
                "--fidelity", "average", "--out", tmp_path / "b")
    assert r.code == 0, r.err
    m = json.loads((tmp_path / "b" / "metrics.json").read_text())
    dz = design(load_motor("ecce2010"), DriveData(f_pwm=20000.0, i_max=3.0), analyse=False)
    assert (m["f_pwm_hz"], m["i_max_a"]) == (20000.0, 3.0)
    assert (m["f_inj_hz"], m["v_inj"], m["injection_quad"]) == pytest.approx((dz.f_inj, dz.v_inj, dz.quad))
    assert "20000 Hz PWM" in r.out and "kappa 0.9" in r.out


def test_bad_input_is_one_line(tmp_path, run_cli):
    sc = _scenario(tmp_path, 0.0)
    other = CLASS / "m30_low.toml"
    line = run_cli("calibrate", "--scenario", sc, "--motor", other, "--out", tmp_path / "o").refused(
        str(sc), "motor", "'ecce2010'", "m30_low")
    assert "is not the motor given" in line
    # the same motor twice is accepted (the preset by name or by the scenario)
    r = run_cli("calibrate", "--scenario", sc, "--motor", "ecce2010", "--positions", 4, "--fidelity",
                "average", "--out", tmp_path / "p")
    assert r.code == 0, r.err
    run_cli("calibrate", "--out", tmp_path / "o").refused("--motor or --scenario")
    run_cli("calibrate", "--motor", "ecce2010", "--f-inj", 5000, "--out", tmp_path / "o").refused(
        "ecce2010", "injection.frequency", "f_inj", "4000", "5000")
    run_cli("calibrate", "--scenario", sc, "--f-pwm", 3000, "--out", tmp_path / "o").refused(
        str(sc), "injection.frequency", "750", "1250")
    run_cli("calibrate", "--motor", "ecce2010", "--dead-time", -1e-6, "--out", tmp_path / "o").refused(
        "--dead-time", "-1e-06")
    run_cli("calibrate", "--motor", "ecce2010", "--quad", 1.0, "--out", tmp_path / "o").refused(
        "--quad", "1.0")
    assert not (tmp_path / "o").exists()
    with pytest.raises(InputError, match="not a drive-data key"):
        calibration_scenario("ecce2010", drive={"v_bus": 48.0})
    assert set(DRIVE_KEYS) <= {f for f in DriveData.__dataclass_fields__}


# ---------------------------------------------------------------------- its own timings
def test_timings_follow_the_design():
    """k_int, t_hold, t_settle and t_max from the designed dither, injection, demodulator and
    position loop: the window a whole number of periods of the dither's beat with the injection;
    keys the scenario gives are kept and the others follow them."""
    t = calibration_timing(500.0, 0.3, 75.0, 150.0, 5.0)
    assert t["k_int"] == pytest.approx(2 * math.pi * 75.0 / 15.0)
    beat = 1.0 / math.gcd(75, 500)  # 40 ms
    assert t["t_hold"] / beat == pytest.approx(round(t["t_hold"] / beat)) and t["t_hold"] >= 6.0 / t["k_int"]
    assert t["t_settle"] == pytest.approx(1.5 / 5.0) and t["t_max"] == pytest.approx(30 * t["t_hold"])
    assert calibration_timing(1000.0, 0.0, 150.0, 300.0, 10.0)["t_hold"] * 1000.0 == pytest.approx(
        round(calibration_timing(1000.0, 0.0, 150.0, 300.0, 10.0)["t_hold"] * 1000.0))
    kept = calibration_timing(500.0, 0.3, 75.0, 150.0, 5.0, k_int=10.0)
    assert kept["k_int"] == 10.0 and kept["t_hold"] >= 0.6
    # in a scenario: designed where not given (the class motor on 8 kHz), kept where given
    sc, _ = calibration_scenario(str(CLASS / "m20_hv.toml"), drive=_drive("m20_hv"),
                                 calibration={"t_hold": 0.3})
    s = designed(sc, resolve_motor(sc)).spec
    cal, want = s.calibration, calibration_timing(
        s.injection.frequency, s.calibration.dither_a, s.calibration.dither_hz, s.observer.demod_lpf_hz,
        s.controller.kp_x, t_hold=0.3)
    assert (cal.k_int, cal.t_hold, cal.t_settle, cal.t_max) == pytest.approx(
        (want["k_int"], 0.3, want["t_settle"], want["t_max"]))


def test_a_window_of_half_dither_periods_never_accepts():
    """Why the window follows the dither: with 7.5 dither periods the ripple's remainder keeps the
    window's mean error above the tolerance and the point trips; with the designed window the
    calibration completes (the C default, 0.1 s, is 15 periods only at the paper's 150 Hz)."""
    # (at a 300 Hz dither, whose ripple leaks through the HF band-pass; the design's 55 Hz leaks
    # less and then accepts either window, and so does the former 150 Hz since the dead-time
    # residual's forward model: its ripple's remainder is now within the tolerance)
    f_d = 300.0
    bad = calibrate("ecce2010", 14, quad=0.0, calibration={"dither_hz": f_d, "t_hold": 7.5 / f_d})
    assert not bad.completed and bad.metrics["fault"] == "observer"
    good = calibrate("ecce2010", 14, quad=0.0, calibration={"dither_hz": f_d})
    periods = good.metrics["t_hold_s"] * f_d
    assert good.completed and periods == pytest.approx(round(periods))


# ---------------------------------------------------------------------- the bar
@pytest.mark.parametrize("load", _bar("ecce2010", ABOVE_BAR_ELLIPTICAL))
def test_ecce2010_design_drive_within_the_bar(load):
    """ecce2010 on the design's drive (elliptical injection, kappa 0.9), switching inverter with its
    0.8 us dead time, 56 points at 0, 20 and 40 N: within 0.3 deg of the model LUT for that
    injection."""
    cal = calibrate("ecce2010", 56, load)
    m = cal.metrics
    print(f"\n  ecce2010 {load:g} N, kappa {m['injection_quad']:g}: max diff {m['max_diff_deg']} deg")
    assert m["fidelity"] == "switching" and m["dead_time_s"] > 0 and m["injection_quad"] == DriveData().quad
    assert cal.completed, m
    assert m["max_diff_deg"] <= BAR_DEG
    assert f"{m['max_diff_deg']:.2f}" == _table("ecce2010", load, 1), m["max_diff_deg"]


@pytest.mark.parametrize("load", [0.0, 20.0, 40.0])
def test_ecce2010_pulsating_within_the_bar(load):
    """The same with the paper's pulsating injection (kappa 0): within 0.1 deg."""
    cal = calibrate("ecce2010", 56, load, quad=0.0)
    assert cal.completed and cal.metrics["max_diff_deg"] <= BAR_PULSATING_DEG, cal.metrics
    assert f"{cal.metrics['max_diff_deg']:.2f}" == _table("ecce2010", load, 0), cal.metrics["max_diff_deg"]


@pytest.mark.parametrize("name", _class_params(ABOVE_BAR_ELLIPTICAL))
def test_class_motor_design_drive_within_the_bar(name):
    """Each test motor on its drive (drives.toml: v_dc, f_pwm, dead_time, i_max) with the design's
    injection, switching inverter, 56 points at no load: within 0.3 deg of its model."""
    cal = calibrate(str(CLASS / f"{name}.toml"), 56, 0.0, drive=_drive(name))
    m = cal.metrics
    print(f"\n  {name}: {m['points_done']}/56, max diff {m['max_diff_deg']} deg")
    assert m["dead_time_s"] == _drive(name)["dead_time"] and m["f_pwm_hz"] == _drive(name)["f_pwm"]
    assert cal.completed, m
    assert m["max_diff_deg"] <= BAR_DEG
    assert f"{m['max_diff_deg']:.2f}" == _table(name, 0.0, 1), m["max_diff_deg"]


@pytest.mark.parametrize("name", _class_params(ABOVE_BAR_PULSATING))
def test_class_motor_pulsating_within_the_bar(name):
    """The same with the paper's pulsating injection: the calibration's own timings serve the
    class (before they followed the design, two of the six did not complete)."""
    cal = calibrate(str(CLASS / f"{name}.toml"), 56, 0.0, quad=0.0, drive=_drive(name))
    assert cal.completed, cal.metrics
    assert cal.metrics["max_diff_deg"] <= BAR_PULSATING_DEG
    assert f"{cal.metrics['max_diff_deg']:.2f}" == _table(name, 0.0, 0), cal.metrics["max_diff_deg"]

"""The certificate of `linsense tune` (docs/tuning.md, "The certificate"): its judge on synthetic
runs, the designed limits, the test motors of src/linsense/examples/motors/class tuned and verified (--quick),
and the command's outputs and exit codes."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from linsense.cli import main
from linsense.model.motor import load_motor
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.tune.design import (
    CURRENT_TRIP_MARGIN,
    OVERSPEED_MARGIN,
    SPEED_CAP_MARGIN,
    DriveData,
    design,
)
from linsense.tune.drive_design import design_drive
from linsense.tune.export import scenario_dict
from linsense.verify import criteria as C
from linsense.verify.case_runs import judge
from linsense.verify.cases import Case, all_cases, off_nominal_motor

ROOT = Path(__file__).parents[1]
CLASS = ROOT / "src/linsense/examples" / "motors" / "class"
DRIVES = tomllib.loads((CLASS / "drives.toml").read_text())
NAMES = sorted(DRIVES)


def _drive(name: str) -> DriveData:
    d = DRIVES[name]
    return DriveData(
        v_dc=d["v_dc"],
        f_pwm=d["f_pwm"],
        dead_time=d["dead_time"],
        i_max=d["i_max"],
        v_max=d["v_max"],
        a_max=d["a_max"],
        load=d["load"],
    )


def _arrays(t, x, err=None):
    x = np.asarray(x, float)
    e = np.zeros_like(x) if err is None else np.asarray(err, float)
    return {
        "t": np.asarray(t, float),
        "x_min": x,
        "x_max": x,
        "x_mean": x,
        "err_min": e,
        "err_max": e,
        "err_mean": e,
    }


TAU = 0.056


def test_judge_hold_limit_cycle_in_electrical_degrees():
    """A 0.2 deg p-p oscillation fails, 0.1 deg passes, whatever the pole pitch (same angles)."""
    for tau in (0.02, 0.1):
        t = np.arange(0, 0.8, 5e-4)
        for amp_deg, ok in ((0.1, True), (0.2, False)):
            x = 0.01 + 0.5 * amp_deg / 360 * tau * np.sin(2 * np.pi * 7 * t)
            case = Case("h", "hold", "nominal", {}, target=0.01)
            row = judge(case, _arrays(t, x), 0, 0.8, 0.8, tau)
            assert row["passed"] is ok, row
            assert row["pp_deg"] == pytest.approx(amp_deg, rel=0.02)


def test_judge_step_settling_and_never():
    t = np.arange(0, 0.8, 5e-4)
    tgt = 0.1 * TAU
    x = np.where(t < 0.05, 0.0, tgt * (1 - np.exp(-(t - 0.05) / 0.03)))
    case = Case("s", "step", "nominal", {}, target=tgt, t_event=0.05)
    row = judge(case, _arrays(t, x), 0, 0.8, 0.8, TAU)
    # |x - target| = 36 deg exp(-t/0.03) <= 1 deg after 0.03 ln 36 = 0.1075 s
    assert row["settle_s"] == pytest.approx(0.03 * math.log(36), abs=1e-3) and row["passed"]
    row = judge(case, _arrays(t, x * 0.9), 0, 0.8, 0.8, TAU)  # ends 3.6 deg short
    assert row["settle_s"] is None and not row["passed"] and "never" in row["why"]


def test_judge_fault_and_short_run_fail():
    t = np.arange(0, 0.3, 5e-4)
    case = Case("h", "hold", "nominal", {}, target=0.0)
    row = judge(case, _arrays(t, np.zeros_like(t)), 0x10, 0.3, 0.8, TAU)
    assert not row["passed"] and "overspeed" in row["why"]
    row = judge(case, _arrays(t, np.zeros_like(t)), 0, 0.3, 0.8, TAU)
    assert not row["passed"] and row["why"] == "did not finish"


def test_off_nominal_plants():
    m = load_motor("ecce2010")
    hot = off_nominal_motor(m, "R_s +30 % (hot)")
    assert hot.R_s == pytest.approx(1.3 * m.R_s)
    big = off_nominal_motor(m, "dM0 +25 %")
    a0, a1 = m.inductance.a, big.inductance.a
    assert 0.5 * (a1[4, 0] + a1[5, 0]) - a1[3, 0] == pytest.approx(1.25 * -0.47e-3, rel=1e-9)
    assert off_nominal_motor(m, "L -10 %").inductance.a[0, 0] == pytest.approx(0.9 * a0[0, 0])


def test_cases_full_and_quick():
    """The full certificate: holds over the period and loads on every plant (those whose table is
    measured also with the file's table, at no load, for information), the steps, the moves at
    v_max over every load, a reversal and a hold after a move, the load step, and a move on each
    plant whose table is measured; --quick: the nominal holds at 8 positions, the steps and the
    moves at +-rated load."""
    full = all_cases(TAU, 0.2, 1.0, 40.0, quick=False)
    quick = all_cases(TAU, 0.2, 1.0, 40.0, quick=True)
    holds = [c for c in full if c.kind == "hold"]
    assert len(holds) == (C.POSITIONS * len(C.HOLD_LOADS) * (1 + len(C.OFF_NOMINAL))
                          + C.POSITIONS * len(C.CALIBRATED))
    assert {c.kind for c in full} == {"hold", "step", "trajectory", "reversal", "move_hold", "load_step"}
    assert C.CALIBRATED == ("dM0 +25 %", "dM0 -25 %")
    measured = [c for c in full if c.table == "measured"]
    assert {c.plant for c in measured} == set(C.CALIBRATED)
    assert all(c.plant in C.CALIBRATED for c in full if c.table == "measured")
    moves = [c for c in full if c.kind == "trajectory" and c.plant == "nominal"]
    assert sorted(c.load for c in moves) == sorted(f * 40.0 for f in C.TRAJ_LOADS)
    assert all(c.plant == "nominal" for c in quick)
    assert len([c for c in quick if c.kind == "hold"]) == C.POSITIONS_QUICK * len(C.HOLD_LOADS)
    assert sorted(c.load for c in quick if c.kind == "trajectory") == [-40.0, 40.0]


def test_moves_reach_the_speed_asked_for():
    """The moves cruise at v_max over a pole pitch at least (not a short move's peak): 1 m/s at
    1 m/s^2 on a 56 mm motor is a 1.056 m move; a stroke too short for it shortens the move, and
    the case's name says the speed it then reaches."""
    from linsense.verify.cases import move_distance, moves, peak_speed

    assert move_distance(TAU, 1.0, 1.0) == pytest.approx(1.0 + TAU)
    assert move_distance(TAU, 0.1, 10.0) == pytest.approx(C.TRAJ_PITCHES * TAU)
    full = moves(TAU, 1.0, 1.0, 10.0, quick=False)
    assert all(c.speed == pytest.approx(1.0) for c in full)
    short = moves(TAU, 1.0, 1.0, 10.0, quick=True, travel=0.3)
    v = peak_speed(0.3 - 2 * TAU * 0.37 / C.POSITIONS, 1.0, 1.0)
    assert all(c.speed == pytest.approx(v) and "the stroke" in c.name for c in short) and v < 0.6


def test_designed_limits_follow_the_application():
    m = load_motor("ecce2010")
    made = design_drive(m, DriveData(v_max=0.4, load=20.0), analyse=False, startup=False)
    dz = made.design
    assert dz.v_cap == pytest.approx(SPEED_CAP_MARGIN * 0.4)
    assert dz.omega_trip == pytest.approx(OVERSPEED_MARGIN * dz.v_cap * 2 * math.pi / m.pole_pitch)
    assert dz.omega_obs > dz.omega_trip  # the trip must see the speed the observer reports
    assert dz.i_trip > CURRENT_TRIP_MARGIN * 2.5
    # what tune writes carries them, and a scenario that gives only motor and drive data gets them
    sc = scenario_dict(made, motor_ref="ecce2010")
    assert sc["controller"]["v_max"] == pytest.approx(dz.v_cap, rel=1e-5)
    assert sc["protection"]["omega_max"] == pytest.approx(dz.omega_trip, rel=1e-5)
    assert sc["protection"]["i_max"] == pytest.approx(dz.i_trip, rel=1e-5)
    assert sc["observer"]["omega_max"] == pytest.approx(dz.omega_obs, rel=1e-5)
    bare = {"motor": "ecce2010", "scenario": {"duration": 0.01},
            "reference": {"type": "trajectory", "waypoints_mm": [5.0], "v_max": 0.4, "at": 0.0}}
    b = build(scenario_from_dict(bare))
    for got, want in ((b.drive.cfg.pos.v_max, dz.v_cap), (b.drive.cfg.prot.omega_max, dz.omega_trip),
                      (b.drive.cfg.prot.i_max, dz.i_trip), (b.drive.cfg.obs.omega_max, dz.omega_obs)):
        assert float(got) == pytest.approx(want, rel=1e-5)
    # without a table the estimate moves up to max(1 + de*/dtheta) = 2.93 times the mover: the trips
    # on the estimate are that much wider
    b = build(scenario_from_dict({**bare, "control": {"mode": "sensorless_nolut"}}))
    assert float(b.drive.cfg.prot.omega_max) == pytest.approx(2.93 * dz.omega_trip, rel=0.01)


def test_injection_follows_dead_time_and_saliency():
    """More dead time -> more injection (up to the bus share); an impossible one is refused."""
    m = load_motor("ecce2010")
    lo = design(m, DriveData(dead_time=0.4e-6), analyse=False)
    hi = design(m, DriveData(dead_time=0.8e-6), analyse=False)
    assert lo.v_inj < hi.v_inj <= 72.0 / 4.5 + 1e-9
    from linsense.errors import InputError

    with pytest.raises(InputError, match="saliency is too small for this dead time"):
        design(m, DriveData(dead_time=3e-6), analyse=False)


def _quick_certificate(name: str):
    from linsense.verify.certificate import design_and_verify

    return design_and_verify(str(CLASS / f"{name}.toml"), _drive(name), quick=True, workers=1)[1]


@pytest.mark.parametrize("name", NAMES)
def test_class_motor_tuned_and_quick_verified(name):
    """Each test motor designed from its file and drive data, then the quick certificate on the
    switching inverter with dead time: every run judged, the verdict is the checks', and every
    failed check names its number and a likely cause."""
    cert = _quick_certificate(name)
    assert len(cert.rows) == (C.POSITIONS_QUICK * len(C.HOLD_LOADS) + len(C.STEP_FRACTIONS)
                              + len(C.TRAJ_LOADS_QUICK))
    assert all(r["passed"] == (r["why"] == "") for r in cert.rows)
    assert cert.passed == all(c.passed for c in cert.checks) and cert.checks
    for c in cert.checks:
        assert c.passed or (c.cause and c.failed > 0), c
    lines = cert.lines()
    # (a quick certificate that passes says so and that it is not a verification)
    assert lines[-1].startswith("quick checks passed" if cert.passed else "NOT verified")
    assert not cert.verified


def test_every_class_motor_passes_the_quick_certificate():
    """Every test motor's design passes the quick certificate (its nominal holds at 8 positions and
    three loads, its steps, its moves at v_max at +-rated load) on the switching inverter
    (docs/tuning.md, "Where the design stands")."""
    failed = [n for n in NAMES if not _quick_certificate(n).passed]
    assert not failed, failed


#: the measured table's distance from the plant's own beyond CAL_TABLE_ERR_DEG where the dead time's
#: bias in what the calibration measures exceeds it (docs/tuning.md, "The end-effect tolerance"):
#: ecce2010 at dM0 x 0.75 0.305 deg (a smaller dither, 0.2 A, gives 0.24 there but 0.33 at 40 N in
#: the calibration under load), m20_hv 0.36 at either plant whatever the dither and the window
CAL_EXCESS = {"ecce2010": 0.02, "m20_hv": 0.1, "harmonic": 0.1}

#: every shipped motor (the presets and the example and test motors) with its drive data; harmonic
#: (friction, a PM-flux harmonic) passes every nominal check with the friction and thrust-ripple
#: feed-forward but 4 tolerance hold sets end in 0.17-0.21 deg p-p cycles (bound 0.15): not verified
#: yet (docs/tuning.md, "Friction and thrust ripple"); strict, so that the day it passes says so
_NOT_YET = pytest.mark.xfail(strict=True, reason="4 tolerance hold sets cycle at 0.17-0.21 deg p-p")
SHIPPED = ["ecce2010", "small30", pytest.param("harmonic", marks=_NOT_YET)] + NAMES


def _spec_and_drive(name: str):
    if name in NAMES:
        return str(CLASS / f"{name}.toml"), _drive(name)
    return ("ecce2010" if name == "ecce2010" else
            str(ROOT / "src/linsense/examples" / "motors" / f"{name}.toml")), DriveData()


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_motor_is_verified(name):
    """Each shipped motor's design, from its file and drive data alone, passes every check of the
    full certificate on the switching inverter with dead time: the holds, the steps, the moves at
    v_max over the loads (out and back, a reversal, a hold after a move), the load step, the L and
    R_s tolerances with the file's table and the end-effect tolerance with the table the
    calibration measured on the off-nominal plant (docs/tuning.md, "The certificate"); each
    measured table within 0.3 deg of the plant's own (:data:`CAL_EXCESS` beyond it: a bias of the
    dead time the calibration measures with the table, 0.17 deg on average on m20_hv, whose 1.5 us
    at 8 kHz and 300 V are 3.6 V against 45 V of injection; longer windows do not move it)."""
    from linsense.verify.certificate import design_and_verify

    spec, dd = _spec_and_drive(name)
    cert = design_and_verify(spec, dd, quick=False, workers=1)[1]
    failed = [c.line() for c in cert.checks if not c.passed]
    assert cert.verified and not failed, failed
    assert cert.lines()[-1] == "verified: every check passed"
    cals = cert.extra["calibrations"]
    assert set(cals) == set(C.CALIBRATED)
    for plant, cal in cals.items():
        bound = C.CAL_TABLE_ERR_DEG + CAL_EXCESS.get(name, 0.0)
        assert cal["completed"] and cal["max_diff_deg"] <= bound, (plant, cal["max_diff_deg"])
    moving = [r for r in cert.rows if r["kind"] in ("trajectory", "reversal", "move_hold")]
    assert moving and all(r["speed_peak_m_s"] >= dd.v_max for r in moving if r["plant"] == "nominal")
    # docs/tuning.md's class table (tools/class_table.py) says what this run says
    from linsense.verify.certificate import summary_row

    row = "| " + " | ".join(summary_row(name, cert)) + " |"
    assert row in (ROOT / "docs" / "tuning.md").read_text().splitlines(), row


def test_tune_cli_writes_certificate_and_exit_code(tmp_path, capsys):
    out = tmp_path / "t.toml"
    with pytest.raises(SystemExit) as e:
        main(["tune", "--motor", "ecce2010", "--quick", "--out", str(out)])
    text = capsys.readouterr().out
    doc = json.loads((tmp_path / "t.verification.json").read_text())
    assert (tmp_path / "t.verification.png").stat().st_size > 10_000
    assert e.value.code == (0 if doc["passed"] else 1)
    assert doc["quick"] and not doc["verified"]  # (a quick run never claims the certificate)
    assert "verification (quick" in text and ("NOT verified" in text) != doc["passed"]
    assert doc["checks"]
    for c in doc["checks"]:
        assert ("PASS  " + c["name"] if c["passed"] else "FAIL  " + c["name"]) in text
        if not c["passed"]:
            assert c["cause"]
    assert tomllib.loads(out.read_text())["protection"]["omega_max"] > 0


def test_quick_pass_is_not_verified():
    from linsense.verify.certificate import Certificate, Check

    ok = Certificate([Check("x", True, "v", "b")], [], 0.1, quick=True)
    assert ok.passed and not ok.verified and "not verified" in ok.verdict()
    assert Certificate([Check("x", True, "v", "b")], [], 0.1, quick=False).verdict().startswith("verified")


def test_tune_scenario_options_reach_the_file(tmp_path, capsys, monkeypatch):
    """A relative --motor with --scenario is the working folder's; --v-max and --a-max reach the
    scenario's trajectory (the limits are designed from them); a scenario without its table gets
    the widened trips; a start-up scenario verifies; --travel shortens the certificate's moves."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.toml").write_text((ROOT / "src/linsense/examples" / "motors" / "small30.toml").read_text())
    sub = tmp_path / "s"
    sub.mkdir()
    (sub / "sc.toml").write_text('motor = "ecce2010"\n[scenario]\nduration = 1.0\n[control]\n'
                                 'mode = "sensorless_nolut"\n[reference]\ntype = "trajectory"\n'
                                 'waypoints_mm = [20.0]\n')
    with pytest.raises(SystemExit) as e:
        main(["tune", "--motor", "m.toml", "--scenario", "s/sc.toml", "--v-max", "0.1", "--no-verify",
              "--out", "o/x.toml"])
    assert e.value.code in (0, None)
    doc = tomllib.loads((tmp_path / "o" / "x.toml").read_text())
    assert (tmp_path / "o" / doc["motor"]).resolve() == (tmp_path / "m.toml").resolve()
    assert doc["reference"]["v_max"] == 0.1
    dz = design(load_motor(tmp_path / "m.toml"), DriveData(v_max=0.1))
    from linsense.tune.design import uncompensated_speed_factor

    k = uncompensated_speed_factor(load_motor(tmp_path / "m.toml"))
    assert doc["protection"]["omega_max"] == pytest.approx(k * dz.omega_trip, rel=1e-4) and k > 1.5
    from linsense.scenario.load import load_scenario

    build(load_scenario(tmp_path / "o" / "x.toml"))  # (it runs as written)
    capsys.readouterr()
    cases = all_cases(TAU, 0.2, 1.0, 20.0, quick=False, travel=0.07)
    traj = next(c for c in cases if c.kind == "trajectory")
    assert max(traj.sections["reference"]["waypoints_mm"]) <= 70.0
    assert all(c.sections["travel"]["max_mm"] <= 73.0 for c in cases)


def test_tune_bad_application_is_one_line_before_writing(tmp_path, capsys):
    for args, key in ((["--load", "0"], "load"), (["--a-max", "1e-9"], "a_max"),
                      (["--f-inj", "0.2"], "f_inj"), (["--travel", "10"], "travel")):
        out = tmp_path / f"{key}.toml"
        with pytest.raises(SystemExit) as e:
            main(["tune", "--motor", "ecce2010", *args, "--quick", "--out", str(out)])
        err = capsys.readouterr().err.strip().splitlines()
        assert e.value.code == 2 and len(err) == 1 and key in err[0], (args, err)
        assert not out.exists()


def test_tune_no_verify_and_refusal(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["tune", "--motor", "ecce2010", "--no-verify", "--out", str(tmp_path / "a.toml")])
    assert e.value.code in (0, None) and not (tmp_path / "verification.json").exists()
    capsys.readouterr()
    with pytest.raises(SystemExit) as e:
        main(["tune", "--motor", "ecce2010", "--dead-time", "3e-6", "--out", str(tmp_path / "b.toml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert e.value.code == 2 and len(err) == 1 and "dead_time" in err[0] and "saliency" in err[0]


def _full_off_nominal(name: str):
    m = load_motor(CLASS / f"{name}.toml")
    dd = _drive(name)
    made = design_drive(m, dd, startup=False)
    dz = made.design
    spec = str(CLASS / f"{name}.toml")
    from linsense.verify.case_runs import run_cases
    from linsense.verify.cases import hold_cases

    cases = []
    for plant in C.OFF_NOMINAL:
        cases += hold_cases(m.pole_pitch, dz.load, C.POSITIONS, plant=plant, loads=(0.0,))
    rows = run_cases(cases, scenario_dict(made, motor_ref=spec), spec, m, str(ROOT), workers=1)
    return dz, rows


#: the class motors whose drive holds the position (m20_hv's 500 Hz injection does not: docs/tuning.md)
HOLDING = [n for n in NAMES if n != "m20_hv"]


@pytest.mark.parametrize("name", HOLDING)
def test_predicted_tolerance_costs_agree_with_the_simulation(name):
    """The model's prediction of each tolerance's hold error (linsense.tune.margins, before any
    simulation) agrees with the switching simulation with dead time within 1 deg or 25 %, so that
    its verdict against the 3 deg bound is the certificate's (measured: within 0.1-0.9 deg)."""
    dz, rows = _full_off_nominal(name)
    assert dz.tolerances and rows
    for plant, pred in dz.tolerances.items():
        meas = max(r.get("err_deg", math.inf) for r in rows if r["plant"] == plant)
        tol = max(1.0, 0.25 * pred["error_deg"])
        assert abs(meas - pred["error_deg"]) <= tol, (plant, meas, pred)
        if abs(pred["error_deg"] - C.OFF_ERR_DEG) > tol:  # (clear of the bound: the same verdict)
            assert (meas <= C.OFF_ERR_DEG) == (pred["error_deg"] <= C.OFF_ERR_DEG), (plant, meas, pred)


def test_margins_differ_by_motor():
    """The tolerance costs and the error-gain range under them, which the loops' margins are
    evaluated over, are the motor's own."""
    costs = {n: design(load_motor(CLASS / f"{n}.toml"), _drive(n)).tolerances for n in NAMES}
    worst = {n: max(t["error_deg"] for t in c.values()) for n, c in costs.items()}
    assert max(worst.values()) > 2 * min(worst.values()), worst
    k_lo = {n: min(t["k_lo"] for t in c.values()) for n, c in costs.items()}
    assert max(k_lo.values()) - min(k_lo.values()) > 0.01, k_lo


def test_tune_square_wave(tmp_path, capsys):
    """--injection square: a scenario with the square wave (no kappa, no frequency: f_pwm / 2) that
    the simulator runs; the C header refuses it in one line (it configures the elliptical one)."""
    out = tmp_path / "sq.toml"
    with pytest.raises(SystemExit) as e:
        main(["tune", "--motor", "ecce2010", "--injection", "square", "--no-verify", "--out", str(out)])
    assert e.value.code in (0, None)
    inj = tomllib.loads(out.read_text())["injection"]
    assert inj["shape"] == "square" and "quadrature" not in inj and "frequency" not in inj
    from linsense.scenario.load import load_scenario

    assert build(load_scenario(out)).drive.cfg.inject.shape == 2  # LS_INJ_SQUARE
    capsys.readouterr()
    with pytest.raises(SystemExit) as e:
        main(["tune", "--motor", "ecce2010", "--injection", "square", "--format", "c",
              "--out", str(tmp_path / "sq.h")])
    err = capsys.readouterr().err.strip().splitlines()
    assert e.value.code == 2 and len(err) == 1 and "--format" in err[0]


def _tuned_trajectory(name: str):
    """``(spec, motor, drive, design, tuned scenario dict, trajectory case)`` of a test motor on its
    drive, as linsense tune designs it."""
    from linsense.verify.cases import trajectory_case
    from linsense.verify.certificate import motor_ref

    spec = motor_ref(str(CLASS / f"{name}.toml"))
    motor = load_motor(spec)
    d = _drive(name)
    made = design_drive(motor, d, source=spec, analyse=False, startup=False)
    dz = made.design
    base = scenario_dict(made, motor_ref=spec)
    return spec, motor, d, dz, base, trajectory_case(motor.pole_pitch, d.v_max, d.a_max, dz.load)


def test_a_trajectory_of_fractional_periods_is_judged_to_its_end():
    """A trajectory's run lasts its motion time and margins, not a whole number of PWM periods: the
    simulator runs round(duration f_pwm) periods, and the judge compares with what was run (it
    said "did not finish" for m100_edge's, one third of a period short, before)."""
    from linsense.verify.case_runs import run_case

    spec, motor, d, _, base, case = _tuned_trajectory("m100_edge")
    periods = case.sections["scenario"]["duration"] * d.f_pwm
    assert abs(periods - round(periods)) > 1e-3  # (the case this test is about)
    row = run_case(case, base, spec, motor, str(ROOT))
    assert row["fault"] == "none" and "did not finish" not in row["why"], row["why"]
    assert "peak_err_deg" in row


def test_the_hf_delay_compensation_removes_the_speed_lag():
    """While the HF current passes the band-pass the estimated axis turns, and the demodulated error
    lags by omega times that delay: the estimate's error during a move grows with the speed. The
    design advances it by about one injection period (docs/tuning.md, "The HF path's delay").
    m30_low's trajectory (0.3 m/s on a 30 mm pitch, 63 rad/s): the speed-proportional part of the
    estimation error, fitted, drops from 0.055 deg per rad/s to below a fifth of it (measured
    0.008), and the peak error from 6.0 to 3.7 deg."""
    from linsense.verify.case_runs import run_case

    spec, motor, _, dz, base, case = _tuned_trajectory("m30_low")
    assert dz.hf_delay == pytest.approx(1.0 / dz.f_inj)
    assert base["observer"]["hf_delay_s"] == pytest.approx(dz.hf_delay)

    def lag(delay: float) -> tuple[float, float]:
        b = json.loads(json.dumps(base))
        b["observer"]["hf_delay_s"] = delay
        tr = run_case(case, b, spec, motor, str(ROOT))["trace"]
        t, x, e = (np.asarray(tr[k]) for k in ("t", "x_deg", "err_deg"))
        w = np.radians(np.gradient(x, t))  # rad/s (electrical)
        k = np.linalg.lstsq(np.vstack([w, np.ones_like(w)]).T, e, rcond=None)[0][0]
        return float(k), float(np.abs(e).max())

    k0, peak0 = lag(0.0)
    k1, peak1 = lag(dz.hf_delay)
    assert k0 < -0.03 and abs(k1) < 0.2 * abs(k0), (k0, k1)
    assert peak1 < 0.75 * peak0, (peak0, peak1)


def test_judge_load_step_still_approaching_passes_a_limit_cycle_fails():
    """The load step is bounded by its recovery (back within 1 deg within 0.3 s, as
    docs/tuning.md says): a mover still approaching within the band at the end passes, with a note,
    and so does a decaying oscillation; one cycling by more than 0.15 deg p-p fails. A hold or a
    step must be still at its end."""
    t = np.arange(0, 0.9, 5e-4)
    deg = TAU / 360.0
    # back within 1 deg 0.2 s after the step at 0.3 s, then creeping: 0.6 deg over the end window
    after = t - 0.3
    creep = np.where(t < 0.3, 0.0, 20.0 * deg * np.exp(-after / 0.05) + 0.9 * deg * np.exp(-after / 0.4))
    case = Case("l", "load_step", "nominal", {}, target=0.0, t_event=0.3, load=10.0)
    row = judge(case, _arrays(t, creep), 0, 0.9, 0.9, TAU)
    assert row["passed"] and row["recover_s"] < 0.3 and "still settling" in row["note"], row
    cyc = creep + np.where(t < 0.3, 0.0, 0.15 * deg * np.sin(2 * np.pi * 15 * t))
    row = judge(case, _arrays(t, cyc), 0, 0.9, 0.9, TAU)
    assert not row["passed"] and "limit cycle" in row["why"], row
    # an overshoot's oscillation that decays within the end window (MECH observer with the load
    # fed forward: ecce2010's 0.6 deg, 0.2 deg p-p over the window's start) settles: passes
    ring = np.where(t < 0.3, 0.0, 20.0 * deg * np.exp(-after / 0.07) * np.cos(2 * np.pi * 4 * after))
    row = judge(case, _arrays(t, ring), 0, 0.9, 0.9, TAU)
    assert row["passed"] and "still settling" in row["note"], row
    # one that decays too slowly (still above 0.15 deg p-p over the window's second half) does not
    slow = np.where(t < 0.3, 0.0, 0.8 * deg * np.exp(-after / 2.0) * np.sin(2 * np.pi * 15 * after))
    row = judge(case, _arrays(t, slow), 0, 0.9, 0.9, TAU)
    assert not row["passed"] and "limit cycle" in row["why"], row
    # the same creep at the end of a hold fails
    row = judge(Case("h", "hold", "nominal", {}, target=0.0), _arrays(t, creep), 0, 0.9, 0.9, TAU)
    assert not row["passed"] and "still moving" in row["why"]


@pytest.mark.parametrize("adapt", [True, False])
def test_the_drive_measures_a_hot_winding(adapt):
    """A winding 30 % hotter than the motor file: the drive measures the resistance's scale from the
    HF current changes (ls_dtres_adapt) and its table follows it (ls_demod_cfg.comp_r); ecce2010 at
    the position where the model puts the nominal table's worst error (4.2 deg): within 1 deg with
    the measurement, beyond the certificate's 3 deg bound without it (observer.resistance_adapt)."""
    from linsense.model.tolerance import perturbed
    from linsense.sim.core import run_closed_loop
    from linsense.tune.margins import hold_error
    from linsense.verify.case_runs import _BLOCKS, _SIGNALS, case_scenario

    m = load_motor("ecce2010")
    dd = DriveData(v_dc=72.0, f_pwm=16000.0, dead_time=0.8e-6, i_max=2.5, v_max=0.2, a_max=1.0, load=40.0)
    made = design_drive(m, dd, analyse=False, startup=False)
    dz = made.design
    hot = perturbed(m, 1.0, 1.3, 1.0, label="hot")
    e = hold_error(m, hot, dz.f_inj, dz.quad, 72)  # the nominal table's error, target = k 5 deg
    deg = 5.0 * float(np.argmax(np.abs(e)))
    assert math.degrees(np.max(np.abs(e))) > 4.0
    case = Case(name="hot", kind="hold", plant="nominal", target=m.pole_pitch * deg / 360.0,
                sections={"scenario": {"duration": 0.6}, "reference": {"type": "hold"},
                          "initial": {"position_mm": m.pole_pitch * deg / 360.0 * 1e3, "load_balanced": True},
                          "observer": {"resistance_adapt": adapt}})
    base = scenario_dict(made, motor_ref="ecce2010")
    sc = scenario_from_dict(case_scenario(case, base, "ecce2010"), source="<test>", base_dir=str(ROOT))
    b = build(sc, motor=hot)
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, signals=_SIGNALS, blocks=_BLOCKS)
    err_deg = abs(float(raw.arrays["x_mean"][-1]) - case.target) * 360.0 / m.pole_pitch
    k_r = float(b.drive.state.dtres.k_r)
    if adapt:
        assert abs(k_r - 1.3) < 0.03 and err_deg < 1.0, (k_r, err_deg)
    else:
        assert k_r == 1.0 and err_deg > C.OFF_ERR_DEG, (k_r, err_deg)


def test_the_end_effect_tolerance_costs_what_the_end_effect_ratio_says():
    """The model's cost of dM0 +25 % (pulsating injection, nominal table) is a quarter of the end
    effect's share of the saliency over 2, in rad, on every test motor (docs/tuning.md, "The
    end-effect tolerance"): a property of the motor, which the design's warning names."""
    from linsense.tune.design import end_effect_ratio
    from linsense.tune.margins import tolerance_costs

    for name in NAMES + ["ecce2010"]:
        m = load_motor("ecce2010" if name == "ecce2010" else CLASS / f"{name}.toml")
        dz = design(m, _drive(name) if name != "ecce2010" else DriveData(), analyse=False)
        cost = tolerance_costs(m, dz.f_inj, 0.0, n=90)["dM0 +25 %"]["error_deg"]
        assert cost == pytest.approx(math.degrees(0.25 * end_effect_ratio(m) / 2.0), rel=0.12), name


@pytest.mark.parametrize("adapt", [True, False])
def test_the_rotating_injection_follows_a_hot_winding(adapt):
    """The rotating vector's table and reference phase move with the resistance more than the
    elliptical injection's (ecce2010 with R_s +30 %: 6 of 48 holds within the bounds, 8.9 deg, with
    the file's tables): with the measured scale and the rotating tables' slopes
    (linsense.tune.injection.rotating_r_slopes) the hold at the slope's largest position is within
    1 deg, without them beyond 3 deg."""
    from linsense.model.tolerance import perturbed
    from linsense.sim.core import run_closed_loop
    from linsense.tune.injection import rotating_r_slopes
    from linsense.verify.case_runs import _BLOCKS, _SIGNALS, case_scenario

    m = load_motor("ecce2010")
    dd = DriveData(v_dc=72.0, f_pwm=16000.0, dead_time=0.8e-6, i_max=2.5, v_max=0.2, a_max=1.0, load=40.0,
                   shape="rotating")
    made = design_drive(m, dd, analyse=False, startup=False)
    dz = made.design
    base = scenario_dict(made, motor_ref="ecce2010")
    slope, _ = rotating_r_slopes(m, 72, dz.f_inj, dd.f_pwm, 1.5, dz.v_inj)
    deg = 5.0 * float(np.argmax(np.abs(slope)))
    x0 = m.pole_pitch * deg / 360.0
    case = Case(name="hot", kind="hold", plant="nominal", target=x0,
                sections={"scenario": {"duration": 0.6}, "reference": {"type": "hold"},
                          "initial": {"position_mm": x0 * 1e3, "load_balanced": True},
                          "observer": {"resistance_adapt": adapt}})
    sc = scenario_from_dict(case_scenario(case, base, "ecce2010"), source="<test>", base_dir=str(ROOT))
    b = build(sc, motor=perturbed(m, 1.0, 1.3, 1.0, label="hot"))
    assert (b.drive.comp_r is not None) == adapt
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, signals=_SIGNALS, blocks=_BLOCKS)
    err_deg = abs(float(raw.arrays["x_mean"][-1]) - x0) * 360.0 / m.pole_pitch
    if adapt:
        assert err_deg < 1.0, err_deg
    else:
        assert err_deg > C.OFF_ERR_DEG, err_deg


def test_a_figure_of_many_faulted_runs_stays_readable():
    """A drive whose every run trips (a hold of an 80 mm motor on a weak signal before the observer
    rule: 336 of them) names a few faulted runs in each empty panel and counts the rest: the panels
    were covered by hundreds of overlapping lines."""
    from linsense.report.verify_figures import FAULTS_SHOWN, certificate_figure

    rows = [{"case": f"hold {k:.1f} deg, +0 N", "why": "fault: overspeed at 0.03 s", "fault": "overspeed",
             "kind": "hold", "plant": "nominal", "load_n": 0.0, "passed": False} for k in range(150)]
    fig = certificate_figure(rows, "faulted", calibrations=None)
    texts = [t.get_text() for a in fig.axes for t in a.texts]
    assert texts and all(t.count("\n") <= FAULTS_SHOWN + 1 for t in texts), texts
    assert all("and 146 more faulted runs" in t for t in texts)


def test_a_move_failing_below_the_hand_over_band_says_so():
    """A 40 mm, 150 V motor at 6.4 m/s: its HF estimate crosses 3 deg at 1.04 m/s, its band starts at
    1.82 m/s; the advice was only 'a --v-max below 1.04', as if the EMF estimate were not there."""
    from linsense.verify.certificate import _crossing_cause

    text = _crossing_cause(1.04, (1.82, 3.64))
    assert "below the hand-over band 1.82 - 3.64 m/s" in text and "a --v-max below 1.04 m/s" in text
    assert "hand-over" not in _crossing_cause(1.04, None)
    # inside the band the two estimates are weighed together: "a --v-max below 0.344" only moved the
    # crossing (0.307 at 0.33, on a motor with a 3 % fifth flux harmonic); the cap below the band does
    text = _crossing_cause(0.344, (0.229, 0.457))
    assert "inside the hand-over band 0.229 - 0.457 m/s" in text and "--v-max under 0.183" in text
    text = _crossing_cause(0.6, (0.229, 0.457))  # (above it: the EMF estimate alone, not the HF one)
    assert "above the hand-over band, where the EMF estimate carries alone" in text and "HF" not in text


def test_holds_that_all_faulted_say_so_without_nan():
    """A plant whose every hold tripped: the check said '|x - target| <= nan deg ... cost +nan deg'."""
    from linsense.verify.certificate import _hold_check

    rows = [{"case": "hold 8.3 deg, +0 N", "why": "fault: overspeed at 0.03 s", "passed": False,
             "fault": "overspeed"} for _ in range(3)]
    c = _hold_check("holds, nominal plant", rows, 1.0)
    assert "nan" not in c.value and "no hold finished (3 of 3 faulted)" in c.value, c.value


def test_a_square_wave_drive_is_not_told_to_try_the_square_wave():
    """The limit cycle's remedy named the square wave to a drive that runs it (a helper's L -10 %
    hold on a square-wave design)."""
    from linsense.verify.certificate import REMEDY, Check, _for_shape

    def one() -> Check:
        return Check("holds, L -10 %", False, "limit cycle", "0.15 deg p-p", REMEDY["limit cycle"], 48, 1)

    assert "--injection square" in _for_shape([one()], {"injection": {"shape": "pulsating"}})[0].cause
    sq = _for_shape([one()], {"injection": {"shape": "square"}})[0].cause
    assert "--injection square" not in sq
    assert "more injection voltage (--v-inj), less dead time, or lower" in sq


def test_the_crossing_speed_is_where_the_error_first_exceeds_the_bound():
    """A move's error that grew at speed stays over the bound while the mover slows to the reversal:
    the speed named is the first block's over it, not the slowest one's (a 20 mm motor was told its
    HF error crossed 3 deg at 0.019 m/s, where it first did at 1.6 m/s)."""
    from linsense.verify.case_runs import speed_profile

    t = np.linspace(0.0, 1.0, 101)
    x = np.where(t < 0.5, t * t, 0.25 + (t - 0.5) - (t - 0.5) ** 2)  # (up to 1 m/s at 0.5 s, then down)
    err = np.where(t >= 0.4, 4.0, 1.0)  # (over 3 deg from 0.8 m/s on, and while slowing)
    got = speed_profile(t, x, x, err, 0.02)
    assert got["err_crosses_at_speed"] == pytest.approx(0.8, abs=0.03)
    assert speed_profile(t, x, x, np.ones_like(t), 0.02)["err_crosses_at_speed"] is None


def test_a_limit_cycle_with_coulomb_friction_names_the_friction():
    """A motor with Coulomb friction whose holds limit-cycle had every failed check blame the dead
    time (a 15 kg mover with 15 N failed 14 of 16 at 1.5 and at 0.3 us, verified without the
    friction): the friction comes first in the cause; without friction the cause is unchanged."""
    from linsense.verify.certificate import REMEDY, Check, _for_friction

    def made():
        return [Check("holds", False, "v", "b", REMEDY["limit cycle"], 1, 1),
                Check("moves", False, "v", "b", REMEDY["trajectory"], 1, 1)]

    cks = _for_friction(made(), {"controller": {"friction_coulomb": 15.0}})
    assert cks[0].cause.startswith("the motor's Coulomb friction, 15 N")
    assert REMEDY["limit cycle"] in cks[0].cause
    assert cks[1].cause == REMEDY["trajectory"]
    assert [c.cause for c in _for_friction(made(), {"controller": {}})] == [c.cause for c in made()]

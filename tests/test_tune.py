"""linsense tune: the design rules, one source with the C defaults, a second motor tuned and run
on the switching inverter, and the scenario and C outputs."""

from __future__ import annotations

import subprocess
import tomllib
from pathlib import Path

import pytest

import linsense
from linsense.cli import main
from linsense.ctrl import drive_default_cfg
from linsense.scenario.load import load_scenario, scenario_from_dict
from linsense.sim.build import build
from linsense.tune import DriveData, design

ROOT = Path(__file__).parents[1]
SMALL = ROOT / "src/linsense/examples" / "motors" / "small30.toml"
#: a 40 mm, L_q / L_d 1.46 motor of a helper's (negative end effect), driven at 150 V in the tests
H40 = ('[motor]\nname = "h40"\nR_s = 3.5\npole_pitch = 0.04\nforce_constant = 12.0\nmass = 1.0\n'
       '[inductance]\nL0 = 4.5e-3\nL2 = -7.9e-4\nM0 = -1.5e-3\nM2 = -7.9e-4\ndM0 = -4.5e-4\n')


def test_scenario_without_gains_gets_the_design_for_its_motor():
    sc = scenario_from_dict(
        {"motor": str(SMALL), "scenario": {"duration": 0.1}, "reference": {"type": "hold"}}
    )
    b = build(sc)
    dz = design(b.motor, DriveData(), analyse=False)
    assert float(b.drive.cfg.inject.amplitude) == pytest.approx(dz.v_inj, rel=1e-6)
    c_default = drive_default_cfg()  # (kept: c_default.current does not own it)
    assert dz.current_kp != pytest.approx(c_default.current.kp, rel=0.05)  # not ecce2010's
    assert float(b.drive.cfg.current.kp) == pytest.approx(dz.current_kp, rel=1e-5)
    assert float(b.drive.cfg.pos.speed.kp) == pytest.approx(dz.speed_kp, rel=1e-5)
    # what the file gives is kept, also across replace()
    sc2 = scenario_from_dict(
        {
            "motor": str(SMALL),
            "scenario": {"duration": 0.1},
            "reference": {"type": "hold"},
            "injection": {"amplitude": 8.0},
        }
    ).replace(inverter={"fidelity": "switching"})
    assert float(build(sc2).drive.cfg.inject.amplitude) == 8.0


@pytest.mark.parametrize("x_mm", [0.0, 7.5, 15.0, 22.5])
def test_tuned_second_motor_switching(tmp_path, x_mm):
    """A motor with another pole pitch, resistance and inductances (30 mm, 2 ohm, 1.5 mH), tuned
    by `linsense tune` and nothing else: a 3 mm step settles, on the switching inverter with dead
    time, within 1 deg and without limit cycle (measured: bias <= 0.14 deg, 0.0004 mm)."""
    out = tmp_path / "small30_tuned.toml"
    with pytest.raises(SystemExit) as e:
        main(["tune", "--no-verify", "--motor", str(SMALL), "--out", str(out)])
    assert e.value.code == 0
    sc = load_scenario(out).replace(
        inverter={"fidelity": "switching"},
        initial={"position_mm": x_mm},
        reference={"type": "step", "position_mm": x_mm + 3.0, "at": 0.2},
        scenario={"duration": 3.0},
    )
    m = linsense.simulate(sc).metrics
    assert m["stable"], m["unstable_reason"]
    assert abs(m["bias_deg"]) <= 1.0 and m["limit_cycle_mm"] <= 0.02 and m["settling_time_s"] is not None


def test_tune_outputs(tmp_path, capsys):
    out = tmp_path / "t.toml"
    base = tmp_path / "base.toml"
    base.write_text(
        'motor = "ecce2010"\n[scenario]\nname = "mine"\nduration = 1.5\n[inverter]\nv_dc = 96.0\n'
        '[reference]\ntype = "step"\nposition_mm = 3.0\n[observer]\nbandwidth_hz = 12.0\n'
    )
    with pytest.raises(SystemExit) as e:
        main(["tune", "--no-verify", "--motor", "ecce2010", "--scenario", str(base), "--out", str(out)])
    assert e.value.code == 0
    printed = capsys.readouterr().out
    assert "observer loop (scheduled, k_e = 1.00)" in printed and "margins" in printed
    data = tomllib.loads(out.read_text())
    assert data["scenario"]["name"] == "mine" and data["reference"]["position_mm"] == 3.0
    assert data["inverter"]["v_dc"] == 96.0 and data["injection"]["amplitude"] == pytest.approx(16.0)
    # designed, the base's 12 Hz replaced: the mechanical observer at f_lpf / 20
    assert data["observer"]["bandwidth_hz"] == 15.0 and data["observer"]["type"] == "mech"
    assert linsense.simulate(out).metrics["fault"] == "none"
    # the C set-up compiles under the library's strict warnings, with the library
    hdr = tmp_path / "ls_cfg_small30.h"
    with pytest.raises(SystemExit) as e:
        main(["tune", "--quick", "--motor", str(SMALL), "--format", "c", "--out", str(hdr)])
    assert e.value.code == 0
    src = tmp_path / "use.c"
    src.write_text(
        '#include "ls_cfg_small30.h"\nint main(void)\n{\n    static ls_drive d;\n    ls_drive_cfg cfg;\n'
        "    ls_lut c, g, r, h;\n    ls_lut_cfg cc = {ls_cfg_small30_comp, SMALL30_LEN};\n"
        "    ls_lut_cfg gc = {ls_cfg_small30_gain, SMALL30_LEN};\n"
        "    ls_lut_cfg rc = {ls_cfg_small30_comp_r, SMALL30_LEN};\n"
        "    ls_lut_cfg hc = {ls_cfg_small30_gain_r, SMALL30_LEN};\n"
        "    if (ls_lut_init(&c, &cc) != LS_OK || ls_lut_init(&g, &gc) != LS_OK\n"
        "        || ls_lut_init(&r, &rc) != LS_OK || ls_lut_init(&h, &hc) != LS_OK) return 2;\n"
        "    ls_cfg_small30(&cfg, &c, &g, &r, &h);\n    return ls_drive_init(&d, &cfg) == LS_OK ? 0 : 1;\n}\n"
    )
    exe = tmp_path / "use"
    ctrl_src = sorted(str(p) for p in (ROOT / "csrc" / "ctrl").glob("*.c"))
    cc = subprocess.run(
        [
            "cc",
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Wpedantic",
            "-Werror",
            "-Wdouble-promotion",
            "-Wconversion",
            "-Wshadow",
            "-O1",
            f"-I{ROOT / 'csrc' / 'include'}",
            f"-I{tmp_path}",
            str(src),
            *ctrl_src,
            "-lm",
            "-o",
            str(exe),
        ],
        capture_output=True,
        text=True,
    )
    assert cc.returncode == 0, cc.stderr
    assert subprocess.run([str(exe)]).returncode == 0  # ls_drive_init accepts the design


def test_tune_refuses_an_impossible_drive(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(
            [
                "tune",
                "--motor",
                "ecce2010",
                "--v-dc",
                "30",
                "--v-inj",
                "12",
                "--out",
                str(tmp_path / "x.toml"),
            ]
        )
    err = capsys.readouterr().err.strip()
    assert e.value.code == 2 and err.count("\n") == 0 and "v_inj" in err and "30 V bus" in err
    assert not (tmp_path / "x.toml").exists()


def test_a_mass_typed_in_grams_is_named(run_cli, tmp_path):
    """The force the application needs names the motor's mass beside m a_max, and asks about grams
    from 100 kg: a 350 g mover typed as 350 was refused on the default i_max alone (116.7 A needed),
    a value the user never gave, with nothing pointing at the mass."""
    from importlib.resources import files

    text = (files("linsense.model") / "presets" / "ecce2010.toml").read_text()
    path = tmp_path / "m.toml"
    path.write_text(text.replace("mass = 1.5 ", "mass = 350 "))
    r = run_cli("tune", "--motor", path, "--out", tmp_path / "x.toml", "--no-verify")
    assert r.code == 2 and "the motor's mass 350 kg (did you type g?" in r.err, r.err
    r = run_cli("tune", "--motor", "ecce2010", "--a-max", "1000", "--out", tmp_path / "x.toml", "--no-verify")
    assert r.code == 2 and "a_max" in r.err and "the motor's mass 1.5 kg)" in r.err, r.err


def test_a_scenario_of_another_motor_is_said(run_cli, tmp_path):
    """tune --motor A --scenario S, S written for motor B: B's drive data are designed for A, and
    tune says so (it did without a word); S's own motor gives no such line."""
    path = tmp_path / "s.toml"
    path.write_text('motor = "ecce2010"\n[scenario]\nduration = 0.1\n[reference]\ntype = "hold"\n'
                    "[inverter]\nv_dc = 96.0\n")
    r = run_cli("tune", "--motor", "small30", "--scenario", path, "--out", tmp_path / "a.toml", "--no-verify")
    assert r.code == 0 and "was written for the motor 'ecce2010'" in r.err and "'small30' (--motor)" in r.err
    r = run_cli("tune", "--motor", "ecce2010", "--scenario", path, "--out", tmp_path / "b.toml",
                "--no-verify")
    assert r.code == 0 and "was written for the motor" not in r.err, r.err


def test_review_regressions(tmp_path, capsys):
    """Cases a review found: a sensored scenario without injection still builds; an injection at
    f_pwm / 4 (no room for the demodulator's zeros at 2 f_inj) still runs; an injection the drive
    would refuse (above 0.8 of the under-voltage limit) is refused by tune; derived bus limits do not
    stick to a scenario through replace()."""
    sc = scenario_from_dict(
        {
            "motor": "ecce2010",
            "scenario": {"duration": 0.05},
            "reference": {"type": "hold"},
            "control": {"mode": "sensored"},
            "injection": {"amplitude": 0.0},
        }
    )
    assert float(build(sc).drive.cfg.inject.amplitude) == 0.0
    out = tmp_path / "f4.toml"
    with pytest.raises(SystemExit) as e:
        main(["tune", "--no-verify", "--motor", "ecce2010", "--f-inj", "4000", "--out", str(out)])
    assert e.value.code == 0
    b = build(load_scenario(out))
    assert float(b.drive.cfg.demod.f_notch) == 0.0
    with pytest.raises(SystemExit) as e:
        main(
            [
                "tune",
                "--motor",
                "ecce2010",
                "--v-inj",
                "20",
                "--i-max",
                "1.5",
                "--out",
                str(tmp_path / "x.toml"),
            ]
        )
    err = capsys.readouterr().err
    assert e.value.code == 2 and "v_inj" in err and "under-voltage limit" in err
    sc = scenario_from_dict(
        {
            "motor": "ecce2010",
            "scenario": {"duration": 0.05},
            "reference": {"type": "hold"},
            "protection": {"i_max": 5.0},
        }
    )
    assert "v_dc_min" not in sc.given().get("protection", {})
    assert sc.replace(inverter={"v_dc": 30.0}).spec.protection.v_dc_min == pytest.approx(30.0 * 5 / 9)


def test_sensored_observer_beside_the_encoder():
    """In sensored mode the injection (on by default) feeds the HF estimate beside the encoder (the
    encoder's position plus the error demodulated there, with the table): its estimation metrics
    are the sensorless estimate's, not the frozen start position."""
    r = linsense.simulate(
        {
            "motor": "ecce2010",
            "scenario": {"duration": 2.0},
            "control": {"mode": "sensored"},
            "reference": {"type": "step", "position_mm": 3.0},
        }
    )
    m = r.metrics
    # (the transient error of the 3 mm step, a move at the designed step acceleration: 3.52 deg with
    # the default 8 Hz speed loop, 3.23 deg as a jump; the frozen start position would be 19 deg off)
    assert m["stable"] and abs(m["bias_deg"]) < 1.0 and m["max_abs_err_deg"] < 4.5


def test_a_step_runs_as_the_designed_move():
    """A scenario that names only the motor gets the design's step (docs/tuning.md, "Steps"): a
    minimum-time move at the speed cap and the step acceleration, its acceleration feed-forward
    low-passed at the demodulator's bandwidth; ``controller.step_a_max = 0`` keeps the jump."""
    from linsense.model.motor import load_motor
    from linsense.tune.design import STEP_ACCEL_DIV, STEP_FORCE_SHARE

    motor = load_motor("ecce2010")
    dz = design(motor, DriveData(), analyse=False)
    assert dz.a_step == pytest.approx(min(dz.v_cap * 2 * 3.141592653589793 * dz.speed_bw / STEP_ACCEL_DIV,
                                          STEP_FORCE_SHARE * motor.force_constant * 2.5 / motor.mass))
    base = {"motor": "ecce2010", "scenario": {"duration": 0.3}, "control": {"mode": "sensored"},
            "reference": {"type": "step", "position_mm": 3.0, "at": 0.05}, "record": {"decimate": 1}}
    b = build(scenario_from_dict(base))
    assert b.cfg is not None
    d = b.drive.state.cfg
    assert d.traj.a_step == pytest.approx(dz.a_step, rel=1e-6) and d.traj.v_step == pytest.approx(dz.v_cap)
    assert d.traj.a_lpf == pytest.approx(dz.demod_lpf)
    moved = linsense.simulate(base)
    jumped = linsense.simulate({**base, "controller": {"step_a_max": 0.0}})
    t, x_move, x_jump = moved.t, moved.x_ref, jumped.x_ref
    after = (t > 0.05) & (t < 0.06)
    assert x_jump[after] == pytest.approx(3.0e-3)  # the reference jumps
    assert (x_move[after] < 0.5e-3).all()  # the move starts from rest: 0.2 mm in its first 10 ms
    t_move = 2.0 * (3.0e-3 / dz.a_step) ** 0.5  # (triangular: 3 mm is short of v_cap^2 / a_step)
    done = t > 0.05 + t_move + 2e-3
    assert x_move[done] == pytest.approx(3.0e-3, abs=1e-9) and (x_move[~done] < 3.0e-3).all()


def test_the_designed_observer_is_the_mechanical_one_with_its_load_fed_forward():
    """The design's observer for the pulsating and elliptical injections (docs/tuning.md, "The
    observer"): mechanical, at f_lpf / 20, its load estimate fed forward; the PLL keeps the paper's
    rule; a load feed-forward without the mechanical observer is refused, naming the key."""
    from linsense.errors import InputError
    from linsense.model.motor import load_motor
    from linsense.tune.design import RATIO_LPF_MECH, RATIO_LPF_OBS, startup_lock_gain

    motor = load_motor("ecce2010")
    dz = design(motor, DriveData(), analyse=False)
    assert dz.observer_type == "mech" and dz.load_ff
    assert dz.observer_bw == pytest.approx(dz.demod_lpf / RATIO_LPF_MECH)
    sq = design(motor, DriveData(shape="square"), analyse=False)
    assert sq.observer_type == "pll" and not sq.load_ff
    assert sq.observer_bw == pytest.approx(sq.demod_lpf / RATIO_LPF_OBS)
    # the start-up's lock as the PLL's: k1 of the mechanical observer times the gain = the PLL's k1
    g = startup_lock_gain("mech", dz.observer_bw, dz.demod_lpf)
    assert 3 * dz.observer_bw * g == pytest.approx(2 * dz.observer_bw_pll)
    assert startup_lock_gain("pll", 40, 300) == 1
    hold = {"motor": "ecce2010", "scenario": {"duration": 0.1}, "reference": {"type": "hold"}}
    b = build(scenario_from_dict(hold))
    d = b.drive.state.cfg
    assert d.obs.type == 1 and d.load_ff and d.startup.lock_gain == pytest.approx(g)
    assert d.obs.force_max == pytest.approx(dz.force_max)
    b = build(scenario_from_dict({**hold, "observer": {"type": "pll"}}))
    d = b.drive.state.cfg
    assert d.obs.type == 0 and not d.load_ff and d.startup.lock_gain == 1.0
    # the PLL's 40 Hz
    assert d.obs.k1 == pytest.approx(2 * 2 * 3.141592653589793 * dz.observer_bw_pll, rel=1e-5)
    with pytest.raises(InputError) as e:
        build(scenario_from_dict({**hold, "observer": {"type": "pll", "load_feedforward": True}}))
    assert "observer.load_feedforward" in str(e.value) and "mech" in str(e.value)


def test_a_v_max_beyond_the_pwm_rate_is_named(run_cli, tmp_path):
    """A 40 mm, 150 V motor at 6.4 m/s on 8 kHz PWM with the EMF estimate: the observer's clamp
    (2.5 v_max) turns the angle by more than the controller library's 0.25 rad per period; tune named
    the designed observer.omega_max and ls_drive_init's emf.omega_max. Now --v-max, its largest value
    and the PWM rate that would take it; no unit slip is suggested for a plausible value (it said "did
    you type mm/s? (6.4 mm/s is 0.0064 m/s)"). The rotating vector (no EMF step) is not held to it."""
    motor = tmp_path / "h40.toml"
    motor.write_text(H40)
    drive = ("--v-dc", "150", "--f-pwm", "8000", "--dead-time", "1e-6", "--i-max", "3", "--a-max", "10",
             "--no-verify")
    r = run_cli("tune", "--motor", str(motor), *drive, "--v-max", "6.4", "--out", str(tmp_path / "a.toml"))
    assert r.code == 2 and "v_max: 6.4 m/s is beyond" in r.err and "at most 5.092 m/s" in r.err, r.err
    assert "did you type" not in r.err and "omega_max" not in r.err
    r = run_cli("tune", "--motor", str(motor), *drive, "--v-max", "5", "--out", str(tmp_path / "b.toml"))
    assert r.code == 0, r.err
    r = run_cli("tune", "--motor", str(motor), *drive, "--v-max", "6.4", "--injection", "rotating",
                "--out", str(tmp_path / "c.toml"))
    assert r.code == 0, r.err


def test_no_speed_cap_warning_where_the_injection_fades_out_first():
    """The same motor at 12 kHz: the speed cap (8 m/s) is beyond the 5.82 m/s the bus drives beside
    the injection, but the injection fades out at 4.33 m/s: the warning was wrong there."""
    from linsense.model.motor import motor_from_toml
    from linsense.tune.drive_design import design_drive

    m = motor_from_toml(H40, "h40.toml")
    dd = DriveData(v_dc=150.0, f_pwm=12000.0, dead_time=1e-6, i_max=3.0, v_max=6.4, a_max=10.0)
    made = design_drive(m, dd, analyse=False, startup=False)
    assert made.handover.on and made.handover.v_off < made.design.headroom_speed < made.design.v_cap
    assert any(w.startswith("the speed cap ") for w in made.design.warnings)
    assert not any(w.startswith("the speed cap ") for w in made.warnings), made.warnings


@pytest.mark.parametrize("args, text", [
    (("--no-verify", "--quick"), "--quick shapes the certificate, which --no-verify does not run"),
    (("--no-verify", "--table-route", "commission"), "--table-route shapes the certificate"),
    (("--no-verify", "--table-route", "calibrate"), "--table-route shapes the certificate"),
    (("--no-verify", "--load", "0"), "must be a finite number > 0, got 0.0"),
    (("--no-verify", "--unverified", "--format", "c"), "--format c writes a C header, not a .toml file"),
])
def test_tune_options_that_would_do_nothing_are_refused(run_cli, tmp_path, args, text):
    """--quick and --table-route with --no-verify wrote the same bytes as without them; --load 0 passed
    the option's '>= 0' and was refused by the design as 'a force > 0 N'; --format c wrote a C header
    into t.toml."""
    r = run_cli("tune", "--motor", "ecce2010", *args, "--out", str(tmp_path / "t.toml"))
    assert r.code == 2 and text in r.err and len(r.err.strip().splitlines()) == 1, r.err
    assert not (tmp_path / "t.toml").exists()


def test_a_scenarios_emf_off_is_kept(run_cli, tmp_path):
    """tune --scenario over a scenario with observer.emf = false: it came out with emf = true and the
    designed band (a key the file gives, replaced without a word); now kept, and the print says so."""
    r = run_cli("tune", "--motor", "ecce2010", "--v-max", "1.0", "--no-verify", "--out",
                str(tmp_path / "a.toml"))
    assert r.code == 0, r.err
    text = (tmp_path / "a.toml").read_text()
    assert "emf = true" in text and "handover_v_lo" in text
    lines = [ln for ln in text.splitlines() if not ln.startswith(("emf_lpf_hz", "handover_", "inject_v_"))]
    (tmp_path / "b.toml").write_text("\n".join(lines).replace("emf = true", "emf = false") + "\n")
    r = run_cli("tune", "--motor", "ecce2010", "--scenario", str(tmp_path / "b.toml"), "--v-max", "1.0",
                "--no-verify", "--out", str(tmp_path / "c.toml"))
    assert r.code == 0, r.err
    out = (tmp_path / "c.toml").read_text()
    assert "emf = false" in out and "handover_v_lo" not in out
    assert "observer.emf = false in the scenario" in r.out

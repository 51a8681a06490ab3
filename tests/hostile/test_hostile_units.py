"""Slips of unit outside the motor file: mm for m,
degrees for radians, kHz for Hz, rad/s for Hz, percent for a fraction, mH for H, mA for A, in the
scenario and sweep files, the command's options, the bench and table files and the Python API.

Before: accepted, a meaningless run or design with exit 0 (``protection.err_max = 30`` rad, a trip
that never fires; a bench in mA identified as a 2.75 uH motor; ``lut --f-inj 1``; ``bench-emulate
--noise 1``, 100 % noise; ``--travel 200000`` mm), or a run stopped on a fault that names another
cause (``controller.model.L_d = 10`` H: "overspeed"), or a refusal that does not suggest the slip
(``--dead-time 0.8``, ``--f-pwm 16``, ``--quad 90``, ``--pole-pitch 0.056``).

The rule: one table of plausible values per kind of quantity, :data:`linsense.plausible.KINDS`
(the motor file's rows among them), applied to every input of that kind: a value outside its range is
refused naming the key, the value, the range and the slip of unit that brings it in
(:func:`linsense.plausible.check`); a value a rule of its own refuses gets the slip that makes the
rule hold (:func:`linsense.plausible.slip`).
"""

from __future__ import annotations

import csv
import math

import pytest
from tests.conftest import scenario_with

BASE = """motor = "ecce2010"

[scenario]
name = "u"
duration = 0.3
seed = 1

[reference]
type = "step"
position_mm = 3.0
at = 0.05
"""

TRAJ = BASE.replace('type = "step"\nposition_mm = 3.0\nat = 0.05',
                    'type = "trajectory"\nwaypoints_mm = [30.0]\nv_max = 0.2\na_max = 2.0\nat = 0.05')


def simulate(tmp_path, text: str) -> list[str]:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return ["simulate", str(p), "--out", str(tmp_path / "o"), "--trace", "none"]


def tune(*args: str) -> list[str]:
    return ["tune", "--motor", "small30", "--no-verify", *args, "--out", "t.toml"]


# name: (scenario keys added to BASE, or a whole text; words of the one-line refusal)
SCENARIO = {
    # before: accepted, the run stopped on "fault overspeed" (what the controller believes, in mH)
    "model L in mH": ("[controller.model]\nL_d = 10.0\nL_q = 12.0\n[observer]\ngain_schedule = false",
                      ["controller.model.L_d", "10 H", "real linear motors", "did you type mH?"]),
    "model R_s in milliohm": ("[controller.model]\nR_s = 9000.0",
                              ["controller.model.R_s", "9000 ohm", "Did you type milliohm?"]),
    "model mass in g": ("[controller.model]\nmass = 1500.0", ["controller.model.mass", "did you type g?"]),
    # before: accepted, "stable": the observer-loss trip can never fire beyond pi
    "err_max in degrees": ("[protection]\nerr_max = 30.0",
                           ["protection.err_max", "30 rad", "3.14159", "did you type deg?"]),
    # before: accepted, "stable" at a 200 m/s speed cap
    "v_max in mm/s": ("[controller]\nv_max = 200.0", ["controller.v_max", "200 m/s", "did you type mm/s?"]),
    # before: accepted, "fault observer" (a 12-bit ADC over +-10 kA quantises the HF current away)
    "ADC range in mA": ("[sensors]\nadc_bits = 12\nadc_range = 10000.0",
                        ["sensors.adc_range", "10000 A", "did you type mA?"]),
    # before: refused, without the slip
    "dead time in us": ("[inverter]\ndead_time = 0.8", ["inverter.dead_time", "did you type us?"]),
    "dead time in ns": ("[inverter]\ndead_time = 800.0", ["inverter.dead_time", "did you type ns?"]),
    "PWM rate in kHz": ("[inverter]\nf_pwm = 16.0", ["inverter.f_pwm", "did you type kHz?"]),
    "injection in kHz": ("[injection]\nfrequency = 1.0", ["injection.frequency", "did you type kHz?"]),
    "kappa in percent": ("[injection]\nquadrature = 90.0",
                         ["injection.quadrature", "did you type %? (90 % is 0.9)"]),
    "current limit in mA": ("[controller]\ni_max = 2500.0", ["controller.i_max", "did you type mA?"]),
    "bus in kV": ("[inverter]\nv_dc = 0.072", ["inverter.v_dc", "did you type kV?"]),
    # before: a limit cycle or an "overspeed" fault, the cause unnamed
    "low-pass in rad/s": ("[observer]\ndemod_lpf_hz = 6283.0",
                          ["observer.demod_lpf_hz", "injection frequency", "did you type rad/s?"]),
    "observer bandwidth above its low-pass": ("[observer]\nbandwidth_hz = 600.0",
                                              ["observer.bandwidth_hz", "observer.demod_lpf_hz"]),
    "current loop in rad/s": ("[controller]\ncurrent_bandwidth_hz = 6283.0",
                              ["controller.current_bandwidth_hz", "f_pwm / 10", "did you type rad/s?"]),
    # before: accepted, "stable" with a band of 50 A (bias 0.85 deg), an HF delay of 50 ms ("overspeed")
    "compensation band in mA": ("[inverter]\ndtc_current_band = 50.0",
                                ["inverter.dtc_current_band", "controller.i_max", "did you type mA?"]),
    "HF delay in ms": ("[observer]\nhf_delay_s = 0.05", ["observer.hf_delay_s", "did you type ms?"]),
    "HF delay in ms, beyond its bound": ("[observer]\nhf_delay_s = 1.0",
                                         ["observer.hf_delay_s", "did you type ms? (1 ms is 0.001 s)"]),
    # before: "fault travel" at 0.06 s (a stroke of 0.2 mm)
    "travel in m": ("[travel]\nmin_mm = -0.1\nmax_mm = 0.1",
                    ["travel.max_mm", "0.2 mm is outside", "did you type m? (0.2 m is 200 mm)"]),
    # before: "saturation.polarity: ... beyond what a magnet current of 16000 A can give"
    "magnet current in mA": ("[saturation]\nenabled = true\nmagnet_current = 16000.0",
                             ["saturation.magnet_current", "did you type mA?"]),
    # before: accepted, a calibration whose 100 A dither the current limit clamps
    "calibration dither in mA": ('[control]\nmode = "calibration"\n[calibration]\ndither_a = 100.0',
                                 ["calibration.dither_a", "did you type mA?"]),
    # before: accepted, 20 kV pulses on a 72 V bus
    "start-up pulse in mV": ('[control]\nmode = "startup"\n[saturation]\nenabled = true\n[startup]\n'
                             "v_pulse = 20000.0", ["startup.v_pulse", "did you type mV?"]),
    "start-up lock in ms": ('[control]\nmode = "startup"\n[saturation]\nenabled = true\n[startup]\n'
                            "t_lock = 200.0", ["startup.t_lock", "did you type ms? (200 ms is 0.2 s)"]),
}

TRAJ_CASES = {
    # before: the estimate clamped at 5 rad/s (0.045 m/s): "not stable", |x - target| 21.6 mm
    "observer clamp in Hz": ("[observer]\nomega_max = 5.0",
                             ["observer.omega_max", "controller.v_max", "did you type Hz?"]),
    # before: "fault overspeed" at 0.12 s on a move at 0.2 m/s
    "over-speed trip in Hz": ("[protection]\nomega_max = 16.0",
                              ["protection.omega_max", "controller.v_max", "did you type Hz?"]),
}


@pytest.mark.parametrize("name", list(SCENARIO))
def test_a_scenario_value_in_another_unit_is_refused_with_the_slip(run_cli, tmp_path, name):
    keys, words = SCENARIO[name]
    run_cli(*simulate(tmp_path, scenario_with(BASE, keys))).refused(*words)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name", list(TRAJ_CASES))
def test_a_trajectory_value_in_another_unit_is_refused_with_the_slip(run_cli, tmp_path, name):
    keys, words = TRAJ_CASES[name]
    run_cli(*simulate(tmp_path, scenario_with(TRAJ, keys))).refused(*words)


def test_a_trajectory_speed_in_mm_s_is_refused_with_the_slip(run_cli, tmp_path):
    run_cli(*simulate(tmp_path, TRAJ.replace("v_max = 0.2", "v_max = 200.0"))).refused(
        "reference.v_max", "did you type mm/s? (200 mm/s is 0.2 m/s)")


def test_plausible_values_of_every_kind_still_run(run_cli, tmp_path):
    """The same keys at plausible values (the slips' readings) run."""
    keys = ("[controller.model]\nL_d = 0.003\n[protection]\nerr_max = 0.52\n[controller]\nv_max = 0.2\n"
            "[sensors]\nadc_bits = 12\nadc_range = 10.0\n[observer]\ndemod_lpf_hz = 250.0\nomega_max = 60.0")
    res = run_cli(*simulate(tmp_path, scenario_with(BASE, keys)))
    assert res.code == 0, res.err


# name: (arguments, words of the one-line refusal)
OPTIONS = {
    "tune --dead-time 0.8": (tune("--dead-time", "0.8"), ["dead_time", "did you type us?"]),
    "tune --dead-time 800": (tune("--dead-time", "800"), ["dead_time", "did you type ns?"]),
    "tune --f-pwm 16": (tune("--f-pwm", "16"), ["f_pwm", "did you type kHz?"]),
    "tune --f-inj 1": (tune("--f-inj", "1"), ["f_inj", "did you type kHz?"]),
    "tune --quad 90": (tune("--quad", "90"), ["--quad", "did you type %?"]),
    "tune --v-max 200": (tune("--v-max", "200"), ["v_max", "did you type mm/s?"]),
    "tune --i-max 2500": (tune("--i-max", "2500"), ["i_max", "did you type mA?"]),
    "tune --travel 0.2": (tune("--travel", "0.2"), ["travel", "did you type m? (0.2 m is 200 mm)"]),
    # before: accepted, a 200 m stroke (exit 0)
    "tune --travel 200000": (tune("--travel", "200000"), ["travel", "200000 mm", "did you type um?"]),
    # before: accepted, a table for an injection at 1 Hz (exit 0)
    "lut --f-inj 1": (["lut", "--motor", "ecce2010", "--f-inj", "1", "--out", "l.csv"],
                      ["--f-inj", "125 Hz", "did you type kHz?"]),
    # before: accepted, 100 % noise on every phasor (exit 0)
    "bench-emulate --noise 1": (["bench-emulate", "--motor", "ecce2010", "--noise", "1", "--out", "b.csv"],
                                ["noise", "did you type %? (1 % is 0.01)"]),
    # before: "need at least 8 distinct electrical positions, got 7"
    "identify --pole-pitch 0.056": (["identify", "BENCH", "--motor", "ecce2010", "--pole-pitch", "0.056",
                                     "--out", "id"], ["--pole-pitch", "0.056 mm", "did you type m?"]),
    # before: "positions do not cover one electrical period: gap of 359.6 deg"
    "identify --pole-pitch 56000": (["identify", "BENCH", "--motor", "ecce2010", "--pole-pitch", "56000",
                                     "--out", "id"], ["--pole-pitch", "did you type um?"]),
}


@pytest.mark.parametrize("name", list(OPTIONS))
def test_an_option_in_another_unit_is_refused_with_the_slip(run_cli, tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    args, words = OPTIONS[name]
    args = [a if a != "BENCH" else "ecce2010_56_1pct_seed1" for a in args]
    run_cli(*args).refused(*words)


# ------------------------------------------------------------------ bench and table files
def _bench(tmp_path, name: str, edit) -> str:
    from linsense import examples

    rows = list(csv.reader(examples.path("bench", "ecce2010_56_1pct_seed1").open()))
    out = tmp_path / name
    with out.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(rows[0])
        for r in rows[1:]:
            w.writerow(edit(list(r)))
    return str(out)


def _scale(cols, k):
    def edit(r):
        for c in cols:
            r[c] = repr(float(r[c]) * k)
        return r
    return edit


BENCH = {
    # before: exit 0, motor.toml with L0 = 2.75 uH and R_s = 9 milliohm (a motor 1000 times off)
    "current in mA": (_scale((3, 4), 1000.0), ["column I_re, I_im", "A and V peak", "did you type mA?"]),
    "voltages in mV": (_scale(tuple(range(5, 11)), 1000.0), ["VA_re", "did you type mV?"]),
    # before: exit 0, motor.toml with L0 = 2.75 H (a file linsense then refuses to load)
    "frequency in kHz": (_scale((2,), 1e-3), ["bench", "L0", "kHz"]),
    # before: "positions do not cover one electrical period" (0.055 of a 56 mm pitch)
    "positions in m": (_scale((0,), 1e-3), ["position_mm", "did you type m?"]),
    # before: "need at least 8 distinct electrical positions, got 7"
    "positions in um": (_scale((0,), 1e3), ["position_mm", "did you type um?"]),
}


@pytest.mark.parametrize("name", list(BENCH))
def test_a_bench_file_in_other_units_is_refused_naming_them(run_cli, tmp_path, name):
    edit, words = BENCH[name]
    bench = _bench(tmp_path, "b.csv", edit)
    run_cli("identify", bench, "--motor", "ecce2010", "--out", str(tmp_path / "id")).refused(*words)
    assert not (tmp_path / "id").exists()


def test_a_bench_file_in_ma_within_the_current_range_is_a_warning(run_cli, tmp_path):
    """Currents in mA of 0.5 A (400 to 600 "A", within the range of currents): the fitted motor,
    500 times below --motor ecce2010 in L and R_s, was written without a word; now a warning names
    the fitted values, the motor's and the slip."""
    bench = _bench(tmp_path, "b.csv", _scale((3, 4), 500.0))
    res = run_cli("identify", bench, "--motor", "ecce2010", "--out", str(tmp_path / "id"))
    assert res.code == 0, res.err
    warning = next(line for line in res.err.splitlines() if "warning" in line and "L0" in line)
    assert "ecce2010" in warning and "mA" in warning, warning


def test_an_inductance_table_in_radians_says_so(run_cli, tmp_path):
    """Before: "positions do not cover one electrical period: gap of 353.8 deg after 6.2 deg"."""
    from importlib import resources

    rows = list(csv.reader((resources.files("linsense.examples") / "motors" / "ecce2010_table.csv").open()))
    with (tmp_path / "t.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(rows[0][:7])
        for r in rows[1:]:
            w.writerow([repr(math.radians(float(r[0])))] + r[1:7])
    (tmp_path / "m.toml").write_text('[motor]\nname = "t"\nR_s = 9.0\npole_pitch = 0.056\n'
                                     'force_constant = 20.0\nmass = 1.5\n[inductance]\ntable = "t.csv"\n')
    run_cli("model", "--motor", str(tmp_path / "m.toml"), "--out", str(tmp_path / "o.csv")).refused(
        "theta_deg", "did you type rad?")


def test_an_fea_geometry_in_mm_names_the_pole_pitch(run_cli, tmp_path):
    """A geometry file's pole pitch in mm: before, "armature: outer radius 0.0255 m or pole pitch
    beyond 10 m: check the units (m)", naming [armature]."""
    from importlib import resources

    text = (resources.files("linsense.examples") / "fea" / "fig4_three_coils.toml").read_text()
    (tmp_path / "g.toml").write_text(text.replace("pole_pitch = 0.056", "pole_pitch = 56.0"))
    run_cli("fea", str(tmp_path / "g.toml"), "--out", str(tmp_path / "o")).refused(
        "motor.pole_pitch", "56 m", "did you type mm?")


def test_fea_load_currents_in_ma_are_refused():
    """``fea --load-current 0,2000`` (mA typed): before, an FEA at 2 kA (|I| <= 1e6 A accepted)."""
    from linsense.errors import InputError
    from linsense.fea.per_load import parse_currents

    with pytest.raises(InputError, match=r"--load-current.*2000 A.*did you type mA\?"):
        parse_currents("0,2000")


# ------------------------------------------------------------------ sweeps
def test_relative_factors_in_percent_are_refused(run_cli, tmp_path):
    """``relative = true`` with values [80, 100]: before, exit 0, every run refused blaming the
    saliency (a factor of 80 on dM0)."""
    (tmp_path / "s.toml").write_text(BASE)
    (tmp_path / "w.toml").write_text('[sweep]\nname = "w"\nscenario = "s.toml"\n[[axis]]\n'
                                     'key = "lut_motor.inductance.dM0"\nrelative = true\n'
                                     'values = [80.0, 100.0]\n')
    run_cli("sweep", str(tmp_path / "w.toml"), "--out", str(tmp_path / "o")).refused(
        "axis", "80", "did you type %? (80 % is 0.8)")


def test_a_motor_axis_with_a_relative_out_runs(run_cli, tmp_path, monkeypatch):
    """A ``motor.*`` axis with a relative ``--out``: every run was refused, "no such motor file
    'scen/o/motors/motor-....toml'" (the edited motor's path, relative to the working folder, read
    relative to the scenario's)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scen").mkdir()
    (tmp_path / "scen" / "s.toml").write_text(BASE)
    (tmp_path / "w.toml").write_text('[sweep]\nname = "w"\nscenario = "scen/s.toml"\n[[axis]]\n'
                                     'key = "lut_motor.inductance.dM0"\nrelative = true\nvalues = [1.0]\n')
    res = run_cli("sweep", "w.toml", "--out", "o", "--workers", "1", "--no-progress")
    assert res.code == 0 and "1 runs:" in res.out and "0 refused" in res.out, res.out + res.err


# ------------------------------------------------------------------ the Python API
def test_the_api_holds_the_same_table():
    import linsense
    from linsense.compensation.lut import build_lut
    from linsense.errors import InputError
    from linsense.identify.bench import emulate_bench
    from linsense.identify.identification import identify
    from linsense.model.motor import load_motor

    m = load_motor("ecce2010")
    with pytest.raises(InputError, match=r"noise.*did you type %\?"):
        emulate_bench(m, noise=1.0)
    with pytest.raises(InputError, match=r"f_inj.*did you type kHz\?"):
        build_lut(m, 64, f_inj=1.0)
    from linsense import examples

    with pytest.raises(InputError, match=r"pole_pitch.*56 m.*did you type mm\?"):
        identify(examples.path("bench", "ecce2010_56_1pct_seed1"), base=m, pole_pitch=56.0)
    d = {"motor": "ecce2010", "scenario": {"duration": 0.3}, "reference": {"position_mm": 3.0, "at": 0.05},
         "controller": {"model": {"L_q": 12.0}}, "observer": {"gain_schedule": False}}
    with pytest.raises(InputError, match=r"controller.model.L_q.*did you type mH\?"):
        linsense.simulate(d)


def test_the_table_reads_each_slip_both_ways():
    from linsense.plausible import KINDS, implausible, slip

    assert slip("dead_time", 0.8) == "did you type us? (0.8 us is 8e-07 s)"
    assert slip("dead_time", 800.0).startswith("did you type ns?")
    assert slip("stroke", 0.2, "mm", ok=lambda v: v >= 30.0) == "did you type m? (0.2 m is 200 mm)"
    assert slip("share", 90.0, ok=lambda v: 0.0 <= v < 1.0) == "did you type %? (90 % is 0.9)"
    assert slip("dead_time", 1.0e30) == "" and slip("dead_time", float("nan")) == ""
    assert implausible("angle_error", 0.6) is None
    for kind in KINDS.values():
        assert kind.low <= kind.high and all(size > 0 for _, size in kind.slips)

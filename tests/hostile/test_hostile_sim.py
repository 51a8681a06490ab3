"""Hostile simulator inputs: scenario keys out of the range the controller library
accepts, keys another key makes meaningless, and Ctrl-C at start-up. Each case: the input, the exit
code and the words of its one line (the key the user wrote, the value, the limit)."""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

from conftest import scenario_with

# the console entry under a stalled import of numpy: Ctrl-C arrives while it imports, always
_STALLED_IMPORT = r'''
import sys, time

class Stall:
    def find_spec(self, name, path=None, target=None):
        if name == "numpy":
            print("importing numpy", flush=True)
            time.sleep(60)
        return None

sys.meta_path.insert(0, Stall())
from linsense.__main__ import entry
entry(["--version"])
'''


def test_ctrl_c_while_importing_is_one_line_and_130():
    p = subprocess.Popen([sys.executable, "-c", _STALLED_IMPORT], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "importing numpy"  # (the interrupt lands in the import)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
    finally:
        p.kill()
    assert p.returncode == 130, (p.returncode, err)
    assert err == "linsense: interrupted\n", err


def test_the_entry_is_light_and_is_the_script():
    """``import linsense`` imports no numpy (the entry imports it inside its handling), and the
    ``linsense`` script is that entry."""
    code = "import sys, linsense.__main__; print('numpy' in sys.modules, 'click' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout.split() == ["False", "False"], r
    import tomllib
    from pathlib import Path

    pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
    scripts = tomllib.loads(pyproject.read_text())["project"]["scripts"]
    assert scripts["linsense"] == "linsense.__main__:entry"
    r = subprocess.run([sys.executable, "-m", "linsense", "--version"], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0 and "linsense" in r.stdout, r


BASE = """motor = "ecce2010"

[scenario]
name = "s"
duration = 0.2

[reference]
type = "step"
position_mm = 3.0
at = 0.05
"""


# name: (keys added to the base, words the one line must contain: the key, the value, the limit)
RANGE = {
    # the controller library's limits, read from it (before: "injection: ... see the named sections")
    "filter_q huge": ("[injection]\nfilter_q = 1e30", ["injection.filter_q", "1e+30", "1000"]),
    "filter_q tiny": ("[injection]\nfilter_q = 1e-30", ["injection.filter_q", "1e-30", "0.001"]),
    "observer bandwidth": ("[observer]\nbandwidth_hz = 1e5",
                           ["observer.bandwidth_hz", "100000", "obs.k1", "16000"]),
    "observer k1": ("[observer]\nk1 = 1e30\nk2 = 1.0\nk3 = 1.0", ["observer.k1", "1e+30", "16000"]),
    "demodulator low-pass": ("[observer]\ndemod_lpf_hz = 9000.0", ["observer.demod_lpf_hz", "9000", "8000"]),
    "observer speed clamp": ("[observer]\nomega_max = 1e30", ["observer.omega_max", "1e+30", "50265.5"]),
    "observer force clamp": ("[observer]\nforce_max = 1e30", ["observer.force_max", "1e+30", "1.0752e+07"]),
    "current bandwidth": ("[controller]\ncurrent_bandwidth_hz = 1e30",
                          ["controller.current_bandwidth_hz", "1e+30", "current.kp", "1e+06"]),
    "speed bandwidth": ("[controller]\nspeed_bandwidth_hz = 1e30",
                        ["controller.speed_bandwidth_hz", "1e+30", "finite"]),
    "model psi_pm": ("[controller.model]\npsi_pm = 1e30", ["controller.model.psi_pm", "1e+30", "100"]),
    "model L_d tiny": ("[controller.model]\nL_d = 1e-30", ["controller.model.L_d", "1e-30", "0.000313333"]),
    # (the tables' motor, a Motor held to the motor file's limits)
    "model R_s": ("[controller.model]\nR_s = 1e30",
                  ["controller.model.R_s", "1e+30", "[0, 100] ohm"]),
    "model mass tiny": ("[controller.model]\nmass = 1e-30",
                        ["controller.model.mass", "1e-30", "6.97545e-06"]),
    "trip current": ("[protection]\ni_max = 1e30", ["protection.i_max", "1e+30", "100000"]),
    # (a trip delay beyond the run's end: the run's events are checked first)
    "trip time": ("[protection]\nerr_time = 1e30", ["protection.err_time", "1e+30", "would never act",
                                                     "scenario.duration = 0.2 s"]),
    "bus trip": ("[protection]\nv_dc_max = 1e30", ["protection.v_dc_max", "1e+30", "100000"]),
    "start-up pulse": ('[control]\nmode = "startup"\n[saturation]\nenabled = true\n'
                       '[startup]\nv_pulse = 1e30',
                       ["startup.v_pulse", "1e+30", "100000"]),
    "calibration dither": ('[control]\nmode = "calibration"\n[calibration]\ndither_hz = 1e30',
                           ["calibration.dither_hz", "1e+30", "4000"]),
    "calibration rate": ('[control]\nmode = "calibration"\n[calibration]\nk_int = 1e30',
                         ["calibration.k_int", "1e+30", "cal.t_hold"]),
    "calibration tolerance": ('[control]\nmode = "calibration"\n[calibration]\ntol_deg = 1e30',
                              ["calibration.tol_deg", "1e+30", "180"]),
    # the PWM rate (before: blamed inverter.dead_time or injection.frequency, keys not written)
    "PWM far too fast": ("[inverter]\nf_pwm = 1e7", ["inverter.f_pwm", "1e+07", "125000"]),
    "PWM beyond the library": ("[inverter]\nf_pwm = 2e6\ndead_time = 0.0",
                               ["inverter.f_pwm", "2e+06", "1e+06"]),
    "PWM too slow": ("[inverter]\nf_pwm = 100.0", ["inverter.f_pwm", "100", "[500, 1e+06] Hz"]),
    # the design's rules (before: "dead_time:", "a_max:", "load:", "inverter.v_dc" for i_max)
    "bus huge": ("[inverter]\nv_dc = 1e30", ["inverter.v_dc", "1e+30", "at most 338.3 V"]),
    "bus tiny": ("[inverter]\nv_dc = 1e-30", ["inverter.v_dc", "1e-30"]),
    "current limit huge": ("[controller]\ni_max = 1e30", ["controller.i_max", "1e+30", "R_s i_max"]),
    "trajectory speed huge": ("[reference]\nv_max = 1e30",
                              ["reference.v_max", "1e+30", "speeds of linear motors", "at most 2.221 m/s"]),
    "trajectory acceleration huge": ("[reference]\na_max = 1e30", ["reference.a_max", "1e+30", "K_f i_max"]),
    # the sensors (before: accepted, then "protection.i_max: the drive trips at t = 0")
    "sensor noise": ("[sensors]\ncurrent_noise = 1e30",
                     ["sensors.current_noise", "1e+30", "protection.i_max"]),
    "sensor offset": ("[sensors]\ncurrent_offset = 1e30",
                      ["sensors.current_offset", "1e+30", "protection.i_max"]),
    "sensor gain 0": ("[sensors]\ncurrent_gain = 0.0", ["sensors.current_gain", "0.0", "above 0"]),
    "sensor gain negative": ("[sensors]\ncurrent_gain = [1.0, -1.0, 1.0]", ["sensors.current_gain", "-1.0"]),
}

# a key another key makes meaningless (before: accepted and ignored or overridden)
OVERRIDE = {
    "bandwidth with gains": ("[observer]\nbandwidth_hz = 10.0\nk1 = 100.0\nk2 = 100.0\nk3 = 10.0",
                             ["observer.bandwidth_hz", "observer.k1"]),
    "speed bandwidth with gains": ("[controller]\nspeed_bandwidth_hz = 5.0\nspeed_kp = 10.0\nspeed_ki = 1.0",
                                   ["controller.speed_bandwidth_hz", "controller.speed_kp"]),
    "current bandwidth with gains": ("[controller]\ncurrent_bandwidth_hz = 100.0\ncurrent_kp = 5.0\n"
                                     "current_ki = 100.0",
                                     ["controller.current_bandwidth_hz", "controller.current_kp"]),
    "force_max with the PLL": ('[observer]\ntype = "pll"\nforce_max = 20.0',
                               ["observer.force_max", "observer.type = 'pll'"]),
    "force_max with the square wave's PLL": ('[injection]\nshape = "square"\n[observer]\nforce_max = 20.0',
                                             ["observer.force_max", "observer.type = 'pll'"]),
    "k3 with the PLL": ('[observer]\ntype = "pll"\nk1 = 100.0\nk2 = 100.0\nk3 = 10.0',
                        ["observer.k3", "observer.type = 'pll'"]),
    "HF delay with the rotating vector": ('[injection]\nshape = "rotating"\n[observer]\nhf_delay_s = 0.05',
                                          ["observer.hf_delay_s", "0.05", "injection.shape = 'rotating'"]),
    "filter Q with the square wave": ('[injection]\nshape = "square"\nfilter_q = 3.0',
                                      ["injection.filter_q", "injection.shape = 'square'"]),
    "notch with the square wave": ('[injection]\nshape = "square"\n[observer]\ndemod_notch = false',
                                   ["observer.demod_notch", "injection.shape = 'square'"]),
    "table model without a table": ('[control]\nmode = "sensorless_nolut"\n[observer]\nlut_model = "eq12"',
                                    ["observer.lut_model", "'eq12'", "observer.compensation = 'none'"]),
    "residual model without the residual": ('[observer]\ndead_time_residual = false\ndead_time_model = '
                                            '"interpolated"', ["observer.dead_time_model",
                                                               "observer.dead_time_residual = false"]),
    "resistance adaptation without adaptation": ("[observer]\ndead_time_adapt = false\n"
                                                 "resistance_adapt = true",
                                                 ["observer.resistance_adapt", "dead_time_adapt"]),
    "dwell of a step": ("[reference]\ndwell = 0.5", ["reference.dwell", "reference.type = 'step'"]),
    "step time of a hold": ('[reference]\nat = 0.2', None),  # (replaced below: a hold has no target)
    "load after of a constant load": ("[load]\nforce_after = 3.0",
                                      ["load.force_after", "load.type = 'constant'"]),
    "incline of a step load": ('[load]\ntype = "step"\nincline_deg = 10.0',
                               ["load.incline_deg", "load.type = 'step'"]),
    "ADC range of an ideal ADC": ("[sensors]\nadc_range = 20.0",
                                  ["sensors.adc_range", "sensors.adc_bits = 0"]),
    "sensored setting in a sensorless mode": ("[control]\ninject_sensored = false",
                                              ["control.inject_sensored", "control.mode = 'sensorless_lut'"]),
    "compensation band without compensation": ("[inverter]\ndead_time_compensation = false\n"
                                               "dtc_current_band = 0.1", ["inverter.dtc_current_band",
                                                                          "dead_time_compensation = false"]),
    "demodulator gain of the rotating vector": ('[injection]\nshape = "rotating"\n[observer]\n'
                                                'gain_schedule = false\n[controller.model]\ndemod_gain = 2.0',
                                                ["controller.model.demod_gain", "rotating"]),
}
HOLD = BASE.replace('type = "step"\nposition_mm = 3.0\nat = 0.05', 'type = "hold"\nat = 0.2')


def _scenario(name: str, cases: dict) -> tuple[str, list]:
    if name == "step time of a hold":
        return HOLD, ["reference.at", "reference.type = 'hold'"]
    keys, words = cases[name]
    return scenario_with(BASE, keys), words


@pytest.mark.parametrize("case", list(RANGE) + list(OVERRIDE))
def test_hostile_sim(run_cli, tmp_path, case):
    text, words = _scenario(case, RANGE if case in RANGE else OVERRIDE)
    path = tmp_path / "s.toml"
    path.write_text(text)
    out = tmp_path / "out"
    r = run_cli("simulate", path, "--out", out)
    line = r.refused("s.toml", *words)
    assert "refused by the controller library" not in line and "see the named sections" not in line, line
    assert not out.exists()


def test_the_base_builds():
    """The base and the keys of each case taken one at a time are the only thing wrong: the base
    itself builds (so each refusal is its case's)."""
    from linsense.io import parse_toml
    from linsense.scenario.load import scenario_from_dict
    from linsense.sim.build import build

    build(scenario_from_dict(parse_toml(BASE, "base.toml"), "base.toml"))

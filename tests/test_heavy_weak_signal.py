"""A heavy mover on a weak HF signal (docs/tuning.md, "A heavy mover on a weak signal"): the
mechanical observer and the speed loop slowed by the design where the q-current the motion asks per
radian at the observer's bandwidth outweighs the HF error signal, so that the drive holds on the
switching inverter with dead time; the shipped motors' designs unchanged."""

from __future__ import annotations

import math

import pytest

import linsense
from conftest import class_drive
from linsense.cli import main
from linsense.model.motor import load_motor
from linsense.scenario.load import load_scenario
from linsense.tune import DriveData, design
from linsense.tune.design import MOTION_SIGNAL_MAX, RATIO_LPF_MECH, motion_signal_bandwidth

#: two motors of the class at its weak end (L_q / L_d about 1.1), heavy for their force constant:
#: name -> (motor file's text, tune's drive options). Without the rule both trip over-speed within
#: 30 ms of a hold (measured: 0.028 s and 0.015 s)
HEAVY = {
    "h80_48v": ("""[motor]
name = "h80_48v"
R_s = 0.8
pole_pitch = 0.08
force_constant = 20.0
mass = 3.0
[inductance]
L0 = 1.8e-3
L2 = -9.06e-5
M0 = -6.0e-4
M2 = -9.06e-5
dM0 = 1.0e-4
""", ["--v-dc", "48", "--f-pwm", "20000", "--dead-time", "0.4e-6", "--i-max", "6"]),
    "h60_24v": ("""[motor]
name = "h60_24v"
R_s = 0.5
pole_pitch = 0.06
force_constant = 12.0
mass = 4.0
[inductance]
L0 = 1.2e-3
L2 = -4.0e-5
M0 = -4.0e-4
M2 = -4.0e-5
dM0 = -6.0e-5
""", ["--v-dc", "24", "--f-pwm", "16000", "--dead-time", "0.3e-6", "--i-max", "8"]),
}


@pytest.mark.parametrize("name", sorted(HEAVY))
def test_a_heavy_mover_on_a_weak_signal_holds(tmp_path, name):
    text, opts = HEAVY[name]
    motor = tmp_path / f"{name}.toml"
    motor.write_text(text)
    out = tmp_path / "tuned.toml"
    with pytest.raises(SystemExit) as e:
        main(["tune", "--motor", str(motor), *opts, "--v-max", "0.2", "--a-max", "2", "--no-verify",
              "--out", str(out)])
    assert e.value.code == 0
    sc = load_scenario(out).replace(inverter={"fidelity": "switching"}, reference={"type": "hold"},
                                    scenario={"duration": 0.4})
    sc = sc.replace(initial={"position_mm": 7.0})
    m = linsense.simulate(sc).metrics
    assert m["stable"], m["unstable_reason"]
    assert m["fault"] == "none" and abs(m["bias_deg"]) <= 1.0 and m["limit_cycle_deg"] <= 0.15
    # the design says why its observer is slower than the low-pass's rule
    dz = design(load_motor(motor), DriveData(v_dc=float(opts[1]), f_pwm=float(opts[3]),
                                             dead_time=float(opts[5]), i_max=float(opts[7])))
    assert dz.observer_slowed < 0.7
    assert dz.observer_bw == pytest.approx(dz.observer_slowed * dz.demod_lpf / RATIO_LPF_MECH)
    assert "heavy mover on a weak HF signal" in dz.limits["observer"]


def test_the_rule_is_the_ratio_it_names():
    """At the bandwidth it gives, the q-current per radian the motion asks is MOTION_SIGNAL_MAX
    times the HF error signal's."""
    text, opts = HEAVY["h80_48v"]
    from linsense.model.motor import motor_from_toml

    m = motor_from_toml(text, "h80")
    i_hf, gain = 0.464, 9.085
    f = motion_signal_bandwidth(m, i_hf, gain)
    asked = m.mass * (2.0 * math.pi * f) ** 2 * (m.pole_pitch / math.pi) / m.force_constant
    assert asked == pytest.approx(MOTION_SIGNAL_MAX * i_hf / gain, rel=1e-12)
    assert motion_signal_bandwidth(m, i_hf, math.inf) == math.inf


@pytest.mark.parametrize("name", ["ecce2010", "m20_hv", "m30_low", "m45_24v", "m60_pos20k", "m90_heavy",
                                  "m100_edge"])
def test_the_shipped_motors_keep_their_observer(name):
    spec, dd = class_drive(name)
    dz = design(load_motor(spec), dd, analyse=False)
    assert dz.observer_slowed == 1.0
    assert dz.observer_bw == pytest.approx(dz.demod_lpf / RATIO_LPF_MECH)

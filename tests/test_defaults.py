"""One home for each default: the C library's design defaults are generated from the
design (linsense.tune.defaults), ls_drive.c sets those fields from the generated macros only, and
the compiled defaults are that design."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from linsense.ctrl import drive_default_cfg, observer_gains
from linsense.model.motor import load_motor
from linsense.tune.defaults import default_values, header
from linsense.tune.design import DriveData, design

ROOT = Path(__file__).parents[1]
HEADER = ROOT / "csrc" / "ctrl" / "ls_drive_defaults.h"
DRIVE_C = ROOT / "csrc" / "ctrl" / "ls_drive.c"

#: cfg fields the design sets: ls_drive_default_cfg must take them from ls_drive_defaults.h
DESIGNED_FIELDS = ("i_max", "inject.amplitude", "inject.freq", "inject.quad", "bpf.f0", "sep.f0",
                   "demod.f_lpf", "demod.f_notch", "demod.gain", "pos.kp_x", "traj.v_max", "traj.a_max",
                   "mod.dead_time", "prot.v_dc_min", "prot.v_dc_max", "cal.dither_amp", "cal.dither_freq",
                   "pos.v_max", "pos.speed.kp", "pos.speed.ki", "traj.v_step", "traj.a_step", "traj.a_lpf",
                   "load_ff", "current.kp", "current.ki", "startup.err_lock", "startup.t_quiet",
                   "startup.v_pulse", "startup.t_pulse", "startup.t_rest", "startup.pairs", "startup.i_min",
                   "startup.t_settle")


def test_header_is_generated_from_the_design():
    """Regenerate: a rule or default changed in Python without regenerating fails here."""
    regen = "python -m linsense.tune.defaults csrc/ctrl/ls_drive_defaults.h"
    assert HEADER.read_text(encoding="utf-8") == header(), f"ls_drive_defaults.h is stale: {regen}"


def test_designed_fields_are_not_literals_in_c():
    body = DRIVE_C.read_text(encoding="utf-8")
    start = body.index("void ls_drive_default_cfg")
    body = body[start:body.index("/* ------", start)]
    for f in DESIGNED_FIELDS:
        m = re.search(rf"c->{re.escape(f)} = ([^;]*);", body)
        assert m, f
        assert "LS_R(" not in m.group(1) and not re.search(r"\d\.\d|\d+e-?\d", m.group(1)), (f, m.group(1))
    # and the design's bandwidths are not restated as literals
    for macro in ("LS_DEF_CURRENT_KP", "LS_DEF_CURRENT_KI", "LS_DEF_SPEED_KP", "LS_DEF_SPEED_KI",
                  "LS_DEF_OBSERVER_BW", "LS_DEF_OBSERVER_MECH", "LS_DEF_V_CAP", "LS_DEF_TRAJ_A_STEP"):
        assert macro in body


def test_compiled_defaults_are_the_design():
    c = drive_default_cfg()
    dz = design(load_motor("ecce2010"), DriveData(), analyse=False)
    w_v = 2 * math.pi * dz.speed_bw
    k_obs = observer_gains(dz.observer_bw, mech=True)  # (the library's rule: one home, in C)
    vals = dict((n, v) for n, v, _ in default_values())
    pairs = {
        "inject.amplitude": (c.inject.amplitude, dz.v_inj), "inject.freq": (c.inject.freq, dz.f_inj),
        "demod.f_lpf": (c.demod.f_lpf, dz.demod_lpf), "demod.gain": (c.demod.gain, dz.demod_gain),
        "obs.k1": (c.obs.k1, k_obs[0]), "obs.k2": (c.obs.k2, k_obs[1]), "obs.k3": (c.obs.k3, k_obs[2]),
        "pos.speed.kp": (c.pos.speed.kp, 1.5 * w_v), "pos.speed.ki": (c.pos.speed.ki, 1.5 * w_v**2 / 4),
        "pos.kp_x": (c.pos.kp_x, dz.kp_x), "pos.v_max": (c.pos.v_max, dz.v_cap),
        "traj.a_step": (c.traj.a_step, dz.a_step), "traj.a_lpf": (c.traj.a_lpf, dz.demod_lpf),
        "obs.force_max": (c.obs.force_max, dz.force_max),
        "current.kp": (c.current.kp, dz.current_kp), "current.ki": (c.current.ki, dz.current_ki),
        "fs": (c.fs, vals["LS_DEF_FS"]), "mod.dead_time": (c.mod.dead_time, DriveData().dead_time),
    }
    for key, (c_val, py_val) in pairs.items():
        assert float(c_val) == pytest.approx(py_val, rel=1e-6), key
    assert dz.observer_type == "mech" and c.obs.type == 1 and c.load_ff


def test_compiled_startup_defaults_are_the_startup_design():
    """The C start-up defaults are tune.startup's design for the reference motor (the pulse's
    amplitude to 0.1 V and the threshold to 0.1 mA, as generated)."""
    from linsense.tune.defaults import REFERENCE_POLARITY
    from linsense.tune.startup import design_startup

    cfg, d = drive_default_cfg(), DriveData()  # (cfg kept: .startup is a view into it)
    c = cfg.startup
    dz = design(load_motor("ecce2010"), d, analyse=False)
    su = design_startup(load_motor("ecce2010"), v_dc=d.v_dc, f_pwm=d.f_pwm, i_max=d.i_max,
                        observer_bw=dz.observer_bw, v_inj=dz.v_inj, polarity=REFERENCE_POLARITY,
                        ramp_rate=dz.inj_ramp_rate)
    assert int(c.pairs) == su.pairs
    assert float(c.v_pulse) == pytest.approx(su.v_pulse, abs=0.05)
    assert float(c.i_min) == pytest.approx(su.i_min, abs=0.5e-4)
    for k in ("err_lock", "t_quiet", "t_pulse", "t_rest", "t_settle"):
        assert float(getattr(c, k)) == pytest.approx(getattr(su, k), rel=1e-6), k


def test_the_generator_takes_no_option_for_a_file(tmp_path, monkeypatch, capsys):
    """``--help`` prints the usage and writes nothing (it wrote the header into a file named
    ``--help``); another option is refused with exit code 2."""
    from linsense.tune.defaults import main

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0 and "usage" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        main(["-o"])
    assert e.value.code == 2
    assert list(tmp_path.iterdir()) == []

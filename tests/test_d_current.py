"""The injection's d-current and the drive's force (docs/theory.md, "The d-current's reluctance
force"; docs/tuning.md, "Why the rotating vector and the square wave cycle"): the design gives the
rotating vector 0.4 i_max on d, the drive's force constant follows it, and the loaded holds that
crept without it on the motor whose reluctance force is largest (m20_hv) and the holds that cycled
without the d-current on ecce2010 and m30_low hold still; on the switching inverter with each drive's
dead time."""

from __future__ import annotations

import dataclasses

import pytest

from conftest import class_drive
from linsense.errors import InputError
from linsense.model.motor import load_motor
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.tune import DriveData, design_drive
from linsense.tune.design import DriveInputs, check_drive, drive_force_max, rated_load
from linsense.tune.export import scenario_dict
from linsense.tune.injection import INJECTION_D_FRACTION, deliverable_force, injection_d_current
from linsense.verify.case_runs import run_cases
from linsense.verify.cases import hold_cases
from linsense.verify.tuning import design_lines


def _rotating(name: str):
    spec, dd = class_drive(name)
    m = load_motor(spec)
    made = design_drive(m, DriveData(**{**vars(dd), "shape": "rotating"}), source=spec, analyse=False,
                        startup=False)
    return spec, m, made, scenario_dict(made, motor_ref=spec)


def test_the_rule():
    assert injection_d_current(2.5, "rotating") == INJECTION_D_FRACTION * 2.5
    assert injection_d_current(2.5, "square") == INJECTION_D_FRACTION * 2.5
    assert injection_d_current(2.5, "pulsating") == 0.0


# (the rated loads of drives.toml, ecce2010's the design's 24.8 N, half its force at i_max with the
# d-current; the bench's 96 positions: a sparser grid finds marginal holds, e.g. m30_low at 290.6 deg,
# 10 N, 0.156 deg p-p, between two of these)
@pytest.mark.parametrize("name", ["m20_hv", "ecce2010", "m30_low"])
def test_rotating_holds_with_the_design_d_current(name):
    """Cycles above 0.15 deg p-p over 96 positions at 0 N and the rated load: none (measured:
    m20_hv 0 / 0, with the d-current and without the force constant following it 0 / 80;
    ecce2010 0 / 0, without the d-current 3 / 1; m30_low 0 / 0, without it 29 / 6)."""
    spec, m, made, base = _rotating(name)
    i_max = base["controller"]["i_max"]
    assert "d_current" not in base["injection"]  # (the design's default, not a value written over it)
    st = build(scenario_from_dict(base, source=name, base_dir="."), motor=m).drive.state
    assert st.cfg.i_d_inj == pytest.approx(INJECTION_D_FRACTION * i_max, rel=1e-6)
    # (the drive starts injecting: its force constant is the one at that d-current)
    assert st.kf_id < 0.0
    assert st.kf == pytest.approx(m.force_constant * (1.0 + st.kf_id * st.cfg.i_d_inj), rel=1e-5)
    load = float(made.design.load)
    rows = run_cases(hold_cases(m.pole_pitch, 1.0, 96, loads=(0.0, load)), base, spec, m, ".")
    assert len(rows) == 192 and all(r["fault"] == "none" for r in rows)
    cycling = [(r["load_n"], round(r["position_deg"], 1), round(r["pp_deg"], 3))
               for r in rows if r["pp_deg"] > 0.15]
    assert not cycling, (name, i_max, cycling)


def test_the_force_limits_follow_the_d_current():
    """The design's force at i_max, the position controller's clamp, the speed PI's limits and the
    observer's load clamp are the force the drive makes while it injects (m20_hv's rotating vector:
    9.33 N, not K_f i_max = 12 N); the rated load a share of it; the pulsating drive's K_f i_max."""
    spec, m, made, base = _rotating("m20_hv")
    st = build(scenario_from_dict(base, source="m20_hv", base_dir="."), motor=m).drive.state
    f_max = st.kf * st.cfg.i_max  # (the drive's force at i_max while it injects)
    assert f_max < 0.8 * m.force_constant * st.cfg.i_max
    for got in (st.cfg.pos.force_max, st.cfg.pos.speed.out_max, -st.cfg.pos.speed.out_min,
                made.design.force_max, st.cfg.obs.force_max):
        assert got == pytest.approx(f_max, rel=1e-5)
    # (the design print says it, beside the rated load)
    limits = next(ln for ln in design_lines(made.design, "m20_hv", made.drive) if "limits" in ln)
    assert f"the force at i_max {f_max:.3g} N, K_f i_max x 0.778 (" in limits, limits
    dd = DriveData(**{**vars(class_drive("m20_hv")[1]), "shape": "rotating", "load": None})
    assert drive_force_max(m, dd) == pytest.approx(f_max, rel=1e-5)
    assert rated_load(m, dd) == pytest.approx(0.5 * f_max, rel=1e-5)
    pulsating = dataclasses.replace(dd, shape="pulsating")
    assert drive_force_max(m, pulsating) == m.force_constant * dd.i_max
    # (more current at speed for the same force: the bus allows less speed)
    assert DriveInputs(m, dd).v_bus_speed < DriveInputs(m, pulsating).v_bus_speed
    # (a d-current that adds force does not raise the limit: the modes without the injection)
    assert deliverable_force(6.0, 2.0, 1.2) == 12.0 and deliverable_force(6.0, 2.0, 0.75) == 9.0


def test_a_given_d_current_is_the_one_counted():
    """A scenario's injection.d_current is the design's and the drive's: 0.5 A at i_max 5 A leaves
    0.86 of the force constant (the designed 0.4 i_max = 2 A would leave 0.444, refused), and one
    that leaves too little is refused naming the key and its largest value."""
    spec, m, made, base = _rotating("m20_hv")
    base["controller"]["i_max"] = 5.0
    base.setdefault("protection", {})["i_max"] = 9.0
    base["injection"]["d_current"] = 0.5
    st = build(scenario_from_dict(base, source="m20_hv", base_dir="."), motor=m).drive.state
    assert st.cfg.i_d_inj == pytest.approx(0.5)
    assert st.cfg.pos.force_max == pytest.approx(st.kf * 5.0, rel=1e-5)
    assert st.kf == pytest.approx(0.861 * m.force_constant, rel=2e-3)
    base["injection"]["d_current"] = 2.0
    with pytest.raises(InputError, match=r"injection\.d_current.*2 A.* leaves 0\.444 of the force constant.*"
                                         r"\|d_current\| at most 1\.798 A$"):
        build(scenario_from_dict(base, source="m20_hv", base_dir="."), motor=m)


def test_a_d_current_that_takes_half_the_force_is_refused():
    """The design refuses what ls_drive_init would (the d-current leaving less than KF_SHARE_MIN of
    the force constant), naming the largest i_max; the smallest i_max it asks for a force makes
    that force with the d-current's share (a given load, and the default's share of the force); and
    a force beyond the peak of K_f i (1 - c i) is said to be beyond every i_max."""
    spec, dd = class_drive("m20_hv")
    m = load_motor(spec)
    rot = dataclasses.replace(dd, shape="rotating")
    said = (r"i_max: 5 A: the rotating injection's d-current .* leaves 0\.444 of the force constant .* "
            r"below the 0\.5 the drive accepts: at most 4\.49\d A, or the pulsating injection$")
    with pytest.raises(InputError, match=said):
        check_drive(m, dataclasses.replace(rot, i_max=5.0))
    check_drive(m, dataclasses.replace(rot, i_max=4.4))
    with pytest.raises(InputError, match=r"i_max must be at least 2\.81") as e:
        check_drive(m, dataclasses.replace(rot, load=11.0))
    i_min = float(str(e.value).split("at least ")[1].split(" A")[0])
    need = 11.0 + m.mass * rot.a_max
    made = drive_force_max(m, dataclasses.replace(rot, load=11.0, i_max=i_min))
    assert made == pytest.approx(need, rel=1e-3)
    # (K_f i_max would have asked for 1.93 A, at which the drive makes 9.11 N)
    assert need / m.force_constant < 0.7 * i_min
    # the default load, half the force at i_max: the rest accelerates the mover
    with pytest.raises(InputError, match=r"i_max must be at least") as e:
        check_drive(m, dataclasses.replace(rot, load=None, a_max=30.0))
    i_min = float(str(e.value).split("at least ")[1].split(" A")[0])
    made = drive_force_max(m, dataclasses.replace(rot, load=None, i_max=i_min))
    assert 0.5 * made == pytest.approx(m.mass * 30.0, rel=1e-3)
    with pytest.raises(InputError, match=r"is below the 20\.6 N .*, and no i_max makes it; with the square "
                                         r"injection's d-current 0\.4 i_max the force at i_max peaks at "
                                         r"13\.49 N \(i_max 4\.497 A\): use the pulsating injection"):
        check_drive(m, dataclasses.replace(dd, shape="square", load=20.0))

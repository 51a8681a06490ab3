"""The injection's d-current and the drive's force (docs/theory.md, "The d-current's reluctance
force"; docs/tuning.md, "Why the rotating vector and the square wave cycle"): the design gives the
rotating vector 0.4 i_max on d, the drive's force constant follows it, and the loaded holds that
crept without it on the motor whose reluctance force is largest (m20_hv) and the holds that cycled
without the d-current on ecce2010 and m30_low hold still; on the switching inverter with each drive's
dead time."""

from __future__ import annotations

import pytest

from conftest import class_drive
from linsense.model.motor import load_motor
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.tune import DriveData, design_drive
from linsense.tune.export import scenario_dict
from linsense.tune.injection import INJECTION_D_FRACTION, injection_d_current
from linsense.verify.case_runs import run_cases
from linsense.verify.cases import hold_cases


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


# (the rated loads of drives.toml, ecce2010's the design's 25 N; the bench's 96 positions: a sparser
# grid finds marginal holds, e.g. m30_low at 290.6 deg, 10 N, 0.156 deg p-p, between two of these)
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

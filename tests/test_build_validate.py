"""The build checks the scenario in one pass (linsense.sim.build.validate) before any C object is
made: a scenario that will be refused is refused before the plant, the tables and the drive."""

from __future__ import annotations

from pathlib import Path

import pytest

import linsense
import linsense.sim.build as sim_build
from linsense.errors import InputError
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.studies.startup_runs import base_scenario

ROOT = Path(__file__).resolve().parent.parent
M20 = str(ROOT / "src/linsense/examples" / "motors" / "class" / "m20_hv.toml")  # (its design injects 49 V)


@pytest.fixture
def no_work(monkeypatch):
    """The plant, the tables and the drive fail the test if the build reaches them."""
    def reached(*a, **k):
        raise AssertionError("the build made C objects before refusing the scenario")
    for name in ("plant", "fill", "make_drive"):
        monkeypatch.setattr(sim_build, name, reached)


def _startup(**keys) -> dict:
    d = base_scenario(motor=M20)
    d["inverter"]["v_dc"] = 300.0
    d["scenario"]["duration"] = 0.3  # (the start-up's end within the run: one after it is refused)
    for k, v in keys.items():
        d.setdefault(k, {}).update(v)
    return d


def test_startup_ramp_of_the_designed_injection_refused_before_the_run(no_work):
    """The scenario's own check sees the default amplitude (12 V / 1200 V/s = 10 ms); the drive runs
    the designed one (49 V at the given 1200 V/s: 41 ms), which ls_drive_set_mode refused after the
    plant and the tables were made, naming control.mode and the wrong cause (a missing table)."""
    sc = scenario_from_dict(_startup(injection={"ramp_rate": 1200.0}), "su.toml")
    with pytest.raises(InputError) as e:
        build(sc)
    msg = str(e.value)
    assert "startup.t_quiet" in msg and "ramp" in msg and "0.0410739 s" in msg, msg


def test_startup_ramp_covered_builds():
    keys = _startup(injection={"ramp_rate": 1200.0}, startup={"t_quiet": 0.05, "t_settle": 0.05})
    sc = scenario_from_dict(keys, "su.toml")
    b = build(sc)
    assert b.drive is not None and b.scenario.spec.injection.amplitude > 40.0


def test_startup_settle_named(no_work):
    keys = _startup(injection={"ramp_rate": 1200.0}, startup={"t_quiet": 0.05, "t_settle": 0.03})
    sc = scenario_from_dict(keys, "su.toml")
    with pytest.raises(InputError, match="startup.t_settle"):
        build(sc)


def test_run_length_refused_before_the_tables(no_work):
    """The run's length and its trace's memory were checked after the drive and its tables."""
    hold = {"motor": "ecce2010", "reference": {"type": "hold"}}
    sc = scenario_from_dict({**hold, "scenario": {"duration": 1e308}}, "long.toml")
    with pytest.raises(InputError, match="scenario.duration"):
        build(sc)
    sc = scenario_from_dict({**hold, "scenario": {"duration": 3000.0}}, "big.toml")
    with pytest.raises(InputError, match="record.decimate"):
        build(sc)


def test_position_and_feedforward_refused_before_the_plant(no_work):
    sc = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 0.1}, "reference": {"type": "step",
                             "position_mm": 1e15}, "travel": {"min_mm": -1e16, "max_mm": 1e16}}, "far.toml")
    with pytest.raises(InputError, match="reference.position_mm"):
        build(sc)
    sc = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 0.1},
                             "reference": {"type": "hold"},
                             "observer": {"type": "pll", "load_feedforward": True}}, "ff.toml")
    with pytest.raises(InputError, match="observer.load_feedforward"):
        build(sc)


@pytest.mark.parametrize("load, key", [({"force": 1e300}, "load.force"),
                                       ({"type": "step", "force_after": -1e39, "time": 0.0},
                                        "load.force_after")])
def test_balanced_load_beyond_the_drive_refused_before_the_drive(no_work, load, key):
    """A start in equilibrium with a force LS_REAL cannot hold was a ConfigError of ls_drive_set_load
    naming no scenario key, after the plant, the tables and the drive were made."""
    sc = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 0.01},
                             "reference": {"type": "hold"}, "load": load, "initial": {"load_balanced": True}},
                            "load.toml")
    with pytest.raises(InputError, match=key):
        build(sc)


def test_balanced_load_within_the_drive_builds():
    """Up to the force the drive makes, K_f controller.i_max (50 N for ecce2010 at 2.5 A); beyond it
    there is no equilibrium to start in (a calibration under 1e6 N once stopped on "fault
    encoder")."""
    for force, ok in ((50.0, True), (-50.0, True), (50.001, False), (3e38, False)):
        sc = scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 0.01},
                                 "reference": {"type": "hold"}, "load": {"force": force},
                                 "initial": {"load_balanced": True}}, "load.toml")
        if ok:
            assert build(sc).drive is not None
        else:
            with pytest.raises(InputError, match="load.force: .* K_f controller.i_max = 50 N"):
                build(sc)


def test_a_trip_at_t0_on_the_sensor_names_the_sensor():
    """A current sensor noisy enough to trip the designed over-current trip at the first step (4 A rms
    against 4.2 A, under check_sensors' refusal at the trip itself) is refused naming the sensor key
    the file gives, not protection.i_max, which it does not give (a refusal names a key the file gives); with
    protection.i_max given, that key is named."""
    base = {"motor": "ecce2010", "scenario": {"name": "noise", "duration": 0.01},
            "reference": {"type": "hold"}, "sensors": {"current_noise": 4.0}}
    with pytest.raises(InputError) as exc:
        linsense.simulate(scenario_from_dict(base))
    assert exc.value.key == "sensors.current_noise", str(exc.value)
    assert "trips at t = 0 (overcurrent) on the current sensor: 4 A rms" in str(exc.value)
    with pytest.raises(InputError) as exc:
        linsense.simulate(scenario_from_dict({**base, "protection": {"i_max": 4.2}}))
    assert exc.value.key == "protection.i_max", str(exc.value)

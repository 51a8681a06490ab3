"""Hostile metrics and events: settings that blinded the metrics, events after the run's
end, the verdict of a run a fault stopped, and an approach called a limit cycle. Each case: the
scenario, the exit code and the words of its one line, or the verdict of metrics.json.

The rules: the metrics are computed from every PWM period whatever is stored (``record.decimate``,
``--decimate``, ``--trace`` and ``record="metrics"`` change only what is written); the end window
is at least half the period of the drive's slowest loop (:func:`linsense.sim.checks.slowest_loop`);
every timed event is checked against the run's end in one place
(:func:`linsense.sim.checks.run_events`); a fault is the verdict; a mover still approaching
monotonically in the end window is "still moving", not a "limit cycle"."""

from __future__ import annotations

import json

import pytest

import linsense
from conftest import scenario_with
from linsense.errors import InputError
from linsense.scenario.load import scenario_from_dict
from linsense.sim.simulation import metrics_only

WALL = ("wall_s", "realtime_factor")

#: a 3 mm step on the reference motor with the paper's slow loops (step3_lut's), 0.6 s
BASE = """motor = "ecce2010"

[scenario]
name = "m"
duration = 0.6
seed = 1

[controller]
position_type = "p"
kp_x = 10.0
speed_bandwidth_hz = 3.0

[reference]
type = "step"
position_mm = 3.0
at = 0.1
"""


def _metrics(run_cli, tmp_path, text: str, *args: str) -> dict:
    p = tmp_path / "s.toml"
    p.write_text(text)
    out = tmp_path / ("o" + "".join(a.strip("-") for a in args))
    r = run_cli("simulate", p, "--out", out, *args)
    assert r.code == 0, r.err
    return json.loads((out / "metrics.json").read_text())


def _refused(run_cli, tmp_path, text: str, *words: str) -> str:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return run_cli("simulate", p, "--out", tmp_path / "o", "--trace", "none").refused(*words)


# ------------------------------------------------------------ metrics that a setting can blind
def test_an_end_window_shorter_than_the_loops_is_refused(run_cli, tmp_path):
    """final_window_s = 1e-9 with kp_x = 5000 said "stable", limit cycle 0, exit 0, where the
    default window shows a 17 deg cycle."""
    text = scenario_with(BASE.replace("kp_x = 10.0", "kp_x = 5000.0"), "[metrics]\nfinal_window_s = 1e-9")
    _refused(run_cli, tmp_path, text, "metrics.final_window_s", "1e-09", "the speed loop",
             "controller.speed_bandwidth_hz = 3 Hz", "at least 0.167 s")


@pytest.mark.parametrize("keys", [
    "[controller]\nspeed_bandwidth_hz = 1.0",  # a slow loop the file gives
    "[observer]\ntype = \"pll\"\nbandwidth_hz = 1.0",
])
def test_a_default_window_too_short_for_a_slow_loop_is_widened(run_cli, tmp_path, keys):
    """A window the file leaves out is widened to half the slowest loop's period (0.5 s for 1 Hz),
    and metrics.json says the window the verdict read (it was 0.3 s, a third of a 1 Hz cycle)."""
    from linsense.sim.checks import slowest_loop

    text = scenario_with(BASE.replace("speed_bandwidth_hz = 3.0\n", ""), keys)
    p = tmp_path / "s.toml"
    p.write_text(text)
    sc = designed_scenario(p)
    least = 0.5 / slowest_loop(sc, sc_mass(sc))[2]
    assert least > 0.3
    assert sc.spec.metrics.final_window_s == pytest.approx(least)
    r = run_cli("simulate", p, "--out", tmp_path / "o", "--trace", "none")
    assert r.code == 0, r.err
    t0, t1 = json.loads((tmp_path / "o" / "metrics.json").read_text())["final_window_s"]
    assert t1 - t0 == pytest.approx(least, abs=1e-3)


def test_a_window_the_file_gives_too_short_for_a_slow_loop_is_refused(run_cli, tmp_path):
    text = scenario_with(BASE.replace("speed_bandwidth_hz = 3.0\n", ""),
                         "[controller]\nspeed_bandwidth_hz = 1.0\n[metrics]\nfinal_window_s = 0.4")
    _refused(run_cli, tmp_path, text, "metrics.final_window_s", "0.4 s is too short",
             "controller.speed_bandwidth_hz = 1 Hz", "at least 0.5 s")


def designed_scenario(path):
    """The scenario at ``path`` (BASE's motor, ecce2010) with the design's values."""
    from linsense.model.motor import load_motor
    from linsense.scenario.load import load_scenario
    from linsense.sim.build import designed

    return designed(load_scenario(path), load_motor("ecce2010"))


def sc_mass(sc):
    from linsense.model.motor import load_motor

    return load_motor("ecce2010").mass


def test_metrics_do_not_depend_on_how_the_trace_is_stored(run_cli, tmp_path):
    """`simulate --decimate 2048 --trace none` gave settling_time_s 0 against 0.045 s at full rate
    and another limit cycle: metrics.json is now the same, byte for byte, whatever is written."""
    p = tmp_path / "s.toml"
    p.write_text(BASE)
    got = {}
    for args in [(), ("--decimate", "2048", "--trace", "none"), ("--decimate", "16", "--trace", "csv"),
                 ("--trace", "none"), ("--decimate", "7")]:
        out = tmp_path / ("o" + "_".join(args))
        assert run_cli("simulate", p, "--out", out, *args).code == 0
        got[args] = (out / "metrics.json").read_bytes()
    assert len(set(got.values())) == 1, {k: json.loads(v)["settling_time_s"] for k, v in got.items()}


def test_the_api_metrics_do_not_depend_on_the_record():
    """simulate with any record.decimate, record="metrics" and metrics_only: one set of metrics."""
    data = {"motor": "ecce2010", "scenario": {"name": "m", "duration": 0.6, "seed": 1},
            "controller": {"kp_x": 10.0, "speed_bandwidth_hz": 3.0},
            "reference": {"type": "step", "position_mm": 3.0, "at": 0.1}}
    sc = scenario_from_dict(data)

    def clean(m):
        return {k: v for k, v in m.items() if k not in WALL}

    full = clean(linsense.simulate(sc).metrics)
    for dec in (3, 2048):
        r = linsense.simulate(sc.replace(record={"decimate": dec}))
        assert clean(r.metrics) == full, dec
        assert r.t.size == -(-9600 // dec)  # (what is kept is still decimated)
    assert clean(linsense.simulate(sc, record="metrics").metrics) == full
    assert clean(metrics_only(sc)) == full


# ------------------------------------------------------------ events after the run's end
@pytest.mark.parametrize("keys, words", [
    ("[load]\ntype = \"step\"\ntime = 5.0\nforce_after = 30.0", ["load.time", "5.0 s", "the load step",
                                                                "scenario.duration = 0.6 s"]),
    # within the last period: no period starts after it
    ("[load]\ntype = \"step\"\ntime = 0.59999\nforce_after = 30.0", ["load.time", "0.59999 s", "0.6 s"]),
    ("", ["reference.at", "0.6 s", "the step", "scenario.duration = 0.6 s"]),
    ("[metrics]\nconvergence_s = 2.0", ["metrics.convergence_s", "2.0 s", "error windows", "0.6 s"]),
    ("[protection]\nerr_time = 1.0", ["protection.err_time", "1.0 s", "observer-loss trip", "0.6 s"]),
    # the step at 0.1 s + a 0.6 s transient window: no steady sample (before: n/a metrics, exit 0)
    ("[metrics]\nsettle_s = 0.6", ["metrics.settle_s", "transient window", "0.7 s", "steady metrics",
                                    "scenario.duration = 0.6 s"]),
])
def test_an_event_after_the_end_is_refused(run_cli, tmp_path, keys, words):
    """A step load at 5 s in a 0.6 s run said "stable", exit 0 (the step at 0.6 s: "not reached")."""
    text = scenario_with(BASE, keys) if keys else BASE.replace("at = 0.1", "at = 0.6")
    _refused(run_cli, tmp_path, text, *words)


def test_a_trajectory_move_after_the_end_is_refused(run_cli, tmp_path):
    text = BASE.replace('type = "step"\nposition_mm = 3.0\nat = 0.1',
                        'type = "trajectory"\nwaypoints_mm = [3.0, 0.0]\nat = 0.05\ndwell = 0.5')
    _refused(run_cli, tmp_path, text, "reference.waypoints_mm[1]", "reference.dwell = 0.5 s",
             "would never act", "scenario.duration = 0.6 s")


def test_a_start_up_longer_than_the_run_is_refused():
    from linsense.studies.startup_runs import base_scenario

    d = base_scenario()
    d["scenario"] = {"name": "su", "duration": 0.05}
    d["reference"] = {"type": "step", "position_mm": 3.0, "at": 0.01}
    with pytest.raises(InputError, match=r"startup: the start-up ends at 0.\d+ s at the earliest .*: the "
                       r"position control after it would never act: the run ends at scenario.duration = "
                       r"0.05 s"):
        linsense.simulate(d)


# ------------------------------------------------------------ the verdict of a faulted run
def test_a_fault_is_the_verdict(run_cli, tmp_path):
    """A run a travel fault stopped at 73 ms, shorter than the end window: its verdict was
    "too short"; it is the fault, named with its time."""
    text = scenario_with(BASE.replace("duration = 0.6", "duration = 0.2").replace("at = 0.1", "at = 0.05"),
                         "[travel]\nmax_mm = 1.0")
    m = _metrics(run_cli, tmp_path, text, "--trace", "none")
    assert m["verdict"] == "fault" and not m["stable"], m
    assert m["unstable_reason"].startswith("fault: travel at 0.07"), m["unstable_reason"]


# ------------------------------------------------------------ an approach is not a limit cycle
def test_an_approach_still_moving_is_not_a_limit_cycle(run_cli, tmp_path):
    """A slow position loop (kp_x 2 1/s) still approaching its target monotonically in the end
    window was "not settled (limit cycle)"."""
    text = BASE.replace("kp_x = 10.0", "kp_x = 2.0\nstep_a_max = 0.0").replace("duration = 0.6",
                                                                              "duration = 1.0")
    m = _metrics(run_cli, tmp_path, text, "--trace", "none")
    assert m["verdict"] == "still moving" and not m["stable"], m
    assert "limit cycle" not in m["unstable_reason"] and "still moving" in m["unstable_reason"], m


def test_a_limit_cycle_is_still_one(run_cli, tmp_path):
    m = _metrics(run_cli, tmp_path, BASE.replace("kp_x = 10.0", "kp_x = 5000.0"), "--trace", "none")
    assert m["verdict"] == "limit cycle" and m["unstable_reason"].startswith("not settled (limit cycle)"), m


# ------------------------------------------------------------ further settings that blinded a metric
def test_a_sweeps_hf_current_does_not_depend_on_the_record():
    """A sweep's hf_current_a from a record of every 16th period (the 1 kHz injection at 16 kHz,
    sampled once per period) was 0.0 A, 0.476 A at every 3rd, against 0.507 A: it reads the
    block envelopes of every period now."""
    from linsense.sweep.runner import hf_current

    d = {"motor": "ecce2010", "scenario": {"name": "h", "duration": 0.6, "seed": 1},
         "reference": {"type": "hold"}}
    full = hf_current(linsense.simulate(d))
    assert full > 0.3
    for dec in (3, 16, 50):
        got = hf_current(linsense.simulate({**d, "record": {"decimate": dec}}))
        assert got == pytest.approx(full, rel=0.01), (dec, got, full)


def test_a_load_step_of_nothing_is_refused(run_cli, tmp_path):
    """`[load] type = "step", time = 0.2` without force_after stepped from 0 N to 0 N: a load that
    never acts, "stable", exit 0."""
    _refused(run_cli, tmp_path, scenario_with(BASE, '[load]\ntype = "step"\ntime = 0.2'), "load.force_after",
             "0.0 N (the default)", "load.force = 0.0 N", "change nothing")


def test_a_sweep_map_does_not_colour_a_mover_as_a_cycle():
    """The sweep's stability map coloured every "not settled" run as a limit cycle."""
    from linsense.report.sweep_figures import OUTCOMES, outcome

    row = {"stable": False, "error": None}
    moving = outcome({**row, "unstable_reason": "not settled (still moving): x moves one way only"})
    cycle = outcome({**row, "unstable_reason": "not settled (limit cycle): x varies by 2 deg"})
    assert OUTCOMES[cycle][0] == "cycle" and OUTCOMES[moving][0] == "moving"


def test_a_calibration_run_is_not_judged_as_a_hold():
    """`linsense simulate` of a calibration scenario judged the drive moving through its points as
    a hold: "not settled (limit cycle)"."""
    d = {"motor": "ecce2010", "scenario": {"name": "cal", "duration": 1.0},
         "control": {"mode": "calibration"}, "reference": {"type": "hold"}}
    m = linsense.simulate(d, record="metrics").metrics
    assert m["verdict"] == "calibration" and not m["stable"], m
    assert "limit cycle" not in m["unstable_reason"] and "linsense calibrate" in m["unstable_reason"]

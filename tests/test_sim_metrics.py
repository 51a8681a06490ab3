"""The closed-loop metrics: what `stable` means, and the keys that say how a run ended."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import linsense
from linsense.cli import main
from linsense.errors import InputError
from linsense.scenario.load import scenario_from_dict
from linsense.scenario.sections import MetricsSection
from linsense.sim.metrics import REQUIRED_KEYS, compute_metrics, settling_time

F_PWM = 1000.0
PITCH = 0.056  # m, ecce2010
DEFAULTS = dict(
    convergence_s=0.1,
    settle_s=0.3,
    pole_pitch=PITCH,
    tolerance_deg=3.0,
    bound_deg=22.5,
    settle_band_deg=0.15,
    settling_band_deg=1.0,
    final_window_s=0.3,
)


def _arrays(x: np.ndarray, err_rad: np.ndarray | None = None) -> dict:
    t = np.arange(x.size) / F_PWM
    return {"t": t, "x": x, "theta_err": np.zeros_like(x) if err_rad is None else err_rad}


def _metrics(x, moves, x_target, x_start=0.0, err_rad=None, **kw):
    a = _arrays(np.asarray(x, dtype=float), err_rad)
    return compute_metrics(
        a,
        fault=0,
        steps_done=a["t"].size,
        f_pwm=F_PWM,
        moves=moves,
        wall_s=0.01,
        observer_active=True,
        x_target=x_target,
        x_start=x_start,
        **{**DEFAULTS, **kw},
    )


def test_a_drive_that_never_moved_is_not_stable():
    """A 3 mm step that the mover never follows stays within the 3.5 mm bound: bounded and settled,
    and still not stable, because it never reached the reference region."""
    x = np.zeros(2000)
    m = _metrics(x, [(0.1, 0.1, 0.0, 3e-3)], 3e-3)
    assert not m["stable"] and not m["reached"] and "never reached" in m["unstable_reason"]
    assert m["limit_cycle_mm"] == 0.0 and m["settling_time_s"] is None


def test_a_limit_cycle_is_not_stable_and_is_measured():
    t = np.arange(2000) / F_PWM
    x = 3e-3 + 0.06e-3 * np.sin(2 * np.pi * 10.0 * t) * (t > 0.3)
    x[t < 0.3] = np.linspace(0, 3e-3, np.sum(t < 0.3))
    err = np.radians(2.0) + np.radians(5.0) * np.sin(2 * np.pi * 10.0 * t)
    m = _metrics(x, [(0.0, 0.0, 0.0, 3e-3)], 3e-3, err_rad=err)
    assert not m["stable"] and "limit cycle" in m["unstable_reason"]
    assert m["limit_cycle_mm"] == pytest.approx(0.12, rel=0.01)
    assert m["bias_deg"] == pytest.approx(2.0, abs=0.05)  # mean over the final window (3 periods)
    assert m["final_window_s"] == [pytest.approx(1.699), pytest.approx(1.999)]


def test_settled_run_and_its_keys():
    t = np.arange(3000) / F_PWM
    tt = (t - 0.1).clip(0)
    x = 3e-3 * (1 - np.exp(-tt / 0.1) * np.cos(2 * np.pi * 5 * tt))  # under-damped step at 0.1 s
    m = _metrics(x, [(0.1, 0.1, 0.0, 3e-3)], 3e-3)
    assert m["stable"] and m["reached"] and m["unstable_reason"] is None
    assert 0.5 < m["overshoot_mm"] < 3.0
    st = m["settling_time_s"]
    # after st the position stays within 1 electrical deg (0.156 mm) of the target, just before not
    band = 1.0 / 360.0 * PITCH
    after = t >= 0.1 + st - 0.5 / F_PWM
    assert np.all(np.abs(x[after] - 3e-3) <= band) and np.abs(x[~after][-1] - 3e-3) > band


def test_overshoot_is_measured_beyond_the_steady_offset():
    """A drive that settles 3 mm beyond its target (the uncompensated observer's bias) has an
    offset, not an overshoot."""
    t = np.arange(2000) / F_PWM
    x = 6e-3 * (1 - np.exp(-t / 0.05))
    m = _metrics(x, [(0.0, 0.0, 0.0, 3e-3)], 3e-3)
    assert m["final_offset_mm"] == pytest.approx(3.0, abs=1e-3)
    assert m["overshoot_mm"] == pytest.approx(0.0, abs=1e-6)


def test_error_peak_covers_the_whole_run():
    x = np.full(2000, 1e-3)
    err = np.zeros(2000)
    err[10] = np.radians(30.0)  # inside the first convergence_s
    m = _metrics(x, [], 1e-3, x_start=1e-3, err_rad=err)
    assert m["max_abs_err_deg"] == pytest.approx(30.0)
    assert m["transient_max_err_deg"] is None and m["steady_max_err_deg"] == 0.0
    assert m["max_abs_err_window_s"][0] == 0.0 and m["errors_from_s"] == 0.1


def test_settling_time_none_when_outside_at_the_end():
    t = np.linspace(0, 1, 101)
    assert settling_time(t, np.ones(101), 0.0, 0.0, 0.1) is None
    assert settling_time(t, np.zeros(101), 0.0, 0.0, 0.1) == 0.0


# ------------------------------------------------------- bounds in electrical degrees
DEG_KEYS = ("limit_cycle_deg", "final_error_deg", "final_offset_deg", "overshoot_deg")


def _angle_run(theta_deg: np.ndarray, pitch: float, moves_deg, target_deg: float, **kw) -> dict:
    """Metrics of a run given as the true electrical angle (deg) on a motor of pole pitch ``pitch``."""
    to_m = pitch / 360.0
    moves = [(t0, t1, a * to_m, b * to_m) for t0, t1, a, b in moves_deg]
    return _metrics(theta_deg * to_m, moves, target_deg * to_m, x_start=theta_deg[0] * to_m,
                    **{"pole_pitch": pitch, **kw})


@pytest.mark.parametrize("pp_deg, stable", [(0.1, True), (0.2, False)])
def test_the_same_hold_in_angle_gets_the_same_verdict_on_any_pole_pitch(pp_deg, stable):
    """A 2 deg step to 30 deg that ends in a 10 Hz cycle of ``pp_deg`` electrical degrees peak to
    peak, 0.4 deg beside the target: on a 20 mm and a 100 mm motor the same angles give the same
    verdict, reason and metrics in degrees, and the metrics in mm scale with the pole pitch. With
    the old fixed 0.02 mm limit-cycle threshold the 0.1 deg cycle (0.0056 and 0.028 mm) would be
    settled on one motor and not on the other."""
    t = np.arange(3000) / F_PWM
    tt = (t - 0.1).clip(0)
    theta = 28.0 + 2.4 * (1 - np.exp(-tt / 0.05)) + 0.5 * pp_deg * np.sin(2 * np.pi * 10.0 * t)
    theta[t < 0.1] = 28.0
    runs = {pitch: _angle_run(theta, pitch, [(0.1, 0.1, 28.0, 30.0)], 30.0) for pitch in (0.02, 0.1)}
    a, b = runs[0.02], runs[0.1]
    for m in (a, b):
        assert m["stable"] is stable and m["reached"] and m["accurate"] is stable, m["unstable_reason"]
        assert m["limit_cycle_deg"] == pytest.approx(pp_deg, rel=1e-3)
        assert m["final_offset_deg"] == pytest.approx(0.4, abs=0.01)
        assert m["settling_time_s"] is not None  # within 1 deg of the target
    for k in (*DEG_KEYS, "settling_time_s", "bias_deg", "stable", "accurate", "reached"):
        assert a[k] == pytest.approx(b[k], abs=2e-6), k
    for k in ("limit_cycle_mm", "final_error_mm", "final_offset_mm"):
        assert b[k] == pytest.approx(5.0 * a[k], rel=1e-4, abs=1e-6), k
    if not stable:
        assert a["unstable_reason"] == b["unstable_reason"].replace(f"({b['limit_cycle_mm']:.3g} mm)",
                                                                    f"({a['limit_cycle_mm']:.3g} mm)")
        assert a["unstable_reason"].startswith("not settled (limit cycle): x varies by 0.2 deg (0.0111 mm)")
        assert a["unstable_reason"].endswith("in the last 0.3 s (tolerance 0.15 deg)")
    else:  # the old 0.02 mm threshold judged the two motors differently
        old = {p: _angle_run(theta, p, [(0.1, 0.1, 28.0, 30.0)], 30.0, settle_band_deg=360.0 * 0.02e-3 / p)
               for p in (0.02, 0.1)}
        assert old[0.02]["stable"] and not old[0.1]["stable"]


def test_bound_reason_in_degrees_with_mm_beside():
    """A drive that settles 25 deg beside its target is beyond the 22.5 deg bound; the reason gives
    degrees with mm beside (1.39 mm on a 20 mm motor)."""
    theta = np.full(2000, 25.0)
    m = _angle_run(theta, 0.02, [], 0.0)
    assert not m["stable"] and m["final_error_deg"] == pytest.approx(25.0)
    assert m["unstable_reason"] == "|x - target| reaches 25 deg (1.39 mm) in the last 0.3 s (bound 22.5 deg)"
    assert set(REQUIRED_KEYS) <= set(m) and m["pole_pitch_mm"] == 20.0


def test_metrics_bounds_in_both_units_are_refused():
    """A file that gives one bound in both forms is refused in one line naming both keys."""
    for name, mm, deg in (("bound", 3.5, 22.5), ("settle_band", 0.02, 0.15), ("tolerance", 0.5, 3.0),
                          ("settling_band", 0.1, 1.0)):
        data = {"motor": "ecce2010", "scenario": {"duration": 0.2}, "reference": {"type": "hold"},
                "metrics": {f"{name}_mm": mm, f"{name}_deg": deg}}
        with pytest.raises(InputError) as e:
            scenario_from_dict(data, "s.toml")
        msg = str(e.value)
        assert "\n" not in msg and f"metrics.{name}_mm" in msg and f"metrics.{name}_deg" in msg, msg
        assert msg.startswith(f"s.toml: metrics.{name}_deg: "), msg
    with pytest.raises(InputError, match="metrics.bound_inch: unknown key"):
        scenario_from_dict({"motor": "ecce2010", "scenario": {"duration": 0.2}, "reference": {"type": "hold"},
                            "metrics": {"bound_inch": 1.0}}, "s.toml")


def test_metrics_bounds_in_mm_still_work():
    """The mm keys of older files keep their meaning: converted with the motor's pole pitch, mixed
    with the other bounds in degrees, and a run's verdict follows them."""
    sec = MetricsSection(settle_band_mm=0.02, bound_deg=10.0)
    got = sec.bounds_deg(0.056)
    assert got == {"tolerance_deg": 3.0, "bound_deg": 10.0, "settling_band_deg": 1.0,
                   "settle_band_deg": pytest.approx(360.0 * 0.02 / 56.0, rel=1e-12)}
    # a 0.03 mm cycle is beyond 0.02 mm, within 0.05 mm (0.193 and 0.321 deg at 56 mm)
    t = np.arange(2000) / F_PWM
    x = 3e-3 + 0.015e-3 * np.sin(2 * np.pi * 10.0 * t)
    for band_mm, stable in ((0.02, False), (0.05, True)):
        bounds = MetricsSection(settle_band_mm=band_mm).bounds_deg(PITCH)
        m = _metrics(x, [], 3e-3, x_start=3e-3, **bounds)
        assert m["stable"] is stable and m["limit_cycle_mm"] == pytest.approx(0.03, rel=1e-3)
    sc = {"motor": "ecce2010", "scenario": {"duration": 0.4}, "control": {"mode": "sensored"},
          "reference": {"type": "hold"}, "metrics": {"bound_mm": 3.5, "settling_band_mm": 0.1}}
    m = linsense.simulate(sc, record="metrics").metrics
    assert m["stable"] and m["pole_pitch_mm"] == 56.0 and m["settling_time_s"] == 0.0, m["unstable_reason"]


def _fig13_like(balanced: bool):
    return scenario_from_dict(
        {
            "motor": "ecce2010",
            "scenario": {"name": "load", "duration": 0.3},
            "reference": {"type": "hold"},
            "load": {"force": 20.0},
            "initial": {"position_mm": 0.0, "load_balanced": balanced},
        }
    )


def test_load_balanced_start_does_not_sag():
    """20 N from t = 0: without the preset the mover sags by millimetres before the integrators
    catch up; with initial.load_balanced the drive produces the force from the first step."""
    sag = {b: float(np.max(np.abs(linsense.simulate(_fig13_like(b)).x))) * 1e3 for b in (False, True)}
    assert sag[False] > 5.0
    assert sag[True] < 0.3


def test_cli_check_exit_codes(tmp_path, capsys):
    ok = tmp_path / "ok.toml"
    ok.write_text(
        'motor = "ecce2010"\n[scenario]\nduration = 1.0\n[control]\nmode = "sensored"\n'
        '[reference]\ntype = "hold"\n'
    )
    with pytest.raises(SystemExit) as e:
        main(["simulate", str(ok), "--out", str(tmp_path / "a"), "--no-plot", "--check"])
    assert e.value.code == 0
    cyc = Path(__file__).parents[1] / "src/linsense/examples/scenarios/step6_nolut.toml"  # a limit cycle
    with pytest.raises(SystemExit) as e:
        main(["simulate", str(cyc), "--out", str(tmp_path / "b"), "--no-plot", "--check"])
    assert e.value.code == 1
    assert "not stable" in capsys.readouterr().err
    m = json.loads((tmp_path / "b" / "metrics.json").read_text())
    assert m["stable"] is False and m["limit_cycle_mm"] > 0.02


def test_configuration_that_trips_at_t0_is_an_input_error(tmp_path, capsys):
    """A bus outside the protection's range is refused when the scenario is read; a drive that
    trips at its first step anyway (here: over-current limit below the injection's current) is a
    configuration error too: exit 2, one line naming the file and key, nothing written."""
    low = tmp_path / "low.toml"
    low.write_text(
        'motor = "ecce2010"\n[scenario]\nduration = 0.1\n[inverter]\nv_dc = 30.0\n'
        '[reference]\ntype = "hold"\n'
    )
    with pytest.raises(SystemExit) as e:
        main(["simulate", str(low), "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err.strip()
    assert e.value.code == 2 and err.count("\n") == 0
    assert "low.toml: inverter.v_dc" in err and "30" in err
    trip = tmp_path / "trip.toml"
    trip.write_text(
        'motor = "ecce2010"\n[scenario]\nduration = 0.1\n[reference]\ntype = "hold"\n'
        "[protection]\ni_max = 0.5\n[sensors]\ncurrent_offset = 0.6\n"
    )
    with pytest.raises(SystemExit) as e:
        main(["simulate", str(trip), "--out", str(tmp_path / "d")])
    err = capsys.readouterr().err.strip()
    assert e.value.code == 2 and "trip.toml: protection.i_max" in err and "t = 0" in err
    assert not (tmp_path / "d").exists()


# ---------------------------------------------------------------- the fast metrics = the reference
def _random_run(rng: np.random.Generator, blocks: bool, n: int):
    """Arrays of a run of ``n`` samples: a step with a limit cycle, noise, optionally non-finite
    samples; moves and the keyword arguments of compute_metrics."""
    t = np.arange(1, n + 1) / 1024.0  # (dyadic: windows that start exactly on a sample are exact)

    def when(hi: float) -> float:  # a time, on a sample half of the time
        return float(rng.integers(0, n + 1)) / 1024.0 if rng.random() < 0.5 else rng.uniform(0.0, hi)

    x_to = rng.choice([0.0, 3e-3, -6e-3])
    x0 = rng.choice([0.0, 1e-3])
    t0 = when(0.5 * t[-1])
    # (a third of the drives stop short of the target: beyond the bound, or within half the move)
    short = (x_to - x0) * rng.choice([0.0, 0.0, 0.0, 0.03, 0.1, 0.3, 0.7])
    x = np.where(t < t0, x0, x_to - short + rng.normal(0, 2e-5, n) + 3e-5 * np.sin(40 * t))
    e = rng.normal(0, 0.01, n)
    arrays = {"t": t, "x": x.copy(), "theta_err": e.copy()}
    if blocks:
        w = np.abs(rng.normal(0, 1e-5, n))
        arrays.update(x_min=x - w, x_max=x + w, x_mean=x, err_min=e - 0.002, err_max=e + 0.003, err_mean=e)
    if rng.random() < 0.4:  # non-finite samples (a diverging run)
        for k in rng.choice(list(arrays), size=2):
            if k != "t":
                arrays[k] = arrays[k].copy()
                arrays[k][rng.integers(0, n, size=rng.integers(1, 4))] = rng.choice([np.nan, np.inf, -np.inf])
    moves = [] if rng.random() < 0.2 else [(t0, t0 + rng.choice([0.0, 0.0625]), x0, x_to)]
    if moves and rng.random() < 0.3:
        moves.insert(0, (0.0, 0.015625, x0, x0))
    kw = dict(fault=int(rng.choice([0, 0, 1, 0x200])), steps_done=n * 16, f_pwm=16e3, moves=moves,
              wall_s=0.01, observer_active=bool(rng.random() < 0.85), convergence_s=when(0.2),
              settle_s=when(0.3), pole_pitch=float(rng.choice([0.02, 0.056, 0.1])), tolerance_deg=0.3,
              bound_deg=6.0, settle_band_deg=0.3, settling_band_deg=float(rng.choice([0.06, 0.6])),
              final_window_s=when(0.4), x_target=x_to, x_start=x0,
              load_step_s=when(0.5 * t[-1]) if rng.random() < 0.2 else None)
    return arrays, kw


@pytest.mark.parametrize("blocks", [False, True])
def test_metrics_equal_the_reference_from_the_docs(blocks):
    """compute_metrics (index ranges by bisection, a sweep's hot path) gives the same metrics as a
    reference written from docs/simulator.md's definitions alone (tests/ref_metrics.py: per-sample
    records and time selections, nothing imported from linsense.sim.metrics) on 400 random runs:
    steps, moves, faults, NaN and inf samples, short runs, windows longer than the run."""
    from ref_metrics import compute_metrics_ref

    rng = np.random.default_rng(7 + blocks)
    kinds, unobserved = set(), 0
    for k in range(400):
        n = int(rng.choice([1, 2, 5, 50, 600]))
        arrays, kw = _random_run(rng, blocks, n)
        got = compute_metrics(arrays, **kw)
        want = compute_metrics_ref(arrays, **kw)
        differ = {key: (got[key], want[key]) for key in got if got[key] != want[key]}
        assert not differ, (k, differ)
        unobserved += _unobserved_move(arrays, kw)
        kinds.add((got["verdict"], got["fault"] != "none", got["bias_deg"] is None))
    assert 0 < unobserved < 200, unobserved  # (runs with nothing recorded after their move: they agree too)
    # (the runs reach every verdict, with and without a fault and an error statistic; "not reached"
    # needs a move after the run's end without a fault, which a scenario cannot give)
    verdicts = {v for v, _, _ in kinds}
    assert {"stable", "unstable", "fault", "too short", "limit cycle"} <= verdicts <= \
        {"stable", "unstable", "fault", "too short", "limit cycle", "still moving"}, kinds
    assert {(f, b) for _, f, b in kinds} == {(False, False), (False, True), (True, False), (True, True)}


def _unobserved_move(arrays: dict, kw: dict) -> bool:
    """Whether the run has a last move of some length and no kept sample (not the tripped one) with a
    finite position from its start on."""
    if not kw["moves"] or kw["moves"][-1][2] == kw["moves"][-1][3]:
        return False
    t = arrays["t"][:-1] if kw["fault"] else arrays["t"]
    finite = np.ones(t.size, dtype=bool)
    for key in ("x", "x_min", "x_max", "x_mean"):
        if key in arrays and (key != "x" or "x_min" not in arrays):
            finite &= np.isfinite(arrays[key][:t.size])
    return not np.any((t >= kw["moves"][-1][0]) & finite)


def test_reached_needs_a_sample_after_the_move():
    """Blocks of 0.1 s recorded at 0, 0.1 and 0.2 s of a 0.3 s run, a 1 mm step at 0.25 s and an end
    window (0.04 s) shorter than a block: nothing was recorded after the step, so the drive was never
    seen to reach it: neither `reached` nor `stable`, although the samples before the step lie within
    the bound (1 mm = 6.4 deg beside the target, bound 22.5 deg); the reason says so. (compute_metrics
    said `reached` and `stable` here until the reference written from the docs caught it.)"""
    from ref_metrics import compute_metrics_ref

    t = np.array([0.0, 0.1, 0.2])
    x, e = np.zeros(3), np.zeros(3)
    arrays = {"t": t, "x": x, "theta_err": e, "x_min": x, "x_max": x, "x_mean": x, "err_min": e,
              "err_max": e, "err_mean": e}
    kw = dict(fault=0, steps_done=4800, f_pwm=16000.0, moves=[(0.25, 0.25, 0.0, 1e-3)], wall_s=0.01,
              observer_active=True, convergence_s=0.0, settle_s=0.0, pole_pitch=0.056, tolerance_deg=3.0,
              bound_deg=22.5, settle_band_deg=0.15, settling_band_deg=1.0, final_window_s=0.04,
              x_target=1e-3, x_start=0.0)
    want = compute_metrics_ref(arrays, **kw)
    assert not want["reached"] and not want["stable"]  # (the reference, from the docs)
    got = compute_metrics(arrays, **kw)
    assert not got["reached"] and not got["stable"], (got["reached"], got["verdict"])
    assert got["unstable_reason"].startswith("never seen to reach the target: nothing was recorded"), got


def test_the_reference_is_not_the_code_it_checks():
    """tests/ref_metrics.py imports nothing of linsense (its fault names come from the C headers),
    and its names agree with the code's for every bit."""
    import ast

    import ref_metrics
    from linsense.sim.metrics import fault_reason

    tree = ast.parse(Path(ref_metrics.__file__).read_text())
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not any(m and m.startswith("linsense") for m in imported), imported
    assert len(ref_metrics.FAULTS) == 10
    for bits in (0, *(1 << k for k in range(12)), 0x109, 0x7FF):
        assert ref_metrics.fault_text(bits) == fault_reason(bits), hex(bits)


STEP = {"motor": "ecce2010", "control": {"mode": "sensored"},
        "reference": {"type": "step", "position_mm": 3.0, "at": 0.1}}


@pytest.mark.parametrize("duration, at, verdict, fragment", [
    (0.6, 10.0, None, "reference.at: 10.0 s: the step would never act"),  # the move after the run's end
    (2.0 / 16000.0, 0.1, None, "reference.at: 0.1 s: the step would never act"),  # two PWM periods
    (0.3, 0.1, "too short", "to last at least 0.4 s"),  # the end window would hold the step itself
    (0.25, None, "too short", "needs the run (0.25 s)"),  # a hold shorter than its end window
])
def test_verdicts_judged_on_nothing_are_their_own(duration, at, verdict, fragment, tmp_path, capsys):
    """A run that does not hold its commanded move, or an end window after it, is not judged stable
    (before these checks a move at 10 s in a 0.6 s run, two PWM periods, and an end window longer than the
    run were all "stable"; the last reported the step as a 2.9 mm limit cycle): a step after the
    run's end is refused (it never acts), an end window over the step is "too short" and
    `linsense simulate --check` exits 1 naming the keys."""
    sc = json.loads(json.dumps(STEP))
    sc["scenario"] = {"duration": duration}
    if at is None:
        sc["reference"] = {"type": "hold"}
    else:
        sc["reference"]["at"] = at
    if verdict is None:
        with pytest.raises(InputError, match=fragment):
            linsense.simulate(sc, record="metrics")
        return
    m = linsense.simulate(sc, record="metrics").metrics
    assert m["verdict"] == verdict and not m["stable"], m["unstable_reason"]
    assert fragment in m["unstable_reason"], m["unstable_reason"]
    assert m["reached"] is True
    path = tmp_path / "s.toml"
    import tomli_w

    path.write_text(tomli_w.dumps(sc))
    with pytest.raises(SystemExit) as e:
        main(["simulate", str(path), "--out", str(tmp_path / "o"), "--check"])
    assert e.value.code == 1
    err = capsys.readouterr().err
    assert verdict in err and ("reference.at" in err or "final_window_s" in err), err


def test_a_fault_before_the_step_is_not_reached():
    """A drive that trips before its step never reached it (it was once `reached`); the
    verdict is the fault, with its time (it was then "not reached")."""
    t = np.arange(50) / F_PWM  # (tripped at 49 ms, the step at 0.1 s)
    a = _arrays(np.zeros(t.size), None)
    m = compute_metrics(a, fault=0x01, steps_done=t.size, f_pwm=F_PWM, moves=[(0.1, 0.1, 0.0, 3e-3)],
                        wall_s=0.01, observer_active=True, x_target=3e-3, x_start=0.0, **DEFAULTS)
    assert not m["reached"] and m["verdict"] == "fault"
    assert m["unstable_reason"] == "fault: overcurrent at 0.049 s", m["unstable_reason"]


@pytest.mark.parametrize("shape, want", [
    ("approach", "still moving"), ("drift", "still moving"), ("approach from above", "still moving"),
    ("ring down", "still moving"), ("cycle", "limit cycle"), ("growing cycle", "limit cycle"),
])
def test_an_end_window_moving_one_way_is_no_limit_cycle(shape, want):
    """end_motion tells a mover still approaching (or drifting, or ringing down) from one that keeps
    swinging (a long approach was once called a "limit cycle"); the HF ripple below the hysteresis."""
    from linsense.sim.metrics import end_motion

    t = np.linspace(0.0, 0.3, 4801)
    ripple = 1e-6 * np.sin(2 * np.pi * 1000 * t)
    x = {"approach": 3e-3 - 5e-4 * np.exp(-t / 0.2), "drift": 1e-4 * t,
         "approach from above": 3e-3 + 5e-4 * np.exp(-t / 0.05),
         "ring down": 3e-3 + 2e-4 * np.exp(-t / 0.02) * np.cos(2 * np.pi * 30 * t),
         "cycle": 3e-3 + 1e-4 * np.sin(2 * np.pi * 11 * t),
         "growing cycle": 3e-3 + 1e-4 * (1 + t) * np.sin(2 * np.pi * 11 * t)}[shape] + ripple
    assert end_motion(x, 11.7e-6, 23.3e-6)[0] == want


def test_a_settled_step_is_stable():
    m = linsense.simulate({**STEP, "scenario": {"duration": 0.8}}, record="metrics").metrics
    assert m["verdict"] == "stable" and m["stable"], m["unstable_reason"]

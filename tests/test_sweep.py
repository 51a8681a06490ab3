"""The sweep engine (docs/sweeps.md): points, sweep files, runs on dask (threads, processes on
loopback, a scheduler by address), Parquet partitions, kill and resume, the CLI and its studies."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from linsense.sweep import load_sweep, sweep, sweep_from_dict
from linsense.sweep.points import points

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = """motor = "ecce2010"
[scenario]
duration = 0.3
seed = 1
[control]
mode = "sensorless_lut"
[reference]
type = "step"
position_mm = 2.0
at = 0.05
[observer]
type = "pll"  # (the axis below sweeps the PLL's bandwidth: 30 and 50 Hz)
"""


def spec(tmp_path: Path, axes: str, sweep_keys: str = "") -> dict:
    (tmp_path / "base.toml").write_text(SCENARIO)
    text = f'[sweep]\nname = "t"\nscenario = "base.toml"\nbatch = 2\n{sweep_keys}\n{axes}'
    (tmp_path / "sweep.toml").write_text(text)
    return tmp_path / "sweep.toml"


AXES = """[[axis]]
key = "reference.position_mm"
values = [1.0, 2.0, 3.0]
[[axis]]
key = "observer.bandwidth_hz"
values = [30.0, 50.0]
"""


# ---------------------------------------------------------------------- points and files
def test_grid_is_the_product_in_order(tmp_path):
    pts = points(load_sweep(spec(tmp_path, AXES)))
    assert [(p["reference.position_mm"], p["observer.bandwidth_hz"]) for p in pts] == [
        (1.0, 30.0), (1.0, 50.0), (2.0, 30.0), (2.0, 50.0), (3.0, 30.0), (3.0, 50.0)]


def test_latin_hypercube_is_stratified_and_seeded(tmp_path):
    axes = ('[[axis]]\nkey = "observer.bandwidth_hz"\nmin = 10.0\nmax = 90.0\n'
            '[[axis]]\nkey = "inverter.v_dc"\nmin = 60.0\nmax = 80.0\n')
    f = spec(tmp_path, axes, 'sampling = "lhs"\nsamples = 20\nseed = 3')
    a, b = points(load_sweep(f)), points(load_sweep(f))
    assert a == b  # deterministic
    bw = np.array([p["observer.bandwidth_hz"] for p in a])
    # one sample in each of the 20 strata of [10, 90]
    assert sorted(((bw - 10.0) / 80.0 * 20).astype(int)) == list(range(20))
    other = points(load_sweep(spec(tmp_path, axes, 'sampling = "lhs"\nsamples = 20\nseed = 4')))
    assert other != a


HEAD = '[sweep]\nscenario = "b.toml"\n'
AB = '[[axis]]\nkey = "a.b"\n'


@pytest.mark.parametrize("text, words", [
    (HEAD + AB + "values = [1]\n" + AB + "values = [2]\n", ["axis", "'a.b'", "twice"]),
    (HEAD + AB + "min = 1.0\nmax = 2.0\n", ["axis.0.n", "needs n"]),
    (HEAD + AB + "min = 2.0\nmax = 1.0\nn = 3\n", ["axis.0.max"]),
    (HEAD + 'sampling = "lhs"\n' + AB + "values = [1]\n", ["sweep.samples"]),
    (HEAD + '[[axis]]\nkey = "ab"\nvalues = [1]\n', ["axis.0.key", "dotted"]),
    (HEAD + AB + 'values = ["x"]\nrelative = true\n', ["factors"]),
    ('[sweep]\nscenaro = "b.toml"\n' + AB + "values = [1]\n", ["sweep.scenaro", "did you mean 'scenario'"]),
    (HEAD + AB + "values = [1]\nlog = true\n", ["axis"]),
    # (a misspelt key refused every run, and the sweep ended with exit code 0: "4 runs: ... 4 refused")
    (HEAD + '[[axis]]\nkey = "reference.positon_mm"\nvalues = [1]\n',
     ["axis.0.key", "did you mean 'reference.position_mm'"]),
    (HEAD + 'set = { "duration" = 0.3 }\n[[axis]]\nkey = "reference.position_mm"\nvalues = [1]\n',
     ["sweep.set.duration", "did you mean 'scenario.duration'"]),
])
def test_bad_sweep_files_name_the_key(run_cli, tmp_path, text, words):
    (tmp_path / "s.toml").write_text(text)
    run_cli("sweep", tmp_path / "s.toml", "--out", tmp_path / "out").refused("s.toml", *words)
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------------- runs
def test_sweep_rows_values_and_metrics(tmp_path):
    df = sweep(spec(tmp_path, AXES), tmp_path / "out", workers=2)
    assert list(df["run"]) == list(range(6))
    assert {"reference.position_mm", "observer.bandwidth_hz", "stable", "bias_deg", "limit_cycle_mm",
            "error"} <= set(df.columns)
    assert df["error"].isna().all()
    # the swept value reached the run: the final position follows the step size
    assert np.allclose(df["final_position_mm"], df["reference.position_mm"], atol=0.5)
    assert len(list((tmp_path / "out" / "parts").glob("part-*.parquet"))) == 3  # batch = 2


def test_motor_keys_and_refused_points(tmp_path):
    """A plant-motor key changes the run; a point the checks refuse is a row with its error."""
    axes = ('[[axis]]\nkey = "motor.motor.mass"\nvalues = [1.5, 6.0]\n'
            '[[axis]]\nkey = "inverter.v_dc"\nvalues = [72.0, 15.0]\n')
    df = sweep(spec(tmp_path, axes), workers=1)
    ok = df[df["error"].isna()]
    assert list(ok["inverter.v_dc"]) == [72.0, 72.0]
    assert ok["settling_time_s"].iloc[0] != ok["settling_time_s"].iloc[1]  # a heavier mover
    bad = df[df["error"].notna()]
    assert len(bad) == 2 and not bad["stable"].any()
    assert bad["error"].str.contains("v_dc").all()


def test_lut_motor_keys_leave_the_plant(tmp_path):
    """lut_motor.* changes what the controller believes (its LUT), not the plant: the bias moves."""
    axes = '[[axis]]\nkey = "lut_motor.inductance.dM0"\nrelative = true\nvalues = [1.0, 0.0]\n'
    df = sweep(spec(tmp_path, axes), workers=1)
    assert df["error"].isna().all()
    assert abs(df["bias_deg"].iloc[1]) > abs(df["bias_deg"].iloc[0]) + 0.5  # a LUT without the end-effect


@pytest.mark.slow
def test_worker_processes_on_loopback_and_a_scheduler_by_address(tmp_path):
    from dask.distributed import LocalCluster

    f = spec(tmp_path, AXES)
    threads = sweep(f, workers=2)
    procs = sweep(f, workers=2, processes=True)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tcp",
                      host="127.0.0.1", dashboard_address=None) as cluster:
        remote = sweep(f, scheduler=cluster.scheduler_address)
    cols = ["run", "stable", "bias_deg", "final_position_mm"]
    pd.testing.assert_frame_equal(threads[cols], procs[cols])
    pd.testing.assert_frame_equal(threads[cols], remote[cols])


@pytest.mark.slow
def test_a_killed_sweep_resumes_without_lost_or_duplicated_rows(tmp_path):
    f = spec(tmp_path, AXES)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "linsense", "sweep", str(f), "--out", str(out), "--workers", "1",
           "--no-progress"]
    env = dict(os.environ, LINSENSE_TEST_KILL_AFTER_PARTS="1")
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == -signal.SIGKILL, r.stderr
    parts = sorted((out / "parts").glob("part-*.parquet"))
    assert 1 <= len(parts) < 3
    first = {p.name: p.read_bytes() for p in parts}
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    df = pd.read_parquet(out / "results.parquet")
    assert list(df["run"]) == list(range(6))  # none lost, none twice
    for name, data in first.items():  # the partitions written before the kill were kept, not redone
        assert (out / "parts" / name).read_bytes() == data
    fresh = sweep(f, tmp_path / "fresh", workers=1)
    pd.testing.assert_frame_equal(df[["run", "stable", "bias_deg"]], fresh[["run", "stable", "bias_deg"]])


def test_another_sweep_in_the_same_folder_is_refused(run_cli, tmp_path):
    f = spec(tmp_path, AXES)
    out = tmp_path / "out"
    assert run_cli("sweep", f, "--out", out, "--workers", 1, "--no-progress").code == 0
    (tmp_path / "sweep.toml").write_text(f.read_text().replace("50.0", "60.0"))
    # (the line names what changed, and --restart)
    run_cli("sweep", f, "--out", out, "--no-progress").refused("--out", "sweep file", "sweep.toml", "changed",
                                                               "--restart")
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("x")
    run_cli("sweep", f, "--out", tmp_path / "mine", "--no-progress").refused("--out", "not a sweep folder")


@pytest.mark.parametrize("name", ["stability_map", "stability_map_dm0", "lut_robustness", "injection"])
def test_shipped_sweep_files_are_valid(name):
    sw = load_sweep(ROOT / "src/linsense/examples" / "sweeps" / f"{name}.toml")
    assert sw.scenario_path.is_file()
    assert len(points(sw)) >= 20
    assert sw.spec.sweep.study is not None


def test_study_figure_and_summary(run_cli, tmp_path):
    text = (ROOT / "src/linsense/examples" / "sweeps" / "stability_map.toml").read_text()
    text = text.replace('scenario = "../scenarios/step6_lut.toml"', f'scenario = "{tmp_path / "base.toml"}"')
    text = text.replace("values = [1.5, 3.0, 4.5, 6.0, 9.0]", "values = [2.0, 4.0]").replace("n = 6", "n = 2")
    (tmp_path / "base.toml").write_text(SCENARIO)
    (tmp_path / "map.toml").write_text(text)
    r = run_cli("sweep", tmp_path / "map.toml", "--out", tmp_path / "out", "--workers", 2, "--no-progress")
    assert r.code == 0, r.err
    png = tmp_path / "out" / "stability-map.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = (tmp_path / "out" / "summary.txt").read_text()
    assert "8 runs" in summary and "control.mode = sensorless_lut" in summary
    assert r.out.strip().splitlines()[-1] == summary.strip()


def test_sweep_from_a_dict():
    with pytest.raises(Exception, match="scenario"):
        sweep_from_dict({"sweep": {}, "axis": [{"key": "a.b", "values": [1]}]})


def test_simulate_many_from_a_script_without_a_main_guard(tmp_path):
    """simulate_many runs on the engine's worker threads: a plain script works (no spawn guard)."""
    (tmp_path / "base.toml").write_text(SCENARIO)
    script = tmp_path / "many.py"
    script.write_text(
        "import linsense\n"
        f"rs = linsense.simulate_many([{str(tmp_path / 'base.toml')!r}] * 3, workers=2)\n"
        "print(sum(r.metrics['final_position_mm'] > 1.5 for r in rs), len(rs))\n"
        "import sys\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))\n")
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    # 3 runs on 2 local threads, without dask (the core install has none)
    assert r.stdout.split("\n")[:2] == ["3 3", "[]"]


def test_metrics_only_equals_simulate_metrics(tmp_path):
    """A sweep's lean run (only what the metrics read) gives simulate(record="metrics")'s metrics."""
    from linsense.sim.simulation import metrics_only, simulate

    (tmp_path / "base.toml").write_text(SCENARIO)
    lean = metrics_only(tmp_path / "base.toml")
    full = simulate(tmp_path / "base.toml", record="metrics").metrics
    drop = {"wall_s", "realtime_factor"}
    assert {k: v for k, v in lean.items() if k not in drop} == \
        {k: v for k, v in full.items() if k not in drop}


# ------------------------------------------------------------------- an axis whose span overflows
HUGE = 1.7976931348623157e308  # (the largest float)


@pytest.mark.parametrize("sampling", ["grid", "random", "lhs"])
@pytest.mark.parametrize("lo, hi, log", [(-1.7e308, 1.7e308, False), (-HUGE, HUGE, False),
                                         (-1e308, HUGE, False), (5e-324, HUGE, True), (1e-300, HUGE, True)])
def test_an_axis_whose_span_overflows_gives_finite_points_within_it(tmp_path, sampling, lo, hi, log):
    """``min = -1.7e308, max = 1.7e308``: ``max - min`` overflows, and the grid and the samples held inf
    and nan. Every point is finite and within [min, max], the grid's ends are min and max."""
    n = "n = 3" if sampling == "grid" else ""
    samples = "" if sampling == "grid" else "samples = 50"
    axis = (f'[[axis]]\nkey = "controller.kp_x"\nmin = {lo!r}\nmax = {hi!r}\n{n}\n'
            f'log = {str(log).lower()}\n')
    pts = [p["controller.kp_x"] for p in points(load_sweep(spec(tmp_path, axis,
                                                                f'sampling = "{sampling}"\n{samples}')))]
    assert len(pts) == (3 if sampling == "grid" else 50)
    assert all(np.isfinite(v) and lo <= v <= hi for v in pts), pts
    if sampling == "grid":
        assert pts[0] == lo and pts[-1] == hi
        if not log:
            assert pts[1] == pytest.approx(0.5 * lo + 0.5 * hi, abs=1e-12 * hi)
    else:
        assert len(set(pts)) == len(pts)  # (samples spread over the axis, not one clipped end)


def test_the_points_of_an_ordinary_axis_are_unchanged(tmp_path):
    """Where max - min is finite the points are what they were to the last bit (np.linspace, min + u
    (max - min)): a sweep that ran before asks for the same runs when resumed."""
    axis = '[[axis]]\nkey = "controller.kp_x"\nmin = 0.1\nmax = 0.7\nn = 7\n'
    pts = [p["controller.kp_x"] for p in points(load_sweep(spec(tmp_path, axis)))]
    assert pts == [float(v) for v in np.linspace(0.1, 0.7, 7)]
    axis = '[[axis]]\nkey = "controller.kp_x"\nmin = 0.1\nmax = 0.7\n'
    keys = 'sampling = "random"\nsamples = 5\nseed = 3'
    pts = [p["controller.kp_x"] for p in points(load_sweep(spec(tmp_path, axis, keys)))]
    u = np.random.default_rng(3).random((5, 1))[:, 0]
    assert pts == [float(v) for v in 0.1 + u * (0.7 - 0.1)]

"""Sweep benchmark (make bench): throughput of the sweep engine on 1 and 2 workers and its overhead
above the C loop's own time (the targets: 2 workers >= 1.8x one worker, overhead <= 10 %).

Runs N copies (seeds) of the paper's 2 s, 3 mm step (step3_lut) on the switching inverter, metrics only, with
1 worker thread, 2 worker threads and 2 worker processes (the processes' start-up counted apart).
Prints each figure. Usage: python tools/bench_sweep.py [N] (default 2,000 runs).
The C loop's time is the runs' own ``wall_s``, summed as they finish (a sweep's rows carry no wall
time: its tables are byte-reproducible).
"""

from __future__ import annotations

import sys
import tempfile
import threading
import time
from pathlib import Path

import linsense.sim.simulation as simulation
from linsense.sweep import sweep

ROOT = Path(__file__).resolve().parents[1]


def spec(n: int, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    f = folder / "bench_sweep.toml"
    f.write_text(f"""[sweep]
name = "bench"
scenario = "{ROOT / 'src/linsense/examples' / 'scenarios' / 'step3_lut.toml'}"
set = {{ "inverter.fidelity" = "switching" }}

[[axis]]
key = "scenario.seed"
values = {list(range(n))}
""")
    return f


C_LOOP = [0.0]  # s, the C loop's time of the runs in this process (worker threads)
_LOCK = threading.Lock()
_metrics_only = simulation.metrics_only


def _timed(scenario):
    m = _metrics_only(scenario)
    with _LOCK:
        C_LOOP[0] += m["wall_s"]
    return m


simulation.metrics_only = _timed  # (what each run of the sweep calls, looked up at the call)


def run(f: Path, **kw) -> tuple[float, float, int]:
    C_LOOP[0] = 0.0
    t0 = time.perf_counter()
    df = sweep(f, **kw)
    return time.perf_counter() - t0, C_LOOP[0], len(df)


def main() -> int:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000  # (the default size)
    with tempfile.TemporaryDirectory() as tmp:
        f = spec(n, Path(tmp))
        run(spec(8, Path(tmp) / "warm"), workers=1)  # imports and caches
        t1, c1, _ = run(f, workers=1)
        t2, c2, _ = run(f, workers=2)
        from dask.distributed import Client, LocalCluster

        t0 = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                          silence_logs=40) as cluster, Client(cluster):
            start = time.perf_counter() - t0
            tp, cp, _ = run(f, scheduler=cluster.scheduler_address)
    print(f"sweep benchmark: {n} runs of a 2 s switching scenario (step3_lut), metrics only")
    print(f"  1 worker thread : {n / t1:6.1f} runs/s, C loop {c1 / t1:.0%} of the time, "
          f"overhead {1 - c1 / t1:.1%} (target <= 10 %)")
    print(f"  2 worker threads: {n / t2:6.1f} runs/s, {t1 / t2:.2f}x one worker (target >= 1.8x)")
    print(f"  2 worker processes: {n / tp:6.1f} runs/s, {t1 / tp:.2f}x one worker thread "
          f"(their start-up, {start:.1f} s, apart)")
    ok = 1 - c1 / t1 <= 0.10 and t1 / t2 >= 1.8  # (the default engine: worker threads)
    print(f"  sweep targets (overhead, 2 threads): {'PASS' if ok else 'FAIL'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

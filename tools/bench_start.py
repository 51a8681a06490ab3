#!/usr/bin/env python3
"""Quick to start, light to run (make bench): every figure side by side, in one run.

Each figure is taken on a whole child process (``os.wait4`` gives that child's own CPU time and
peak RSS), except the Parquet trace's CPU, which is the writer's own time inside a run:

- ``import linsense``: CPU of the import alone (process time around it), the least of 5;
- ``linsense simulate`` of a 2 s scenario (step3_lut, default Parquet trace): CPU of the whole
  process, the least of 3;
- a sweep's fixed cost: whole-process CPU of ``linsense sweep`` with 2 and with N of those runs
  on one worker, the cost per run and the fixed part from the line through both;
- N short runs (the 2 s step3_lut on the switching inverter, metrics only: tools/bench_sweep.py's
  runs, about 10 ms of CPU each) on 1 and on 2 workers: wall time of the whole
  ``linsense sweep`` process, their ratio, measured twice (a wall ratio needs a quiet machine:
  the load average is printed beside it), and the ratio the CPU figures predict for 2 idle cores
  (a model, not a measurement);
- ``linsense simulate --trace none`` of 1,800 s simulated: peak RSS of the process;
- the Parquet trace: CPU of the trace writer per simulated second (a 20 s run written in chunks
  into a file, as ``linsense simulate`` does; the least of 3), beside the C loop's.

Prints a table (target, measured, PASS/FAIL); exit status 1 if a target is missed.

  python tools/bench_start.py [N]      (N short runs, default 200)
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
LINSENSE = [PY, "-m", "linsense"]
SCENARIO = ROOT / "src" / "linsense" / "examples" / "scenarios" / "step3_lut.toml"


def child(argv: list[str], **kw) -> dict:
    """Run ``argv`` to its end: its wall time, CPU (user + sys) and peak RSS (MB), its own figures
    (os.wait4), never another process's. Raises if it fails."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        p = subprocess.Popen(argv, stdout=out, stderr=err, **kw)
        _, status, ru = os.wait4(p.pid, 0)  # (this child's own rusage; Popen must not reap it first)
        wall = time.perf_counter() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        out, err = out.read(), err.read()
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, argv))} failed ({p.returncode}):\n{err.decode()[-2000:]}")
    return {"wall": wall, "cpu": ru.ru_utime + ru.ru_stime, "rss_mb": ru.ru_maxrss / 1024.0,
            "out": out.decode()}


def import_cpu() -> float:
    code = "import time; t = time.process_time(); import linsense; print(time.process_time() - t)"
    return min(float(child([PY, "-c", code])["out"]) for _ in range(5))


def simulate_cpu(tmp: Path) -> float:
    return min(child([*LINSENSE, "simulate", str(SCENARIO), "--out", str(tmp / f"sim{k}")])["cpu"]
               for k in range(3))


def sweep_file(tmp: Path, n: int) -> Path:
    """tools/bench_sweep.py's sweep of ``n`` short runs, written into its own folder of ``tmp``."""
    sys.path.insert(0, str(ROOT / "tools"))
    from bench_sweep import spec

    return spec(n, tmp / f"sweep{n}")


def sweep_run(tmp: Path, n: int, workers: int, tag: str) -> dict:
    out = tmp / f"sw-{n}-{workers}-{tag}"
    return child([*LINSENSE, "sweep", str(sweep_file(tmp, n)), "--out", str(out), "--workers", str(workers),
                  "--no-progress"])


def long_scenario(tmp: Path, seconds: float) -> Path:
    text = SCENARIO.read_text().replace("duration = 2.0", f"duration = {seconds!r}")
    assert f"duration = {seconds!r}" in text
    f = tmp / f"long{int(seconds)}.toml"
    f.write_text(text)
    return f


def parquet_cpu(tmp: Path, seconds: float = 20.0) -> tuple[float, float]:
    """(writer CPU, C loop wall) per simulated second: a run of ``seconds`` streamed into a Parquet
    trace in this process, the writer's calls timed with the process clock (the C loop is not
    running meanwhile: the chunks are handed on between its calls)."""
    from linsense.scenario.load import load_scenario
    from linsense.sim.build import build
    from linsense.sim.stream import simulate_streamed
    from linsense.sim.trace import TraceWriter

    b = build(load_scenario(long_scenario(tmp, seconds)), trace_in_memory=False)
    spent = [0.0]
    with open(tmp / "trace.parquet", "wb") as f:
        w = TraceWriter(f, "parquet")

        def on_chunk(arrays):
            t0 = time.process_time()
            w.write(arrays)
            spent[0] += time.process_time() - t0

        sr = simulate_streamed(b, on_chunk=on_chunk)
        t0 = time.process_time()
        w.close()
        spent[0] += time.process_time() - t0
    return spent[0] / seconds, sr.metrics["wall_s"] / seconds


def load() -> str:
    try:
        return "load average " + " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:
        return ""


def main() -> int:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    rows = []

    def row(name: str, target: str, measured: str, ok: bool | None) -> None:
        rows.append((name, target, measured, "PASS" if ok else "FAIL" if ok is not None else "-"))
        print(f"  {name}: {measured} (target {target}) {rows[-1][3]}", flush=True)

    print(f"point 7 (quick to start, light to run); {os.cpu_count()} cores, {load()}", flush=True)
    with tempfile.TemporaryDirectory(prefix="linsense-bench-") as d:
        tmp = Path(d)
        # the bytecode a pip install compiles (also where PYTHONDONTWRITEBYTECODE is set, which would
        # have every process compile the package's changed sources again), then the disk caches warm
        import compileall

        import linsense

        compileall.compile_dir(Path(linsense.__file__).parent, quiet=1)
        child([*LINSENSE, "--version"])
        c = import_cpu()
        row("import linsense, CPU", "<= 0.12 s", f"{c:.3f} s", c <= 0.12)
        c = simulate_cpu(tmp)
        row("linsense simulate, 2 s scenario, CPU of the process", "<= 0.30 s", f"{c:.3f} s", c <= 0.30)
        small = min((sweep_run(tmp, 2, 1, f"f{k}") for k in range(2)), key=lambda r: r["cpu"])
        big = sweep_run(tmp, n, 1, "c")
        per = (big["cpu"] - small["cpu"]) / (n - 2)
        fixed = small["cpu"] - 2 * per
        row("sweep fixed cost, CPU (linsense sweep, 2 and N runs)", "<= 1.0 s",
            f"{fixed:.2f} s ({per * 1e3:.1f} ms per run; 2 runs {small['cpu']:.2f} s, "
            f"wall {small['wall']:.2f} s)",
            fixed <= 1.0)
        model = (fixed + n * per) / (fixed + n * per / 2)  # (the runs in parallel, the rest not)
        row(f"{n} short runs, 1 worker / 2 workers, from the CPU figures above", "(a model)",
            f"{model:.2f}x if the runs alone ran in parallel on 2 idle cores", None)
        for k in (1, 2):
            w1 = sweep_run(tmp, n, 1, f"w1-{k}")["wall"]
            w2 = sweep_run(tmp, n, 2, f"w2-{k}")["wall"]
            r = w1 / w2
            row(f"{n} short runs, wall 1 worker / 2 workers (take {k})", ">= 1.6x",
                f"{r:.2f}x ({w1:.2f} s / {w2:.2f} s; {load()}; a quiet machine is needed)", r >= 1.6)
        long = long_scenario(tmp, 1800.0)
        r = child([*LINSENSE, "simulate", str(long), "--out", str(tmp / "long"), "--trace", "none"])
        row("simulate --trace none, 1,800 s simulated, peak RSS", "<= 60 MB",
            f"{r['rss_mb']:.1f} MB ({r['cpu']:.1f} s CPU)", r["rss_mb"] <= 60)
        w, cl = min(parquet_cpu(tmp) for _ in range(3))
        row("Parquet trace, writer CPU per simulated s", "<= 5 ms",
            f"{w * 1e3:.2f} ms (the C loop: {cl * 1e3:.2f} ms wall)", w <= 5e-3)
    print("\npoint 7 summary (CPU times are robust to a busy machine; wall ratios are not)")
    wid = [max(len(r[i]) for r in rows) for i in range(3)]
    for name, target, measured, verdict in rows:
        print(f"  {name:<{wid[0]}}  {target:<{wid[1]}}  {verdict:4}  {measured}")
    return 1 if any(r[3] == "FAIL" for r in rows) else 0


if __name__ == "__main__":
    raise SystemExit(main())

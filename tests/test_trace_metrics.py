"""A run's metrics without its trace: ``linsense simulate --trace none`` keeps
only the samples that decide a metric (:class:`linsense.sim.stream.MetricSamples`), so its memory
does not grow with the duration, and its metrics are those of the same run with a trace; the
Parquet trace written without dictionaries reads back with every column and value."""

from __future__ import annotations

import io
import json
import tracemalloc

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import linsense
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.sim.metrics import compute_metrics
from linsense.sim.stream import BLOCK_SPEC, POINT_SPEC, MetricSamples, Reducer, simulate_streamed
from linsense.sim.trace import TraceWriter, write_trace

WALL = ("wall_s", "realtime_factor")


def sc(duration=0.3, **sections):
    d = {"motor": "ecce2010", "scenario": {"name": "m", "duration": duration},
         "control": {"mode": "sensorless_lut"},
         "reference": {"type": "step", "position_mm": 1.0, "at": 0.02}}
    if sections.get("reference", {}).get("type") == "trajectory":
        del d["reference"]
    for k, v in sections.items():
        d.setdefault(k, {}).update(v)
    return scenario_from_dict(d)


def no_wall(m: dict) -> dict:
    return {k: v for k, v in m.items() if k not in WALL}


def every_sample(b, metrics_cap: int) -> dict:
    """The metrics of the streamed run from every reduced sample (the way before MetricSamples): the
    samples of every PWM period whatever the record's decimate, merged into blocks only
    when the end window holds more than the cap."""
    from linsense.sim.core import run_closed_loop_chunks
    from linsense.sim.simulation import finish_metrics, run_metrics
    from linsense.sim.stream import full_rate, metrics_block

    k = metrics_block(b.scenario.spec, metrics_cap)
    red = Reducer(k, BLOCK_SPEC if k > 1 else POINT_SPEC)
    raw = run_closed_loop_chunks(full_rate(b.cfg), b.drive.state, b.n_steps, b.commands, on_chunk=red.add,
                                 chunk=1000)
    m = run_metrics(b, raw, red.finish(split_last=bool(raw.fault)))
    finish_metrics(b, raw, m, k)
    m["samples"] = int(red.n_in)
    return m


@pytest.mark.parametrize("cap, decimate, extra", [
    (2**19, 1, {}), (300, 1, {}), (150, 3, {}),
    # moves (the transient window, overshoot and settling from the last one's start) and a trip
    (400, 1, {"reference": {"type": "trajectory", "waypoints_mm": [1.0, 2.0], "at": 0.05}}),
    (400, 1, {"load": {"type": "step", "force": 0.0, "force_after": 300.0, "time": 0.15}}),
])
def test_streamed_metrics_equal_those_of_every_sample(cap, decimate, extra):
    """Keeping only the deciding samples changes no metric, bit for bit: blocks merged (a small cap on
    the end window's periods), a decimated record (no change: the metrics read every period), a
    move, a fault."""
    s = sc(0.4, record={"decimate": decimate}, **extra)
    ref = every_sample(build(s, trace_in_memory=False), cap)
    m = simulate_streamed(build(s, trace_in_memory=False), chunk=700, metrics_cap=cap).metrics
    note = m.pop("metrics_note", None)  # (said when the end window is merged into blocks)
    assert (note is not None) == (cap < 4800), note
    assert no_wall(m) == no_wall(ref)
    if "load" in extra:
        assert ref["fault"] != "none"  # (the case is the one meant)


def _arrays(rng, n: int, blocks: bool) -> dict:
    t = np.cumsum(rng.uniform(0.5, 1.5, n)) * 1e-3
    x = 1e-3 * (1 - np.exp(-t / 0.05)) + rng.normal(0, 2e-6, n)
    e = rng.normal(0, 0.01, n)
    for a in (x, e):  # (non-finite samples: a diverged estimate, a bad position)
        a[rng.integers(0, n, rng.integers(0, 3))] = np.nan
    if not blocks:
        return {"t": t, "x": x, "theta_err": e}
    w = np.abs(rng.normal(0, 3e-6, n))
    v = np.abs(rng.normal(0, 0.005, n))
    return {"t": t, "x": x, "theta_err": e, "x_min": x - w, "x_max": x + w, "x_mean": x,
            "err_min": e - v, "err_max": e + v, "err_mean": e}


@pytest.mark.parametrize("seed", range(12))
def test_metric_samples_against_compute_metrics(seed):
    """Random traces fed in random pieces: the samples kept give compute_metrics' result of all."""
    rng = np.random.default_rng(seed)
    blocks = bool(seed % 2)
    n = int(rng.integers(50, 3000))
    a = _arrays(rng, n, blocks)
    moves = [(0.02, 0.02 + rng.uniform(0, 0.3), 0.0, 1e-3)] if seed % 3 else []
    kw = dict(f_pwm=1000.0, moves=moves, wall_s=1.0, observer_active=True,
              convergence_s=float(rng.uniform(0, 0.2)), settle_s=float(rng.uniform(0, 0.3)),
              pole_pitch=0.03, tolerance_deg=3.0, bound_deg=22.5, settle_band_deg=0.15,
              settling_band_deg=float(rng.uniform(0.001, 0.05)), final_window_s=float(rng.uniform(0.01, 0.5)),
              x_target=1e-3, x_start=0.0)
    fault = int(rng.integers(0, 2)) * 0x08
    ref = compute_metrics(a, fault=fault, steps_done=n, **kw)
    keep = MetricSamples(moves=moves, convergence_s=kw["convergence_s"], settle_s=kw["settle_s"],
                         final_window_s=kw["final_window_s"], settling_band_deg=kw["settling_band_deg"],
                         pole_pitch=kw["pole_pitch"], x_target=kw["x_target"])
    cuts = np.sort(rng.integers(0, n, 12))
    for lo, hi in zip([0, *cuts], [*cuts, n], strict=True):
        if hi > lo:
            keep.add({k: v[lo:hi].copy() for k, v in a.items()})
    kept = keep.arrays(list(a))
    got = compute_metrics(kept, fault=fault, steps_done=n, **kw)
    assert got.pop("samples") <= n
    ref.pop("samples")
    assert got == ref
    assert kept["t"].size < n or n < 400  # (it does keep fewer)


def test_trace_none_metrics_equal_those_with_a_trace(run_cli, tmp_path):
    """`linsense simulate --trace none` writes the metrics of the same run with a Parquet or CSV trace."""
    p = tmp_path / "s.toml"
    p.write_text('motor = "ecce2010"\n[scenario]\nname = "t"\nduration = 0.4\n'
                 '[reference]\nposition_mm = 1.0\n')
    got = {}
    for fmt in ("none", "parquet", "csv"):
        out = tmp_path / fmt
        run_cli("simulate", p, "--out", out, "--trace", fmt)
        got[fmt] = no_wall(json.loads((out / "metrics.json").read_text()))
        assert (out / f"trace.{fmt}").exists() == (fmt != "none")
    assert got["none"] == got["parquet"] == got["csv"]


def _peak(duration: float, cap: int) -> int:
    b = build(sc(duration), trace_in_memory=False)
    tracemalloc.start()
    try:
        simulate_streamed(b, metrics_cap=cap)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("cap", [2**19, 2**10])
def test_metrics_only_memory_is_flat(cap):
    """A run without a trace holds no more memory for 40 s simulated than for 8 s (a few MB: the
    chunk buffers, the samples of the end window and the work on a chunk; before, every reduced
    sample up to the cap: up to 38 MB), with every period's sample for the metrics (the cap 2**19
    on the end window's 4800 periods) or its periods merged into blocks (the cap 2**10: of 5)."""
    short, long = _peak(8.0, cap), _peak(40.0, cap)
    assert long < 8e6, long
    assert long < short + 1.5e6, (short, long)


def test_parquet_trace_reads_back_without_dictionaries(tmp_path):
    """The streamed and the whole-run Parquet traces hold every column and value of the run; the
    float columns are written without a dictionary (its cost, 10 ms per simulated second, bought
    nothing), the fault bits with one."""
    s = sc(0.2)
    ref = linsense.simulate(s)
    buf = io.BytesIO()
    w = TraceWriter(buf, "parquet")
    simulate_streamed(build(s, trace_in_memory=False), on_chunk=w.write, chunk=1000)
    w.close()
    whole = write_trace(ref, tmp_path / "trace.parquet", "parquet")
    for src in (io.BytesIO(buf.getvalue()), whole):
        pd.testing.assert_frame_equal(pd.read_parquet(src), ref.to_dataframe())
    meta = pq.ParquetFile(io.BytesIO(buf.getvalue())).metadata
    assert meta.num_row_groups == -(-ref.t.size // 1000)
    for j in range(meta.num_columns):
        col = meta.row_group(0).column(j)
        dictionary = any("DICTIONARY" in e for e in col.encodings)
        assert dictionary == (col.path_in_schema == "fault"), (col.path_in_schema, col.encodings)
